//! The Prandtl–Ishlinskii hysteresis operator `H` (10)–(12) with the `std`
//! conveniences: heap storage, the object-safe [`Operator`](crate::operators::traits::Operator) and
//! [`Snapshot`] traits (in `f64`, whatever `T`), partial sums and the
//! initial loading curve. The operator itself is
//! [`crate::realtime::Hysteresis`].

use crate::error::ModelError;
use crate::operators::heap::Heap;
use crate::operators::model::ModelFile;
use crate::operators::traits::{InverseHysteresis, Snapshot};
use crate::realtime::{Hysteresis, Real, Storage};

/// `H` in `f64` on the heap: what most programs use.
pub type HysteresisOperator = Hysteresis<f64, Heap>;

impl<S: Storage> Hysteresis<f64, S> {
    /// Partial sums `s_j = Σ_{i≤j} w_i`: the branch slopes, all positive by
    /// (11).
    pub fn partial_sums(&self) -> Vec<f64> {
        partial_sums(self.weights())
    }

    /// The initial loading curve `φ(v) = H[0 → v]` from the virgin state:
    /// `φ(v) = sign(v) Σ w_i max(|v| − r_i, 0)`.
    pub fn initial_loading(&self, v: f64) -> f64 {
        let a = v.abs();
        let s: f64 = self
            .thresholds()
            .iter()
            .zip(self.weights())
            .map(|(&r, &w)| w * (a - r).max(0.0))
            .sum();
        s.copysign(v)
    }
}

impl<T: Real, S: Storage> Hysteresis<T, S> {
    /// `H⁻¹` of a model file's hysteresis by (22), matched to its state.
    pub fn inverse_from_file(file: &ModelFile) -> Result<Self, ModelError> {
        Ok(Self::inverse_of(
            &file.parameters().hysteresis,
            file.hysteresis.state.as_deref(),
        )?)
    }
}

crate::operators::traits::operator_in_any_precision!(Hysteresis);

impl<T: Real, S: Storage> Snapshot for Hysteresis<T, S> {
    type State = Vec<f64>;

    fn state(&self) -> Vec<f64> {
        self.play_states().iter().map(|x| x.to_f64()).collect()
    }

    fn set_state(&mut self, state: &Vec<f64>) -> Result<(), ModelError> {
        Ok(Hysteresis::set_state(self, state)?)
    }
}

/// A PI operator built by (22) is the inverse of another.
impl<T: Real, S: Storage> InverseHysteresis for Hysteresis<T, S> {}

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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::realtime::ParameterError;

    #[test]
    fn slopes_are_partial_sums() {
        // w = (1, 1), r = (0, 1): slope 1 until the second play engages, then 2.
        let mut h = HysteresisOperator::new([0.0, 1.0], [1.0, 1.0]).unwrap();
        assert_eq!(h.step(0.5), 0.5);
        assert_eq!(h.step(1.0), 1.0);
        assert_eq!(h.step(2.0), 3.0);
        // reversal: slope 1 over a band of width 2 r_1
        assert_eq!(h.step(1.0), 2.0);
    }

    #[test]
    fn refuses_broken_parameters_with_the_field_named() {
        let e = HysteresisOperator::new([0.0, 1.0, 1.0], [1.0; 3]).unwrap_err();
        assert!(matches!(
            e,
            ParameterError::ThresholdsNotIncreasing { index: 2, .. }
        ));
        let e = HysteresisOperator::new([0.5, 1.0], [1.0; 2]).unwrap_err();
        assert!(matches!(e, ParameterError::FirstThresholdNotZero { .. }));
        let e = HysteresisOperator::new([0.0, 1.0], [1.0, -1.0]).unwrap_err();
        assert!(matches!(
            e,
            ParameterError::PartialSumNotPositive { index: 1, .. }
        ));
        assert!(e.to_string().contains("hysteresis.weights"));
        let e = HysteresisOperator::new([0.0, 1.0], [1.0]).unwrap_err();
        assert!(matches!(e, ParameterError::LengthMismatch { .. }));
        let e = HysteresisOperator::new([], []).unwrap_err();
        assert!(matches!(e, ParameterError::Empty { .. }));
    }

    #[test]
    fn refuses_inadmissible_state() {
        // x_1 - x_0 = 2 > r_1 - r_0 = 1: no input reaches this state.
        let e = HysteresisOperator::with_state([0.0, 1.0], [1.0, 1.0], [0.0, 2.0]).unwrap_err();
        assert!(matches!(
            e,
            ParameterError::InadmissibleState { index: 1, .. }
        ));
        assert!(HysteresisOperator::with_state([0.0, 1.0], [1.0, 1.0], [0.0, 1.0]).is_ok());
    }

    #[test]
    fn initial_loading_matches_stepping_from_virgin() {
        let mut h = HysteresisOperator::new([0.0, 1.0, 2.5], [0.5, 0.25, -0.125]).unwrap();
        let phi = h.initial_loading(-3.0);
        assert_eq!(h.step(-3.0), phi);
    }
}
