//! The threshold-discrete Prandtl–Ishlinskii hysteresis operator, equations
//! (10)–(12) with the time-discrete play of (20).
//!
//! `H[v]_k = Σ_{i=0..n} w_i x_{i,k}`, `x_{i,k} = max(v_k − r_i, min(v_k + r_i, x_{i,k−1}))`,
//! thresholds `0 = r_0 < r_1 < … < r_n` (12) and weights whose partial sums
//! `s_j = Σ_{i≤j} w_i` are all positive (11); single weights may be negative.
//! On a monotone branch the slope is `s_j` on the `j`-th segment, which is why
//! (11) makes `H` strictly increasing on monotone inputs and invertible.
//!
//! A state is *admissible* if some input drives the virgin state (all zeros) to
//! it; equivalently `|x_i − x_{i−1}| ≤ r_i − r_{i−1}` for `i ≥ 1` (with
//! `x_0` the last input). The inverse (22) relies on it, so states set from
//! outside are checked.

use crate::error::ModelError;
use crate::operators::traits::{InverseHysteresis, Operator, Snapshot};
use crate::realtime;
use crate::realtime::parameters;

/// The Prandtl–Ishlinskii hysteresis operator `H` (10).
#[derive(Debug, Clone, PartialEq)]
pub struct HysteresisOperator {
    thresholds: Vec<f64>,
    weights: Vec<f64>,
    state: Vec<f64>,
}

impl HysteresisOperator {
    /// A PI operator in the virgin state. Checks (12) for the thresholds and
    /// (11) for the weights.
    pub fn new(thresholds: Vec<f64>, weights: Vec<f64>) -> Result<Self, ModelError> {
        check_thresholds("hysteresis.thresholds", &thresholds)?;
        check_finite("hysteresis.weights", &weights)?;
        check_length("hysteresis.weights", thresholds.len(), weights.len())?;
        check_partial_sums_positive("hysteresis.weights", &weights)?;
        let state = vec![0.0; thresholds.len()];
        Ok(Self {
            thresholds,
            weights,
            state,
        })
    }

    /// A PI operator with initial play states `x_init` (applied through (8) at
    /// the first sample), which must be admissible.
    pub fn with_state(
        thresholds: Vec<f64>,
        weights: Vec<f64>,
        state: Vec<f64>,
    ) -> Result<Self, ModelError> {
        let mut h = Self::new(thresholds, weights)?;
        h.set_state(&state)?;
        Ok(h)
    }

    /// Build from parts already known to satisfy (11), (12) and admissibility,
    /// such as the output of the transformation rules (22).
    pub(crate) fn from_trusted_parts(
        thresholds: Vec<f64>,
        weights: Vec<f64>,
        state: Vec<f64>,
    ) -> Self {
        debug_assert_eq!(thresholds.len(), weights.len());
        debug_assert_eq!(thresholds.len(), state.len());
        Self {
            thresholds,
            weights,
            state,
        }
    }

    /// Number of plays `n + 1`.
    pub fn len(&self) -> usize {
        self.thresholds.len()
    }

    /// Never true: a PI operator has at least the play with `r_0 = 0`.
    pub fn is_empty(&self) -> bool {
        self.thresholds.is_empty()
    }

    /// Thresholds `r_0 = 0 < r_1 < … < r_n`.
    pub fn thresholds(&self) -> &[f64] {
        &self.thresholds
    }

    /// Weights `w_0, …, w_n`.
    pub fn weights(&self) -> &[f64] {
        &self.weights
    }

    /// Play states `x_0, …, x_n` (the last outputs of the plays).
    pub fn play_states(&self) -> &[f64] {
        &self.state
    }

    /// Thresholds, weights and the mutable play states (the compensator's view).
    #[inline(always)]
    pub(crate) fn parts_mut(&mut self) -> (&[f64], &[f64], &mut [f64]) {
        (&self.thresholds, &self.weights, &mut self.state)
    }

    /// Partial sums `s_j = Σ_{i≤j} w_i`: the branch slopes, all positive by (11).
    pub fn partial_sums(&self) -> Vec<f64> {
        partial_sums(&self.weights)
    }

    /// The output `Σ w_i x_i` of the current state (the last output).
    pub fn output(&self) -> f64 {
        weighted_sum(&self.weights, &self.state)
    }

    /// The initial loading curve `φ(v) = H[0 → v]` from the virgin state:
    /// `φ(v) = sign(v) Σ w_i max(|v| − r_i, 0)`.
    pub fn initial_loading(&self, v: f64) -> f64 {
        let a = v.abs();
        let s: f64 = self
            .thresholds
            .iter()
            .zip(&self.weights)
            .map(|(&r, &w)| w * (a - r).max(0.0))
            .sum();
        s.copysign(v)
    }
}

impl Operator for HysteresisOperator {
    /// A non-finite input is taken as the previous one held: the state
    /// does not change and the last output is returned.
    #[inline]
    fn step(&mut self, v: f64) -> f64 {
        // the play with r_0 = 0 holds the last input
        realtime::hysteresis::step(&mut self.state, &self.thresholds, &self.weights, v)
    }

    fn reset(&mut self) {
        self.state.fill(0.0);
    }
}

impl Snapshot for HysteresisOperator {
    type State = Vec<f64>;

    fn state(&self) -> Vec<f64> {
        self.state.clone()
    }

    fn set_state(&mut self, state: &Vec<f64>) -> Result<(), ModelError> {
        check_length("hysteresis.state", self.thresholds.len(), state.len())?;
        check_finite("hysteresis.state", state)?;
        check_admissible("hysteresis.state", &self.thresholds, state)?;
        self.state.copy_from_slice(state);
        Ok(())
    }
}

/// A PI operator built by (22) is the inverse of another.
impl InverseHysteresis for HysteresisOperator {}

pub(crate) use crate::realtime::hysteresis::weighted_sum;

/// Partial sums `s_j = Σ_{i≤j} w_i`.
pub fn partial_sums(weights: &[f64]) -> Vec<f64> {
    let mut s = 0.0;
    weights
        .iter()
        .map(|&w| {
            s += w;
            s
        })
        .collect()
}

// The conditions live in the real-time core; these keep the `String` field
// names the heap operators build (`creep.state[3]`).
pub(crate) fn check_finite(field: &str, values: &[f64]) -> Result<(), ModelError> {
    parameters::check_finite("", values).map_err(|e| e.named(field))
}

pub(crate) fn check_length(field: &str, expected: usize, found: usize) -> Result<(), ModelError> {
    parameters::check_length("", expected, found).map_err(|e| e.named(field))
}

/// (12)/(18): finite, `r_0 = 0`, strictly increasing.
pub(crate) fn check_thresholds(field: &str, r: &[f64]) -> Result<(), ModelError> {
    parameters::check_thresholds("", r).map_err(|e| e.named(field))
}

/// (11): every partial sum strictly positive.
pub(crate) fn check_partial_sums_positive(field: &str, w: &[f64]) -> Result<(), ModelError> {
    parameters::check_partial_sums("", w, true).map_err(|e| e.named(field))
}

/// Admissibility `|x_i − x_{i−1}| ≤ r_i − r_{i−1}` up to rounding.
pub(crate) fn check_admissible(field: &str, r: &[f64], x: &[f64]) -> Result<(), ModelError> {
    parameters::check_admissible("", r, x, f64::EPSILON).map_err(|e| e.named(field))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::realtime::ParameterError;

    #[test]
    fn slopes_are_partial_sums() {
        // w = (1, 1), r = (0, 1): slope 1 until the second play engages, then 2.
        let mut h = HysteresisOperator::new(vec![0.0, 1.0], vec![1.0, 1.0]).unwrap();
        assert_eq!(h.step(0.5), 0.5);
        assert_eq!(h.step(1.0), 1.0);
        assert_eq!(h.step(2.0), 3.0);
        // reversal: slope 1 over a band of width 2 r_1
        assert_eq!(h.step(1.0), 2.0);
    }

    #[test]
    fn refuses_broken_parameters_with_the_field_named() {
        let e = HysteresisOperator::new(vec![0.0, 1.0, 1.0], vec![1.0; 3]).unwrap_err();
        assert!(matches!(
            e.parameter(),
            Some(ParameterError::ThresholdsNotIncreasing { index: 2, .. })
        ));
        let e = HysteresisOperator::new(vec![0.5, 1.0], vec![1.0; 2]).unwrap_err();
        assert!(matches!(
            e.parameter(),
            Some(ParameterError::FirstThresholdNotZero { .. })
        ));
        let e = HysteresisOperator::new(vec![0.0, 1.0], vec![1.0, -1.0]).unwrap_err();
        assert!(matches!(
            e.parameter(),
            Some(ParameterError::PartialSumNotPositive { index: 1, .. })
        ));
        assert!(e.to_string().contains("hysteresis.weights"));
        let e = HysteresisOperator::new(vec![0.0, 1.0], vec![1.0]).unwrap_err();
        assert!(matches!(
            e.parameter(),
            Some(ParameterError::LengthMismatch { .. })
        ));
        let e = HysteresisOperator::new(vec![], vec![]).unwrap_err();
        assert!(matches!(e.parameter(), Some(ParameterError::Empty { .. })));
    }

    #[test]
    fn refuses_inadmissible_state() {
        // x_1 - x_0 = 2 > r_1 - r_0 = 1: no input reaches this state.
        let e = HysteresisOperator::with_state(vec![0.0, 1.0], vec![1.0, 1.0], vec![0.0, 2.0])
            .unwrap_err();
        assert!(matches!(
            e.parameter(),
            Some(ParameterError::InadmissibleState { index: 1, .. })
        ));
        assert!(
            HysteresisOperator::with_state(vec![0.0, 1.0], vec![1.0, 1.0], vec![0.0, 1.0]).is_ok()
        );
    }

    #[test]
    fn initial_loading_matches_stepping_from_virgin() {
        let mut h = HysteresisOperator::new(vec![0.0, 1.0, 2.5], vec![0.5, 0.25, -0.125]).unwrap();
        let phi = h.initial_loading(-3.0);
        assert_eq!(h.step(-3.0), phi);
    }
}
