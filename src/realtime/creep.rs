//! PI creep (13)–(18): the operator with its state and parameters; its
//! per-sample kernel is `creep_pass` (portable) and
//! `simd` (dispatched).
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

use crate::realtime::checks::{check_finite, check_length};
use crate::realtime::creep_pass::output;
use crate::realtime::error::ParameterError;
use crate::realtime::parameters::CreepParameters;
#[cfg(all(feature = "std", target_arch = "x86_64"))]
use crate::realtime::placement::chi_start;
use crate::realtime::placement::SLACK;
use crate::realtime::real::Real;
use crate::realtime::simd::{self, Kernels};
use crate::realtime::storage::{Buffer, Storage};

/// `1 − e^{−a T_s}` without cancellation (`−expm1(−aT_s)`; the literal form
/// loses five digits at `a = 0.05 s⁻¹`, `T_s = 0.2 ms`).
///
/// Always the `libm` crate's `expm1`, with or without `std`: `std`'s calls
/// the platform's C library, whose results differ in the last bit between
/// platforms (mingw-w64's from glibc's at two of the nominal five gains),
/// and a gain that differs in one bit changes every output after it.
#[inline]
pub fn creep_gain(eigenvalue: f64, sample_time: f64) -> f64 {
    -libm::expm1(-eigenvalue * sample_time)
}

/// A PI creep operator `C` (16): `n + 1` log(t)-creep operators (15) of `m`
/// elementary operators (13)–(14) each, thresholds as (18), weights with
/// non-negative partial sums (17), in `T`, kept in storage `S`.
#[derive(Debug, Clone)]
pub struct Creep<T: Real, S: Storage> {
    // what a step reads and writes first, the parameters as given after
    thresholds: S::Creep<T>,
    /// `1 − e^{−a_j T_s}` per eigenvalue and `w_i / m` per threshold.
    gains: S::Creep<T>,
    scaled_weights: S::Creep<T>,
    /// `χ[j * n + i]` (eigenvalue `j`, threshold `i`) from `chi_start` on,
    /// placed so that no register's worth straddles a page
    /// ([`placement`](crate::realtime::placement)) for the buffer at
    /// `chi_placed_at`.
    chi: S::CreepState<T>,
    chi_start: usize,
    // kept on every target: one layout, one C storage size per word size
    #[cfg_attr(not(all(feature = "std", target_arch = "x86_64")), allow(dead_code))]
    chi_placed_at: usize,
    /// The output of the current state, kept so `output()` is O(1).
    output: T,
    /// The last finite input, held in place of a non-finite one.
    last_input: T,
    weights: S::Creep<T>,
    eigenvalues: S::Creep<T>,
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

    /// `C` of `parameters` at `sample_time`, checked here, in the zero
    /// state.
    pub fn from_parameters(
        parameters: &CreepParameters<'_>,
        sample_time: f64,
    ) -> Result<Self, ParameterError> {
        parameters.validate(sample_time)?;
        Self::build(parameters, sample_time)
    }

    /// `C` of parameters checked before; only the capacity can refuse.
    pub(crate) fn build(
        parameters: &CreepParameters<'_>,
        sample_time: f64,
    ) -> Result<Self, ParameterError> {
        let n = parameters.thresholds.len();
        let m = parameters.eigenvalues.len();
        let field = "creep";
        let mut c = Self {
            thresholds: S::Creep::zeroed(field, n)?,
            weights: S::Creep::zeroed(field, n)?,
            eigenvalues: S::Creep::zeroed(field, m)?,
            gains: S::Creep::zeroed(field, m)?,
            scaled_weights: S::Creep::zeroed(field, n)?,
            chi: S::CreepState::zeroed(field, n.saturating_mul(m))?,
            chi_start: 0,
            chi_placed_at: 0,
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

    /// Set `χ` from `state[i * m + j]` (threshold `i`, eigenvalue `j`: the
    /// model file's rows, flattened), its zeros `+0` (no state holds a
    /// `−0`: see `creep_pass::advance`). Checked before anything changes.
    pub fn set_state_flat(&mut self, state: &[f64]) -> Result<(), ParameterError> {
        let (n, m) = self.shape();
        check_length("creep.state", n * m, state.len())?;
        check_finite("creep.state", state)?;
        for i in 0..n {
            for j in 0..m {
                // `+ 0`: `−0` (or a value that rounds to it in `T`) to `+0`
                self.chi_mut()[j * n + i] = T::from_f64(state[i * m + j]) + T::ZERO;
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
                state[i * m + j] = self.chi()[j * n + i].to_f64();
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
        check_length("creep.state", self.chi().len(), other.chi().len())?;
        for (x, &y) in self.chi_mut().iter_mut().zip(other.chi()) {
            // `+ 0`: a value that rounds to `−0` in `T` to `+0`
            *x = T::from_f64(y.to_f64()) + T::ZERO;
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
        out[..n].copy_from_slice(&self.chi()[..n]);
        for row in self.chi().chunks_exact(n).skip(1) {
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
        // `move`: `v` travels with the closure, not by reference through
        // memory (a store and a load on a chain that feeds the output back:
        // 11 cycles of 87 measured)
        Kernels::detect().run(move |k| self.advance_with(k, v))
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
        self.place_chi();
        let start = self.chi_offset();
        self.output = simd::creep_advance(
            k,
            placed_mut(&mut self.chi, start),
            &self.thresholds,
            &self.gains,
            &self.scaled_weights,
            v,
            &mut self.last_input,
        );
        self.output
    }

    /// The state, parameters, last input and output a compensator step's
    /// kernel works on.
    #[inline(always)]
    pub(crate) fn step_parts(&mut self) -> simd::CreepParts<'_, T> {
        self.place_chi();
        let start = self.chi_offset();
        simd::CreepParts {
            chi: placed_mut(&mut self.chi, start),
            thresholds: &self.thresholds,
            gains: &self.gains,
            weights: &self.scaled_weights,
            last_input: &mut self.last_input,
            output: &mut self.output,
        }
    }

    /// [`Self::step_parts`] for the step compiled for the paper's layout
    /// ([`simd::PAPER_CREEP`]; [`Buffer::prefix`]: ask only with that
    /// layout).
    #[inline(always)]
    pub(crate) fn paper_step_parts(&mut self) -> simd::CreepParts<'_, T> {
        const NC: usize = simd::PAPER_CREEP.0;
        const M: usize = simd::PAPER_CREEP.1;
        self.place_chi();
        // `≤ SLACK` (`min` tells the compiler, which then checks nothing)
        let start = self.chi_offset().min(SLACK);
        simd::CreepParts {
            chi: &mut self.chi.prefix_mut::<{ NC * M + SLACK }>()[start..][..NC * M],
            thresholds: self.thresholds.prefix::<NC>(),
            gains: self.gains.prefix::<M>(),
            weights: self.scaled_weights.prefix::<NC>(),
            last_input: &mut self.last_input,
            output: &mut self.output,
        }
    }

    /// `C_k`, then advance with `v_k`.
    #[inline]
    pub fn step(&mut self, v: T) -> T {
        let out = self.output;
        self.advance(v);
        out
    }

    fn refresh_output(&mut self) {
        self.output = output(self.chi(), &self.scaled_weights);
    }

    /// Where `χ` starts in its buffer: always 0 where it is not placed
    /// (a constant the compiler folds into the slicing).
    #[inline(always)]
    fn chi_offset(&self) -> usize {
        if cfg!(all(feature = "std", target_arch = "x86_64")) {
            self.chi_start
        } else {
            0
        }
    }

    /// `χ`, wherever it starts in its buffer.
    #[inline(always)]
    fn chi(&self) -> &[T] {
        let start = self.chi_offset();
        &self.chi[start..start + self.chi.len() - SLACK]
    }

    /// `χ`, mutable.
    #[inline(always)]
    fn chi_mut(&mut self) -> &mut [T] {
        let start = self.chi_offset();
        placed_mut(&mut self.chi, start)
    }

    /// Places `χ` for its buffer's address if it has not been placed for
    /// it (a new object, or one moved since): a compare and a predicted
    /// branch per step, and a copy of `χ` in the first step after a move.
    /// Only where the vector kernels run (x86-64 with `std`): elsewhere
    /// `χ` stays at the buffer's start (a Cortex-M has no pages, and its
    /// worst step would carry the copy).
    #[inline(always)]
    fn place_chi(&mut self) {
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        {
            let at = self.chi.as_ptr() as usize;
            if at != self.chi_placed_at {
                self.place_chi_at(at);
            }
        }
    }

    /// Moves `χ` to the start [`chi_start`] gives for the buffer at `at`.
    #[cfg(all(feature = "std", target_arch = "x86_64"))]
    #[cold]
    #[inline(never)]
    fn place_chi_at(&mut self, at: usize) {
        let (n, len) = (self.thresholds.len(), self.chi.len() - SLACK);
        let start = chi_start(at, size_of::<T>(), n, len);
        self.chi
            .copy_within(self.chi_start..self.chi_start + len, start);
        self.chi_start = start;
        self.chi_placed_at = at;
    }

    /// Back to the zero state.
    pub fn reset(&mut self) {
        self.chi_mut().fill(T::ZERO);
        self.last_input = T::ZERO;
        self.refresh_output();
    }
}

/// `χ` in its buffer (which holds [`SLACK`] values more) from `start`
/// on: a function of the buffer alone, so that a step can borrow `χ`
/// beside the operator's other fields.
#[inline(always)]
fn placed_mut<T>(buffer: &mut [T], start: usize) -> &mut [T] {
    let end = start + buffer.len() - SLACK;
    &mut buffer[start..end]
}

/// Equal when the parameters and states are, wherever `χ` lies in its
/// buffer.
impl<T: Real, S: Storage> PartialEq for Creep<T, S> {
    fn eq(&self, other: &Self) -> bool {
        self.thresholds == other.thresholds
            && self.gains == other.gains
            && self.scaled_weights == other.scaled_weights
            && self.chi() == other.chi()
            && self.output == other.output
            && self.last_input == other.last_input
            && self.weights == other.weights
            && self.eigenvalues == other.eigenvalues
    }
}
