//! Prandtl–Ishlinskii hysteresis (10): `H[v]_k = Σ_i w_i x_{i,k}` over plays
//! (20), in fixed-capacity storage, and the per-sample kernel the `std`
//! operator shares.

use crate::realtime::error::ParameterError;
use crate::realtime::parameters::{
    check_admissible, check_capacity, check_finite, check_length, HysteresisParameters,
};
use crate::realtime::play::play;
use crate::realtime::real::Real;

/// One sample of `H`: advance every play with `v` and return `Σ w_i x_i`. A
/// non-finite `v` is replaced by `x_0` (the zero-threshold play holds the
/// last input), so it never enters the state.
#[inline(always)]
pub fn step<T: Real>(state: &mut [T], thresholds: &[T], weights: &[T], v: T) -> T {
    let v = if v.is_finite() { v } else { state[0] };
    let mut y = T::ZERO;
    for ((x, &r), &w) in state.iter_mut().zip(thresholds).zip(weights) {
        *x = play(v, r, *x);
        y += w * *x;
    }
    y
}

/// `Σ w_i x_i` in four interleaved partial sums (vectorizes without
/// `-ffast-math`-style reassociation of one running sum).
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
    (a[0] + a[1]) + (a[2] + a[3])
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
