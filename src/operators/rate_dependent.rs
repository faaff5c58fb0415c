//! A PI hysteresis operator whose thresholds grow with the input rate, and
//! its exact inverse (docs/MATHEMATICS.md §4.3, "the other candidate").
//!
//! Each play `i` of `H` (10) steps with the threshold
//! `ρ_i = r_i + g |u_k − u_{k−1}|`, `g = β/T_s`, the rate dependence of a
//! piezo stage's loops (Al Janaideh–Krejčí), which the synthetic lab
//! records ([`crate::suite::records`]) are made with:
//!
//! ```text
//! x_i ← max(u_k − ρ_i, min(u_k + ρ_i, x_i)),     y_k = Σ w_i x_i
//! ```
//!
//! With `0 ≤ g < 1`, non-negative weights and `w_0 > 0`, `y_k` is a
//! continuous, piecewise-linear, non-decreasing function of `u_k` (its
//! slopes are sums of `w_i (1 − g)`, `0` and `w_i (1 + g)`) that takes
//! every value. It can be flat near `u_{k−1}`: under the rate even play 0
//! has a threshold, `g|Δu|`. [`RateDependentHysteresis::invert`] walks the
//! pieces from `u_{k−1}` and stops at the first input that gives `y_k`; on
//! a flat piece (where rounding decides which of its inputs) every weighted
//! play is flat too, so they all leave the same play states. With `g = 0`
//! it is `H`.
//!
//! This is the operator and its inverse in `f64`. The model steps the same
//! thresholds (`hysteresis.rate_gain`, [`crate::realtime::RateGain`]) and
//! the identification fits `β` ([`crate::identification::rate_gain`]); the
//! real-time compensator inverts them by bisection, which needs no buffer
//! of sorted pieces.

use std::vec::Vec;

use crate::realtime::checks::{check_finite, check_sample_time, check_thresholds};
use crate::realtime::error::ParameterError;
use crate::realtime::play::play;

/// `H` with rate-dependent thresholds `r_i + g |Δu|`, in `f64` (module
/// docs).
#[derive(Debug)]
pub struct RateDependentHysteresis {
    thresholds: Vec<f64>,
    weights: Vec<f64>,
    /// `g = β/T_s`, in `[0, 1)`.
    gain: f64,
    plays: Vec<f64>,
    /// The last input, `None` before the first step (which therefore has
    /// no rate).
    last: Option<f64>,
    /// The inverse's pieces: where a play's slope changes, and by how much
    /// (preallocated: a step allocates nothing).
    changes: Vec<(f64, f64)>,
}

// by hand: a derived clone's scratch would have no capacity, and its
// first inverse steps would allocate
impl Clone for RateDependentHysteresis {
    fn clone(&self) -> Self {
        Self {
            thresholds: self.thresholds.clone(),
            weights: self.weights.clone(),
            gain: self.gain,
            plays: self.plays.clone(),
            last: self.last,
            changes: Vec::with_capacity(2 * self.thresholds.len()),
        }
    }
}

/// Equal parameters and state (the inverse's scratch aside).
impl PartialEq for RateDependentHysteresis {
    fn eq(&self, other: &Self) -> bool {
        self.thresholds == other.thresholds
            && self.weights == other.weights
            && self.gain == other.gain
            && self.plays == other.plays
            && self.last == other.last
    }
}

impl RateDependentHysteresis {
    /// `thresholds` as in (12) (`r_0 = 0`, increasing), non-negative
    /// `weights` with `w_0 > 0`, and `0 ≤ β < T_s` (`rate_gain`, s), so
    /// that every step is strictly increasing in its input. Virgin.
    pub fn new(
        thresholds: &[f64],
        weights: &[f64],
        rate_gain: f64,
        sample_time: f64,
    ) -> Result<Self, ParameterError> {
        check_thresholds("thresholds", thresholds)?;
        check_finite("weights", weights)?;
        if weights.len() != thresholds.len() {
            return Err(ParameterError::LengthMismatch {
                field: "weights",
                expected: thresholds.len(),
                found: weights.len(),
            });
        }
        if let Some((index, &value)) = weights.iter().enumerate().find(|(_, &w)| w < 0.0) {
            return Err(ParameterError::NegativeWeight {
                field: "weights",
                index,
                value,
            });
        }
        if weights[0] <= 0.0 {
            return Err(ParameterError::PartialSumNotPositive {
                field: "weights",
                index: 0,
                sum: weights[0],
            });
        }
        check_sample_time(sample_time)?;
        if !(rate_gain.is_finite() && rate_gain >= 0.0 && rate_gain < sample_time) {
            return Err(ParameterError::OutOfHalfOpenRange {
                field: "rate_gain",
                value: rate_gain,
                lower: 0.0,
                upper: sample_time,
            });
        }
        Ok(Self {
            thresholds: thresholds.to_vec(),
            weights: weights.to_vec(),
            gain: rate_gain / sample_time,
            plays: vec![0.0; thresholds.len()],
            last: None,
            changes: Vec::with_capacity(2 * thresholds.len()),
        })
    }

    /// The play states `x_i`.
    pub fn play_states(&self) -> &[f64] {
        &self.plays
    }

    /// A forward model of any weights and `0 ≤ g < 1`, unchecked: the
    /// synthetic records' actuator, whose last weight is negative. Its
    /// steps are monotone only under `new`'s conditions, so it is never
    /// inverted.
    #[cfg(feature = "suite")]
    pub(crate) fn forward_only(thresholds: Vec<f64>, weights: Vec<f64>, gain: f64) -> Self {
        let n = thresholds.len();
        Self {
            thresholds,
            weights,
            gain,
            plays: vec![0.0; n],
            last: None,
            changes: Vec::new(),
        }
    }

    /// The last input, `None` before the first step.
    pub fn last_input(&self) -> Option<f64> {
        self.last
    }

    /// The thresholds `r_i`.
    pub fn thresholds(&self) -> &[f64] {
        &self.thresholds
    }

    /// The weights `w_i`.
    pub fn weights(&self) -> &[f64] {
        &self.weights
    }

    /// `g = β/T_s`.
    pub fn gain(&self) -> f64 {
        self.gain
    }

    /// One step: the output for input `u`. A non-finite `u` gives NaN and
    /// leaves the state as it was.
    pub fn step(&mut self, u: f64) -> f64 {
        if !u.is_finite() {
            return f64::NAN;
        }
        let grow = self.last.map_or(0.0, |l| self.gain * (u - l).abs());
        self.last = Some(u);
        let mut y = 0.0;
        for ((x, &r), &w) in self
            .plays
            .iter_mut()
            .zip(&self.thresholds)
            .zip(&self.weights)
        {
            *x = play(u, r + grow, *x);
            y += w * *x;
        }
        y
    }

    /// The output a step with input `u` would give, the state unchanged
    /// (on a copy: it allocates).
    pub fn output_at(&self, u: f64) -> f64 {
        self.clone().step(u)
    }

    /// The exact inverse: the first input `u` from the last one whose step
    /// gives `y`, and that step taken. A non-finite `y` gives NaN and
    /// leaves the state as it was. Allocation-free.
    pub fn invert(&mut self, y: f64) -> f64 {
        if !y.is_finite() {
            return f64::NAN;
        }
        // before the first step there is no rate: any point serves as the
        // start of the walk
        let (from, gain) = match self.last {
            Some(l) => (l, self.gain),
            None => (0.0, 0.0),
        };
        let at_from = self
            .plays
            .iter()
            .zip(&self.thresholds)
            .zip(&self.weights)
            .map(|((&x, &r), &w)| w * play(from, r, x))
            .sum::<f64>();
        // downwards is upwards in the mirror image (the play is odd)
        let sign = if y >= at_from { 1.0 } else { -1.0 };
        let u = sign * self.walk_up(sign, sign * from, gain, sign * at_from, sign * y);
        self.step(u);
        u
    }

    /// The input `u ≥ l` where the mirrored output (`sign`) reaches
    /// `target ≥ start`, walking the pieces from `l`.
    fn walk_up(&mut self, sign: f64, l: f64, g: f64, start: f64, target: f64) -> f64 {
        // For u ≥ l, play i gives clamp(x, lo(u), hi(u)) with
        // lo(u) = (1 − g)u + gl − r and hi(u) = (1 + g)u − gl + r: slope
        // 1 + g while x > hi, 0 while lo ≤ x ≤ hi, 1 − g once lo > x.
        self.changes.clear();
        let mut slope = 0.0;
        for ((&x, &r), &w) in self.plays.iter().zip(&self.thresholds).zip(&self.weights) {
            let x = sign * x;
            if x > l + r {
                slope += w * (1.0 + g);
                self.changes
                    .push(((x + g * l - r) / (1.0 + g), -w * (1.0 + g)));
                self.changes
                    .push(((x + r - g * l) / (1.0 - g), w * (1.0 - g)));
            } else if x > l - r {
                self.changes
                    .push(((x + r - g * l) / (1.0 - g), w * (1.0 - g)));
            } else {
                slope += w * (1.0 - g);
            }
        }
        self.changes.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
        let (mut u, mut y) = (l, start);
        if y >= target {
            return u;
        }
        for &(at, change) in &self.changes {
            let at = at.max(u);
            let next = y + slope * (at - u);
            if next >= target {
                // the input lies in [u, at]; the slope, a sum of changes,
                // may be a rounding residue where it should be 0
                return if slope > 0.0 {
                    (u + (target - y) / slope).clamp(u, at)
                } else {
                    u
                };
            }
            (u, y) = (at, next);
            slope += change;
        }
        // past the last change every play follows lo: slope ≥ w_0 (1 − g) > 0
        u + (target - y) / slope
    }
}
