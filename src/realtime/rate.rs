//! Rate-dependent thresholds of `H` (docs/MATHEMATICS.md §4.3): every play
//! of (20) steps with its threshold widened by the input's rate,
//!
//! ```text
//! x_i ← max(v_k − ρ_k, min(v_k + ρ_k, x_i)) with ρ_k = r_i + g |v_k − v_{k−1}|,  g = β/T_s,
//! ```
//!
//! so that a fast input opens the loop as a piezo stage's does. The model
//! file's `hysteresis.rate_gain` is `β` (s); `0 ≤ β < T_s` keeps each step
//! continuous and (with non-negative weights) monotone in its input. The
//! first sample after a start has no rate (`v_{k−1}` unknown): its
//! thresholds are the `r_i`.

use crate::realtime::play::play;
use crate::realtime::real::{add_term, Real};

/// The widening `g |v_k − v_{k−1}|` of the thresholds at each sample, and
/// the last input it needs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RateGain<T: Real> {
    /// `β` (s), as given.
    rate_gain: f64,
    /// `g = β/T_s`.
    gain: T,
    last: Option<T>,
}

impl<T: Real> RateGain<T> {
    /// `β` and `T_s` checked already (`0 < β < T_s`).
    pub(crate) fn new(rate_gain: f64, sample_time: f64) -> Self {
        Self {
            rate_gain,
            gain: T::from_f64(rate_gain / sample_time),
            last: None,
        }
    }

    /// `β` (s).
    pub fn rate_gain(&self) -> f64 {
        self.rate_gain
    }

    /// `g = β/T_s`, the widening per unit of input change.
    pub fn gain(&self) -> T {
        self.gain
    }

    /// The input of the last sample (`None`: not started).
    pub fn last_input(&self) -> Option<T> {
        self.last
    }

    /// Set the last input (`None`: not started); a finite value, checked
    /// by the caller.
    pub(crate) fn set_last_input(&mut self, last: Option<T>) {
        self.last = last;
    }

    /// The widening a step to `v` would have: `g |v − v_{k−1}|`, none
    /// before the first step.
    #[inline(always)]
    pub(crate) fn widening_at(&self, v: T) -> T {
        match self.last {
            Some(l) => {
                let d = v - l;
                self.gain * if d < T::ZERO { -d } else { d }
            }
            None => T::ZERO,
        }
    }

    /// The widening for input `v` (finite), which becomes the last input.
    #[inline(always)]
    pub(crate) fn widen(&mut self, v: T) -> T {
        let widening = self.widening_at(v);
        self.last = Some(v);
        widening
    }

    /// Not started.
    pub(crate) fn reset(&mut self) {
        self.last = None;
    }
}

/// `Σ w_i x_i` of the plays stepped with input `u` and the thresholds
/// widened by `widening`, the states unchanged: the output the forward
/// step ([`crate::realtime::Hysteresis`]) would give, summed in its order
/// (four lanes, `i ≡ l mod 4`, then `(a₀ + a₂) + (a₁ + a₃)`).
#[inline]
pub(crate) fn output_at<T: Real>(x: &[T], thresholds: &[T], weights: &[T], u: T, widening: T) -> T {
    let mut lanes = [T::ZERO; 4];
    let full = x.len() - x.len() % 4;
    for (i, ((&x, &r), &w)) in x.iter().zip(thresholds).zip(weights).enumerate() {
        let p = play(u, r + widening, x);
        // a term of the tail goes to lane `i − full`, first in it only when
        // no block came before (as `weighted_sum` adds them)
        let (lane, first) = if i < full {
            (i % 4, i < 4)
        } else {
            (i - full, full == 0)
        };
        lanes[lane] = add_term(lanes[lane], w, p, first);
    }
    (lanes[0] + lanes[2]) + (lanes[1] + lanes[3])
}

/// The inverse of one step of `H` with rate-dependent thresholds: the
/// least input `u` (the greatest, downwards), from the last input `last`
/// (0 before the first step) in the target's direction, whose step
/// output reaches `target`, to the resolution of `T`. With non-negative
/// weights and `g < 1` the output is continuous and non-decreasing in `u`
/// (docs/MATHEMATICS.md §4.3), so the input is bracketed by doubling steps
/// and then bisected down to neighbouring numbers of `T`: at most about
/// `2 × 64` evaluations of `n` plays in `f64`. (The `f64` operator of
/// `operators::rate_dependent` walks the sorted pieces instead, which
/// needs a buffer of `2n` of them.) A target beyond the output's reach in
/// `T` gives an infinite input, which the caller clips. Allocation-free.
pub(crate) fn invert_step<T: Real>(
    x: &[T],
    thresholds: &[T],
    weights: &[T],
    rate: &RateGain<T>,
    target: T,
) -> T {
    let from = rate.last.unwrap_or(T::ZERO);
    let f = |u: T| output_at(x, thresholds, weights, u, rate.widening_at(u));
    let at_from = f(from);
    if at_from == target {
        return from;
    }
    // `reached(u)`: the output at `u` has reached the target in the
    // direction of the search
    let up = target > at_from;
    let reached = |u: T| {
        let y = f(u);
        if up {
            y >= target
        } else {
            y <= target
        }
    };
    // bracket: `near` has not reached the target, `far` has
    let (mut near, mut far) = (from, from);
    let mut step = T::ONE;
    loop {
        far = if up { far + step } else { far - step };
        if !far.is_finite() {
            return far;
        }
        if reached(far) {
            break;
        }
        near = far;
        step = step + step;
    }
    // bisect to neighbours: the midpoint of neighbours is one of them
    loop {
        let mid = near + (far - near) / (T::ONE + T::ONE);
        if mid == near || mid == far {
            return far;
        }
        if reached(mid) {
            far = mid;
        } else {
            near = mid;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::realtime::{Hysteresis, Inline};

    /// `output_at` is the forward step's output, bit for bit, for every
    /// number of plays (blocks of four and a tail).
    #[test]
    fn the_output_at_an_input_is_the_steps() {
        for n in 1..=11 {
            let r: [f64; 11] = core::array::from_fn(|i| 7.0 * i as f64);
            let w: [f64; 11] = core::array::from_fn(|i| 1.0 / (1.0 + i as f64));
            let (r, w) = (&r[..n], &w[..n]);
            let mut h = Hysteresis::<f64, Inline<16, 1>>::new(r, w).unwrap();
            for (k, u) in [30.0, -12.5, 44.0, 3.25].into_iter().enumerate() {
                let widening = 0.3 * k as f64;
                let expected = output_at(h.play_states(), r, w, u, widening);
                assert_eq!(h.step_widened(u, widening).to_bits(), expected.to_bits());
            }
        }
    }
}
