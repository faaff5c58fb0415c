//! One step of a run of blocks of a [`CompensatorBank`](super::CompensatorBank):
//! `H⁻¹`, the clip and the re-seat of a clipped sample, then the creep pass,
//! software-pipelined by one block, each lane in the order of
//! [`Compensator`](crate::realtime::Compensator) (21).

use crate::operators::heap::Heap;
use crate::realtime::compensator::Compensated;
use crate::realtime::compensator_step::{padded_groups, CREEP_ACCUMULATORS, PLAY_ACCUMULATORS};
use crate::realtime::play::play;
use crate::realtime::real::Real;
use crate::realtime::simd::block::{lanes, run_blocks, Block, BlockWork, Ops, Row};
use crate::realtime::simd::Kernels;
use crate::realtime::superposition::Superposition;

use super::Layout;

/// Blocks `first..` whose rows are `state` (their channels' targets and
/// outputs), on `k`'s kernels.
pub(super) fn step_blocks<T: Real>(
    k: Kernels,
    fixed: &Fixed<'_, T>,
    first: usize,
    state: &mut [Row],
    targets: &[T],
    out: &mut [Compensated<T>],
) {
    run_blocks(
        k,
        Step {
            bank: fixed,
            state,
            first_block: first,
            targets,
            out,
        },
    );
}

/// What a step reads and does not change.
pub(super) struct Fixed<'a, T: Real> {
    pub(super) layout: Layout,
    pub(super) parameters: &'a [Row],
    pub(super) parameter_rows: usize,
    pub(super) shared: bool,
    pub(super) lower: T,
    pub(super) upper: T,
    pub(super) parity: usize,
    /// Whether this step sums the creep outputs from their states.
    pub(super) resum: bool,
    pub(super) inverse_superposition: &'a [Option<Superposition<T, Heap>>],
    pub(super) superposed: &'a [bool],
}

/// One step of a run of blocks: their state, targets and outputs.
struct Step<'a, 'b, T: Real> {
    bank: &'a Fixed<'b, T>,
    state: &'a mut [Row],
    /// The index of the first block in the bank.
    first_block: usize,
    targets: &'a [T],
    out: &'a mut [Compensated<T>],
}

impl<T: Real> BlockWork<T> for Step<'_, '_, T> {
    type Output = ();

    #[inline(always)]
    fn run<V: Block<T>>(self, o: Ops<T, V>) {
        let f = self.bank;
        let sr = f.layout.state_rows();
        let blocks = self.state.len() / sr;
        if blocks == 0 {
            return;
        }
        // Software-pipelined by one block: H⁻¹ and the clip of block b + 1
        // (a chain of dependent reductions) are issued before the creep pass
        // of block b (independent rows), so the core has work while the
        // chain's latency runs out. (Plain functions, no closures: see
        // `creep_update`.)
        let (first, targets, out) = (self.first_block, self.targets, self.out);
        let p = |b: usize| parameters(f, first + b);
        first_part(o, f, first, 0, &mut self.state[..sr], p(0), targets, out);
        for b in 0..blocks {
            if b + 1 < blocks {
                let state = &mut self.state[(b + 1) * sr..][..sr];
                first_part(o, f, first, b + 1, state, p(b + 1), targets, out);
            }
            creep_pass(o, f, &mut self.state[b * sr..][..sr], p(b));
        }
    }
}

/// The parameter rows of block `block` of the bank.
#[inline(always)]
fn parameters<'a, T: Real>(f: &Fixed<'a, T>, block: usize) -> &'a [Row] {
    if f.shared {
        &f.parameters[..f.parameter_rows]
    } else {
        &f.parameters[block * f.parameter_rows..][..f.parameter_rows]
    }
}

/// [`inverse_and_clip`] of block `b` of a run starting at bank block
/// `first`, its outputs written to the run's `out`.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn first_part<T: Real, V: Block<T>>(
    o: Ops<T, V>,
    f: &Fixed<'_, T>,
    first: usize,
    b: usize,
    state: &mut [Row],
    p: &[Row],
    targets: &[T],
    out: &mut [Compensated<T>],
) {
    let width = lanes::<T>();
    let c0 = b * width;
    let k = width.min(targets.len() - c0);
    // a whole block (all but perhaps the last) straight from the caller's
    // slice; the last one through a padded row
    let target = if k == width {
        o.load_values(&targets[c0..][..width])
    } else {
        let mut row = Row::default();
        row.lanes_mut()[..k].copy_from_slice(&targets[c0..c0 + k]);
        o.load(&row)
    };
    let (u, saturated, fault) = inverse_and_clip(o, f, first + b, state, p, target);
    let out = if k == width {
        &mut out[c0..][..width]
    } else {
        &mut out[c0..c0 + k]
    };
    for ((l, out), &u) in out.iter_mut().enumerate().zip(u.lanes::<T>()) {
        *out = Compensated {
            u,
            saturated: saturated & (1 << l) != 0,
            fault: fault & (1 << l) != 0,
        };
    }
}

/// Block `block` of the bank, first part: what `Compensator::compensate`
/// does up to the applied voltage, lane by lane, in its order of
/// operations (the creep pass is [`creep_pass`]). Returns the voltages and
/// the saturated and fault bits.
#[inline(always)]
fn inverse_and_clip<T: Real, V: Block<T>>(
    o: Ops<T, V>,
    f: &Fixed<'_, T>,
    block: usize,
    s: &mut [Row],
    p: &[Row],
    t: V,
) -> (Row, u32, u32) {
    let a = f.layout;
    let (cur, next) = (f.parity, f.parity ^ 1);
    let fault = o.non_finite(t);
    // S⁻¹[t − offset], less the creep output before its last increment: Z;
    // the play bounds are (Z ∓ r') − Δ, or x'_0 ∓ r' where Z is not finite
    // (the plays then hold), as the single compensator forms them
    let mut y = o.sub(t, o.load(&p[a.offset()]));
    if f.superposed[block] {
        y = inverse_superposition(o, f, block, y);
    }
    let z = o.sub(y, o.load(&s[a.creep_out()]));
    let delta = o.load(&s[a.creep_delta()]);
    let held = o.non_finite(z);
    let x0 = o.load(&s[a.inv_x(cur, 0)]);
    // H⁻¹ (22): the plays into the other copy; a faulted lane keeps its
    // own. The weighted plays summed as `compensator_step::canonical_sum`.
    let n = a.n;
    let (first_copy, second_copy) = s[..2 * n].split_at_mut(n);
    let (old, new_rows) = if cur == 0 {
        (&*first_copy, second_copy)
    } else {
        (&*second_copy, first_copy)
    };
    let (inv_r, inv_w) = (&p[a.inv_r(0)..][..n], &p[a.inv_w(0)..][..n]);
    let zero = o.splat(T::ZERO);
    let mut acc = [[zero; 4]; PLAY_ACCUMULATORS];
    for g in 0..padded_groups(n) {
        let mut products = [zero; 4];
        for (l, product) in products.iter_mut().enumerate() {
            let i = 4 * g + l;
            if i < n {
                let r = o.load(&inv_r[i]);
                let lower = o.select(held, o.sub(x0, r), o.sub(o.sub(z, r), delta));
                let upper = o.select(held, o.add(x0, r), o.sub(o.add(z, r), delta));
                *product =
                    inverse_play(o, fault, lower, upper, &old[i], &inv_w[i], &mut new_rows[i]);
            }
        }
        accumulate(o, &mut acc, g, products);
    }
    let v = finish(o, acc);
    // clip; a faulted lane holds its last voltage
    let (lower, upper) = (o.splat(f.lower), o.splat(f.upper));
    let (below, above) = (o.lt(v, lower), o.gt(v, upper));
    let clipped = o.select(below, lower, o.select(above, upper, v));
    let u = o.select(fault, o.load(&s[a.last_u()]), clipped);
    let saturated = o.and_not(o.or(below, above), fault);
    o.store(u, &mut s[a.last_u()]);
    let saturated = o.bits(saturated);
    if saturated != 0 {
        reseat(f, s, p, saturated, cur, next);
    }
    // the creep input: the voltage applied, or the last one if not finite
    let uc = o.select(o.non_finite(u), o.load(&s[a.creep_last()]), u);
    o.store(uc, &mut s[a.creep_last()]);
    let mut out = Row::default();
    o.store(u, &mut out);
    (out, saturated, o.bits(fault))
}

/// Block `block`'s creep pass (20) with the input stored by
/// [`inverse_and_clip`], as the single compensator's step runs it: each
/// elementary operator advanced (`χ ← χ + g d`), the increment `Δ = Σ q d`
/// summed in the order of `compensator_step::creep_increment` (elements
/// `e = j n + i`, eigenvalue-major), and the running output advanced with
/// it: `creep_out ← creep_out + Δ_{k−1}`, `Δ_{k−1} ← Δ`, or summed from the
/// state on a re-sum step. Whole slices of rows, so that no index
/// arithmetic or bounds check stands between the vector operations.
#[inline(always)]
fn creep_pass<T: Real, V: Block<T>>(o: Ops<T, V>, f: &Fixed<'_, T>, s: &mut [Row], p: &[Row]) {
    let a = f.layout;
    let (nc, m) = (a.nc, a.m);
    let uc = o.load(&s[a.creep_last()]);
    let zero = o.splat(T::ZERO);
    let minus_zero = o.splat(-T::ZERO);
    let thresholds = &p[a.creep_r(0)..][..nc];
    let gains = &p[a.gain(0)..][..m];
    let q = &p[a.creep_q(0, 0)..][..nc * m];
    let mut acc = [[zero; 4]; CREEP_ACCUMULATORS];
    let (mut products, mut lane, mut group) = ([zero; 4], 0, 0);
    {
        let chi = &mut s[a.chi(0, 0)..][..nc * m];
        for (j, g) in gains.iter().enumerate() {
            let g = o.load(g);
            for (i, r) in thresholds.iter().enumerate() {
                let r = o.load(r);
                let (d, x) = creep_update(o, &mut chi[i * m + j], g, uc, o.sub(minus_zero, r), r);
                let _ = x;
                products[lane] = o.mul(o.load(&q[i * m + j]), d);
                lane += 1;
                if lane == 4 {
                    accumulate(o, &mut acc, group, products);
                    (products, lane, group) = ([zero; 4], 0, group + 1);
                }
            }
        }
    }
    if lane > 0 {
        accumulate(o, &mut acc, group, products);
        group += 1;
    }
    while group < padded_groups(nc * m) {
        accumulate(o, &mut acc, group, [zero; 4]);
        group += 1;
    }
    let increment = finish(o, acc);
    let (out, delta) = if f.resum {
        (creep_output(o, f, s, p), zero)
    } else {
        (
            o.add(o.load(&s[a.creep_out()]), o.load(&s[a.creep_delta()])),
            increment,
        )
    };
    o.store(out, &mut s[a.creep_out()]);
    o.store(delta, &mut s[a.creep_delta()]);
}

/// The creep output of the state, `Σ_i (w_i/m) Σ_j χ_ij`, summed as
/// `creep_pass::output` sums it (each threshold's rows in order, the
/// weighted rows into the partial sum `i mod 4`).
#[cold]
#[inline(never)]
fn creep_output<T: Real, V: Block<T>>(o: Ops<T, V>, f: &Fixed<'_, T>, s: &[Row], p: &[Row]) -> V {
    let a = f.layout;
    let zero = o.splat(T::ZERO);
    let mut sums = [zero; 4];
    for i in 0..a.nc {
        let mut row = zero;
        for j in 0..a.m {
            row = o.add(row, o.load(&s[a.chi(i, j)]));
        }
        sums[i % 4] = o.add(sums[i % 4], o.mul(o.load(&p[a.creep_w(i)]), row));
    }
    o.add(o.add(sums[0], sums[2]), o.add(sums[1], sums[3]))
}

/// Group `g` of a canonical sum (`compensator_step::canonical_sum`): into
/// accumulator `g mod A`, its value if it is the accumulator's first.
#[inline(always)]
fn accumulate<T: Real, V: Block<T>, const A: usize>(
    o: Ops<T, V>,
    acc: &mut [[V; 4]; A],
    g: usize,
    products: [V; 4],
) {
    let a = g % A;
    for l in 0..4 {
        acc[a][l] = if g < A {
            products[l]
        } else {
            o.add(acc[a][l], products[l])
        };
    }
}

/// The accumulators added by halving and the four lanes as
/// `(l₀ + l₂) + (l₁ + l₃)`: the canonical sum.
#[inline(always)]
fn finish<T: Real, V: Block<T>, const A: usize>(o: Ops<T, V>, mut acc: [[V; 4]; A]) -> V {
    let mut h = A / 2;
    while h >= 1 {
        for a in 0..h {
            let other = acc[a + h];
            for (x, y) in acc[a].iter_mut().zip(other) {
                *x = o.add(*x, y);
            }
        }
        h /= 2;
    }
    let s = acc[0];
    o.add(o.add(s[0], s[2]), o.add(s[1], s[3]))
}

/// One play of `H⁻¹` (22) on a block: `x` clamped into `[lower, upper]`
/// into `next` (the old `x` where the lane is faulted), its weighted value
/// returned. A function, not a closure: see [`creep_update`].
#[inline(always)]
fn inverse_play<T: Real, V: Block<T>>(
    o: Ops<T, V>,
    fault: V::Mask,
    lower: V,
    upper: V,
    x: &Row,
    w: &Row,
    next: &mut Row,
) -> V {
    let x = o.load(x);
    let new = o.clamp(x, lower, upper);
    o.store(o.select(fault, x, new), next);
    o.mul(o.load(w), new)
}

/// One creep operator's update (20) on a block, `χ ← χ + g d` with the
/// dead zone `d = clamp(z, −r, r) − z`, `z = χ − u` (as
/// `creep_pass::dead_zone`; `lower` is `−r`, `upper` is `r`), returning
/// `d` and the new `χ`. A function marked `inline(always)`, not a closure: a closure
/// body left out of line is compiled without the step's instruction set,
/// and every vector operation in it becomes a call.
#[inline(always)]
fn creep_update<T: Real, V: Block<T>>(
    o: Ops<T, V>,
    x: &mut Row,
    g: V,
    u: V,
    lower: V,
    upper: V,
) -> (V, V) {
    let v = o.load(x);
    let z = o.sub(v, u);
    let d = o.sub(o.clamp(z, lower, upper), z);
    let v = o.add(v, o.mul(g, d));
    o.store(v, x);
    (d, v)
}

/// `S⁻¹` lane by lane on a block some of whose channels have `S`.
#[cold]
#[inline(never)]
fn inverse_superposition<T: Real, V: Block<T>>(
    o: Ops<T, V>,
    f: &Fixed<'_, T>,
    block: usize,
    y: V,
) -> V {
    let mut row = Row::default();
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
fn reseat<T: Real>(
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
