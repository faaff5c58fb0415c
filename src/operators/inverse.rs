//! The analytic inverse of the Prandtl–Ishlinskii operator: the Krejčí–Kuhnen
//! transformation rules (22).
//!
//! With `s_j = Σ_{i≤j} w_i > 0` (11):
//!
//! ```text
//! r'_j = Σ_{i≤j} w_i (r_j − r_i)     computed as r'_j = r'_{j−1} + s_{j−1} (r_j − r_{j−1})
//! w'_0 = 1 / w_0,   w'_j = − w_j / (s_j s_{j−1})
//! x'_j = s_j x_j + Σ_{i>j} w_i x_i
//! ```
//!
//! The recursive form of `r'` adds only positive terms, so it never cancels and
//! keeps `r'` strictly increasing. `H⁻¹` is again a PI operator whose partial
//! sums are `1/s_j`, and applying the rules twice gives back `H` (an involution,
//! up to rounding). `H⁻¹[H[v]] = v` and `H[H⁻¹[y]] = y` hold for admissible,
//! matched states.

use crate::operators::hysteresis::{partial_sums, HysteresisOperator};

/// Thresholds and weights of `H⁻¹` by (22), written into caller buffers.
pub fn inverse_parameters_into(
    thresholds: &[f64],
    weights: &[f64],
    inv_thresholds: &mut [f64],
    inv_weights: &mut [f64],
) {
    let n = thresholds.len();
    assert!(weights.len() == n && inv_thresholds.len() == n && inv_weights.len() == n);
    let mut s_prev = weights[0];
    inv_thresholds[0] = 0.0;
    inv_weights[0] = 1.0 / weights[0];
    for j in 1..n {
        let s = s_prev + weights[j];
        inv_thresholds[j] = inv_thresholds[j - 1] + s_prev * (thresholds[j] - thresholds[j - 1]);
        inv_weights[j] = -weights[j] / (s * s_prev);
        s_prev = s;
    }
}

/// Initial states of `H⁻¹` by (22), `x'_j = s_j x_j + Σ_{i>j} w_i x_i`, from
/// the forward play states `x` and the partial sums `s`. Allocation-free, O(n).
#[inline]
pub fn inverse_state_into(weights: &[f64], sums: &[f64], x: &[f64], inv_state: &mut [f64]) {
    let n = x.len();
    debug_assert!(weights.len() == n && sums.len() == n && inv_state.len() == n);
    let mut tail = 0.0;
    for j in (0..n).rev() {
        inv_state[j] = sums[j] * x[j] + tail;
        tail += weights[j] * x[j];
    }
}

impl HysteresisOperator {
    /// The inverse operator `H⁻¹` with its transformed state, by (22).
    ///
    /// Always exists: the constructor and `set_state` guarantee (11), (12) and
    /// admissibility.
    pub fn inverse(&self) -> HysteresisOperator {
        let n = self.len();
        let mut r = vec![0.0; n];
        let mut w = vec![0.0; n];
        inverse_parameters_into(self.thresholds(), self.weights(), &mut r, &mut w);
        let mut x = vec![0.0; n];
        inverse_state_into(
            self.weights(),
            &partial_sums(self.weights()),
            self.play_states(),
            &mut x,
        );
        HysteresisOperator::from_trusted_parts(r, w, x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rules_are_an_involution() {
        let h =
            HysteresisOperator::new(vec![0.0, 0.3, 1.1, 2.0], vec![0.7, 0.2, -0.3, 0.9]).unwrap();
        let back = h.inverse().inverse();
        for (a, b) in back.thresholds().iter().zip(h.thresholds()) {
            assert!((a - b).abs() <= 8.0 * f64::EPSILON * 2.0);
        }
        for (a, b) in back.weights().iter().zip(h.weights()) {
            assert!((a - b).abs() <= 16.0 * f64::EPSILON);
        }
    }
}
