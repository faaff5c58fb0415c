//! Worker threads for a large [`CompensatorBank`](super::bank::CompensatorBank):
//! the bank's blocks split over cores within one step.
//!
//! The threads are made once ([`Workers::new`]); a step hands them a job by
//! bumping a generation counter and waits for a done counter — atomics
//! only, no allocation and no lock. An idle worker spins for a while
//! (a control loop's next sample is close) and then parks; the step wakes
//! it. The job borrows the caller's stack: `Workers::run` returns only
//! when every worker has finished it (and a worker's panic is re-raised),
//! the scoped-thread rule kept by hand.

use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::Arc;
use std::thread::{self, JoinHandle, Thread};

/// A job: called with the part index `1..=workers` on each worker.
type Job = dyn Fn(usize) + Sync;

/// What the step and its workers share.
struct Shared {
    /// Bumped for each job; a worker runs every generation once.
    generation: AtomicU64,
    /// Workers that have finished the current job.
    done: AtomicUsize,
    /// A worker's job panicked.
    panicked: AtomicBool,
    stop: AtomicBool,
    /// The current job, valid while `run` waits (a fat pointer in two words).
    job: AtomicJob,
}

/// `*const Job` in two atomics (a fat pointer; only `run` writes it, before
/// it bumps the generation, and clears nothing: a worker reads it only
/// after seeing the new generation).
struct AtomicJob([AtomicUsize; 2]);

impl AtomicJob {
    fn set(&self, job: *const Job) {
        // SAFETY: a `*const dyn` is two words.
        let words: [usize; 2] = unsafe { std::mem::transmute(job) };
        self.0[0].store(words[0], Ordering::Relaxed);
        self.0[1].store(words[1], Ordering::Relaxed);
    }

    fn get(&self) -> *const Job {
        let words = [
            self.0[0].load(Ordering::Relaxed),
            self.0[1].load(Ordering::Relaxed),
        ];
        // SAFETY: the two words `set` stored.
        unsafe { std::mem::transmute::<[usize; 2], *const Job>(words) }
    }
}

/// Spins before a waiting thread parks (about 50–100 µs).
const SPINS: usize = 50_000;

/// Banks of fewer blocks than this step on the calling thread alone
/// (`CompensatorBank::compensate_on`): handing a step to a worker costs
/// about a quarter of a microsecond, a block's step about 60 ns. Measured
/// on an AMD EPYC Zen 5 (`cargo bench --bench bank_limit`, crossover scan):
/// a split is slower up to 4 blocks, 4 % (`f64`) and 11 % (`f32`) faster
/// at 8, 21–24 % at 24; from 12 on it is faster with a margin.
pub const DEFAULT_MIN_BLOCKS: usize = 12;

/// Threads that step parts of a bank together with the calling thread.
pub struct Workers {
    shared: Arc<Shared>,
    threads: Vec<JoinHandle<()>>,
    handles: Vec<Thread>,
    /// The crossover: fewer blocks run on the caller alone.
    min_blocks: usize,
}

impl std::fmt::Debug for Workers {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Workers")
            .field("threads", &self.threads.len())
            .finish()
    }
}

impl Workers {
    /// `extra` worker threads (the calling thread is the first part: a
    /// step on `extra + 1` cores). 0 is allowed: every step on the caller.
    pub fn new(extra: usize) -> std::io::Result<Self> {
        let shared = Arc::new(Shared {
            generation: AtomicU64::new(0),
            done: AtomicUsize::new(0),
            panicked: AtomicBool::new(false),
            stop: AtomicBool::new(false),
            job: AtomicJob([AtomicUsize::new(0), AtomicUsize::new(0)]),
        });
        let mut threads = Vec::with_capacity(extra);
        for part in 1..=extra {
            let shared = Arc::clone(&shared);
            threads.push(
                thread::Builder::new()
                    .name(format!("mfcbeam-bank-{part}"))
                    .spawn(move || work(&shared, part))?,
            );
        }
        let handles = threads.iter().map(|t| t.thread().clone()).collect();
        Ok(Self {
            shared,
            threads,
            handles,
            min_blocks: DEFAULT_MIN_BLOCKS,
        })
    }

    /// The crossover set to `blocks`: a bank of fewer blocks steps on the
    /// calling thread alone (0: every bank is split).
    pub fn with_min_blocks(mut self, blocks: usize) -> Self {
        self.min_blocks = blocks;
        self
    }

    /// Banks of fewer blocks than this step on the calling thread alone
    /// ([`DEFAULT_MIN_BLOCKS`] unless set).
    pub fn min_blocks(&self) -> usize {
        self.min_blocks
    }

    /// How many jobs the workers have been handed (for tests: whether a
    /// step was split).
    #[doc(hidden)]
    pub fn jobs_handed(&self) -> u64 {
        self.shared.generation.load(Ordering::Relaxed)
    }

    /// The number of parts a job is split into (the workers and the caller).
    pub fn parts(&self) -> usize {
        self.threads.len() + 1
    }

    /// `job(0)` here and `job(p)` on worker `p`, returning when all are done.
    /// Allocation-free.
    pub(crate) fn run(&self, job: &(dyn Fn(usize) + Sync + '_)) {
        let workers = self.threads.len();
        if workers == 0 {
            job(0);
            return;
        }
        let s = &*self.shared;
        s.done.store(0, Ordering::Relaxed);
        // SAFETY: only the lifetime is erased; the job is not used after
        // this call returns (every worker is done with it then).
        s.job.set(unsafe {
            std::mem::transmute::<*const (dyn Fn(usize) + Sync + '_), *const Job>(job)
        });
        // Release: the job and the caller's data are visible to a worker
        // that sees the new generation
        s.generation.fetch_add(1, Ordering::Release);
        for h in &self.handles {
            h.unpark();
        }
        // the workers borrow the caller's data until they are done, so a
        // panic of this part waits for them before it unwinds
        let mine = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| job(0)));
        let mut spins = 0;
        while s.done.load(Ordering::Acquire) < workers {
            if spins < SPINS {
                spins += 1;
                std::hint::spin_loop();
            } else {
                thread::yield_now();
            }
        }
        if let Err(payload) = mine {
            std::panic::resume_unwind(payload);
        }
        if s.panicked.swap(false, Ordering::Relaxed) {
            panic!("a bank worker panicked");
        }
    }
}

impl Drop for Workers {
    fn drop(&mut self) {
        self.shared.stop.store(true, Ordering::Release);
        self.shared.generation.fetch_add(1, Ordering::Release);
        for h in &self.handles {
            h.unpark();
        }
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

/// A worker: wait for a new generation, run its part, count it done.
fn work(s: &Shared, part: usize) {
    let mut seen = 0u64;
    loop {
        let mut spins = 0;
        let generation = loop {
            let g = s.generation.load(Ordering::Acquire);
            if g != seen {
                break g;
            }
            if spins < SPINS {
                spins += 1;
                std::hint::spin_loop();
            } else {
                thread::park();
            }
        };
        seen = generation;
        if s.stop.load(Ordering::Acquire) {
            return;
        }
        // SAFETY: `run` stored a job that lives until every worker has
        // counted itself done, which this one has not yet.
        let job = unsafe { &*s.job.get() };
        if std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| job(part))).is_err() {
            s.panicked.store(true, Ordering::Relaxed);
        }
        s.done.fetch_add(1, Ordering::Release);
    }
}

/// A mutable slice that several parts of one job write, each its own
/// disjoint range.
pub(crate) struct SharedMut<T> {
    ptr: *mut T,
    len: usize,
}

// SAFETY: the parts access disjoint ranges (the `slice` contract); the
// elements are sent between threads.
unsafe impl<T: Send> Sync for SharedMut<T> {}

impl<T> SharedMut<T> {
    pub(crate) fn new(slice: &mut [T]) -> Self {
        Self {
            ptr: slice.as_mut_ptr(),
            len: slice.len(),
        }
    }

    /// The elements `range`.
    ///
    /// # Safety
    /// No other part uses an overlapping range while the slice lives, and
    /// the slice given to `new` outlives it.
    #[allow(clippy::mut_from_ref)]
    pub(crate) unsafe fn slice(&self, range: std::ops::Range<usize>) -> &mut [T] {
        assert!(range.start <= range.end && range.end <= self.len);
        // SAFETY: in bounds (asserted); disjointness and lifetime are the
        // caller's contract.
        unsafe { std::slice::from_raw_parts_mut(self.ptr.add(range.start), range.len()) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::panic::{catch_unwind, AssertUnwindSafe};

    #[test]
    fn every_part_runs_once_and_a_panic_waits_for_the_others() {
        let w = Workers::new(2).unwrap();
        assert_eq!(w.parts(), 3);
        let parts = AtomicUsize::new(0);
        for _ in 0..100 {
            w.run(&|p| {
                parts.fetch_add(1 << (8 * p), Ordering::Relaxed);
            });
        }
        assert_eq!(
            parts.load(Ordering::Relaxed),
            100 * (1 + (1 << 8) + (1 << 16))
        );
        // a panic on the calling thread's part unwinds only after the
        // workers, which may borrow the caller's data, are done
        let done = AtomicUsize::new(0);
        let r = catch_unwind(AssertUnwindSafe(|| {
            w.run(&|p| {
                if p == 0 {
                    panic!("part 0 fails");
                }
                thread::sleep(std::time::Duration::from_millis(20));
                done.fetch_add(1, Ordering::Relaxed);
            })
        }));
        assert!(r.is_err());
        assert_eq!(done.load(Ordering::Relaxed), 2);
        // a worker's panic is raised on the caller, and the pool goes on
        let r = catch_unwind(AssertUnwindSafe(|| {
            w.run(&|p| {
                if p == 2 {
                    panic!("part 2 fails");
                }
            })
        }));
        assert!(r.is_err());
        let after = AtomicUsize::new(0);
        w.run(&|_| {
            after.fetch_add(1, Ordering::Relaxed);
        });
        assert_eq!(after.load(Ordering::Relaxed), 3);
    }
}
