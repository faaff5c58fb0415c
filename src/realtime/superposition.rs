//! The superposition operator `S` of the modified Prandtl–Ishlinskii model
//! (Kuhnen 2003, the paper's reference \[8\]): a memory-free, strictly
//! increasing, piecewise-linear map applied after `H + C`, which gives the
//! loops an asymmetric shape.
//!
//! `S[z] = Σ_i w_i d_{r_i}(z)` with thresholds `r_{−m} < … < r_0 = 0 < … <
//! r_p` and one-sided dead zones `d_0(z) = z`, `d_r(z) = max(z − r, 0)` for
//! `r > 0`, `min(z − r, 0)` for `r < 0`. On the segment between two
//! neighbouring thresholds the slope is the sum of the weights from `r_0`
//! out to the inner one; `S` is strictly increasing, hence invertible,
//! exactly when every such sum is positive.
//!
//! The inverse is a superposition operator again (`docs/MATHEMATICS.md`):
//! thresholds `r'_i = S(r_i)`, weights `w'_0 = 1/w_0` and
//! `w'_i = −w_i / (σ_i σ_{i∓1})`, with `σ_i` the slope outward of `r_i` and
//! `σ_{i∓1}` the one inward of it.

use crate::realtime::error::ParameterError;
use crate::realtime::parameters::{zero_index, SuperpositionParameters};
use crate::realtime::real::Real;
use crate::realtime::storage::{Buffer, Storage};

/// `S[z]` with the zero threshold at `zero`: the dead zones above and below
/// it each summed outward, then `w_0 z + (above + below)`. Summed that way a
/// mirrored `S` (odd) gives `S[−z] = −S[z]` bit for bit.
#[inline(always)]
pub(crate) fn apply<T: Real>(thresholds: &[T], weights: &[T], zero: usize, z: T) -> T {
    let mut above = T::ZERO;
    for j in zero + 1..thresholds.len() {
        let d = z - thresholds[j];
        above += weights[j] * if d > T::ZERO { d } else { T::ZERO };
    }
    let mut below = T::ZERO;
    for j in (0..zero).rev() {
        let d = z - thresholds[j];
        below += weights[j] * if d < T::ZERO { d } else { T::ZERO };
    }
    weights[zero] * z + (above + below)
}

/// Thresholds and weights of `S⁻¹` from those of `S` (checked), in `f64`:
/// on each side of the zero threshold, outward, `r'_j = r'_{j∓1} + σ_{j∓1}
/// (r_j − r_{j∓1})` (the value of `S` at `r_j`, accumulated segment by
/// segment) and `w'_j = −w_j / (σ_j σ_{j∓1})`.
pub(crate) fn inverse_parameters_into(
    r: &[f64],
    w: &[f64],
    zero: usize,
    mut put: impl FnMut(usize, f64, f64),
) {
    put(zero, 0.0, 1.0 / w[zero]);
    let mut side = |indices: &mut dyn Iterator<Item = usize>| {
        let (mut inner, mut slope, mut value) = (zero, w[zero], 0.0);
        for j in indices {
            value += slope * (r[j] - r[inner]);
            let outer = slope + w[j];
            put(j, value, -w[j] / (outer * slope));
            (inner, slope) = (j, outer);
        }
    };
    side(&mut (zero + 1..r.len()));
    side(&mut (0..zero).rev());
}

/// The superposition operator `S` in `T`, kept in storage `S` (memory-free:
/// no state).
#[derive(Debug, Clone, PartialEq)]
pub struct Superposition<T: Real, St: Storage> {
    thresholds: St::Superposition<T>,
    weights: St::Superposition<T>,
    /// The index of the zero threshold.
    zero: usize,
}

impl<T: Real, St: Storage> Superposition<T, St> {
    /// `S` with checked thresholds and weights.
    pub fn new(
        thresholds: impl AsRef<[f64]>,
        weights: impl AsRef<[f64]>,
    ) -> Result<Self, ParameterError> {
        Self::from_parameters(&SuperpositionParameters {
            thresholds: thresholds.as_ref(),
            weights: weights.as_ref(),
        })
    }

    /// `S` of `parameters`, checked here.
    pub fn from_parameters(
        parameters: &SuperpositionParameters<'_>,
    ) -> Result<Self, ParameterError> {
        parameters.validate()?;
        Self::build(parameters)
    }

    /// `S` of parameters checked before; only the capacity can refuse.
    pub(crate) fn build(parameters: &SuperpositionParameters<'_>) -> Result<Self, ParameterError> {
        let mut s = Self::zeroed(parameters.thresholds)?;
        for (i, (&r, &w)) in parameters
            .thresholds
            .iter()
            .zip(parameters.weights)
            .enumerate()
        {
            s.thresholds[i] = T::from_f64(r);
            s.weights[i] = T::from_f64(w);
        }
        Ok(s)
    }

    /// `S⁻¹` of the superposition `parameters` by the inverse rules,
    /// transformed in `f64`, then rounded to `T`.
    pub fn inverse_of(parameters: &SuperpositionParameters<'_>) -> Result<Self, ParameterError> {
        parameters.validate()?;
        Self::inverse_built(parameters)
    }

    /// [`Superposition::inverse_of`] of parameters checked before.
    pub(crate) fn inverse_built(
        parameters: &SuperpositionParameters<'_>,
    ) -> Result<Self, ParameterError> {
        let mut s = Self::zeroed(parameters.thresholds)?;
        inverse_parameters_into(
            parameters.thresholds,
            parameters.weights,
            s.zero,
            |j, r, w| {
                s.thresholds[j] = T::from_f64(r);
                s.weights[j] = T::from_f64(w);
            },
        );
        Ok(s)
    }

    /// Zeros in the shape of (checked) `thresholds`.
    fn zeroed(thresholds: &[f64]) -> Result<Self, ParameterError> {
        let field = "superposition.thresholds";
        Ok(Self {
            thresholds: St::Superposition::zeroed(field, thresholds.len())?,
            weights: St::Superposition::zeroed(field, thresholds.len())?,
            zero: zero_index(thresholds).ok_or(ParameterError::NoZeroThreshold { field })?,
        })
    }

    /// `S[z]`; allocation-free. A non-finite `z` gives a non-finite result
    /// (the model and the compensator hand it finite values only).
    #[inline]
    pub fn apply(&self, z: T) -> T {
        apply(&self.thresholds, &self.weights, self.zero, z)
    }

    /// The thresholds `r_i`, increasing, one of them 0.
    pub fn thresholds(&self) -> &[T] {
        &self.thresholds
    }

    /// The weights `w_i`.
    pub fn weights(&self) -> &[T] {
        &self.weights
    }
}

impl<St: Storage> Superposition<f64, St> {
    /// The parameters, borrowed.
    pub fn parameters(&self) -> SuperpositionParameters<'_> {
        SuperpositionParameters {
            thresholds: &self.thresholds,
            weights: &self.weights,
        }
    }
}
