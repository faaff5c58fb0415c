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
use crate::operators::play::play;
use crate::operators::traits::{InverseHysteresis, Operator, Snapshot};

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

    /// Mutable access for the compensator, which rebuilds states by (22).
    pub(crate) fn play_states_mut(&mut self) -> &mut [f64] {
        &mut self.state
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
        let v = if v.is_finite() { v } else { self.state[0] };
        let mut y = 0.0;
        for ((x, &r), &w) in self
            .state
            .iter_mut()
            .zip(&self.thresholds)
            .zip(&self.weights)
        {
            *x = play(v, r, *x);
            y += w * *x;
        }
        y
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

/// `Σ w_i x_i` in four interleaved partial sums, `(a_0 + a_1) + (a_2 + a_3)`
/// with `a_l = Σ_{i ≡ l mod 4} w_i x_i`: the order every operator here uses.
/// Four independent chains instead of one cut the latency of the dot product
/// that ends every step.
#[inline(always)]
pub(crate) fn weighted_sum(w: &[f64], x: &[f64]) -> f64 {
    let mut a = [0.0f64; 4];
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

pub(crate) fn check_finite(field: &str, values: &[f64]) -> Result<(), ModelError> {
    match values.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(ModelError::NonFinite {
            field: field.into(),
            index,
            value: values[index],
        }),
        None => Ok(()),
    }
}

pub(crate) fn check_length(field: &str, expected: usize, found: usize) -> Result<(), ModelError> {
    if expected == found {
        Ok(())
    } else {
        Err(ModelError::LengthMismatch {
            field: field.into(),
            expected,
            found,
        })
    }
}

/// (12)/(18): finite, `r_0 = 0`, strictly increasing.
pub(crate) fn check_thresholds(field: &str, r: &[f64]) -> Result<(), ModelError> {
    if r.is_empty() {
        return Err(ModelError::Empty {
            field: field.into(),
        });
    }
    check_finite(field, r)?;
    if r[0] != 0.0 {
        return Err(ModelError::FirstThresholdNotZero {
            field: field.into(),
            value: r[0],
        });
    }
    for i in 1..r.len() {
        if r[i] <= r[i - 1] {
            return Err(ModelError::ThresholdsNotIncreasing {
                field: field.into(),
                index: i,
                previous: r[i - 1],
                value: r[i],
            });
        }
    }
    Ok(())
}

/// (11): every partial sum strictly positive.
pub(crate) fn check_partial_sums_positive(field: &str, w: &[f64]) -> Result<(), ModelError> {
    for (index, sum) in partial_sums(w).into_iter().enumerate() {
        if sum <= 0.0 {
            return Err(ModelError::PartialSumNotPositive {
                field: field.into(),
                index,
                sum,
            });
        }
    }
    Ok(())
}

/// Admissibility `|x_i − x_{i−1}| ≤ r_i − r_{i−1}`, allowing rounding of the
/// size the clamps and (22) make: `8 (n+1) ε (max|x| + r_n)`.
pub(crate) fn check_admissible(field: &str, r: &[f64], x: &[f64]) -> Result<(), ModelError> {
    let n = r.len();
    let scale = x.iter().fold(0.0f64, |m, v| m.max(v.abs())) + r[n - 1];
    let tol = 8.0 * n as f64 * f64::EPSILON * scale;
    for i in 1..n {
        let gap = (x[i] - x[i - 1]).abs();
        let allowed = r[i] - r[i - 1];
        if gap > allowed + tol {
            return Err(ModelError::InadmissibleState {
                field: field.into(),
                index: i,
                gap,
                allowed,
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

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
            e,
            ModelError::ThresholdsNotIncreasing { index: 2, .. }
        ));
        let e = HysteresisOperator::new(vec![0.5, 1.0], vec![1.0; 2]).unwrap_err();
        assert!(matches!(e, ModelError::FirstThresholdNotZero { .. }));
        let e = HysteresisOperator::new(vec![0.0, 1.0], vec![1.0, -1.0]).unwrap_err();
        assert!(matches!(
            e,
            ModelError::PartialSumNotPositive { index: 1, .. }
        ));
        assert!(e.to_string().contains("hysteresis.weights"));
        let e = HysteresisOperator::new(vec![0.0, 1.0], vec![1.0]).unwrap_err();
        assert!(matches!(e, ModelError::LengthMismatch { .. }));
        let e = HysteresisOperator::new(vec![], vec![]).unwrap_err();
        assert!(matches!(e, ModelError::Empty { .. }));
    }

    #[test]
    fn refuses_inadmissible_state() {
        // x_1 - x_0 = 2 > r_1 - r_0 = 1: no input reaches this state.
        let e = HysteresisOperator::with_state(vec![0.0, 1.0], vec![1.0, 1.0], vec![0.0, 2.0])
            .unwrap_err();
        assert!(matches!(e, ModelError::InadmissibleState { index: 1, .. }));
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
