//! The time-discrete play (20) and the dead zone of the creep operators (14),
//! for any [`Real`].

use crate::realtime::real::Real;

/// One step of the play (20): `x_k = max(v_k − r, min(v_k + r, x_{k−1}))`.
/// Written with comparisons so that it compiles to `min`/`max` instructions
/// and is exactly odd: `play(−v, r, −x) == −play(v, r, x)` bit for bit.
#[inline(always)]
pub fn play<T: Real>(v: T, r: T, x: T) -> T {
    clamp(x, v - r, v + r)
}

/// The play (20) with the input `v = t − c` given as its two terms: the
/// bounds are `(t − r) − c` and `(t + r) − c`, so that `c`, which arrives
/// last in the compensator's step (the creep's output), takes one
/// subtraction to reach them instead of two operations. Each bound is
/// `t ∓ r − c` rounded twice, as `(t − c) ∓ r` rounds it, but in another
/// order: within `u (1 + u) |t ∓ r| + u |t ∓ r − c|` of the exact value
/// (`u` the unit roundoff). The zero-threshold play's bounds are `t − c`
/// exactly, as before. Exactly odd in `(t, c, x)`, and with `c = 0` it is
/// [`play`] bit for bit.
#[inline(always)]
pub(crate) fn play_of_difference<T: Real>(t: T, c: T, r: T, x: T) -> T {
    clamp(x, (t - r) - c, (t + r) - c)
}

/// `max(lower, min(upper, x))`: the play (20) with its bounds `v ∓ r` formed
/// by the caller, so that one pair serves several states.
#[inline(always)]
pub(crate) fn clamp<T: Real>(x: T, lower: T, upper: T) -> T {
    let t = if x < upper { x } else { upper };
    if t > lower {
        t
    } else {
        lower
    }
}

#[cfg(test)]
mod tests {
    use super::{play, play_of_difference};

    /// Seeded xorshift: an `f32` with a 24-bit mantissa and a binary
    /// exponent in `-8..8`, either sign.
    fn sample(seed: &mut u64) -> f32 {
        *seed ^= *seed << 13;
        *seed ^= *seed >> 7;
        *seed ^= *seed << 17;
        let mantissa = (*seed >> 40) as f32 / (1u64 << 24) as f32;
        let exponent = ((*seed >> 8) % 16) as i32 - 8;
        let sign = if *seed & 1 == 0 { 1.0 } else { -1.0 };
        sign * mantissa * 2f32.powi(exponent)
    }

    /// Against the bounds computed exactly: every sample is a multiple of
    /// `2⁻³²` below `2⁸`, so sums of three are exact in `f64` (42 bits). Each
    /// bound `(t ∓ r) − c` is rounded twice, so with `u = ε/2` it is within
    /// `u (1 + u) |t ∓ r| + u |t ∓ r − c|` of the exact one, and the clamp
    /// moves the state by no more than its bounds move.
    #[test]
    fn play_of_difference_is_within_two_roundings_of_the_exact_play() {
        let u = f64::from(f32::EPSILON) / 2.0;
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        for _ in 0..100_000 {
            let (t, c, x) = (sample(&mut seed), sample(&mut seed), sample(&mut seed));
            let r = sample(&mut seed).abs();
            let got = f64::from(play_of_difference(t, c, r, x));
            let (t, c, r, x) = (f64::from(t), f64::from(c), f64::from(r), f64::from(x));
            let (lower, upper) = (t - r - c, t + r - c);
            let exact = x.min(upper).max(lower);
            let tolerance = (u * (1.0 + u) * (t - r).abs() + u * lower.abs())
                .max(u * (1.0 + u) * (t + r).abs() + u * upper.abs());
            assert!(
                (got - exact).abs() <= tolerance,
                "t {t}, c {c}, r {r}, x {x}: {got} against {exact}"
            );
        }
    }

    /// With `c = 0` it is the play bit for bit, and it is exactly odd.
    #[test]
    fn play_of_difference_is_the_play_at_zero_and_odd() {
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        for _ in 0..100_000 {
            let (t, c, x) = (sample(&mut seed), sample(&mut seed), sample(&mut seed));
            let r = sample(&mut seed).abs();
            let (t, c, r, x) = (f64::from(t), f64::from(c), f64::from(r), f64::from(x));
            assert_eq!(
                play_of_difference(t, 0.0, r, x).to_bits(),
                play(t, r, x).to_bits()
            );
            assert_eq!(
                play_of_difference(-t, -c, r, -x).to_bits(),
                (-play_of_difference(t, c, r, x)).to_bits()
            );
        }
    }
}
