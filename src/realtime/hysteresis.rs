//! Prandtl–Ishlinskii hysteresis (10): `H[v]_k = Σ_i w_i x_{i,k}` over plays
//! (20), in fixed-capacity storage, and the per-sample kernel the `std`
//! operator shares.

use crate::realtime::error::ParameterError;
use crate::realtime::parameters::{
    check_admissible, check_capacity, check_finite, check_length, HysteresisParameters,
};
use crate::realtime::play::play;
use crate::realtime::real::Real;

/// One sample of `H`: advance every play with `v` and return `Σ w_i x_i`
/// (summed as [`weighted_sum`] sums). A non-finite `v` is replaced by `x_0`
/// (the zero-threshold play holds the last input), so it never enters the
/// state.
#[inline(always)]
pub fn step<T: Real>(state: &mut [T], thresholds: &[T], weights: &[T], v: T) -> T {
    let v = if v.is_finite() { v } else { state[0] };
    let n = state.len();
    debug_assert!(thresholds.len() == n && weights.len() == n);
    let full = n - n % 4;
    let mut acc = [T::ZERO; 4];
    for i0 in (0..full).step_by(4) {
        let x: &mut [T; 4] = (&mut state[i0..i0 + 4]).try_into().unwrap();
        let r: &[T; 4] = thresholds[i0..i0 + 4].try_into().unwrap();
        let w: &[T; 4] = weights[i0..i0 + 4].try_into().unwrap();
        for l in 0..4 {
            x[l] = play(v, r[l], x[l]);
        }
        for l in 0..4 {
            acc[l] += w[l] * x[l];
        }
    }
    for i in full..n {
        state[i] = play(v, thresholds[i], state[i]);
        acc[i - full] += weights[i] * state[i];
    }
    reduce(acc)
}

/// [`step`], with the `f64` blocks in explicit AVX registers when `SIMD` is
/// set and the CPU has AVX2: the same operations in the same order, so the
/// same bits (see [`crate::realtime::creep::advance_fast`]).
#[inline(always)]
pub fn step_fast<T: Real, const SIMD: bool>(
    state: &mut [T],
    thresholds: &[T],
    weights: &[T],
    v: T,
) -> T {
    #[cfg(all(feature = "std", target_arch = "x86_64"))]
    if SIMD && crate::realtime::simd::avx2_in_use() {
        use crate::realtime::simd::{as_f64, as_f64_mut};
        let v = if v.is_finite() { v } else { state[0] };
        if let (Some(x), Some(r), Some(w)) =
            (as_f64_mut(state), as_f64(thresholds), as_f64(weights))
        {
            // SAFETY: the CPU has AVX2 (checked above).
            return T::from_f64(unsafe { avx2_f64(x, r, w, v.to_f64()) });
        }
    }
    step(state, thresholds, weights, v)
}

/// The blocks of [`step`] for `f64` in AVX registers; `v` is finite.
#[cfg(all(feature = "std", target_arch = "x86_64"))]
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn avx2_f64(state: &mut [f64], thresholds: &[f64], weights: &[f64], v: f64) -> f64 {
    use core::arch::x86_64::*;
    let n = state.len();
    assert!(thresholds.len() == n && weights.len() == n);
    let full = n - n % 4;
    let vv = _mm256_set1_pd(v);
    let mut acc = _mm256_setzero_pd();
    for i0 in (0..full).step_by(4) {
        // SAFETY: i0 + 4 ≤ n for all three slices.
        let at = state.as_mut_ptr().add(i0);
        let r = _mm256_loadu_pd(thresholds.as_ptr().add(i0));
        let x = _mm256_loadu_pd(at);
        let x = _mm256_max_pd(_mm256_min_pd(x, _mm256_add_pd(vv, r)), _mm256_sub_pd(vv, r));
        _mm256_storeu_pd(at, x);
        acc = _mm256_add_pd(
            acc,
            _mm256_mul_pd(_mm256_loadu_pd(weights.as_ptr().add(i0)), x),
        );
    }
    let mut lanes = [0.0f64; 4];
    _mm256_storeu_pd(lanes.as_mut_ptr(), acc);
    for i in full..n {
        state[i] = play(v, thresholds[i], state[i]);
        lanes[i - full] += weights[i] * state[i];
    }
    reduce(lanes)
}

/// Advance the plays with `v` (20), without the output (the compensator's
/// copy of the plant's plays); AVX for `f64` as in [`step_fast`].
#[inline(always)]
pub fn advance_plays<T: Real, const SIMD: bool>(state: &mut [T], thresholds: &[T], v: T) {
    #[cfg(all(feature = "std", target_arch = "x86_64"))]
    if SIMD && crate::realtime::simd::avx2_in_use() {
        use crate::realtime::simd::{as_f64, as_f64_mut};
        if let (Some(x), Some(r)) = (as_f64_mut(state), as_f64(thresholds)) {
            // SAFETY: the CPU has AVX2 (checked above).
            unsafe { avx2_plays_f64(x, r, v.to_f64()) };
            return;
        }
    }
    for (x, &r) in state.iter_mut().zip(thresholds) {
        *x = play(v, r, *x);
    }
}

#[cfg(all(feature = "std", target_arch = "x86_64"))]
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn avx2_plays_f64(state: &mut [f64], thresholds: &[f64], v: f64) {
    use core::arch::x86_64::*;
    let n = state.len();
    assert!(thresholds.len() == n);
    let full = n - n % 4;
    let vv = _mm256_set1_pd(v);
    for i0 in (0..full).step_by(4) {
        // SAFETY: i0 + 4 ≤ n for both slices.
        let at = state.as_mut_ptr().add(i0);
        let r = _mm256_loadu_pd(thresholds.as_ptr().add(i0));
        let x = _mm256_loadu_pd(at);
        let x = _mm256_max_pd(_mm256_min_pd(x, _mm256_add_pd(vv, r)), _mm256_sub_pd(vv, r));
        _mm256_storeu_pd(at, x);
    }
    for i in full..n {
        state[i] = play(v, thresholds[i], state[i]);
    }
}

/// `Σ w_i x_i` in four partial sums, lane `l` adding the terms `i ≡ l mod
/// 4` in order (SIMD without `-ffast-math`-style reassociation: the order
/// is fixed, the same for every instruction set), then [`reduce`]d.
#[inline(always)]
pub fn weighted_sum<T: Real>(w: &[T], x: &[T]) -> T {
    let mut a = [T::ZERO; 4];
    let wc = w.chunks_exact(4);
    let xc = x.chunks_exact(4);
    let (wr, xr) = (wc.remainder(), xc.remainder());
    for (w4, x4) in wc.zip(xc) {
        for l in 0..4 {
            a[l] += w4[l] * x4[l];
        }
    }
    for l in 0..wr.len() {
        a[l] += wr[l] * xr[l];
    }
    reduce(a)
}

/// The four partial sums added as `(a₀ + a₂) + (a₁ + a₃)`: the two halves
/// of a 4-lane register, then its two lanes, with no shuffle in between.
#[inline(always)]
pub fn reduce<T: Real>(a: [T; 4]) -> T {
    (a[0] + a[2]) + (a[1] + a[3])
}

/// A PI hysteresis operator (10) with at most `N` plays.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FixedHysteresis<T: Real, const N: usize> {
    len: usize,
    thresholds: [T; N],
    weights: [T; N],
    state: [T; N],
}

impl<T: Real, const N: usize> FixedHysteresis<T, N> {
    /// `H` with checked parameters (11), (12), in the virgin state.
    pub fn new(parameters: &HysteresisParameters<'_>) -> Result<Self, ParameterError> {
        parameters.validate()?;
        check_capacity("hysteresis.thresholds", N, parameters.thresholds.len())?;
        Ok(Self::from_trusted(
            parameters.thresholds,
            parameters.weights,
            None,
        ))
    }

    /// From parameters (and a state) already checked, rounded to `T`.
    pub(crate) fn from_trusted(r: &[f64], w: &[f64], x: Option<&[f64]>) -> Self {
        let len = r.len();
        let mut h = Self {
            len,
            thresholds: [T::ZERO; N],
            weights: [T::ZERO; N],
            state: [T::ZERO; N],
        };
        for i in 0..len {
            h.thresholds[i] = T::from_f64(r[i]);
            h.weights[i] = T::from_f64(w[i]);
            if let Some(x) = x {
                h.state[i] = T::from_f64(x[i]);
            }
        }
        h
    }

    /// The number of plays `n + 1`.
    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    pub fn thresholds(&self) -> &[T] {
        &self.thresholds[..self.len]
    }

    pub fn weights(&self) -> &[T] {
        &self.weights[..self.len]
    }

    /// The play states `x_i` after the last step.
    pub fn state(&self) -> &[T] {
        &self.state[..self.len]
    }

    pub(crate) fn state_mut(&mut self) -> &mut [T] {
        &mut self.state[..self.len]
    }

    /// Set the play states (checked: finite, admissible).
    pub fn set_state(&mut self, x: &[f64]) -> Result<(), ParameterError> {
        check_length("hysteresis.state", self.len, x.len())?;
        check_finite("hysteresis.state", x)?;
        let mut r = [0.0f64; N];
        for (ri, &t) in r.iter_mut().zip(self.thresholds()) {
            *ri = t.to_f64();
        }
        check_admissible("hysteresis.state", &r[..self.len], x, T::EPSILON.to_f64())?;
        for (s, &xi) in self.state.iter_mut().zip(x) {
            *s = T::from_f64(xi);
        }
        Ok(())
    }

    /// One sample; allocation-free, a non-finite input is held out.
    #[inline]
    pub fn step(&mut self, v: T) -> T {
        let n = self.len;
        step(
            &mut self.state[..n],
            &self.thresholds[..n],
            &self.weights[..n],
            v,
        )
    }

    /// The output `Σ w_i x_i` of the current state.
    pub fn output(&self) -> T {
        weighted_sum(self.weights(), self.state())
    }

    pub fn reset(&mut self) {
        self.state = [T::ZERO; N];
    }
}

impl<T: Real, const N: usize> FixedHysteresis<T, N> {
    /// Thresholds, weights and the mutable state, at the run-time length.
    #[inline(always)]
    pub(crate) fn parts_mut(&mut self) -> (&[T], &[T], &mut [T]) {
        let n = self.len;
        (
            &self.thresholds[..n],
            &self.weights[..n],
            &mut self.state[..n],
        )
    }
}

impl<T: Real, const N: usize> FixedHysteresis<T, N> {
    /// `H⁻¹` of the hysteresis `parameters` by the rules (22), its plays
    /// matched to `state` of `H` (or virgin); transformed in `f64`.
    pub fn inverse_of(
        parameters: &HysteresisParameters<'_>,
        state: Option<&[f64]>,
    ) -> Result<Self, ParameterError> {
        parameters.validate()?;
        let n = parameters.thresholds.len();
        check_capacity("hysteresis.thresholds", N, n)?;
        let mut r = [0.0f64; N];
        let mut w = [0.0f64; N];
        crate::realtime::inverse::inverse_parameters_into(
            parameters.thresholds,
            parameters.weights,
            &mut r[..n],
            &mut w[..n],
        );
        let mut x = [0.0f64; N];
        if let Some(state) = state {
            check_length("hysteresis.state", n, state.len())?;
            check_finite("hysteresis.state", state)?;
            check_admissible(
                "hysteresis.state",
                parameters.thresholds,
                state,
                f64::EPSILON,
            )?;
            let mut sums = [0.0f64; N];
            let mut s = 0.0;
            for (si, &wi) in sums.iter_mut().zip(parameters.weights) {
                s += wi;
                *si = s;
            }
            crate::realtime::inverse::inverse_state_into(
                parameters.weights,
                &sums[..n],
                state,
                &mut x[..n],
            );
        }
        Ok(Self::from_trusted(&r[..n], &w[..n], Some(&x[..n])))
    }
}
