//! The play operator, equations (7)–(9) and its time-discrete form (20).
//!
//! `x_k = max(v_k − r, min(v_k + r, x_{k−1}))`, with the initial consistency
//! condition (8) `x_0 = max(v_0 − r, min(v_0 + r, x_init))`: the stored state is
//! the previous output, so (8) is simply the first step from `x_init`.
//!
//! For an input that is piecewise linear between the samples the discrete play
//! is exact at the samples: its output depends only on the input values at
//! monotonicity changes (rate independence).

use crate::error::ModelError;
use crate::operators::traits::{Operator, Snapshot};

/// One step of the play (20), for `f32` or `f64`; exactly odd:
/// `play(−v, r, −x) == −play(v, r, x)` bit for bit. The dead zone of (14) is
/// the play from the zero state.
pub use crate::realtime::play::play;

/// The dead zone `d_r(z) = max(z − r, min(z + r, 0))` of (14): the play from
/// the zero state.
#[inline(always)]
pub fn dead_zone(z: f64, r: f64) -> f64 {
    play(z, r, 0.0)
}

/// The play operator `P_r` with threshold `r ≥ 0` and state `x`.
#[derive(Debug, Clone, PartialEq)]
pub struct PlayOperator {
    threshold: f64,
    x: f64,
}

impl PlayOperator {
    /// A play in the virgin state `x = 0`.
    pub fn new(threshold: f64) -> Result<Self, ModelError> {
        crate::realtime::checks::check_threshold("threshold", threshold)?;
        Ok(Self { threshold, x: 0.0 })
    }

    /// A play with initial state `x_init` (applied through (8) at the first sample).
    pub fn with_state(threshold: f64, x_init: f64) -> Result<Self, ModelError> {
        let mut p = Self::new(threshold)?;
        p.set_state(&x_init)?;
        Ok(p)
    }

    /// The threshold `r`.
    pub fn threshold(&self) -> f64 {
        self.threshold
    }
}

impl Operator for PlayOperator {
    #[inline]
    fn step(&mut self, v: f64) -> f64 {
        self.x = play(v, self.threshold, self.x);
        self.x
    }

    fn reset(&mut self) {
        self.x = 0.0;
    }
}

impl Snapshot for PlayOperator {
    type State = f64;

    fn state(&self) -> f64 {
        self.x
    }

    fn set_state(&mut self, state: &f64) -> Result<(), ModelError> {
        crate::realtime::checks::check_finite("state", core::slice::from_ref(state))?;
        self.x = *state;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn play_follows_input_outside_the_band_and_holds_inside() {
        let mut p = PlayOperator::new(1.0).unwrap();
        let y: Vec<f64> = [0.5, 2.0, 1.5, 0.5, -1.0]
            .iter()
            .map(|&v| p.step(v))
            .collect();
        assert_eq!(y, vec![0.0, 1.0, 1.0, 1.0, 0.0]);
    }

    #[test]
    fn initial_consistency_condition_clamps_the_initial_state() {
        // (8): x_init = 5 is pulled into [v_0 - r, v_0 + r] = [-1, 1].
        let mut p = PlayOperator::with_state(1.0, 5.0).unwrap();
        assert_eq!(p.step(0.0), 1.0);
    }

    #[test]
    fn negative_or_nan_threshold_is_refused() {
        assert!(PlayOperator::new(-1.0).is_err());
        assert!(PlayOperator::new(f64::NAN).is_err());
        assert!(PlayOperator::with_state(1.0, f64::INFINITY).is_err());
    }

    #[test]
    fn dead_zone_is_zero_inside_and_shifted_outside() {
        assert_eq!(dead_zone(0.5, 1.0), 0.0);
        assert_eq!(dead_zone(3.0, 1.0), 2.0);
        assert_eq!(dead_zone(-3.0, 1.0), -2.0);
    }
}
