//! The creep pass (20), portable: advance every elementary creep operator
//! with `v` and sum the output in a fixed order. [`crate::realtime::creep`]
//! (the operator) and [`crate::realtime::simd`] (its vector copies, which
//! keep this order) both build on it, and neither imports the other.

use crate::realtime::hysteresis::reduce;
use crate::realtime::play::clamp;
use crate::realtime::real::Real;

/// Thresholds per block of the creep pass: the clamp bounds `v ∓ r_i` are
/// formed once per threshold and reused by every eigenvalue's row, and a
/// block is one AVX register of `f64` (two SSE2 registers).
pub(crate) const LANES: usize = 4;

/// Advance every elementary operator with `v` (20) and return the new output
/// `Σ_i (w_i/m) Σ_j χ_ij`. `chi[j * n + i]` (eigenvalue-major); `thresholds`
/// and `weights` (`w_i/m`) have `n` entries, `gains` one per eigenvalue. A
/// non-finite `v` is replaced by the last finite input, which `last_input`
/// keeps.
///
/// The update is `χ ← χ + g (P_r[v, χ] − χ)`: the dead zone of (14) as the
/// play's output minus its state, `d_r(v − χ) = P_r[v, χ] − χ`, so that
/// `v ∓ r_i` serve all `m` rows. The sums run in a fixed order (lane `l`
/// of a block adds the thresholds `i ≡ l mod 4`, then
/// [`reduce`]), the same for every instruction set: the result does not
/// depend on the CPU. A threshold's rows are summed from its first row, not
/// from zero: the sums differ only where every row is a zero, in the sign
/// of that zero, and the weighted rows go into partial sums that start at
/// `+0`, which a zero of either sign leaves unchanged (a sum from `+0` is
/// never `−0`) — so the output has the same bits as the sum from zero.
#[inline(always)]
pub(crate) fn advance<T: Real>(
    chi: &mut [T],
    thresholds: &[T],
    gains: &[T],
    weights: &[T],
    v: T,
    last_input: &mut T,
) -> T {
    let v = if v.is_finite() { v } else { *last_input };
    *last_input = v;
    let n = thresholds.len();
    debug_assert!(weights.len() == n && chi.len() == n * gains.len());
    let mut acc = [T::ZERO; LANES];
    let full = n - n % LANES;
    for i0 in (0..full).step_by(LANES) {
        let r: &[T; LANES] = thresholds[i0..i0 + LANES].try_into().unwrap();
        let lower = r.map(|r| v - r);
        let upper = r.map(|r| v + r);
        let mut rows = [T::ZERO; LANES];
        for (j, &g) in gains.iter().enumerate() {
            let block: &mut [T; LANES] = (&mut chi[j * n + i0..j * n + i0 + LANES])
                .try_into()
                .unwrap();
            for l in 0..LANES {
                let x = block[l];
                block[l] = x + g * (clamp(x, lower[l], upper[l]) - x);
            }
            // the rows from the first one, not from zero: one addition
            // fewer on the chain, the same output (see above)
            if j == 0 {
                rows = *block;
            } else {
                for l in 0..LANES {
                    rows[l] += block[l];
                }
            }
        }
        let w: &[T; LANES] = weights[i0..i0 + LANES].try_into().unwrap();
        for l in 0..LANES {
            acc[l] += w[l] * rows[l];
        }
    }
    advance_tail(chi, thresholds, gains, weights, v, full, &mut acc);
    reduce(acc)
}

/// The thresholds `full..n` that do not fill a block, one by one, into the
/// lanes `i − full` (shared by [`advance`] and its AVX copy).
#[inline(always)]
pub(crate) fn advance_tail<T: Real>(
    chi: &mut [T],
    thresholds: &[T],
    gains: &[T],
    weights: &[T],
    v: T,
    full: usize,
    acc: &mut [T; LANES],
) {
    let n = thresholds.len();
    for i in full..n {
        let (lower, upper) = (v - thresholds[i], v + thresholds[i]);
        let mut row = T::ZERO;
        for (j, &g) in gains.iter().enumerate() {
            let x = chi[j * n + i];
            let x = x + g * (clamp(x, lower, upper) - x);
            chi[j * n + i] = x;
            row = if j == 0 { x } else { row + x };
        }
        acc[i - full] += weights[i] * row;
    }
}

/// The output `Σ_i (w_i/m) Σ_j χ_ij` of a state, summed in the order
/// [`advance`] uses (bit for bit what it returns for that state).
pub(crate) fn output<T: Real>(chi: &[T], weights: &[T]) -> T {
    let n = weights.len();
    let mut acc = [T::ZERO; LANES];
    for (i, &w) in weights.iter().enumerate() {
        let row = chi
            .iter()
            .skip(i)
            .step_by(n.max(1))
            .copied()
            .reduce(|a, b| a + b);
        acc[i % LANES] += w * row.unwrap_or(T::ZERO);
    }
    reduce(acc)
}
