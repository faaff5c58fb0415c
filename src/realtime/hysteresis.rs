//! Prandtl–Ishlinskii hysteresis (10)–(12): `H[v]_k = Σ_i w_i x_{i,k}` over
//! plays (20), `x_{i,k} = max(v_k − r_i, min(v_k + r_i, x_{i,k−1}))`, and its
//! per-sample kernel. On a monotone branch the slope is the partial sum
//! `s_j = Σ_{i≤j} w_i` on the `j`-th segment, which is why (11) makes `H`
//! strictly increasing on monotone inputs and invertible.

use crate::realtime::checks::{check_admissible, check_finite, check_length};
use crate::realtime::error::ParameterError;
use crate::realtime::inverse::{inverse_parameters_into, inverse_state_into};
use crate::realtime::parameters::HysteresisParameters;
use crate::realtime::play::{play, play_of_difference};
use crate::realtime::real::{add_term, Real};
use crate::realtime::storage::{Buffer, Storage};

/// One sample of `H`: advance every play with `v` and return `Σ w_i x_i`
/// (summed as [`weighted_sum`] sums). A non-finite `v` is replaced by `x_0`
/// (the zero-threshold play holds the last input), so it never enters the
/// state.
#[inline(always)]
pub(crate) fn step<T: Real>(state: &mut [T], thresholds: &[T], weights: &[T], v: T) -> T {
    step_saving::<T, false>(state, &mut [], thresholds, weights, v, T::ZERO)
}

/// [`step`] with the input `v = t − c` given as its two terms, and with
/// `SAVE` the states before it written to `saved` as it goes (the
/// compensator's copy for a re-seat: block by block, where a separate copy
/// of a run-time length is a call to `memmove` per sample). Each play's
/// bounds are `(t ∓ r) − c` ([`play_of_difference`]): the compensator's
/// `c` is the creep's output, the end of its dependency chain, and so it
/// enters each bound last instead of first. With `c = 0` this is [`step`]
/// (`x − 0 = x` exactly). A non-finite `t − c` is replaced by `x_0`.
#[inline(always)]
pub(crate) fn step_saving<T: Real, const SAVE: bool>(
    state: &mut [T],
    saved: &mut [T],
    thresholds: &[T],
    weights: &[T],
    t: T,
    c: T,
) -> T {
    let (t, c) = if (t - c).is_finite() {
        (t, c)
    } else {
        (state[0], T::ZERO)
    };
    let n = state.len();
    debug_assert!(thresholds.len() == n && weights.len() == n);
    debug_assert!(!SAVE || saved.len() == n);
    let full = n - n % 4;
    let mut acc = [T::ZERO; 4];
    for i0 in (0..full).step_by(4) {
        let x: &mut [T; 4] = (&mut state[i0..i0 + 4]).try_into().unwrap();
        if SAVE {
            let before: &mut [T; 4] = (&mut saved[i0..i0 + 4]).try_into().unwrap();
            *before = *x;
        }
        let r: &[T; 4] = thresholds[i0..i0 + 4].try_into().unwrap();
        let w: &[T; 4] = weights[i0..i0 + 4].try_into().unwrap();
        for l in 0..4 {
            x[l] = play_of_difference(t, c, r[l], x[l]);
        }
        for l in 0..4 {
            acc[l] = add_term(acc[l], w[l], x[l], i0 == 0);
        }
    }
    step_tail::<T, SAVE>(state, saved, thresholds, weights, t, c, full, &mut acc);
    reduce(acc)
}

/// The plays `full..n` that do not fill a block, one by one, into the lanes
/// `i − full` (shared by [`step_saving`] and its vector copies, which save
/// every state as they go).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn step_tail<T: Real, const SAVE: bool>(
    state: &mut [T],
    saved: &mut [T],
    thresholds: &[T],
    weights: &[T],
    t: T,
    c: T,
    full: usize,
    acc: &mut [T; 4],
) {
    for i in full..state.len() {
        if SAVE {
            saved[i] = state[i];
        }
        state[i] = play_of_difference(t, c, thresholds[i], state[i]);
        acc[i - full] = add_term(acc[i - full], weights[i], state[i], full == 0);
    }
}

/// Advance the plays with `v` (20), without the output (the compensator's
/// copy of the plant's plays, after a saturated sample).
#[inline(always)]
pub(crate) fn advance_plays<T: Real>(state: &mut [T], thresholds: &[T], v: T) {
    for (x, &r) in state.iter_mut().zip(thresholds) {
        *x = play(v, r, *x);
    }
}

/// [`advance_plays`] with every threshold widened by `widening` (the
/// rate-dependent thresholds of [`crate::realtime::rate`]).
#[inline(always)]
pub(crate) fn advance_plays_widened<T: Real>(state: &mut [T], thresholds: &[T], v: T, widening: T) {
    for (x, &r) in state.iter_mut().zip(thresholds) {
        *x = play(v, r + widening, *x);
    }
}

/// `Σ w_i x_i` in four partial sums, lane `l` adding the terms `i ≡ l mod
/// 4` in order, from its first product, each later term fused with the sum
/// ([`add_term`]) (SIMD without `-ffast-math`-style reassociation: the
/// order is fixed, the same for every instruction set), then [`reduce`]d.
#[inline(always)]
pub(crate) fn weighted_sum<T: Real>(w: &[T], x: &[T]) -> T {
    let mut a = [T::ZERO; 4];
    let wc = w.chunks_exact(4);
    let xc = x.chunks_exact(4);
    let (wr, xr) = (wc.remainder(), xc.remainder());
    let full = wc.len();
    for (k, (w4, x4)) in wc.zip(xc).enumerate() {
        for l in 0..4 {
            a[l] = add_term(a[l], w4[l], x4[l], k == 0);
        }
    }
    for l in 0..wr.len() {
        a[l] = add_term(a[l], wr[l], xr[l], full == 0);
    }
    reduce(a)
}

/// The four partial sums added as `(a₀ + a₂) + (a₁ + a₃)`: the two halves
/// of a 4-lane register, then its two lanes, with no shuffle in between.
#[inline(always)]
pub(crate) fn reduce<T: Real>(a: [T; 4]) -> T {
    (a[0] + a[2]) + (a[1] + a[3])
}

/// The Prandtl–Ishlinskii hysteresis operator `H` (10): plays (20) with
/// thresholds `0 = r_0 < … < r_n` (12) and weights whose partial sums are
/// positive (11), in `T`, kept in storage `S` ([`Inline`] or `Heap`).
///
/// A state is *admissible* if some input drives the virgin state (all
/// zeros) to it; equivalently `|x_i − x_{i−1}| ≤ r_i − r_{i−1}`. The inverse
/// (22) relies on it, so states set from outside are checked.
///
/// [`Inline`]: crate::realtime::Inline
#[derive(Debug, Clone, PartialEq)]
pub struct Hysteresis<T: Real, S: Storage> {
    thresholds: S::Plays<T>,
    weights: S::Plays<T>,
    state: S::Plays<T>,
}

impl<T: Real, S: Storage> Hysteresis<T, S> {
    /// `H` with checked thresholds (12) and weights (11), virgin.
    pub fn new(
        thresholds: impl AsRef<[f64]>,
        weights: impl AsRef<[f64]>,
    ) -> Result<Self, ParameterError> {
        Self::from_parameters(&HysteresisParameters {
            thresholds: thresholds.as_ref(),
            weights: weights.as_ref(),
        })
    }

    /// `H` with initial play states `x_init` (applied through (8) at the
    /// first sample), which must be admissible.
    pub fn with_state(
        thresholds: impl AsRef<[f64]>,
        weights: impl AsRef<[f64]>,
        state: impl AsRef<[f64]>,
    ) -> Result<Self, ParameterError> {
        let mut h = Self::new(thresholds, weights)?;
        h.set_state(state.as_ref())?;
        Ok(h)
    }

    /// `H` of checked `parameters`, virgin.
    pub fn from_parameters(parameters: &HysteresisParameters<'_>) -> Result<Self, ParameterError> {
        parameters.validate()?;
        Self::from_trusted(parameters.thresholds, parameters.weights, None)
    }

    /// From parameters (and a state) already checked, rounded to `T`; only
    /// the capacity can refuse.
    pub(crate) fn from_trusted(
        r: &[f64],
        w: &[f64],
        x: Option<&[f64]>,
    ) -> Result<Self, ParameterError> {
        let field = "hysteresis.thresholds";
        let mut h = Self {
            thresholds: S::Plays::zeroed(field, r.len())?,
            weights: S::Plays::zeroed(field, r.len())?,
            state: S::Plays::zeroed(field, r.len())?,
        };
        for i in 0..r.len() {
            h.thresholds[i] = T::from_f64(r[i]);
            h.weights[i] = T::from_f64(w[i]);
            if let Some(x) = x {
                h.state[i] = T::from_f64(x[i]);
            }
        }
        Ok(h)
    }

    /// `H⁻¹` of the hysteresis `parameters` by the rules (22), its plays
    /// matched to `state` of `H` (or virgin); transformed in `f64`.
    pub fn inverse_of(
        parameters: &HysteresisParameters<'_>,
        state: Option<&[f64]>,
    ) -> Result<Self, ParameterError> {
        parameters.validate()?;
        Self::inverse_built(parameters, state)
    }

    /// [`Hysteresis::inverse_of`] of parameters checked before (the state,
    /// an input of its own, is checked here).
    pub(crate) fn inverse_built(
        parameters: &HysteresisParameters<'_>,
        state: Option<&[f64]>,
    ) -> Result<Self, ParameterError> {
        let n = parameters.thresholds.len();
        let field = "hysteresis.thresholds";
        let mut r = S::Plays::<f64>::zeroed(field, n)?;
        let mut w = S::Plays::<f64>::zeroed(field, n)?;
        inverse_parameters_into(parameters.thresholds, parameters.weights, &mut r, &mut w);
        let mut x = S::Plays::<f64>::zeroed(field, n)?;
        if let Some(state) = state {
            check_length("hysteresis.state", n, state.len())?;
            check_finite("hysteresis.state", state)?;
            check_admissible(
                "hysteresis.state",
                parameters.thresholds,
                state,
                f64::EPSILON,
            )?;
            let mut sums = S::Plays::<f64>::zeroed(field, n)?;
            partial_sums_into(parameters.weights, &mut sums);
            inverse_state_into(parameters.weights, &sums, state, &mut x);
        }
        Self::from_trusted(&r, &w, Some(&x))
    }

    /// `H⁻¹` of this operator by the rules (22), matched to its state.
    pub fn inverse(&self) -> Self {
        // buffers of the right length: copies, every value overwritten
        let (mut r, mut w) = (self.thresholds.clone(), self.weights.clone());
        let (mut x, mut sums) = (self.state.clone(), self.weights.clone());
        inverse_parameters_into(&self.thresholds, &self.weights, &mut r, &mut w);
        partial_sums_into(&self.weights, &mut sums);
        inverse_state_into(&self.weights, &sums, &self.state, &mut x);
        Self {
            thresholds: r,
            weights: w,
            state: x,
        }
    }

    /// The number of plays `n + 1`.
    pub fn len(&self) -> usize {
        self.thresholds.len()
    }

    pub fn is_empty(&self) -> bool {
        self.thresholds.is_empty()
    }

    /// The thresholds `r_i`.
    pub fn thresholds(&self) -> &[T] {
        &self.thresholds
    }

    /// The weights `w_i`.
    pub fn weights(&self) -> &[T] {
        &self.weights
    }

    /// The play states `x_i` after the last step.
    pub fn play_states(&self) -> &[T] {
        &self.state
    }

    pub(crate) fn state_mut(&mut self) -> &mut [T] {
        &mut self.state
    }

    /// Thresholds, weights and the mutable state.
    #[inline(always)]
    pub(crate) fn parts_mut(&mut self) -> (&[T], &[T], &mut [T]) {
        (&self.thresholds, &self.weights, &mut self.state)
    }

    /// [`Self::parts_mut`] for a step compiled for `K` plays
    /// ([`Buffer::prefix`]: ask only with `K` plays).
    #[inline(always)]
    pub(crate) fn prefix_parts_mut<const K: usize>(&mut self) -> (&[T], &[T], &mut [T]) {
        (
            self.thresholds.prefix::<K>(),
            self.weights.prefix::<K>(),
            self.state.prefix_mut::<K>(),
        )
    }

    /// Set the play states (checked: length, finite, admissible).
    pub fn set_state(&mut self, x: &[f64]) -> Result<(), ParameterError> {
        let n = self.len();
        check_length("hysteresis.state", n, x.len())?;
        check_finite("hysteresis.state", x)?;
        let mut r = S::Plays::<f64>::zeroed("hysteresis.state", n)?;
        for (ri, &t) in r.iter_mut().zip(self.thresholds()) {
            *ri = t.to_f64();
        }
        check_admissible("hysteresis.state", &r, x, T::EPSILON.to_f64())?;
        for (s, &xi) in self.state.iter_mut().zip(x) {
            *s = T::from_f64(xi);
        }
        Ok(())
    }

    /// One sample; allocation-free, a non-finite input is held out.
    #[inline]
    pub fn step(&mut self, v: T) -> T {
        step(&mut self.state, &self.thresholds, &self.weights, v)
    }

    /// One sample with every threshold widened by `widening ≥ 0` (the
    /// rate-dependent thresholds of [`crate::realtime::rate`]); with 0 it
    /// is [`Self::step`] bit for bit. `v` finite.
    #[inline]
    pub(crate) fn step_widened(&mut self, v: T, widening: T) -> T {
        advance_plays_widened(&mut self.state, &self.thresholds, v, widening);
        weighted_sum(&self.weights, &self.state)
    }

    /// The output `Σ w_i x_i` of the current state.
    pub fn output(&self) -> T {
        weighted_sum(&self.weights, &self.state)
    }

    /// Back to the virgin state.
    pub fn reset(&mut self) {
        self.state.fill(T::ZERO);
    }
}

/// `s_j = Σ_{i≤j} w_i`, summed in order.
pub(crate) fn partial_sums_into<T: Real>(weights: &[T], sums: &mut [T]) {
    let mut s = T::ZERO;
    for (si, &w) in sums.iter_mut().zip(weights) {
        s += w;
        *si = s;
    }
}
