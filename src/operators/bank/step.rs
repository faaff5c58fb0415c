//! One step of a run of blocks of a [`CompensatorBank`](super::CompensatorBank):
//! `H⁻¹`, the clip and the re-seat of a clipped sample, the creep pass,
//! software-pipelined ([`pipelined`]), each lane in the order of
//! [`Compensator`](crate::realtime::Compensator) (21).

use crate::operators::heap::Heap;
use crate::realtime::compensator::Compensated;
use crate::realtime::play::play;
use crate::realtime::real::Real;
use crate::realtime::simd::block::{lanes, run_blocks, Block, BlockWork, Ops, Row};
use crate::realtime::simd::{Kernels, PAPER_CREEP, PAPER_PLAYS};
use crate::realtime::superposition::Superposition;

use super::walk::Walk;
use super::Layout;

/// Blocks `first..` whose rows are `state` (their channels' targets and
/// outputs), on `k`'s kernels, walked `walk`.
pub(super) fn step_blocks<T: Real>(
    k: Kernels,
    fixed: &Fixed<'_, T>,
    first: usize,
    state: &mut [Row],
    targets: &[T],
    out: &mut [Compensated<T>],
    walk: Walk,
) {
    // the direction is a constant of the compiled step: the one-thread
    // step carries no code of the other
    match walk {
        Walk::Up => step_walking::<T, false>(k, fixed, first, state, targets, out),
        Walk::Down => step_walking::<T, true>(k, fixed, first, state, targets, out),
    }
}

/// [`step_blocks`] walking down if `DOWN`, up otherwise. A function of its
/// own, with `step_blocks`'s parameters: with the `Step` built in
/// `step_blocks`, both walks were compiled into one function and a
/// parameter-row closure was left out of line.
fn step_walking<T: Real, const DOWN: bool>(
    k: Kernels,
    fixed: &Fixed<'_, T>,
    first: usize,
    state: &mut [Row],
    targets: &[T],
    out: &mut [Compensated<T>],
) {
    let step = Step::<T, DOWN> {
        bank: fixed,
        state,
        first_block: first,
        targets,
        out,
    };
    run_blocks(k, step);
}

/// What a step reads and does not change.
pub(super) struct Fixed<'a, T: Real> {
    pub(super) layout: Layout,
    pub(super) parameters: &'a [Row],
    pub(super) shared: bool,
    pub(super) lower: T,
    pub(super) upper: T,
    pub(super) parity: usize,
    pub(super) inverse_superposition: &'a [Option<Superposition<T, Heap>>],
    pub(super) superposed: &'a [bool],
    pub(super) any_superposed: bool,
}

/// One step of a run of blocks: their state, targets and outputs, walked
/// down if `DOWN`.
struct Step<'a, 'b, T: Real, const DOWN: bool> {
    bank: &'a Fixed<'b, T>,
    state: &'a mut [Row],
    /// The index of the first block in the bank.
    first_block: usize,
    targets: &'a [T],
    out: &'a mut [Compensated<T>],
}

impl<T: Real, const DOWN: bool> BlockWork<T> for Step<'_, '_, T, DOWN> {
    type Output = ();

    #[inline(always)]
    fn run<V: Block<T>>(self, o: Ops<T, V>) {
        let f = self.bank;
        // 1 in every lane, hidden from the compiler so that it keeps the
        // fused forms of `add_on_multiplier`. Made once per run: made in
        // every block, it was read back from the stack at the head of each
        // block's chain (a store-to-load forwarding); with the superposed
        // path's spill (see `inverse_sum`), `H⁻¹` and the clip alone took
        // 1.4 times as long.
        let one = o.splat(core::hint::black_box(T::ONE));
        let (first, state, targets, out) = (self.first_block, self.state, self.targets, self.out);
        if f.layout == PAPER {
            run_blocks_of::<T, V, DOWN>(o, f, PAPER, one, first, state, targets, out);
        } else {
            run_blocks_of::<T, V, DOWN>(o, f, f.layout, one, first, state, targets, out);
        }
    }
}

/// [`Step::run`] with the layout `a`: [`PAPER`], a constant, or the
/// bank's; a bank of one model and no `S` (the common case) apart, with
/// nothing to test per block (one vector spill per block instead of five).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn run_blocks_of<T: Real, V: Block<T>, const DOWN: bool>(
    o: Ops<T, V>,
    f: &Fixed<'_, T>,
    a: Layout,
    one: V,
    first: usize,
    state: &mut [Row],
    targets: &[T],
    out: &mut [Compensated<T>],
) {
    let pr = a.parameter_rows();
    let all = f.parameters;
    if f.shared && !f.any_superposed {
        // the common case: one model, no `S` (nothing to test per block)
        let p0 = &all[..pr];
        pipeline::<T, V, DOWN>(
            o,
            f,
            a,
            one,
            state,
            targets,
            out,
            |_| p0,
            |b| (first + b, false),
        );
    } else {
        let shared = f.shared;
        let superposed = &f.superposed[first..];
        pipeline::<T, V, DOWN>(
            o,
            f,
            a,
            one,
            state,
            targets,
            out,
            |b| {
                if shared {
                    &all[..pr]
                } else {
                    &all[(first + b) * pr..][..pr]
                }
            },
            |b| (first + b, superposed[b]),
        );
    }
}

/// The blocks of [`run_blocks_of`], up the memory or, `DOWN`, down, with their
/// parameter rows from `p` and their index and `S` for [`head`] from `input`.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn pipeline<'p, T: Real, V: Block<T>, const DOWN: bool>(
    o: Ops<T, V>,
    f: &Fixed<'_, T>,
    a: Layout,
    one: V,
    state: &mut [Row],
    targets: &[T],
    out: &mut [Compensated<T>],
    p: impl Fn(usize) -> &'p [Row],
    input: impl Fn(usize) -> (usize, bool),
) {
    let (sr, width) = (a.state_rows(), lanes::<T>());
    // whole blocks in chunks of a fixed size (no length arithmetic per
    // block), and the last, partial one if there is one
    let whole = targets.len() / width;
    let (state, last_state) = state.split_at_mut((whole * sr).min(state.len()));
    let (targets, last_targets) = targets.split_at(whole * width);
    let (out, last_out) = out.split_at_mut(whole * width);
    let last = (!last_targets.is_empty()).then_some(((last_state, last_targets), last_out));
    let whole_blocks = state
        .chunks_exact_mut(sr)
        .zip(targets.chunks_exact(width))
        .zip(out.chunks_exact_mut(width));
    if DOWN {
        // the partial block, the highest, first
        let last = last.map(|l| (whole, l));
        let blocks = last.into_iter().chain(whole_blocks.enumerate().rev());
        pipelined(o, f, a, one, blocks, p, input);
    } else {
        pipelined(o, f, a, one, whole_blocks.chain(last).enumerate(), p, input);
    }
}

/// The blocks `blocks` (their indices, state rows, targets and outputs),
/// software-pipelined: a block's plays (`H⁻¹`: four chains of dependent
/// reductions), the next block's [`head`], the creep pass of the block
/// before (independent rows), this block's clip. The chains' latency runs
/// out under the creep pass, and their input `y` is ready when they are
/// issued. One loop, the creep
/// pass due held in an `Option`: with a first and a last block written
/// out, the AVX2 set's extra creep passes made its 64-channel bank 20–35 %
/// slower. The vector work is in plain functions, not closures (see
/// [`creep_update`]); `p` and `input` only pick rows and flags.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn pipelined<'p, 'b, T: Real + 'b, V: Block<T>>(
    o: Ops<T, V>,
    f: &Fixed<'_, T>,
    a: Layout,
    one: V,
    mut blocks: impl Iterator<Item = (usize, ((&'b mut [Row], &'b [T]), &'b mut [Compensated<T>]))>,
    p: impl Fn(usize) -> &'p [Row],
    input: impl Fn(usize) -> (usize, bool),
) {
    let Some((mut b, ((mut this, t), mut this_out))) = blocks.next() else {
        return;
    };
    let mut h = head(o, f, a, input(b), this, p(b), t);
    // the block whose creep pass is due and its input (none before a clip)
    let mut due = None;
    loop {
        let sum = inverse_sum(o, f, a, one, h, this, p(b));
        let after = blocks.next();
        if let Some((after_b, ((after, t), _))) = &after {
            h = head(o, f, a, input(*after_b), after, p(*after_b), t);
        }
        if let Some((due_b, due_state, uc)) = due {
            creep(o, a, one, uc, due_state, p(due_b));
        }
        let uc = clip(o, f, a, sum, (this, p(b)), this_out);
        due = Some((b, this, uc));
        let Some((after_b, ((after, _), after_out))) = after else {
            break;
        };
        (b, this, this_out) = (after_b, after, after_out);
    }
    if let Some((due_b, due_state, uc)) = due {
        creep(o, a, one, uc, due_state, p(due_b));
    }
}

/// [`creep_pass`] on the block, or on each of its halves in turn where
/// `V` says so ([`Block::CREEP_IN_HALVES`]).
#[inline(always)]
fn creep<T: Real, V: Block<T>>(o: Ops<T, V>, a: Layout, one: V, uc: V, s: &mut [Row], p: &[Row]) {
    if V::CREEP_IN_HALVES {
        let (lo, hi) = o.halves();
        creep_pass(lo, a, o.lo(one), o.lo(uc), s, p);
        creep_pass(hi, a, o.hi(one), o.hi(uc), s, p);
    } else {
        creep_pass(o, a, one, uc, s, p);
    }
}

/// The paper's layout (the compensator step's [`PAPER_PLAYS`] and
/// [`PAPER_CREEP`]) is compiled with every row offset and loop count known;
/// any other reads them at run time. The same operations in the same order
/// either way.
const PAPER: Layout = Layout {
    n: PAPER_PLAYS,
    nc: PAPER_CREEP.0,
    m: PAPER_CREEP.1,
};

/// `H⁻¹`'s input `y` (two terms) and faulted lanes for the bank's block
/// `index` (`superposed`: a lane of it has `S`) from its state and
/// parameter rows and targets (fewer than a block's lanes in a last one).
#[inline(always)]
fn head<T: Real, V: Block<T>>(
    o: Ops<T, V>,
    f: &Fixed<'_, T>,
    a: Layout,
    (index, superposed): (usize, bool),
    s: &[Row],
    p: &[Row],
    targets: &[T],
) -> Head<V, V::Mask> {
    // a whole block (all but perhaps the last) straight from the caller's
    // slice; the last one's lanes and zeros
    let target = if targets.len() == lanes::<T>() {
        o.load_values(targets)
    } else {
        o.load_first(targets)
    };
    let fault = o.non_finite(target);
    // y = S⁻¹[t − offset] − C in two terms (the plays' bounds are `(t ∓ r)
    // − C`, as `hysteresis::step_saving` forms them), or held (x₀ and 0)
    // where not finite. The superposed path starts from the targets in
    // memory: no vector handed to a function left out of line (the
    // compiler put `t − offset` on the stack in every block for it).
    let t = if superposed {
        inverse_superposition(o, f, index, targets, p)
    } else {
        o.sub(target, o.load(&p[a.offset()]))
    };
    let creep = o.load(&s[a.creep_out()]);
    let held = o.non_finite(o.sub(t, creep));
    let t = o.select(held, o.load(&s[a.inv_x(f.parity, 0)]), t);
    let creep = o.select(held, o.splat(T::ZERO), creep);
    Head { t, creep, fault }
}

/// What [`head`] hands to [`inverse_sum`].
#[derive(Clone, Copy)]
struct Head<V, M> {
    t: V,
    creep: V,
    fault: M,
}

/// What [`inverse_sum`] hands to [`clip`]: `H⁻¹`'s voltages before the
/// clip and the lanes whose target is not finite.
struct Inverse<V, M> {
    v: V,
    fault: M,
}

/// A block's plays: what `Compensator::compensate` does from `y` ([`head`])
/// to `H⁻¹`'s sum, lane by lane, in its order of operations (the clip is
/// [`clip`], the creep pass [`creep_pass`]).
#[inline(always)]
fn inverse_sum<T: Real, V: Block<T>>(
    o: Ops<T, V>,
    f: &Fixed<'_, T>,
    a: Layout,
    one: V,
    Head { t, creep, fault }: Head<V, V::Mask>,
    s: &mut [Row],
    p: &[Row],
) -> Inverse<V, V::Mask> {
    let cur = f.parity;
    // H⁻¹ (22): the plays into the other copy; a faulted lane keeps its
    // own. Whole slices of rows, walked in fours: no index arithmetic or
    // bounds check between the vector operations.
    let n = a.n;
    let (first_copy, second_copy) = s[..2 * n].split_at_mut(n);
    let (old, new_rows) = if cur == 0 {
        (&*first_copy, second_copy)
    } else {
        (&*second_copy, first_copy)
    };
    let (inv_r, inv_w) = (&p[a.inv_r(0)..][..n], &p[a.inv_w(0)..][..n]);
    let zero = o.splat(T::ZERO);
    let mut sums = [zero; 4];
    let full = n - n % 4;
    let fours = old[..full]
        .chunks_exact(4)
        .zip(inv_r[..full].chunks_exact(4))
        .zip(inv_w[..full].chunks_exact(4))
        .zip(new_rows[..full].chunks_exact_mut(4));
    for (k, (((x, r), w), next)) in fours.enumerate() {
        for q in 0..4 {
            let play = (&x[q], &r[q], &w[q], &mut next[q]);
            sums[q] = inverse_play(o, (sums[q], k == 0), t, creep, one, fault, play);
        }
    }
    for i in full..n {
        let sum = (sums[i - full], full == 0);
        let play = (&old[i], &inv_r[i], &inv_w[i], &mut new_rows[i]);
        sums[i - full] = inverse_play(o, sum, t, creep, one, fault, play);
    }
    let v = o.add(o.add(sums[0], sums[2]), o.add(sums[1], sums[3]));
    Inverse { v, fault }
}

/// The clip of a block's voltages from [`inverse_sum`], the re-seat of a
/// clipped lane's plays, the held voltage and the creep input into the
/// state rows `s`, and the voltages and flags into `out`. Returns the
/// creep input.
#[inline(always)]
fn clip<T: Real, V: Block<T>>(
    o: Ops<T, V>,
    f: &Fixed<'_, T>,
    a: Layout,
    Inverse { v, fault }: Inverse<V, V::Mask>,
    (s, p): (&mut [Row], &[Row]),
    out: &mut [Compensated<T>],
) -> V {
    let (cur, next) = (f.parity, f.parity ^ 1);
    // clip; a faulted lane holds its last voltage
    let (lower, upper) = (o.splat(f.lower), o.splat(f.upper));
    let (below, above) = (o.lt(v, lower), o.gt(v, upper));
    let clipped = o.select(below, lower, o.select(above, upper, v));
    let u = o.store_except(clipped, fault, &mut s[a.last_u()]);
    let saturated_lanes = o.and_not(o.or(below, above), fault);
    let saturated = o.bits(saturated_lanes);
    if saturated != 0 {
        reseat(f, s, p, saturated, cur, next);
    }
    // the creep input: the voltage applied, or the last one if not finite
    let uc = o.store_except(u, o.non_finite(u), &mut s[a.creep_last()]);
    let flags = (
        core::mem::offset_of!(Compensated<T>, saturated),
        core::mem::offset_of!(Compensated<T>, fault),
    );
    if o.store_flagged(u, saturated_lanes, fault, out, flags) {
        return uc;
    }
    let mut row = Row::default();
    o.store(u, &mut row);
    let (saturated, fault) = (o.bits(saturated_lanes), o.bits(fault));
    for ((l, out), &u) in out.iter_mut().enumerate().zip(row.lanes::<T>()) {
        *out = Compensated {
            u,
            saturated: saturated & (1 << l) != 0,
            fault: fault & (1 << l) != 0,
        };
    }
    uc
}

/// A block's creep pass (20) with the input `uc` that
/// [`clip`] returned, as `creep_pass::advance` sums it: each threshold's
/// rows summed over the eigenvalues in order, the weighted rows into the
/// partial sum `i mod 4` (each sum from its first product), each
/// threshold's rows from its first row, as there (summed from zero, one
/// addition more per threshold, for the same bits).
/// Each update is two fused operations ([`creep_update`]); of the four
/// rows' additions two are adds and two go through `add_on_multiplier`
/// (the same bits; on AVX-512 a fused `b · 1 + a`). A core that runs fused
/// multiply-adds on one pair of pipes and adds, `min` and `max` on the
/// other gets work on both from this split, with the plays' bounds on the
/// multiplier ([`inverse_play`]).
/// Four thresholds go together, eigenvalue by eigenvalue, so that four
/// independent update chains stand next to each other in the
/// instruction stream (one threshold's chain — five updates and their sum —
/// is long, and the scheduler holds only so many waiting operations); two
/// at a time where a set has sixteen registers ([`Block::PAIRED_CREEP`]:
/// AVX2, whose blocks run this pass on each of their two registers in
/// turn, see [`creep`], and the portable blocks on x86-64's SSE2). Whole slices of rows, so that no index arithmetic
/// or bounds check stands between the vector operations.
#[inline(always)]
fn creep_pass<T: Real, V: Block<T>>(
    o: Ops<T, V>,
    a: Layout,
    one: V,
    uc: V,
    s: &mut [Row],
    p: &[Row],
) {
    let (nc, m) = (a.nc, a.m);
    let zero = o.splat(T::ZERO);
    let (thresholds, weights) = (&p[a.creep_r(0)..][..nc], &p[a.creep_w(0)..][..nc]);
    let gains = &p[a.gain(0)..][..m];
    let chi = &mut s[a.chi(0, 0)..][..nc * m];
    let mut sums = [zero; 4];
    let full = nc - nc % 4;
    if m > 0 {
        let fours = chi[..full * m]
            .chunks_exact_mut(4 * m)
            .zip(thresholds[..full].chunks_exact(4))
            .zip(weights[..full].chunks_exact(4));
        for (k, ((rows_of_four, r), w)) in fours.enumerate() {
            let (r01, r23) = rows_of_four.split_at_mut(2 * m);
            let (x0, x1) = r01.split_at_mut(m);
            let (x2, x3) = r23.split_at_mut(m);
            if <V as Block<T>>::PAIRED_CREEP {
                // each pair's bounds formed just before it and its
                // weighted sums taken just after, so that one pair's
                // bounds and rows are live at a time (with both pairs'
                // sums taken after them, the AVX2 bank was 7-39 % slower)
                let (row0, row1) = creep_pair(o, one, uc, gains, (x0, &r[0]), (x1, &r[1]));
                sums[0] = o.add_term(sums[0], o.load(&w[0]), row0, k == 0);
                sums[1] = o.add_term(sums[1], o.load(&w[1]), row1, k == 0);
                let (row2, row3) = creep_pair(o, one, uc, gains, (x2, &r[2]), (x3, &r[3]));
                sums[2] = o.add_term(sums[2], o.load(&w[2]), row2, k == 0);
                sums[3] = o.add_term(sums[3], o.load(&w[3]), row3, k == 0);
                continue;
            }
            let mut lower = [zero; 4];
            let mut upper = [zero; 4];
            for q in 0..4 {
                let r = o.load(&r[q]);
                (lower[q], upper[q]) = (o.sub(uc, r), o.add(uc, r));
            }
            let mut rows = [zero; 4];
            for (j, g) in gains.iter().enumerate() {
                let g = o.load(g);
                let x = [
                    creep_update(o, &mut x0[j], g, lower[0], upper[0]),
                    creep_update(o, &mut x1[j], g, lower[1], upper[1]),
                    creep_update(o, &mut x2[j], g, lower[2], upper[2]),
                    creep_update(o, &mut x3[j], g, lower[3], upper[3]),
                ];
                if j == 0 {
                    rows = x;
                    continue;
                }
                // two rows on the adder's pipes, two on the multiplier's
                rows[0] = o.add(rows[0], x[0]);
                rows[1] = o.add(rows[1], x[1]);
                rows[2] = o.add_on_multiplier(rows[2], x[2], one);
                rows[3] = o.add_on_multiplier(rows[3], x[3], one);
            }
            for q in 0..4 {
                sums[q] = o.add_term(sums[q], o.load(&w[q]), rows[q], k == 0);
            }
        }
    }
    for i in full..nc {
        let r = o.load(&thresholds[i]);
        let (lower, upper) = (o.sub(uc, r), o.add(uc, r));
        let mut rows = zero;
        for (j, (x, g)) in chi[i * m..][..m].iter_mut().zip(gains).enumerate() {
            let x = creep_update(o, x, o.load(g), lower, upper);
            rows = if j == 0 {
                x
            } else {
                o.add_on_multiplier(rows, x, one)
            };
        }
        sums[i - full] = o.add_term(sums[i - full], o.load(&weights[i]), rows, full == 0);
    }
    let creep = o.add(o.add(sums[0], sums[2]), o.add(sums[1], sums[3]));
    o.store(creep, &mut s[a.creep_out()]);
}

/// Two thresholds' rows of [`creep_pass`] with the creep input `uc`, `a`
/// and `b` each a threshold's state rows (one per eigenvalue) and its
/// threshold (at least one eigenvalue): every eigenvalue's update, summed
/// over the eigenvalues in order from the first, `a`'s sum on the adder's
/// pipes and `b`'s on the multiplier's where a set has it
/// (`add_on_multiplier`: the same bits).
#[inline(always)]
fn creep_pair<T: Real, V: Block<T>>(
    o: Ops<T, V>,
    one: V,
    uc: V,
    gains: &[Row],
    (xa, ra): (&mut [Row], &Row),
    (xb, rb): (&mut [Row], &Row),
) -> (V, V) {
    let (ra, rb) = (o.load(ra), o.load(rb));
    let (lower_a, upper_a) = (o.sub(uc, ra), o.add(uc, ra));
    let (lower_b, upper_b) = (o.sub(uc, rb), o.add(uc, rb));
    let g = o.load(&gains[0]);
    let mut row_a = creep_update(o, &mut xa[0], g, lower_a, upper_a);
    let mut row_b = creep_update(o, &mut xb[0], g, lower_b, upper_b);
    for (j, g) in gains.iter().enumerate().skip(1) {
        let g = o.load(g);
        row_a = o.add(row_a, creep_update(o, &mut xa[j], g, lower_a, upper_a));
        let x = creep_update(o, &mut xb[j], g, lower_b, upper_b);
        row_b = o.add_on_multiplier(row_b, x, one);
    }
    (row_a, row_b)
}

/// One play of `H⁻¹` (22) on a block, `play` its state `x`, threshold,
/// weight and `next`: `x` clamped into `[(t − r) − c, (t + r) − c]` (the
/// input `y = t − c` in its two terms, as `hysteresis::step_saving` has
/// it) into `next` (the old `x` where the lane is faulted), its weighted
/// value added to `sum` as `realtime::real::add_term` adds it (`sum`: the
/// partial sum and whether this is its first term). `t ∓ r`
/// go through `sub_on_multiplier` and `add_on_multiplier` (the same bits):
/// the rest of a play is adder's work (see [`creep_pass`]). A function,
/// not a closure: see [`creep_update`].
#[inline(always)]
fn inverse_play<T: Real, V: Block<T>>(
    o: Ops<T, V>,
    sum: (V, bool),
    t: V,
    c: V,
    one: V,
    fault: V::Mask,
    play: (&Row, &Row, &Row, &mut Row),
) -> V {
    let (x, r, w, next) = play;
    let x = o.load(x);
    let r = o.load(r);
    let new = o.clamp(
        x,
        o.sub(o.sub_on_multiplier(t, r, one), c),
        o.sub(o.add_on_multiplier(t, r, one), c),
    );
    o.store(o.select(fault, x, new), next);
    o.add_term(sum.0, o.load(w), new, sum.1)
}

/// One creep operator's update (20) on a block, `χ ← χ + g (clamp(χ, u −
/// r, u + r) − χ)` as `creep_pass::update` computes it (`g c + (χ − g χ)`,
/// fused), returning the new `χ`. A function marked
/// `inline(always)`, not a closure: a closure body left out of line is
/// compiled without the step's instruction set, and every vector operation
/// in it becomes a call.
#[inline(always)]
fn creep_update<T: Real, V: Block<T>>(o: Ops<T, V>, x: &mut Row, g: V, lower: V, upper: V) -> V {
    let v = o.load(x);
    let v = o.mul_add(g, o.clamp(v, lower, upper), o.neg_mul_add(g, v, v));
    o.store(v, x);
    v
}

// The lane-by-lane paths, taken only where a block needs them: `S⁻¹` for
// the channels with a superposition, and the re-seat of a saturated lane's
// plays from the voltage applied (22), both as the single compensator
// computes them.

/// `S⁻¹[t − offset]` lane by lane on a block some of whose channels have
/// `S`, from its `targets` (its lanes past them are zero).
#[cold]
#[inline(never)]
fn inverse_superposition<T: Real, V: Block<T>>(
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::operators::bank::CompensatorBank;
    use crate::realtime::nominal::PARAMETERS;
    use crate::realtime::{CompensatorSettings, ModelParameters};

    /// Steps of `bank` on the kernels `k`, its blocks walked `walk`: the
    /// outputs of every step.
    fn run<T: Real>(
        mut bank: CompensatorBank<T>,
        k: Kernels,
        walk: Walk,
        rows: &[Vec<T>],
    ) -> (Vec<Vec<Compensated<T>>>, CompensatorBank<T>) {
        let outs = rows
            .iter()
            .map(|targets| {
                let mut out = vec![Compensated::default(); targets.len()];
                let (fixed, state) = bank.split();
                step_blocks(k, &fixed, 0, state, targets, &mut out, walk);
                bank.parity ^= 1;
                out
            })
            .collect();
        (outs, bank)
    }

    /// Walked down, a run of blocks gives the bits walked up, its outputs
    /// and its state, and so does the one-thread step walking both ways in
    /// turn, on every kernel set: whole blocks and a last, partial
    /// one; one model or one per channel (which reads each block's own
    /// parameters); the paper's layout and another;
    /// saturated and non-finite targets.
    fn check_walks<T: Real>() {
        let no_creep = ModelParameters {
            creep: None,
            ..PARAMETERS
        };
        let settings = CompensatorSettings::with_limits(-150.0, 150.0);
        for model in [PARAMETERS, no_creep] {
            for channels in [1, lanes::<T>(), 3 * lanes::<T>() + 5] {
                let rows: Vec<Vec<T>> = (0..40)
                    .map(|k| {
                        (0..channels)
                            .map(|c| match (k * 7 + c * 3) % 23 {
                                0 => T::from_f64(f64::NAN),
                                _ => T::from_f64(250.0 * ((k + 5 * c) as f64 * 0.3).sin()),
                            })
                            .collect()
                    })
                    .collect();
                let per_channel: Vec<_> = (0..channels)
                    .map(|c| ModelParameters {
                        offset: c as f64,
                        ..model
                    })
                    .collect();
                let banks = [
                    CompensatorBank::<T>::uniform(&model, channels, settings).unwrap(),
                    // a model per channel, each with its own offset
                    CompensatorBank::<T>::new(&per_channel, settings).unwrap(),
                ];
                for bank in banks {
                    for k in Kernels::all() {
                        let (up, up_bank) = run(bank.clone(), k, Walk::Up, &rows);
                        let (down, down_bank) = run(bank.clone(), k, Walk::Down, &rows);
                        assert_eq!(up, down, "{k:?}, {channels} channels, {}", T::NAME);
                        assert_eq!(up_bank.state, down_bank.state, "{k:?}, {channels} channels");
                        // the one-thread step, which walks up and down in turn
                        let mut turns = bank.clone();
                        let turned: Vec<Vec<Compensated<T>>> = rows
                            .iter()
                            .map(|targets| {
                                let mut out = vec![Compensated::default(); channels];
                                turns.compensate_using(k, targets, &mut out).unwrap();
                                out
                            })
                            .collect();
                        assert_eq!(up, turned, "{k:?}, {channels} channels, in turn");
                        assert_eq!(up_bank.state, turns.state, "{k:?}, {channels} channels");
                        assert!(up.iter().flatten().any(|c| c.saturated));
                        assert!(up.iter().flatten().any(|c| c.fault));
                    }
                }
            }
        }
    }

    #[test]
    fn blocks_walked_down_give_the_bits_walked_up() {
        check_walks::<f64>();
        check_walks::<f32>();
    }
}
