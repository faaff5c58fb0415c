//! PI creep (13)–(18) and its per-sample kernel.
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
use crate::realtime::hysteresis::reduce;
use crate::realtime::parameters::{check_finite, check_length, CreepParameters};
use crate::realtime::play::clamp;
use crate::realtime::real::Real;
use crate::realtime::simd::{self, Kernels};
use crate::realtime::storage::{Buffer, Storage};

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

/// Thresholds per block of the creep pass: the clamp bounds `v ∓ r_i` are
/// formed once per threshold and reused by every eigenvalue's row, and a
/// block is one AVX register of `f64` (two SSE2 registers).
pub(crate) const LANES: usize = 4;

/// Advance every elementary operator with `v` (20) and return the new output
/// `Σ_i (w_i/m) Σ_j χ_ij`. `chi[j * n + i]` (eigenvalue-major); `thresholds`
/// and `weights` (`w_i/m`) have `n` entries, `gains` one per eigenvalue. A
/// non-finite `v` is replaced by the last finite input, which `last_input`
/// keeps.
///
/// The update is `χ ← χ + g (P_r[v, χ] − χ)`: the dead zone of (14) as the
/// play's output minus its state, `d_r(v − χ) = P_r[v, χ] − χ`, so that
/// `v ∓ r_i` serve all `m` rows. The sums run in a fixed order (lane `l`
/// of a block adds the thresholds `i ≡ l mod 4`, then
/// [`reduce`]), the same for every instruction set: the result does not
/// depend on the CPU.
#[inline(always)]
pub(crate) fn advance<T: Real>(
    chi: &mut [T],
    thresholds: &[T],
    gains: &[T],
    weights: &[T],
    v: T,
    last_input: &mut T,
) -> T {
    let v = if v.is_finite() { v } else { *last_input };
    *last_input = v;
    let n = thresholds.len();
    debug_assert!(weights.len() == n && chi.len() == n * gains.len());
    let mut acc = [T::ZERO; LANES];
    let full = n - n % LANES;
    for i0 in (0..full).step_by(LANES) {
        let r: &[T; LANES] = thresholds[i0..i0 + LANES].try_into().unwrap();
        let lower = r.map(|r| v - r);
        let upper = r.map(|r| v + r);
        let mut rows = [T::ZERO; LANES];
        for (j, &g) in gains.iter().enumerate() {
            let block: &mut [T; LANES] = (&mut chi[j * n + i0..j * n + i0 + LANES])
                .try_into()
                .unwrap();
            for l in 0..LANES {
                let x = block[l];
                block[l] = x + g * (clamp(x, lower[l], upper[l]) - x);
            }
            for l in 0..LANES {
                rows[l] += block[l];
            }
        }
        let w: &[T; LANES] = weights[i0..i0 + LANES].try_into().unwrap();
        for l in 0..LANES {
            acc[l] += w[l] * rows[l];
        }
    }
    advance_tail(chi, thresholds, gains, weights, v, full, &mut acc);
    reduce(acc)
}

/// The thresholds `full..n` that do not fill a block, one by one, into the
/// lanes `i − full` (shared by [`advance`] and its AVX copy).
#[inline(always)]
pub(crate) fn advance_tail<T: Real>(
    chi: &mut [T],
    thresholds: &[T],
    gains: &[T],
    weights: &[T],
    v: T,
    full: usize,
    acc: &mut [T; LANES],
) {
    let n = thresholds.len();
    for i in full..n {
        let (lower, upper) = (v - thresholds[i], v + thresholds[i]);
        let mut row = T::ZERO;
        for (j, &g) in gains.iter().enumerate() {
            let x = chi[j * n + i];
            let x = x + g * (clamp(x, lower, upper) - x);
            chi[j * n + i] = x;
            row += x;
        }
        acc[i - full] += weights[i] * row;
    }
}

/// The output `Σ_i (w_i/m) Σ_j χ_ij` of a state, summed in the order
/// [`advance`] uses (bit for bit what it returns for that state).
pub(crate) fn output<T: Real>(chi: &[T], weights: &[T]) -> T {
    let n = weights.len();
    let mut acc = [T::ZERO; LANES];
    for (i, &w) in weights.iter().enumerate() {
        let mut row = T::ZERO;
        for x in chi.iter().skip(i).step_by(n.max(1)) {
            row += *x;
        }
        acc[i % LANES] += w * row;
    }
    reduce(acc)
}

/// A PI creep operator `C` (16): `n + 1` log(t)-creep operators (15) of `m`
/// elementary operators (13)–(14) each, thresholds as (18), weights with
/// non-negative partial sums (17), in `T`, kept in storage `S`.
#[derive(Debug, Clone, PartialEq)]
pub struct Creep<T: Real, S: Storage> {
    // what a step reads and writes first, the parameters as given after
    thresholds: S::Creep<T>,
    /// `1 − e^{−a_j T_s}` per eigenvalue and `w_i / m` per threshold.
    gains: S::Creep<T>,
    scaled_weights: S::Creep<T>,
    /// `χ[j * n + i]`: eigenvalue `j`, threshold `i`.
    chi: S::Creep<T>,
    /// The output of the current state, kept so `output()` is O(1).
    output: T,
    /// The last finite input, held in place of a non-finite one.
    last_input: T,
    weights: S::Creep<T>,
    eigenvalues: S::Creep<T>,
    sample_time: f64,
}

impl<T: Real, S: Storage> Creep<T, S> {
    /// `C` with checked thresholds (18), weights (17), eigenvalues `a_j > 0`
    /// (s⁻¹) and sample time, in the zero state.
    pub fn new(
        thresholds: impl AsRef<[f64]>,
        weights: impl AsRef<[f64]>,
        eigenvalues: impl AsRef<[f64]>,
        sample_time: f64,
    ) -> Result<Self, ParameterError> {
        Self::from_parameters(
            &CreepParameters {
                thresholds: thresholds.as_ref(),
                weights: weights.as_ref(),
                eigenvalues: eigenvalues.as_ref(),
            },
            sample_time,
        )
    }

    /// `C` of checked `parameters`, in the zero state.
    pub fn from_parameters(
        parameters: &CreepParameters<'_>,
        sample_time: f64,
    ) -> Result<Self, ParameterError> {
        parameters.validate(sample_time)?;
        let n = parameters.thresholds.len();
        let m = parameters.eigenvalues.len();
        let field = "creep";
        let mut c = Self {
            thresholds: S::Creep::zeroed(field, n)?,
            weights: S::Creep::zeroed(field, n)?,
            eigenvalues: S::Creep::zeroed(field, m)?,
            sample_time,
            gains: S::Creep::zeroed(field, m)?,
            scaled_weights: S::Creep::zeroed(field, n)?,
            chi: S::Creep::zeroed(field, n.saturating_mul(m))?,
            output: T::ZERO,
            last_input: T::ZERO,
        };
        for (j, &a) in parameters.eigenvalues.iter().enumerate() {
            c.eigenvalues[j] = T::from_f64(a);
            c.gains[j] = T::from_f64(creep_gain(a, sample_time));
        }
        for i in 0..n {
            c.thresholds[i] = T::from_f64(parameters.thresholds[i]);
            c.weights[i] = T::from_f64(parameters.weights[i]);
            c.scaled_weights[i] = T::from_f64(parameters.weights[i] / m as f64);
        }
        Ok(c)
    }

    /// `(n + 1, m)`: thresholds and eigenvalues.
    pub fn shape(&self) -> (usize, usize) {
        (self.thresholds.len(), self.eigenvalues.len())
    }

    /// Thresholds `r_{C,i}`.
    pub fn thresholds(&self) -> &[T] {
        &self.thresholds
    }

    /// Weights `w_{C,i}`.
    pub fn weights(&self) -> &[T] {
        &self.weights
    }

    /// Eigenvalues `a_j` (s⁻¹).
    pub fn eigenvalues(&self) -> &[T] {
        &self.eigenvalues
    }

    /// Sample time `T_s` (s).
    pub fn sample_time(&self) -> f64 {
        self.sample_time
    }

    /// Set `χ` from `state[i * m + j]` (threshold `i`, eigenvalue `j`: the
    /// model file's rows, flattened). Checked before anything changes.
    pub fn set_state_flat(&mut self, state: &[f64]) -> Result<(), ParameterError> {
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

    /// `χ_{ij}` of the next sample, as [`Creep::set_state_flat`] takes it.
    pub fn state_flat_into(&self, state: &mut [f64]) -> Result<(), ParameterError> {
        let (n, m) = self.shape();
        check_length("creep.state", n * m, state.len())?;
        for i in 0..n {
            for j in 0..m {
                state[i * m + j] = self.chi[j * n + i].to_f64();
            }
        }
        Ok(())
    }

    /// Take the whole state of `other`, an operator with the same
    /// parameters in any storage (its `χ`, output and held input).
    pub fn copy_state_from<U: Real, S2: Storage>(
        &mut self,
        other: &Creep<U, S2>,
    ) -> Result<(), ParameterError> {
        check_length("creep.state", self.chi.len(), other.chi.len())?;
        for (x, &y) in self.chi.iter_mut().zip(other.chi.iter()) {
            *x = T::from_f64(y.to_f64());
        }
        self.output = T::from_f64(other.output.to_f64());
        self.last_input = T::from_f64(other.last_input.to_f64());
        Ok(())
    }

    /// The output `C_k` of the current state (before the next input acts).
    #[inline]
    pub fn output(&self) -> T {
        self.output
    }

    /// The outputs `ς_{C,i} = (1/m) Σ_j χ_{i,j}` of the log(t)-creep
    /// operators (15), one per threshold, for the current state: the creep
    /// columns of the identification regressor (25).
    #[inline]
    pub fn log_creep_outputs_into(&self, out: &mut [T]) {
        let (n, m) = self.shape();
        out[..n].copy_from_slice(&self.chi[..n]);
        for row in self.chi.chunks_exact(n).skip(1) {
            for (o, &c) in out.iter_mut().zip(row) {
                *o += c;
            }
        }
        let m = T::from_f64(m as f64);
        for o in &mut out[..n] {
            *o = *o / m;
        }
    }

    /// Advance with `v_k` and return `C_{k+1}`; allocation-free. A
    /// non-finite input is taken as the last finite one: it never enters
    /// the state.
    #[inline]
    pub fn advance(&mut self, v: T) -> T {
        Kernels::detect().run(|k| self.advance_with(k, v))
    }

    /// [`Creep::advance`] compiled for the caller's instruction set, no
    /// run-time dispatch (the same bits).
    #[inline(always)]
    pub fn advance_portable(&mut self, v: T) -> T {
        self.advance_with(Kernels::Portable, v)
    }

    /// On the kernels `k`.
    #[inline(always)]
    pub(crate) fn advance_with(&mut self, k: Kernels, v: T) -> T {
        self.output = simd::creep_advance(
            k,
            &mut self.chi,
            &self.thresholds,
            &self.gains,
            &self.scaled_weights,
            v,
            &mut self.last_input,
        );
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
        self.output = output(&self.chi, &self.scaled_weights);
    }

    /// Back to the zero state.
    pub fn reset(&mut self) {
        self.chi.fill(T::ZERO);
        self.last_input = T::ZERO;
        self.refresh_output();
    }
}
