//! The creep pass (20), portable: advance every elementary creep operator
//! with `v` and sum the output in a fixed order. [`crate::realtime::creep`]
//! (the operator) and [`crate::realtime::simd`] (its vector copies, which
//! keep this order) both build on it, and neither imports the other.

use crate::realtime::hysteresis::reduce;
use crate::realtime::play::clamp;
use crate::realtime::real::Real;

/// Thresholds per block of the creep pass: the bounds `∓r_i` of the dead
/// zone serve every eigenvalue's row, and a block is one AVX register of
/// `f64` (two SSE2 registers).
pub(crate) const LANES: usize = 4;

/// Advance every elementary operator with `v` (20) and return the new output
/// `Σ_i (w_i/m) Σ_j χ_ij`. `chi[j * n + i]` (eigenvalue-major); `thresholds`
/// and `weights` (`w_i/m`) have `n` entries, `gains` one per eigenvalue. A
/// non-finite `v` is replaced by the last finite input, which `last_input`
/// keeps.
///
/// The update is `χ ← χ + g d` with the dead zone of (14) written about
/// the state, [`dead_zone`]: `z = χ − v`, `d = clamp(z, −r, r) − z`
/// (`= P_r[v, χ] − χ`). No bound depends on `v`, so the clamp's bounds are
/// the constants `∓r`, and an operator inside its dead zone gets `d = +0`
/// exactly. The sums run in a fixed order (lane `l` of a block adds the
/// thresholds `i ≡ l mod 4`, then [`reduce`]), the same for every
/// instruction set: the result does not depend on the CPU.
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
        let mut rows = [T::ZERO; LANES];
        for (j, &g) in gains.iter().enumerate() {
            let block: &mut [T; LANES] = (&mut chi[j * n + i0..j * n + i0 + LANES])
                .try_into()
                .unwrap();
            for l in 0..LANES {
                block[l] = update(block[l], v, r[l], g);
            }
            for l in 0..LANES {
                rows[l] += block[l];
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
        let mut row = T::ZERO;
        for (j, &g) in gains.iter().enumerate() {
            let x = update(chi[j * n + i], v, thresholds[i], g);
            chi[j * n + i] = x;
            row += x;
        }
        acc[i - full] += weights[i] * row;
    }
}

/// The dead zone of (14) about the state: `z = χ − v`, and
/// `d = clamp(z, −r, r) − z`, which is `d_r(v − χ)`. The clamp takes the
/// lower bound `−r` as negation gives it (`−0.0` for `r = 0`), in every
/// kernel.
#[inline(always)]
pub(crate) fn dead_zone<T: Real>(x: T, v: T, r: T) -> T {
    let z = x - v;
    clamp(z, -r, r) - z
}

/// One elementary creep operator's update (20): `χ + g d_r(v − χ)`.
#[inline(always)]
pub(crate) fn update<T: Real>(x: T, v: T, r: T, g: T) -> T {
    x + g * dead_zone(x, v, r)
}

/// The output `Σ_i (w_i/m) Σ_j χ_ij` of a state, summed in the order
/// [`advance`] uses (bit for bit what it returns for that state).
pub(crate) fn output<T: Real>(chi: &[T], weights: &[T]) -> T {
    let n = weights.len();
    let mut acc = [T::ZERO; LANES];
    for (i, &w) in weights.iter().enumerate() {
        let mut row = T::ZERO;
        for x in chi.iter().skip(i).step_by(n.max(1)) {
            row += *x;
        }
        acc[i % LANES] += w * row;
    }
    reduce(acc)
}
