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
