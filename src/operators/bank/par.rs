//! How a bank's step uses threads: a parameter of the call ([`Par`]), not
//! a policy of the library. The sequential step is the default; the
//! parallel one forks the blocks over the current rayon pool in fixed,
//! even parts, so a step's split depends on nothing but the bank's size
//! and the count asked for.

#[cfg(feature = "rayon")]
use core::num::NonZeroUsize;

#[cfg(feature = "rayon")]
use crate::realtime::compensator::Compensated;
#[cfg(feature = "rayon")]
use crate::realtime::simd::block::Row;

/// The threads a call may use (after faer's `Par`).
///
/// With [`Par::Rayon`] the parts run in the rayon pool the call is made
/// from ([`rayon::ThreadPool::install`]), or in rayon's global pool. A
/// real-time caller builds its own pool with
/// [`rayon::ThreadPoolBuilder::spawn_handler`], the hook where it pins each
/// thread to a core and sets its priority, and runs its control loop
/// inside that pool's `install`: a step then hands its parts to the pool's
/// own threads and allocates nothing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[non_exhaustive]
pub enum Par {
    /// On the calling thread alone.
    #[default]
    Seq,
    /// Split into this many even parts (at most one per block), run by
    /// fork-join in the current rayon pool.
    #[cfg(feature = "rayon")]
    Rayon(NonZeroUsize),
}

impl Par {
    /// [`Par::Rayon`] with `parts` parts, or with one per thread of the
    /// current rayon pool if `parts` is 0.
    #[cfg(feature = "rayon")]
    pub fn rayon(parts: usize) -> Self {
        let parts = NonZeroUsize::new(parts).unwrap_or_else(|| {
            NonZeroUsize::new(rayon::current_num_threads()).unwrap_or(NonZeroUsize::MIN)
        });
        Par::Rayon(parts)
    }

    /// How many parts a call splits its work into.
    pub fn parts(self) -> usize {
        match self {
            Par::Seq => 1,
            #[cfg(feature = "rayon")]
            Par::Rayon(parts) => parts.get(),
        }
    }

    /// `f` of each item, in the items' order: one after another, or with
    /// [`Par::Rayon`] each item a task of the current rayon pool (a search's
    /// trials, which differ in cost, are balanced by the pool's stealing
    /// rather than split into even parts). The results do not depend on it.
    #[cfg(feature = "identification")]
    pub(crate) fn map<T: Sync, R: Send>(
        self,
        items: &[T],
        f: impl Fn(&T) -> R + Sync + Send,
    ) -> std::vec::Vec<R> {
        match self {
            Par::Seq => items.iter().map(f).collect(),
            #[cfg(feature = "rayon")]
            Par::Rayon(_) => {
                use rayon::prelude::*;
                items.par_iter().map(f).collect()
            }
        }
    }
}

/// A part's step: `(part, first block, state rows, targets, outputs)`.
#[cfg(feature = "rayon")]
pub(super) type PartStep<'a, T> =
    dyn Fn(usize, usize, &mut [Row], &[T], &mut [Compensated<T>]) + Sync + 'a;

/// Blocks split into `parts` even parts, each `rows` state rows and `lanes`
/// channels a block.
#[cfg(feature = "rayon")]
#[derive(Debug, Clone, Copy)]
pub(super) struct Division {
    pub(super) parts: usize,
    pub(super) blocks: usize,
    pub(super) rows: usize,
    pub(super) lanes: usize,
}

/// Runs `step(part, first_block, state, targets, out)` on each part of
/// `division`: part `i` holds blocks `⌊i·B/p⌋..⌊(i+1)·B/p⌋`, their state
/// rows, targets and outputs. Halves are forked by `rayon::join`, so the
/// parts are disjoint borrows and the step needs no `unsafe`.
#[cfg(feature = "rayon")]
pub(super) fn fork<T: Send + Sync>(
    step: &PartStep<'_, T>,
    division: Division,
    state: &mut [Row],
    targets: &[T],
    out: &mut [Compensated<T>],
) {
    fork_range(step, division, 0, division.parts, state, targets, out);
}

/// Parts `first..end` of `division`, whose state, targets and outputs are
/// the slices given.
#[cfg(feature = "rayon")]
fn fork_range<T: Send + Sync>(
    step: &PartStep<'_, T>,
    division: Division,
    first: usize,
    end: usize,
    state: &mut [Row],
    targets: &[T],
    out: &mut [Compensated<T>],
) {
    let block = |part: usize| part * division.blocks / division.parts;
    if end - first == 1 {
        step(first, block(first), state, targets, out);
        return;
    }
    let middle = first + (end - first) / 2;
    let left_blocks = block(middle) - block(first);
    let channels = (left_blocks * division.lanes).min(targets.len());
    let (state_left, state_right) = state.split_at_mut(left_blocks * division.rows);
    let (targets_left, targets_right) = targets.split_at(channels);
    let (out_left, out_right) = out.split_at_mut(channels);
    rayon::join(
        || {
            fork_range(
                step,
                division,
                first,
                middle,
                state_left,
                targets_left,
                out_left,
            )
        },
        || {
            fork_range(
                step,
                division,
                middle,
                end,
                state_right,
                targets_right,
                out_right,
            )
        },
    );
}

#[cfg(all(test, feature = "rayon"))]
mod tests {
    use super::*;
    use std::sync::Mutex;

    /// Every part gets its even share of the blocks, with its own rows and
    /// channels, the last partial block included, and each part runs once.
    #[test]
    fn a_division_gives_each_part_its_even_share() {
        for (blocks, parts, channels) in
            [(13, 2, 13 * 8 - 3), (13, 3, 13 * 8), (4, 4, 30), (7, 5, 50)]
        {
            let division = Division {
                parts,
                blocks,
                rows: 3,
                lanes: 8,
            };
            let mut state = vec![Row::default(); blocks * 3];
            let targets: Vec<f64> = (0..channels).map(|c| c as f64).collect();
            let mut out = vec![Compensated::<f64>::default(); channels];
            let seen = Mutex::new(Vec::new());
            fork(
                &|part, first, state: &mut [Row], targets: &[f64], out: &mut [Compensated<f64>]| {
                    assert_eq!(state.len() % 3, 0);
                    let count = state.len() / 3;
                    assert_eq!(first, part * blocks / parts);
                    assert_eq!(count, (part + 1) * blocks / parts - first);
                    assert_eq!(targets.len(), out.len());
                    assert_eq!(targets.first().copied(), Some((first * 8) as f64));
                    for (o, t) in out.iter_mut().zip(targets) {
                        o.u = *t;
                    }
                    seen.lock().unwrap().push(part);
                },
                division,
                &mut state,
                &targets,
                &mut out,
            );
            let mut seen = seen.into_inner().unwrap();
            seen.sort_unstable();
            assert_eq!(seen, (0..parts).collect::<Vec<_>>());
            assert!(out.iter().zip(&targets).all(|(o, t)| o.u == *t));
        }
    }

    #[test]
    fn rayon_of_zero_takes_the_pool_s_threads() {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(3)
            .build()
            .unwrap();
        assert_eq!(pool.install(|| Par::rayon(0)).parts(), 3);
        assert_eq!(Par::rayon(2).parts(), 2);
        assert_eq!(Par::default(), Par::Seq);
        assert_eq!(Par::Seq.parts(), 1);
    }
}
