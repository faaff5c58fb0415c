//! PI creep (13)–(18) in fixed-capacity storage, and the per-sample kernel
//! the `std` operator shares.
//!
//! Each elementary operator `dχ/dt = a d_r(v − χ)` is solved exactly under
//! zero-order hold (20): `χ_{k+1} = χ_k + g d_r(v_k − χ_k)` with
//! `g = 1 − e^{−aT_s}`, and `C_k = Σ_i (w_i/m) Σ_j χ_{ij,k}`: the output at
//! `k` depends on inputs up to `v_{k−1}` (the one-sample delay that makes
//! the compensator (21) explicit). `χ` is stored eigenvalue-major (`j` outer,
//! `i` inner) so the update is one flat pass.
//!
//! In `f32` a slow operator stalls once its increment `g d_r` falls below half
//! an ulp of `χ`: with `g = 10⁻⁵` (`a = 0.05 s⁻¹` at 5 kHz) it can stay up to
//! `ε₃₂ |χ| / (2g) ≈ 0.6 %` of `|χ|` short of its f64 value. The conformance
//! tolerances carry this `1/g` term (see `suite::conformance::tolerance`).

use crate::realtime::error::ParameterError;
use crate::realtime::hysteresis::weighted_sum;
use crate::realtime::parameters::{check_capacity, check_finite, check_length, CreepParameters};
use crate::realtime::play::dead_zone;
use crate::realtime::real::Real;

/// `1 − e^{−a T_s}` without cancellation (`−expm1(−aT_s)`; the literal form
/// loses five digits at `a = 0.05 s⁻¹`, `T_s = 0.2 ms`).
#[inline]
pub fn creep_gain(eigenvalue: f64, sample_time: f64) -> f64 {
    #[cfg(feature = "std")]
    let e = (-eigenvalue * sample_time).exp_m1();
    #[cfg(not(feature = "std"))]
    let e = libm::expm1(-eigenvalue * sample_time);
    -e
}

/// Advance every elementary operator with `v` (20). A non-finite `v` is
/// replaced by the last finite input, which `last_input` keeps.
#[inline(always)]
pub fn advance<T: Real>(chi: &mut [T], thresholds: &[T], gains: &[T], v: T, last_input: &mut T) {
    let v = if v.is_finite() { v } else { *last_input };
    *last_input = v;
    for ((chi, &r), &g) in chi.iter_mut().zip(thresholds).zip(gains) {
        *chi += g * dead_zone(v - *chi, r);
    }
}

/// A PI creep operator (16) with at most `K` elementary operators
/// (`n + 1` thresholds times `m` eigenvalues).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FixedCreep<T: Real, const K: usize> {
    thresholds: usize,
    eigenvalues: usize,
    flat_thresholds: [T; K],
    flat_gains: [T; K],
    flat_weights: [T; K],
    chi: [T; K],
    output: T,
    last_input: T,
}

impl<T: Real, const K: usize> FixedCreep<T, K> {
    /// `C` with checked parameters (17), (18), in the virgin state.
    pub fn new(parameters: &CreepParameters<'_>, sample_time: f64) -> Result<Self, ParameterError> {
        parameters.validate(sample_time)?;
        let n = parameters.thresholds.len();
        let m = parameters.eigenvalues.len();
        check_capacity("creep", K, n.saturating_mul(m))?;
        let mut c = Self {
            thresholds: n,
            eigenvalues: m,
            flat_thresholds: [T::ZERO; K],
            flat_gains: [T::ZERO; K],
            flat_weights: [T::ZERO; K],
            chi: [T::ZERO; K],
            output: T::ZERO,
            last_input: T::ZERO,
        };
        for (j, &a) in parameters.eigenvalues.iter().enumerate() {
            let g = T::from_f64(creep_gain(a, sample_time));
            for i in 0..n {
                c.flat_thresholds[j * n + i] = T::from_f64(parameters.thresholds[i]);
                c.flat_gains[j * n + i] = g;
                c.flat_weights[j * n + i] = T::from_f64(parameters.weights[i] / m as f64);
            }
        }
        Ok(c)
    }

    /// `(n + 1, m)`: thresholds and eigenvalues.
    pub fn shape(&self) -> (usize, usize) {
        (self.thresholds, self.eigenvalues)
    }

    fn len(&self) -> usize {
        self.thresholds * self.eigenvalues
    }

    /// Set `χ` from `state[i * m + j]` (threshold `i`, eigenvalue `j`: the
    /// model file's rows, flattened).
    pub fn set_state(&mut self, state: &[f64]) -> Result<(), ParameterError> {
        let (n, m) = self.shape();
        check_length("creep.state", n * m, state.len())?;
        check_finite("creep.state", state)?;
        for i in 0..n {
            for j in 0..m {
                self.chi[j * n + i] = T::from_f64(state[i * m + j]);
            }
        }
        self.refresh_output();
        Ok(())
    }

    /// `χ_{ij}` of the next sample, as [`FixedCreep::set_state`] takes it.
    pub fn state_into(&self, state: &mut [f64]) -> Result<(), ParameterError> {
        let (n, m) = self.shape();
        check_length("creep.state", n * m, state.len())?;
        for i in 0..n {
            for j in 0..m {
                state[i * m + j] = self.chi[j * n + i].to_f64();
            }
        }
        Ok(())
    }

    /// The output `C_k` of the current state.
    #[inline]
    pub fn output(&self) -> T {
        self.output
    }

    /// Advance with `v_k` and return `C_{k+1}`.
    #[inline]
    pub fn advance(&mut self, v: T) -> T {
        let len = self.len();
        advance(
            &mut self.chi[..len],
            &self.flat_thresholds[..len],
            &self.flat_gains[..len],
            v,
            &mut self.last_input,
        );
        self.refresh_output();
        self.output
    }

    /// `C_k`, then advance with `v_k`.
    #[inline]
    pub fn step(&mut self, v: T) -> T {
        let out = self.output;
        self.advance(v);
        out
    }

    fn refresh_output(&mut self) {
        let len = self.len();
        self.output = weighted_sum(&self.flat_weights[..len], &self.chi[..len]);
    }

    pub fn reset(&mut self) {
        self.chi = [T::ZERO; K];
        self.output = T::ZERO;
        self.last_input = T::ZERO;
    }
}
