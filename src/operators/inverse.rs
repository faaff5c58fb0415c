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

pub use crate::realtime::inverse::{inverse_parameters_into, inverse_state_into};

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
