//! The creep pass (20), portable: advance every elementary creep operator
//! with `v` and sum the output in a fixed order. [`crate::realtime::creep`]
//! (the operator) and [`crate::realtime::simd`] (its vector copies, which
//! keep this order) both build on it, and neither imports the other.

use crate::realtime::hysteresis::reduce;
use crate::realtime::play::clamp;
use crate::realtime::real::{add_term, Real};

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
/// `v ∓ r_i` serve all `m` rows. It is computed as [`update`] does: with
/// `std`, `g c + (χ − g χ)` with `c = P_r[v, χ]`, each product fused with
/// its sum. The sums run in a fixed order (lane `l`
/// of a block adds the thresholds `i ≡ l mod 4`, then
/// [`reduce`]), the same for every instruction set: the result does not
/// depend on the CPU. The weighted rows go into partial sums that start
/// from their first product ([`crate::realtime::real::add_term`]). A
/// threshold's rows are summed from its first row, not from zero, here and
/// in the bank. (The two would differ only where every row is `−0`, and no
/// state holds a `−0`: a state set from outside has its zeros made `+0`,
/// and an update never makes one — `χ − g χ` of `±0` is `+0`, and a zero
/// sum of opposite signs is `+0`.)
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
                block[l] = update(x, g, clamp(x, lower[l], upper[l]));
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
            acc[l] = add_term(acc[l], w[l], rows[l], i0 == 0);
        }
    }
    advance_tail(chi, thresholds, gains, weights, v, full, &mut acc);
    reduce(acc)
}

/// One elementary operator's update (20), `χ + g (c − χ)` with `c` the
/// clamped state.
///
/// With `std` it is computed as `g c + (χ − g χ)`, each product fused with
/// its sum ([`Real::fused_mul_add`]): `χ − g χ` does not depend on the
/// input, so after the clamp a single fused multiply-add stands between the
/// input and the new state, where the literal form has three operations (a
/// subtraction, a product, a sum). A compensator step is bound less by its
/// chain than by how many operations wait for the input, so this shortens
/// the step (by about a sixth in the peers bench where measured).
///
/// It rounds twice, as the literal form does (there `c − χ` and the product
/// are rounded, and the sum). Where `c = χ` (the input within `r` of the
/// state) the result is `χ` itself, up to a tie in the last rounding, which
/// moves it once, by one ulp, to an even significand:
/// `g χ + fl(χ − g χ) = χ + e` exactly, with `|e| ≤ ½ ulp(χ − g χ) ≤
/// ½ ulp(χ)` for `0 ≤ g ≤ 1`. So a state at rest stays at rest, as in the
/// literal form, and does not walk by rounding.
///
/// Without `std` no fused operation is reachable, and unfused the new form
/// costs four operations against three: there it is the literal form, whose
/// bits differ from a `std` build's by the rounding of one product.
#[inline(always)]
pub(crate) fn update<T: Real>(x: T, g: T, c: T) -> T {
    #[cfg(feature = "std")]
    return g.fused_mul_add(c, (-g).fused_mul_add(x, x));
    #[cfg(not(feature = "std"))]
    return x + g * (c - x);
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
            let x = update(x, g, clamp(x, lower, upper));
            chi[j * n + i] = x;
            row = if j == 0 { x } else { row + x };
        }
        acc[i - full] = add_term(acc[i - full], weights[i], row, full == 0);
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
        acc[i % LANES] = add_term(acc[i % LANES], w, row.unwrap_or(T::ZERO), i < LANES);
    }
    reduce(acc)
}

#[cfg(all(test, feature = "std"))]
mod tests {
    use super::update;
    use crate::realtime::real::Real;

    /// Seeded xorshift: states spread over twelve decades, both signs, the
    /// powers of two among them (where the spacing changes below `χ`).
    fn states<T: Real>(count: usize) -> Vec<T> {
        let mut s = 0x2545_F491_4F6C_DD1Du64;
        let mut out = vec![T::ONE, -T::ONE, T::from_f64(512.0), T::from_f64(-0.25)];
        while out.len() < count {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let mantissa = 1.0 + (s >> 11) as f64 / (1u64 << 53) as f64;
            let exponent = (s % 41) as i32 - 20;
            let sign = if s & (1 << 40) == 0 { 1.0 } else { -1.0 };
            out.push(T::from_f64(sign * mantissa * 2f64.powi(exponent)));
        }
        out
    }

    /// The nominal gains `1 − e^{−a T_s}` (`a` = 500 … 0.05 s⁻¹ at 5 kHz),
    /// one half and one.
    fn gains<T: Real>() -> Vec<T> {
        [500.0, 50.0, 5.0, 0.5, 0.05]
            .iter()
            .map(|&a: &f64| T::from_f64(-libm::expm1(-a * 2e-4)))
            .chain([T::from_f64(0.5), T::ONE])
            .collect()
    }

    fn significand_is_even<T: Real>(x: T) -> bool {
        let bits = x.to_f64().to_bits();
        // an f32 widened to f64 carries its last significand bit at 2^29
        let last = if T::NAME == "f32" { 1u64 << 29 } else { 1 };
        bits & last == 0
    }

    /// A state at rest (`c = χ`) stays where it is, or moves once by one
    /// ulp to an even significand (a tie in the last rounding) and stays.
    fn rest_is_kept<T: Real>() {
        let mut moved = 0;
        for x in states::<T>(20_000) {
            for g in gains::<T>() {
                let y = update(x, g, x);
                if y != x {
                    moved += 1;
                    assert!(
                        (y == x.next_up() || y == x.next_down()) && significand_is_even(y),
                        "{} χ = {x:?}, g = {g:?}: at rest to {y:?}",
                        T::NAME
                    );
                }
                assert_eq!(update(y, g, y), y, "{} χ = {x:?}, g = {g:?}", T::NAME);
            }
        }
        // ties are rare: a handful in 140 000 updates
        assert!(moved < 140, "{} moved {moved} times", T::NAME);
    }

    #[test]
    fn a_state_at_rest_stays_at_rest() {
        rest_is_kept::<f64>();
        rest_is_kept::<f32>();
    }

    /// Updates away from rest: every state with a partner state as `c`, at
    /// every gain, and the update's result.
    fn moving<T: Real>() -> impl Iterator<Item = (T, T, T, T)> {
        let xs = states::<T>(4_000);
        let cs: Vec<T> = (0..xs.len()).map(|k| xs[(k * 7 + 3) % xs.len()]).collect();
        xs.into_iter().zip(cs).flat_map(|(x, c)| {
            gains::<T>()
                .into_iter()
                .map(move |g| (x, g, c, update(x, g, c)))
        })
    }

    /// Away from rest, in `f32` against the value in `f64` (the products of
    /// two `f32` are exact there): within `½ ulp(result) + ½ ulp(χ)`, the
    /// rounding of the sum and of `χ − g χ` (plus the `f64` reference's own
    /// rounding, 2⁻⁵² of the terms).
    #[test]
    fn an_update_rounds_twice() {
        for (x, g, c, y) in moving::<f32>() {
            let (xd, gd, cd) = (x as f64, g as f64, c as f64);
            let exact = gd * cd + (xd - gd * xd);
            let ulp = |v: f32| (v.abs().next_up() - v.abs()) as f64;
            let reference = 2f64.powi(-52) * (gd * cd.abs() + 2.0 * xd.abs());
            let bound = 0.5 * ulp(y) + 0.5 * ulp(x) + reference;
            assert!(
                (y as f64 - exact).abs() <= bound,
                "χ = {x}, g = {g}, c = {c}: {y} against {exact} (bound {bound:e})"
            );
        }
    }

    /// `a + b` as a sum and its exact rounding error (Knuth's TwoSum).
    fn two_sum(a: f64, b: f64) -> (f64, f64) {
        let s = a + b;
        let bb = s - a;
        (s, (a - (s - bb)) + (b - bb))
    }

    /// The same in `f64`, against `g c + χ − g χ` in double-double (the
    /// products split exactly by a fused multiply-add, the sums by
    /// TwoSum): the reference's own error is of order `ε²`.
    #[test]
    fn an_update_rounds_twice_in_f64() {
        for (x, g, c, y) in moving::<f64>() {
            let (p1, e1) = (g * c, g.mul_add(c, -(g * c)));
            let (p2, e2) = (g * x, g.mul_add(x, -(g * x)));
            let (s1, t1) = two_sum(p1, x);
            let (s2, t2) = two_sum(s1, -p2);
            let tail = t1 + t2 + e1 - e2;
            let ulp = |v: f64| v.abs().next_up() - v.abs();
            // y − exact as (y − s2) − tail: y − s2 is exact where y and s2
            // are close (Sterbenz), and both are
            let error = ((y - s2) - tail).abs();
            let bound = 0.5 * ulp(y) + 0.5 * ulp(x) + 4.0 * f64::EPSILON * ulp(s2.abs() + x.abs());
            assert!(
                error <= bound,
                "χ = {x:e}, g = {g:e}, c = {c:e}: {y:e}, error {error:e} > {bound:e}"
            );
        }
    }
}
