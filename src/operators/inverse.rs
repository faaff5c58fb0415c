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

#[cfg(test)]
mod tests {
    use crate::operators::hysteresis::HysteresisOperator;

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
