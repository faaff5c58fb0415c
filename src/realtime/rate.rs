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

use crate::realtime::real::Real;

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

    /// The widening for input `v` (finite), which becomes the last input.
    #[inline(always)]
    pub(crate) fn widen(&mut self, v: T) -> T {
        let widening = match self.last {
            Some(l) => {
                let d = v - l;
                self.gain * if d < T::ZERO { -d } else { d }
            }
            None => T::ZERO,
        };
        self.last = Some(v);
        widening
    }

    /// Not started.
    pub(crate) fn reset(&mut self) {
        self.last = None;
    }
}
