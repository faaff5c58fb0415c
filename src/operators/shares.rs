//! How a split step of a [`CompensatorBank`](super::bank::CompensatorBank)
//! shares its blocks out: the calling thread's part and the workers', the
//! caller's share set by measurement.
//!
//! Even shares do not end together. A worker starts its part a hand-over
//! after the caller starts its own (0.1–0.25 µs on a 2-vCPU Zen 4 guest:
//! one to three blocks' work), and on a virtual machine one core may run
//! slower than the other for a while, either one. So every
//! [`TIME_EVERY`]th split step times when the caller's part and the last
//! worker's part end, and every [`MOVE_EVERY`]th moves one block of the
//! caller's share: to the caller where the workers ended more than half a
//! block after it (running estimates of both), back to the workers where
//! they ended more than half a block before it. Within that band nothing
//! moves, so a split in balance keeps its division (a block that changes
//! hands is fetched from the other core's cache once). The caller's share
//! stays within half an even share of even. The blocks are independent,
//! so every division gives the same bits.

use core::ops::Range;
use std::sync::atomic::{AtomicI64, AtomicIsize, AtomicU64, Ordering};

use super::split_choice::fold;

/// Split steps between two timed ones.
pub(crate) const TIME_EVERY: u64 = 16;

/// Split steps between two moves of the division (four timed steps folded
/// into the estimates).
pub(crate) const MOVE_EVERY: u64 = 64;

/// Which blocks each part of a split of `blocks` blocks in `parts` parts
/// steps, the caller's part (0) holding `lead` blocks beyond an even
/// share.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Division {
    blocks: usize,
    parts: usize,
    /// The caller's blocks: `0..first`.
    first: usize,
    /// Each worker's blocks, and one more for the first `rest` workers.
    per_worker: usize,
    rest: usize,
}

impl Division {
    /// `blocks` in `parts` parts (at least one each where there are as
    /// many blocks), the caller's `lead` blocks beyond
    /// `blocks.div_ceil(parts)`.
    pub(crate) fn new(blocks: usize, parts: usize, lead: isize) -> Self {
        let parts = parts.max(1);
        let even = Self::even(blocks, parts);
        // every worker keeps a block where the bank has one for it
        let most = blocks.saturating_sub(parts - 1).max(1).min(blocks);
        let first = even.saturating_add_signed(lead).clamp(1.min(blocks), most);
        let workers = parts - 1;
        let left = blocks - first;
        let (per_worker, rest) = left
            .checked_div(workers)
            .zip(left.checked_rem(workers))
            .unwrap_or((0, 0));
        Self {
            blocks,
            parts,
            first,
            per_worker,
            rest,
        }
    }

    /// An even share of `blocks` in `parts` parts (at least one part),
    /// the share a lead is counted from.
    pub(crate) fn even(blocks: usize, parts: usize) -> usize {
        blocks.div_ceil(parts.max(1))
    }

    /// The blocks of part `part` (empty past the last block).
    pub(crate) fn part(&self, part: usize) -> Range<usize> {
        let start = |p: usize| {
            if p == 0 {
                0
            } else if p >= self.parts {
                self.blocks
            } else {
                let w = p - 1;
                self.first + w * self.per_worker + w.min(self.rest)
            }
        };
        start(part)..start(part + 1)
    }
}

/// The caller's share of a split and what it is set from. Atomics with
/// relaxed loads and stores only (`Workers` is shared by reference; one
/// caller at a time is the expected use, and a race between two only
/// blurs an estimate).
#[derive(Debug, Default)]
pub(crate) struct Shares {
    /// Blocks the caller takes beyond an even share (negative: fewer).
    lead: AtomicIsize,
    /// Split steps so far.
    steps: AtomicU64,
    /// Picoseconds from the end of the caller's part to the end of the
    /// last worker's (negative: the workers ended first), running estimate.
    skew: AtomicI64,
    /// Picoseconds per block of the caller's part, running estimate.
    block: AtomicU64,
}

impl Shares {
    /// The caller's lead for the next split step of a bank whose even
    /// share is `even` blocks (within [`limit`]: a lead set on a larger
    /// bank does not unbalance a smaller one), and the step's number if it
    /// is to be timed (then [`Shares::record`] its times with it).
    #[inline]
    pub(crate) fn next(&self, even: usize) -> (isize, Option<u64>) {
        let step = self.steps.load(Ordering::Relaxed);
        self.steps.store(step.wrapping_add(1), Ordering::Relaxed);
        let limit = limit(even);
        (
            self.lead.load(Ordering::Relaxed).clamp(-limit, limit),
            step.is_multiple_of(TIME_EVERY).then_some(step),
        )
    }

    /// Timed split step `step` (the number [`Shares::next`] gave): its
    /// caller's part of `caller_blocks` blocks ended `caller_ns` and the
    /// last worker's `workers_ns` nanoseconds after the step began, `even`
    /// being an even share.
    pub(crate) fn record(
        &self,
        step: u64,
        caller_ns: u64,
        workers_ns: u64,
        caller_blocks: usize,
        even: usize,
    ) {
        let block = caller_ns.saturating_mul(1000) / caller_blocks.max(1) as u64;
        let block = fold(self.block.load(Ordering::Relaxed), block);
        self.block.store(block, Ordering::Relaxed);
        let skew = (workers_ns as i64 - caller_ns as i64).saturating_mul(1000);
        let skew = fold_skew(self.skew.load(Ordering::Relaxed), skew, block);
        self.skew.store(skew, Ordering::Relaxed);
        if step.is_multiple_of(MOVE_EVERY) {
            let limit = limit(even);
            let lead = self.lead.load(Ordering::Relaxed).clamp(-limit, limit);
            self.lead
                .store(next_lead(lead, skew, block, limit), Ordering::Relaxed);
        }
    }

    /// The caller's lead set to `lead` (tests: every division gives the
    /// same bits).
    #[cfg(test)]
    pub(crate) fn set_lead(&self, lead: isize) {
        self.lead.store(lead, Ordering::Relaxed);
    }
}

/// The largest lead, either way, for a bank whose even share is `even`
/// blocks: half of it.
fn limit(even: usize) -> isize {
    isize::try_from(even / 2).unwrap_or(isize::MAX)
}

/// A skew sample folded into its running estimate `old` (weight ¼), the
/// sample held within four blocks `block` either way, so that a worker the
/// operating system delayed once does not move the division.
pub(crate) fn fold_skew(old: i64, sample: i64, block: u64) -> i64 {
    let bound = i64::try_from(block.saturating_mul(4)).unwrap_or(i64::MAX);
    let sample = sample.clamp(-bound, bound);
    (3 * (old / 4) + sample / 4).clamp(-bound, bound)
}

/// The lead after a move: one block to the caller where the workers end
/// more than half a block `block` after it (`skew`), one back where they
/// end more than half a block before, within `±limit`.
pub(crate) fn next_lead(lead: isize, skew: i64, block: u64, limit: isize) -> isize {
    let half = i64::try_from(block / 2).unwrap_or(i64::MAX);
    let moved = if skew > half {
        lead + 1
    } else if skew < -half {
        lead - 1
    } else {
        lead
    };
    moved.clamp(-limit.max(0), limit.max(0))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every division covers the blocks once, in order, gives the caller an
    /// even share and the lead where it can, the workers' shares a block
    /// apart at most, and every part a block where the bank has one for
    /// each (mutation caught: the workers' remainder left to the last).
    #[test]
    fn a_division_covers_every_block_once() {
        for blocks in 0..40 {
            for parts in 1..5 {
                for lead in -6..7 {
                    let d = Division::new(blocks, parts, lead);
                    let mut next = 0;
                    for p in 0..parts {
                        let r = d.part(p);
                        assert_eq!(r.start, next, "{blocks} {parts} {lead}");
                        assert!(r.start <= r.end);
                        if blocks >= parts {
                            assert!(!r.is_empty(), "{blocks} blocks, {parts} parts, lead {lead}");
                        }
                        next = r.end;
                    }
                    assert_eq!(next, blocks, "{blocks} {parts} {lead}");
                    // the workers' shares differ by a block at most
                    let lengths = (1..parts).map(|p| d.part(p).len());
                    let (short, long) = (lengths.clone().min(), lengths.max());
                    if let (Some(short), Some(long)) = (short, long) {
                        assert!(
                            long - short <= 1,
                            "{blocks} blocks, {parts} parts, lead {lead}"
                        );
                    }
                    assert!(d.part(parts).is_empty());
                    let even = blocks.div_ceil(parts);
                    if blocks >= parts {
                        let wanted = even.saturating_add_signed(lead).max(1);
                        assert!(
                            d.part(0).len() == wanted || d.part(0).len() == blocks - (parts - 1)
                        );
                    }
                }
            }
        }
        // no lead: the even shares of before (the caller first)
        assert_eq!(Division::new(16, 2, 0).part(0), 0..8);
        assert_eq!(Division::new(17, 2, 0).part(1), 9..17);
        assert_eq!(Division::new(16, 2, 2).part(1), 10..16);
    }

    /// The lead moves by one towards the part that ends later, only past
    /// half a block, and stays within its limit.
    #[test]
    fn the_lead_follows_the_later_part() {
        let block = 90_000; // ps
        assert_eq!(next_lead(0, 46_000, block, 4), 1);
        assert_eq!(next_lead(0, 44_000, block, 4), 0);
        assert_eq!(next_lead(0, -44_000, block, 4), 0);
        assert_eq!(next_lead(0, -46_000, block, 4), -1);
        assert_eq!(next_lead(4, 1_000_000, block, 4), 4);
        assert_eq!(next_lead(-4, -1_000_000, block, 4), -4);
        assert_eq!(next_lead(3, 0, block, 1), 1);
        assert_eq!(next_lead(2, 90_000, block, 0), 0);
        // a late sample counts as four blocks at most
        assert_eq!(fold_skew(0, 10_000_000, block), 90_000);
        assert_eq!(fold_skew(0, -10_000_000, block), -90_000);
        assert_eq!(fold_skew(40_000, 40_000, block), 40_000);
    }

    /// Timed steps move the lead towards the later part, one block per
    /// `MOVE_EVERY` steps, and back.
    #[test]
    fn recorded_times_move_the_lead() {
        let b = Shares::default();
        let mut leads = Vec::new();
        for _ in 0..4 * MOVE_EVERY {
            let (lead, timed) = b.next(8);
            if let Some(step) = timed {
                // the workers end 300 ns after the caller's 8 blocks of 90 ns
                b.record(step, 720, 1020, 8, 8);
            }
            leads.push(lead);
        }
        assert_eq!(b.next(8).0, 4);
        // a smaller bank's step takes the lead within its own limit
        assert_eq!(b.next(4).0, 2);
        assert_eq!(b.next(1).0, 0);
        assert_eq!(leads[0], 0);
        // one move per MOVE_EVERY steps, at the timed step that starts each
        let m = MOVE_EVERY as usize;
        assert_eq!(
            (leads[1], leads[m], leads[m + 1], leads[2 * m + 1]),
            (1, 1, 2, 3)
        );
        assert!(leads.windows(2).all(|w| w[1] - w[0] <= 1 && w[1] >= w[0]));
        for _ in 0..16 * MOVE_EVERY {
            let (_, timed) = b.next(8);
            if let Some(step) = timed {
                b.record(step, 720, 420, 8, 8);
            }
        }
        assert_eq!(b.next(8).0, -4);
    }
}
