//! The bank step's lane-by-lane paths, taken only where a block needs
//! them: `S⁻¹` for the channels with a superposition, and the re-seat
//! of a saturated lane's plays from the voltage applied (22), both as the
//! single [`Compensator`](crate::realtime::Compensator) computes them.

use crate::realtime::play::play;
use crate::realtime::real::Real;
use crate::realtime::simd::block::{lanes, Block, Ops, Row};

use super::step::Fixed;

/// `S⁻¹[t − offset]` lane by lane on a block some of whose channels have
/// `S`, from its `targets` (its lanes past them are zero).
#[cold]
#[inline(never)]
pub(super) fn inverse_superposition<T: Real, V: Block<T>>(
    o: Ops<T, V>,
    f: &Fixed<'_, T>,
    block: usize,
    targets: &[T],
    p: &[Row],
) -> V {
    let mut row = Row::default();
    row.lanes_mut()[..targets.len()].copy_from_slice(targets);
    let y = o.sub(o.load(&row), o.load(&p[f.layout.offset()]));
    o.store(y, &mut row);
    let width = lanes::<T>();
    for (l, x) in row.lanes_mut::<T>().iter_mut().enumerate() {
        let c = if f.shared { 0 } else { block * width + l };
        if let Some(Some(s)) = f.inverse_superposition.get(c) {
            *x = s.apply(*x);
        }
    }
    o.load(&row)
}

/// The saturated lanes as the single compensator re-seats: the plays of
/// `H` from the inverse plays before the step (copy `cur`), advanced with
/// the applied `u`, and the inverse plays from them (22) into copy `next`.
#[cold]
#[inline(never)]
pub(super) fn reseat<T: Real>(
    f: &Fixed<'_, T>,
    s: &mut [Row],
    p: &[Row],
    saturated: u32,
    cur: usize,
    next: usize,
) {
    let a = f.layout;
    let n = a.n;
    let u = s[a.last_u()];
    for l in (0..lanes::<T>()).filter(|l| saturated & (1 << l) != 0) {
        let u = u.lanes::<T>()[l];
        let par = |row: usize| p[row].lanes::<T>()[l];
        let old = |s: &[Row], i: usize| s[a.inv_x(cur, i)].lanes::<T>()[l];
        // forward_state_in_place, into copy `next`
        let mut next_inv = old(s, n - 1);
        s[a.inv_x(next, n - 1)].lanes_mut::<T>()[l] = next_inv / par(a.s(n - 1));
        for j in (0..n - 1).rev() {
            let inv = old(s, j);
            let x = s[a.inv_x(next, j + 1)].lanes::<T>()[l] + (inv - next_inv) / par(a.s(j));
            s[a.inv_x(next, j)].lanes_mut::<T>()[l] = x;
            next_inv = inv;
        }
        for j in 0..n {
            let x = &mut s[a.inv_x(next, j)].lanes_mut::<T>()[l];
            *x = play(u, par(a.r(j)), *x);
        }
        // inverse_state_into, in place
        let mut tail = T::ZERO;
        for j in (0..n).rev() {
            let x = &mut s[a.inv_x(next, j)].lanes_mut::<T>()[l];
            let forward = *x;
            *x = par(a.s(j)) * forward + tail;
            tail += par(a.w(j)) * forward;
        }
    }
}
