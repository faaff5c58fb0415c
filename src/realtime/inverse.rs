//! The Krejčí–Kuhnen transformation rules (22): `H⁻¹` is another PI operator
//!
//! * `r'_j = Σ_{i<j} w_i (r_j − r_i)`, computed as
//!   `r'_j = r'_{j−1} + s_{j−1} (r_j − r_{j−1})`,
//! * `w'_0 = 1/w_0`, `w'_j = −w_j / (s_j s_{j−1})`,
//! * `x'_j = Σ_i w_i x_{min(i,j)} = s_j x_j + Σ_{i>j} w_i x_i`,
//!
//! with the partial sums `s_j = Σ_{i≤j} w_i` of (11). The state rule is
//! invertible (the `s_j` are positive), which lets the compensator keep only
//! the states of `H⁻¹`.

use crate::realtime::real::Real;

/// Thresholds and weights of `H⁻¹` from those of `H` (all slices of one
/// length `n + 1 ≥ 1`).
pub(crate) fn inverse_parameters_into<T: Real>(
    thresholds: &[T],
    weights: &[T],
    inv_thresholds: &mut [T],
    inv_weights: &mut [T],
) {
    let n = thresholds.len();
    assert!(weights.len() == n && inv_thresholds.len() == n && inv_weights.len() == n);
    let mut s_prev = weights[0];
    inv_thresholds[0] = T::ZERO;
    inv_weights[0] = T::ONE / weights[0];
    for j in 1..n {
        let s = s_prev + weights[j];
        inv_thresholds[j] = inv_thresholds[j - 1] + s_prev * (thresholds[j] - thresholds[j - 1]);
        inv_weights[j] = -weights[j] / (s * s_prev);
        s_prev = s;
    }
}

/// The play states of `H⁻¹` matching the states `x` of `H` (22), given the
/// weights and their partial sums. Allocation-free: the compensator calls it
/// on saturation.
#[inline]
pub(crate) fn inverse_state_into<T: Real>(weights: &[T], sums: &[T], x: &[T], inv_state: &mut [T]) {
    let n = x.len();
    debug_assert!(weights.len() == n && sums.len() == n && inv_state.len() == n);
    let mut tail = T::ZERO;
    for j in (0..n).rev() {
        inv_state[j] = sums[j] * x[j] + tail;
        tail += weights[j] * x[j];
    }
}

/// The play states of `H` matching the states `inv_state` of `H⁻¹`: (22)
/// solved backwards, `x_n = x'_n / s_n` and
/// `x_j = x_{j+1} + (x'_j − x'_{j+1}) / s_j` (the difference of consecutive
/// rows of (22) is `s_j (x_j − x_{j+1})`). In place: `x` holds `x'` on entry.
/// Allocation-free: the compensator calls it after a saturated sample.
#[inline]
pub(crate) fn forward_state_in_place<T: Real>(sums: &[T], x: &mut [T]) {
    let n = x.len();
    debug_assert!(sums.len() == n);
    if n == 0 {
        return;
    }
    let mut next_inv = x[n - 1];
    x[n - 1] = next_inv / sums[n - 1];
    for j in (0..n - 1).rev() {
        let inv = x[j];
        x[j] = x[j + 1] + (inv - next_inv) / sums[j];
        next_inv = inv;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `forward_state_in_place` undoes `inverse_state_into`: each `x'_j` is a
    /// sum of at most `n` rounded terms (error `≤ n ε max|x'|`); each backward
    /// row divides the difference of two of them, rounded once more, by
    /// `s_j ≥ s_min`, and `n` rows add up: `|x̃_j − x_j| ≤ 2n(n+1) ε max|x'| /
    /// s_min`.
    #[test]
    fn the_backward_rule_undoes_the_state_rule() {
        let mut seed = 0x1234_5678_9abc_def0u64;
        let mut unit = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..500 {
            let n = 1 + (unit() * 16.0) as usize;
            // partial sums in [0.05, 1], so single weights are often negative
            let sums: Vec<f64> = (0..n).map(|_| 0.05 + 0.95 * unit()).collect();
            let weights: Vec<f64> = (0..n)
                .map(|j| {
                    if j == 0 {
                        sums[0]
                    } else {
                        sums[j] - sums[j - 1]
                    }
                })
                .collect();
            let x: Vec<f64> = (0..n).map(|_| 2000.0 * unit() - 1000.0).collect();
            let mut inv = vec![0.0; n];
            inverse_state_into(&weights, &sums, &x, &mut inv);
            let mut back = inv.clone();
            forward_state_in_place(&sums, &mut back);
            let s_min = sums.iter().cloned().fold(f64::INFINITY, f64::min);
            let scale = inv.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let nf = n as f64;
            let bound = 2.0 * nf * (nf + 1.0) * f64::EPSILON * scale / s_min;
            for j in 0..n {
                assert!(
                    (back[j] - x[j]).abs() <= bound,
                    "n = {n}, j = {j}: {} vs {}, bound {bound}",
                    back[j],
                    x[j]
                );
            }
        }
    }
}
