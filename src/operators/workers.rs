//! Worker threads for a large [`CompensatorBank`](super::bank::CompensatorBank):
//! the bank's blocks split over cores within one step.
//!
//! The threads are made once ([`Workers::new`]); a step hands them a job by
//! bumping a generation counter and waits for a done counter — atomics
//! only, no allocation and no lock. An idle worker spins for a while
//! (a control loop's next sample is close), yielding its core now and then
//! to any thread the OS has waiting for it, and then parks; the step wakes
//! it, less often in time while no split follows a wake. The job borrows
//! the caller's stack: `Workers::run` returns only when every part is done
//! (and a worker's panic is re-raised), the scoped-thread rule kept by
//! hand. A worker claims its part before it
//! reads the job; a part still unclaimed a little after the caller's own
//! part ended the caller claims and runs itself, so that a worker the OS
//! has not run yet holds no step. A part claimed is its claimer's to
//! finish: a worker preempted in the middle of its part still holds the
//! step until it runs again.
//!
//! Whether a split pays is measured while the bank runs, by the rules of
//! the `split_choice` module: a split costs a hand-over (the job's cache
//! line to a worker and the done count back: 0.15–0.35 µs on a 2-vCPU
//! Zen 4 guest), which does not pay for every bank nor at every moment.
//! How a split shares out the blocks is the `shares` module's.

use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::Arc;
use std::thread::{self, JoinHandle, Thread};
use std::time::Duration;

use super::shares::Shares;
use super::split_choice::{
    capped, fold_in_use, longest_interval, next_interval, plan, shortest_interval, split_pays,
    Choice, Plan,
};

/// A job: called with the part index `1..=workers` on each worker.
type Job = dyn Fn(usize) + Sync;

/// What the step and its workers share: what a worker reads to start on
/// one cache line (the caller writes it), the count of finished parts on
/// another (the workers write it).
#[repr(C, align(128))]
struct Shared {
    /// Bumped for each job (only by the caller, by a plain store); a worker
    /// runs every generation once.
    generation: AtomicU64,
    stop: AtomicBool,
    /// The current job, valid while `run` waits (a fat pointer in two words).
    job: AtomicJob,
    /// Parts the workers have finished since they were made: after
    /// generation `g`, `g` times the workers. Never reset, so that the
    /// caller does not write the line the workers write.
    done: OwnLine<AtomicU64>,
    /// A worker's job panicked.
    panicked: AtomicBool,
    /// Each worker's earliest time to park ([`Shared::now_ns`]; 0 while
    /// parked): it spins at least until then.
    awake_until: Box<[OwnLine<AtomicU64>]>,
    /// Each worker's part: the last generation whose part was claimed, by
    /// the worker (which then runs it) or by the caller (which runs it
    /// itself: the worker was late). Raised by `fetch_max`, so that exactly
    /// one of them wins a part.
    claimed: Box<[OwnLine<AtomicU64>]>,
    /// Tests only: a worker waits while this is set before it claims its
    /// part (a worker late by as long as a test needs).
    #[cfg(test)]
    hold: AtomicBool,
    /// Tests only: the times a waiting worker yielded its core.
    #[cfg(test)]
    yields: AtomicUsize,
    /// What [`Shared::now_ns`] counts from.
    epoch: std::time::Instant,
    /// Workers that have started running.
    started: AtomicUsize,
}

impl Shared {
    /// Nanoseconds since the workers were made.
    fn now_ns(&self) -> u64 {
        u64::try_from(self.epoch.elapsed().as_nanos()).unwrap_or(u64::MAX)
    }
}

/// A value on cache lines of its own (128 bytes: the pair of lines the
/// adjacent-line prefetchers fetch together).
#[repr(align(128))]
struct OwnLine<T>(T);

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

/// Spins before a waiting thread parks: 50–100 µs where a `pause` takes
/// 1–2 ns, about 1.3 ms on a Zen 4 guest where it took 26–28 ns (there a
/// worker stepped every 0.2 ms sample does not park between samples),
/// about 0.5 ms on a Sapphire Rapids guest; and for [`SPIN_NS`] at least,
/// the time it publishes (where pauses are fast, the time is the longer).
/// A worker spins as long again after every time it wakes, with a job or
/// without (the token a job's unpark left while it spun wakes it once
/// more at its next park).
const SPINS: usize = 50_000;

/// Spins of the calling thread, after its own part, before it takes the
/// parts no worker has claimed yet (0.3–0.5 µs where a `pause` takes
/// 1–2 ns, about 7 µs on a Zen 4 guest, 2.6 µs on a Sapphire Rapids
/// guest, by [`SPINS`]' figures): a worker spinning for the job claims it
/// within a hand-over (0.15–0.35 µs), one that has not by then is not
/// running, and its part run here costs one part's time where waiting
/// costs its wake (36–70 µs after an unpark on a Sapphire Rapids guest) or
/// the rest of a time slice. Checked late, not at once, so that the caller
/// does not read a claim's line while its worker is at work in the common
/// case.
const TAKE_AFTER_SPINS: usize = 256;

/// Banks of fewer blocks than this step on the calling thread alone
/// (`CompensatorBank::compensate_on`): handing a step to a worker costs
/// about a quarter of a microsecond, a block's step about 60 ns. Measured
/// on an AMD EPYC Zen 5 (`cargo bench --bench bank_limit`, crossover scan):
/// a split is slower up to 4 blocks, 4 % (`f64`) and 11 % (`f32`) faster
/// at 8, 21–24 % at 24; from 12 on it is faster with a margin.
pub const DEFAULT_MIN_BLOCKS: usize = 12;

/// The crossover on an Intel CPU. Measured on a Sapphire Rapids guest (the
/// same scan, fifteen runs of `f64` and `f32`): a split took 1.07–1.27
/// times one thread at 12 blocks, 0.90–1.06 at 16 and 0.82–0.94 at 24; a
/// handed-over step waits longer for a worker there, and with the
/// crossover at 12 `compensate_on` ran 1.02–1.04 times one thread at 12
/// blocks. From 24 on a split is faster with a margin.
pub const INTEL_MIN_BLOCKS: usize = 24;

/// The crossover [`Workers::new`] starts with on this CPU:
/// [`INTEL_MIN_BLOCKS`] on an Intel CPU, [`DEFAULT_MIN_BLOCKS`] on any
/// other.
pub fn default_min_blocks() -> usize {
    #[cfg(target_arch = "x86_64")]
    if crate::realtime::simd::vendor_is_intel() {
        return INTEL_MIN_BLOCKS;
    }
    DEFAULT_MIN_BLOCKS
}

/// Threads that step parts of a bank together with the calling thread.
pub struct Workers {
    shared: Arc<Shared>,
    threads: Vec<JoinHandle<()>>,
    handles: Vec<Thread>,
    /// The crossover: fewer blocks run on the caller alone.
    min_blocks: usize,
    /// Above the crossover, choose between one thread and a split by
    /// timing both now and then (else always split).
    adaptive: bool,
    choice: Choice,
    /// A job is running: a second caller at the same time (another thread
    /// with the same `&Workers`) runs all parts of its job itself. Here,
    /// not in `Shared`: the workers never read it, so their spinning does
    /// not share its cache line.
    busy: AtomicBool,
    /// The calling thread's share of a split, and whether it is set by
    /// measurement (else even shares).
    shares: Shares,
    measured_shares: bool,
    /// Waking parked workers: see [`Workers::awake_for_a_split`].
    wakes: Wakes,
}

/// When [`Workers::awake_for_a_split`] wakes the workers: after `after`
/// steps planned split that found one not spinning, and `gap_ns` after the
/// last wake, both doubled after each wake that no split followed.
#[derive(Debug)]
struct Wakes {
    /// Such steps from one wake to the next.
    after: AtomicUsize,
    /// The least time from one wake to the next, ns.
    gap_ns: AtomicU64,
    /// When the last wake was issued ([`Shared::now_ns`]).
    last_wake: AtomicU64,
    /// Such steps since the last wake.
    skipped: AtomicUsize,
    /// A job was handed since the last wake.
    handed: AtomicBool,
    /// When the last step planned split was planned ([`Shared::now_ns`]).
    last_split_plan: AtomicU64,
    /// Tests only: the wakes issued.
    #[cfg(test)]
    issued: AtomicUsize,
}

/// The most steps between two wakes of parked workers.
const MOST_STEPS_BETWEEN_WAKES: usize = 1024;

/// The longest least time between two wakes of parked workers (32 ms, in
/// ns). A wake that no split follows costs an unpark and the worker's
/// spin: where the cores are all busy, with wakes 1024 steps (1.5 ms of a
/// 256-channel `f64` bank on a Zen 5) apart and a worker that yields
/// ([`YIELD_NS`]), `compensate_on` there took 1.02–1.05 times one thread
/// in seven of twelve batches (0.86–1.29 in all); spaced by time as well,
/// about one thread's time (0.81–1.26, the mean about 1.01).
const MOST_NS_BETWEEN_WAKES: u64 = 32_000_000;

/// A worker spins at least this long after a job or a wake before it
/// parks (0.5 ms, in ns), and publishes when that ends.
const SPIN_NS: u64 = 500_000;

/// A waiting worker yields its core this often (20 µs, in ns), so that a
/// thread the OS runs on the same core goes first. Where the cores are
/// all busy (another program's threads, or more of this one's than
/// cores), a worker woken for steps that then did not come to it spun
/// [`SPIN_NS`] of a core some other thread was waiting for, often the
/// calling thread's own: with a third busy thread on a 2-vCPU Zen 5
/// guest, `compensate_on` at 256 `f64` channels took 1.05–1.59 times one
/// thread, every step on the calling thread (no split ever handed). On an
/// idle core the yield returns at once.
const YIELD_NS: u64 = 20_000;

/// A step is handed to the workers only if each will spin at least this
/// much longer (50 µs, in ns): one about to park could otherwise park just
/// before the job arrives, and the job would wait for the OS to run it
/// again (with steps about 0.6 ms apart, 1024 `f64` channels took 1.17
/// times one thread in two runs of three on a Sapphire Rapids guest).
const HANDOVER_NS: u64 = 50_000;

impl std::fmt::Debug for Workers {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Workers")
            .field("threads", &self.threads.len())
            .field("min_blocks", &self.min_blocks)
            .field("adaptive", &self.adaptive)
            .field("measured_shares", &self.measured_shares)
            .finish()
    }
}

impl Workers {
    /// `extra` worker threads (the calling thread is the first part: a
    /// step on `extra + 1` cores). 0 is allowed: every step on the caller.
    /// Returns once every worker runs.
    pub fn new(extra: usize) -> std::io::Result<Self> {
        let shared = Arc::new(Shared {
            generation: AtomicU64::new(0),
            stop: AtomicBool::new(false),
            job: AtomicJob([AtomicUsize::new(0), AtomicUsize::new(0)]),
            done: OwnLine(AtomicU64::new(0)),
            panicked: AtomicBool::new(false),
            awake_until: (0..extra).map(|_| OwnLine(AtomicU64::new(0))).collect(),
            claimed: (0..extra).map(|_| OwnLine(AtomicU64::new(0))).collect(),
            #[cfg(test)]
            hold: AtomicBool::new(false),
            #[cfg(test)]
            yields: AtomicUsize::new(0),
            epoch: std::time::Instant::now(),
            started: AtomicUsize::new(0),
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
        // every worker running before the first step: a thread that starts
        // late starts in some step (the start allocates, and until it runs
        // no step is handed to it)
        while shared.started.load(Ordering::Acquire) < extra {
            thread::yield_now();
        }
        let handles = threads.iter().map(|t| t.thread().clone()).collect();
        Ok(Self {
            shared,
            threads,
            handles,
            min_blocks: default_min_blocks(),
            adaptive: true,
            choice: Choice::default(),
            busy: AtomicBool::new(false),
            shares: Shares::default(),
            measured_shares: true,
            wakes: Wakes {
                after: AtomicUsize::new(1),
                gap_ns: AtomicU64::new(0),
                last_wake: AtomicU64::new(0),
                skipped: AtomicUsize::new(0),
                handed: AtomicBool::new(true),
                last_split_plan: AtomicU64::new(0),
                #[cfg(test)]
                issued: AtomicUsize::new(0),
            },
        })
    }

    /// Above the crossover, choose by timing (`true`, the default) or split
    /// every step (`false`: for tests and for timing a split itself).
    pub fn with_adaptive(mut self, adaptive: bool) -> Self {
        self.adaptive = adaptive;
        self
    }

    /// How the next step of a bank above the crossover runs. A step the
    /// adaptive choice would split runs on the calling thread alone (not
    /// timed) unless every worker will spin [`HANDOVER_NS`] longer at
    /// least: a job handed to a parked worker waits until the OS runs it
    /// again, on a 2-vCPU Sapphire Rapids guest 36–70 µs after the wake
    /// and now and then more than 50 ms. There a 256-channel `f64` bank
    /// stepped about every 0.6 ms (a loop that sleeps between samples; the
    /// worker parks after 0.5 ms) took 2.5–2.9 times one thread on average
    /// with every parked worker handed its part, single steps up to
    /// 1.3 ms; with this check 0.87–1.10 of one thread (256 and 1024
    /// channels, pauses of 0.3 and 1 ms, three runs), the medians within
    /// 4 %.
    pub(crate) fn plan_now(&self) -> Plan {
        let plan = self.plan();
        if self.adaptive && plan.split && !self.awake_for_a_split() {
            return Plan {
                split: false,
                timed: false,
                probe: false,
            };
        }
        plan
    }

    /// The adaptive choice's plan for the next step, whatever the workers
    /// are doing ([`Workers::plan_now`] is the step's).
    pub(crate) fn plan(&self) -> Plan {
        if !self.adaptive {
            return Plan {
                split: true,
                timed: false,
                probe: false,
            };
        }
        let c = &self.choice;
        plan(
            c.steps.fetch_add(1, Ordering::Relaxed),
            c.alone.load(Ordering::Relaxed),
            c.split.load(Ordering::Relaxed),
            c.next_probe.load(Ordering::Relaxed),
        )
    }

    /// Whether every worker will spin [`HANDOVER_NS`] longer at least.
    /// Where one will not (parked, or about to park), wakes them now and
    /// then, so that the steps that follow find them spinning: at once if
    /// the last wake was followed by a split, else after twice as many
    /// such steps as the last time (a bank stepped slower than a worker
    /// spins: each wake would find it parked again), up to
    /// [`MOST_STEPS_BETWEEN_WAKES`], and twice as long after the last wake,
    /// from [`SPIN_NS`] up to [`MOST_NS_BETWEEN_WAKES`]; never where this
    /// step comes more than [`SPIN_NS`] less [`HANDOVER_NS`] after the last
    /// one planned split (the woken worker would park again before the
    /// next such step). A
    /// wake costs the caller an unpark (13–20 µs on the Sapphire Rapids
    /// guest): with steps 0.6 ms apart, the wakes that never paid took the
    /// 99th percentile of a 256-channel `f64` step from 10 to 19 µs there.
    fn awake_for_a_split(&self) -> bool {
        let now = self.shared.now_ns();
        let last = self.wakes.last_split_plan.swap(now, Ordering::Relaxed);
        if self.all_awake_at(now) {
            return true;
        }
        if now.saturating_sub(last) > SPIN_NS - HANDOVER_NS {
            return false;
        }
        let w = &self.wakes;
        let skipped = w.skipped.fetch_add(1, Ordering::Relaxed) + 1;
        let after = w.after.load(Ordering::Relaxed);
        let since = now.saturating_sub(w.last_wake.load(Ordering::Relaxed));
        if skipped >= after && since >= w.gap_ns.load(Ordering::Relaxed) {
            w.skipped.store(0, Ordering::Relaxed);
            w.last_wake.store(now, Ordering::Relaxed);
            let paid = w.handed.swap(false, Ordering::Relaxed);
            let (next, gap) = if paid {
                (1, 0)
            } else {
                let gap = w.gap_ns.load(Ordering::Relaxed);
                (
                    (2 * after).min(MOST_STEPS_BETWEEN_WAKES),
                    (2 * gap).clamp(SPIN_NS, MOST_NS_BETWEEN_WAKES),
                )
            };
            w.after.store(next, Ordering::Relaxed);
            w.gap_ns.store(gap, Ordering::Relaxed);
            #[cfg(test)]
            w.issued.fetch_add(1, Ordering::Relaxed);
            self.wake();
        }
        false
    }

    /// Whether every worker will spin [`HANDOVER_NS`] longer at least
    /// (or is at work): none parked, none about to.
    #[doc(hidden)]
    pub fn all_awake(&self) -> bool {
        self.all_awake_at(self.shared.now_ns())
    }

    /// Whether every worker will spin [`HANDOVER_NS`] past `now` at least.
    fn all_awake_at(&self, now: u64) -> bool {
        let soon = now.saturating_add(HANDOVER_NS);
        self.shared
            .awake_until
            .iter()
            .all(|u| u.0.load(Ordering::Relaxed) > soon)
    }

    /// Wakes the parked workers without a job (they spin, then park
    /// again).
    #[doc(hidden)]
    pub fn wake(&self) {
        for h in &self.handles {
            h.unpark();
        }
    }

    /// Records the time `time` of a step of `blocks` blocks run as `plan`
    /// asked.
    pub(crate) fn record(&self, plan: Plan, time: Duration, blocks: usize) {
        let c = &self.choice;
        let mut ps =
            (time.as_nanos() * 1000 / blocks.max(1) as u128).min(u64::MAX as u128 / 8) as u64;
        if plan.probe {
            let step_ps = u64::try_from(time.as_nanos().saturating_mul(1000)).unwrap_or(u64::MAX);
            match c.probe_sample(step_ps, ps) {
                Some(mean) => ps = mean,
                None => return,
            }
        }
        let was_split_faster = split_pays(
            c.split.load(Ordering::Relaxed),
            c.alone.load(Ordering::Relaxed),
        );
        let estimate = if plan.split { &c.split } else { &c.alone };
        let old = estimate.load(Ordering::Relaxed);
        // a probe's way has not been timed for a while: its new time
        // replaces the old one
        let new = if plan.probe {
            capped(old, ps)
        } else {
            fold_in_use(old, ps)
        };
        estimate.store(new, Ordering::Relaxed);
        if plan.probe {
            let (split, alone) = (
                c.split.load(Ordering::Relaxed),
                c.alone.load(Ordering::Relaxed),
            );
            let split_now = split_pays(split, alone);
            let changed = split_now != was_split_faster;
            let in_use = if split_now { split } else { alone };
            let step_ps = in_use.saturating_mul(blocks.max(1) as u64);
            let interval = next_interval(
                c.interval.load(Ordering::Relaxed),
                changed,
                shortest_interval(step_ps),
                longest_interval(step_ps),
            );
            c.interval.store(interval, Ordering::Relaxed);
            c.next_probe.store(
                c.steps.load(Ordering::Relaxed) + interval,
                Ordering::Relaxed,
            );
        }
    }

    /// The crossover set to `blocks`: a bank of fewer blocks steps on the
    /// calling thread alone (0: none; every bank is split, or chosen for
    /// by the adaptive choice).
    pub fn with_min_blocks(mut self, blocks: usize) -> Self {
        self.min_blocks = blocks;
        self
    }

    /// Banks of fewer blocks than this step on the calling thread alone
    /// ([`default_min_blocks`] unless set).
    pub fn min_blocks(&self) -> usize {
        self.min_blocks
    }

    /// How many jobs the workers have been handed (for tests: whether a
    /// step was split).
    #[doc(hidden)]
    pub fn jobs_handed(&self) -> u64 {
        self.shared.generation.load(Ordering::Relaxed)
    }

    /// The calling thread's share of a split and its measurement, if the
    /// share is set by measurement.
    pub(crate) fn shares(&self) -> Option<&Shares> {
        self.measured_shares.then_some(&self.shares)
    }

    /// A split's shares set by measurement (`true`, the default: the
    /// calling thread takes a block more or less where the parts end more
    /// than half a block apart) or even (`false`: each core keeps the same
    /// blocks from step to step, for timing a split itself or for cores
    /// reserved to the bank).
    pub fn with_measured_shares(mut self, measured: bool) -> Self {
        self.measured_shares = measured;
        self
    }

    /// The number of parts a job is split into (the workers and the caller).
    pub fn parts(&self) -> usize {
        self.threads.len() + 1
    }

    /// `job(0)` here and `job(p)` on worker `p`, returning when all are
    /// done; every part here if the workers are busy with another caller's
    /// job. A part its worker has not claimed [`TAKE_AFTER_SPINS`] spins
    /// after this thread's own part ended runs here as well (its worker is
    /// late: not scheduled, or just woken). Returns whether every worker
    /// ran its own part (`false`: some or all ran here). Allocation-free.
    pub(crate) fn run(&self, job: &(dyn Fn(usize) + Sync + '_)) -> bool {
        let workers = self.threads.len();
        let s = &*self.shared;
        // the workers serve one job at a time: a caller that finds them
        // busy (a bank on another thread with the same `&Workers`) runs
        // every part itself, so that no job's pointer or count is
        // overwritten while a worker may still use it
        if workers == 0 || self.busy.swap(true, Ordering::Acquire) {
            (0..=workers).for_each(job);
            return false;
        }
        // clears `busy` however this call ends
        struct Idle<'a>(&'a AtomicBool);
        impl Drop for Idle<'_> {
            fn drop(&mut self) {
                self.0.store(false, Ordering::Release);
            }
        }
        let _idle = Idle(&self.busy);
        if !self.wakes.handed.load(Ordering::Relaxed) {
            self.wakes.handed.store(true, Ordering::Relaxed);
        }
        // SAFETY: only the lifetime is erased; the job is not used after
        // this call returns (every worker is done with it then).
        s.job.set(unsafe {
            std::mem::transmute::<*const (dyn Fn(usize) + Sync + '_), *const Job>(job)
        });
        // Release: the job and the caller's data are visible to a worker
        // that sees the new generation
        let generation = s.generation.load(Ordering::Relaxed) + 1;
        s.generation.store(generation, Ordering::Release);
        for h in &self.handles {
            h.unpark();
        }
        // the workers borrow the caller's data until they are done, so a
        // panic of this part waits for them before it unwinds
        let mine = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| job(0)));
        let mut spins = 0;
        let all_done = generation * workers as u64;
        let mut taken = None;
        while s.done.0.load(Ordering::Acquire) < all_done {
            if spins == TAKE_AFTER_SPINS {
                taken = Some(self.take_late_parts(generation, job));
            }
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
        let took_any = match taken {
            Some(Err(payload)) => std::panic::resume_unwind(payload),
            Some(Ok(took_any)) => took_any,
            None => false,
        };
        if s.panicked.swap(false, Ordering::Relaxed) {
            panic!("a bank worker panicked");
        }
        !took_any
    }

    /// Runs here the parts of `generation` that no worker has claimed, and
    /// counts them done; whether there were any (a panic in one is
    /// returned after the rest have run).
    fn take_late_parts(
        &self,
        generation: u64,
        job: &(dyn Fn(usize) + Sync + '_),
    ) -> std::thread::Result<bool> {
        let s = &*self.shared;
        let mut took = 0;
        let mut panicked = None;
        for (i, claimed) in s.claimed.iter().enumerate() {
            // the load first: a claimed part's line stays the worker's
            if claimed.0.load(Ordering::Relaxed) < generation
                && claimed.0.fetch_max(generation, Ordering::AcqRel) < generation
            {
                took += 1;
                let part = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| job(i + 1)));
                if let (Err(payload), None) = (part, &panicked) {
                    panicked = Some(payload);
                }
            }
        }
        if took > 0 {
            s.done.0.fetch_add(took, Ordering::Release);
        }
        match panicked {
            Some(payload) => Err(payload),
            None => Ok(took > 0),
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
    s.started.fetch_add(1, Ordering::Release);
    let mut seen = 0u64;
    let awake_until = &s.awake_until[part - 1].0;
    let claimed = &s.claimed[part - 1].0;
    // spin at least SPIN_NS from now, and say so
    let spin_from_now = || {
        let until = s.now_ns().saturating_add(SPIN_NS);
        awake_until.store(until, Ordering::Relaxed);
        until
    };
    let mut until = spin_from_now();
    loop {
        let mut spins = 0usize;
        // the wait began SPIN_NS before `until`
        let mut yield_at = until.saturating_sub(SPIN_NS).saturating_add(YIELD_NS);
        let generation = loop {
            let g = s.generation.load(Ordering::Acquire);
            if g != seen {
                break g;
            }
            spins += 1;
            // the clock read every 64 spins
            if !spins.is_multiple_of(64) {
                std::hint::spin_loop();
                continue;
            }
            let now = s.now_ns();
            if spins >= SPINS && now >= until {
                awake_until.store(0, Ordering::Relaxed);
                thread::park();
                // woken (by a job, a wake without one, or the token a job
                // left while this spun): spin again before parking, so
                // that a wake keeps it awake for the steps that follow
                spins = 0;
                until = spin_from_now();
                yield_at = until.saturating_sub(SPIN_NS).saturating_add(YIELD_NS);
            } else if now >= yield_at {
                #[cfg(test)]
                s.yields.fetch_add(1, Ordering::Relaxed);
                thread::yield_now();
                yield_at = s.now_ns().saturating_add(YIELD_NS);
            } else {
                std::hint::spin_loop();
            }
        };
        seen = generation;
        if s.stop.load(Ordering::Acquire) {
            return;
        }
        // (five seconds at most: a caller that does not take the part
        // then fails its test instead of waiting for ever)
        #[cfg(test)]
        {
            let held = std::time::Instant::now();
            while s.hold.load(Ordering::Acquire) && held.elapsed() < Duration::from_secs(5) {
                thread::sleep(Duration::from_micros(100));
            }
        }
        // the part is this worker's only if the caller has not taken it
        // (then the job may be gone: not read)
        if claimed.fetch_max(generation, Ordering::AcqRel) >= generation {
            until = spin_from_now();
            continue;
        }
        // SAFETY: `run` stored a job that lives until every part is
        // counted done, which this one, claimed here, is not yet.
        let job = unsafe { &*s.job.get() };
        if std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| job(part))).is_err() {
            s.panicked.store(true, Ordering::Relaxed);
        }
        // the next wait's spin, said before the caller can see this part
        // done: its next step reads it (a long job would leave the last
        // one past)
        until = spin_from_now();
        s.done.0.fetch_add(1, Ordering::Release);
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
    use crate::operators::split_choice::{PROBE_EVERY, PROBE_STEPS, PROBE_WARM_UP};
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

    /// Waits (at most ten seconds) until `done` holds.
    fn wait_for(what: &str, done: impl Fn() -> bool) {
        let start = std::time::Instant::now();
        while !done() {
            assert!(start.elapsed() < Duration::from_secs(10), "{what}");
            thread::sleep(Duration::from_micros(100));
        }
    }

    #[test]
    fn a_part_its_late_worker_has_not_claimed_runs_once_on_the_caller() {
        let w = Workers::new(2).unwrap();
        let s = &*w.shared;
        let me = thread::current().id();
        // both workers held before they claim: the caller runs every part
        s.hold.store(true, Ordering::Release);
        let ran: [AtomicUsize; 3] = Default::default();
        let here: [AtomicBool; 3] = Default::default();
        let job = |p: usize| {
            ran[p].fetch_add(1, Ordering::Relaxed);
            here[p].store(thread::current().id() == me, Ordering::Relaxed);
        };
        assert!(!w.run(&job));
        assert!(ran.iter().all(|n| n.load(Ordering::Relaxed) == 1));
        assert!(here.iter().all(|h| h.load(Ordering::Relaxed)));
        // released, the workers find their parts taken and leave the job
        // alone (it is still alive below: a part run twice would count 2)
        s.hold.store(false, Ordering::Release);
        // the workers run their own parts of the next jobs (so they are
        // past the taken one): part 0 waits for theirs to start
        for _ in 0..20 {
            let started = AtomicUsize::new(0);
            let ran: [AtomicUsize; 3] = Default::default();
            let on_workers = w.run(&|p| {
                ran[p].fetch_add(1, Ordering::Relaxed);
                if p == 0 {
                    wait_for("the workers started", || {
                        started.load(Ordering::Acquire) == 2
                    });
                } else {
                    assert_ne!(thread::current().id(), me);
                    started.fetch_add(1, Ordering::Release);
                }
            });
            assert!(on_workers);
            assert!(ran.iter().all(|n| n.load(Ordering::Relaxed) == 1));
        }
        assert!(ran.iter().all(|n| n.load(Ordering::Relaxed) == 1));
        // a taken part's panic is raised on the caller, and the pool goes on
        s.hold.store(true, Ordering::Release);
        let r = catch_unwind(AssertUnwindSafe(|| {
            w.run(&|p| {
                if p == 1 {
                    panic!("part 1 fails");
                }
            })
        }));
        assert!(r.is_err());
        s.hold.store(false, Ordering::Release);
        let after = AtomicUsize::new(0);
        w.run(&|_| {
            after.fetch_add(1, Ordering::Relaxed);
        });
        assert_eq!(after.load(Ordering::Relaxed), 3);
    }

    /// A pool of one worker, once it has parked.
    fn parked_workers() -> Workers {
        let w = Workers::new(1).unwrap();
        wait_for("the worker parked", || {
            w.shared.awake_until[0].0.load(Ordering::Relaxed) == 0
        });
        w
    }

    #[test]
    fn a_parked_worker_is_woken_only_for_steps_close_enough_to_keep_it() {
        let w = parked_workers();
        let issued = || w.wakes.issued.load(Ordering::Relaxed);
        // steps planned split at least 1 ms apart: a woken worker would
        // park again before the next, and none is woken (else each would
        // find it parked again and wake it)
        for _ in 0..4 {
            thread::sleep(Duration::from_millis(1));
            assert!(!w.awake_for_a_split());
        }
        assert_eq!(issued(), 0, "wakes for steps 1 ms apart");
        // two steps close together: the second wakes it (tried again where
        // this thread did not run for 450 µs between the two)
        for _ in 0..100 {
            thread::sleep(Duration::from_millis(1));
            assert!(!w.awake_for_a_split());
            assert!(!w.awake_for_a_split());
            if issued() > 0 {
                break;
            }
        }
        assert_eq!(issued(), 1);
    }

    #[test]
    fn wakes_that_no_split_follows_come_further_apart_in_time() {
        let w = parked_workers();
        let issued = || w.wakes.issued.load(Ordering::Relaxed);
        // steps planned split back to back for 20 ms (and until a second
        // wake, should this thread not run for a while), none handed: each
        // wake finds the worker parked again 0.5 ms later. Spaced by steps
        // alone (at most 1024 apart, some 0.1 ms here) it was woken each
        // time, about 200 wakes; with the least time between two doubled
        // from 0.5 ms, at 0, 0.5, 1.5, 3.5, 7.5 and 15.5 ms
        let start = std::time::Instant::now();
        while start.elapsed() < Duration::from_millis(20)
            || (issued() < 2 && start.elapsed() < Duration::from_secs(10))
        {
            w.awake_for_a_split();
        }
        assert!(
            (2..=8).contains(&issued()),
            "{} wakes in 20 ms of steps",
            issued()
        );
    }

    #[test]
    fn a_waiting_worker_yields_its_core() {
        let w = Workers::new(1).unwrap();
        w.wake();
        wait_for("the waiting worker yielded", || {
            w.shared.yields.load(Ordering::Relaxed) > 0
        });
        // and a job still finds it
        let ran = AtomicUsize::new(0);
        w.run(&|_| {
            ran.fetch_add(1, Ordering::Relaxed);
        });
        assert_eq!(ran.load(Ordering::Relaxed), 2);
    }

    #[test]
    fn workers_late_at_random_leave_every_part_run_once() {
        // a worker still held for a taken job when the next one comes must
        // skip the old one and run the new one's part
        let w = Workers::new(2).unwrap();
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut taken = 0;
        for _ in 0..300 {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            w.shared
                .hold
                .store(seed.is_multiple_of(3), Ordering::Release);
            let ran: [AtomicUsize; 3] = Default::default();
            let all_on_workers = w.run(&|p| {
                ran[p].fetch_add(1, Ordering::Relaxed);
                if seed.is_multiple_of(5) {
                    thread::sleep(Duration::from_micros(50));
                }
            });
            taken += usize::from(!all_on_workers);
            assert!(ran.iter().all(|n| n.load(Ordering::Relaxed) == 1));
        }
        w.shared.hold.store(false, Ordering::Release);
        // about a third of the jobs had both workers held
        assert!((60..=300).contains(&taken), "{taken}");
    }

    /// The runs of consecutive steps in `steps` (ascending): their first
    /// steps and their lengths.
    fn runs(steps: &[u64]) -> Vec<(u64, u64)> {
        let mut runs: Vec<(u64, u64)> = Vec::new();
        for &s in steps {
            match runs.last_mut() {
                Some((start, len)) if *start + *len == s => *len += 1,
                _ => runs.push((s, 1)),
            }
        }
        runs
    }

    #[test]
    fn the_adaptive_choice_leaves_a_split_that_is_slower_and_probes_it_less_often() {
        let w = Workers::new(1).unwrap();
        // a split takes 50 µs for 10 blocks, a step alone 5 µs
        let split_steps = split_steps(&w, 10, |split, _| if split { 50_000 } else { 5000 });
        // two to start, then six per probe (two to wake the workers and
        // four counted, 300 µs: longer than PROBE_LENGTH_PS) at 64, 470,
        // 1276, … the interval from 400 steps (2 ms of 5 µs steps) doubling
        // to every 4000 (20 ms)
        let runs = runs(&split_steps);
        let probe = PROBE_WARM_UP + PROBE_STEPS;
        assert_eq!(runs[0], (0, 2));
        assert!(runs[1..].iter().all(|&(_, len)| len == probe), "{runs:?}");
        let longest = longest_interval(5_000_000);
        assert_eq!(longest, 4000);
        let shortest = shortest_interval(5_000_000);
        assert_eq!(shortest, 400);
        let mut expected = vec![64u64];
        let mut interval = PROBE_EVERY;
        while expected.len() < runs.len() - 1 {
            interval = (2 * interval).clamp(shortest, longest);
            let last = *expected.last().unwrap();
            expected.push(last + probe + interval);
        }
        let starts: Vec<u64> = runs[1..].iter().map(|r| r.0).collect();
        assert_eq!(&starts[..6], &[64, 470, 1276, 2882, 6088, 10_094]);
        assert_eq!(starts, expected);
        // 20 000 steps: then probes at 14 100 and 18 106
        assert_eq!(starts.len(), 8);
        let fixed = Workers::new(1).unwrap().with_adaptive(false);
        assert!((0..100).all(|_| fixed.plan()
            == Plan {
                split: true,
                timed: false,
                probe: false
            }));
    }

    /// The steps of 20 000 planned by the adaptive choice of `w` that ran
    /// split, each step of `blocks` blocks taking `ns(split, run)`
    /// nanoseconds, `run` counting the split steps in a row so far.
    fn split_steps(w: &Workers, blocks: usize, ns: impl Fn(bool, u64) -> u64) -> Vec<u64> {
        let mut run = 0;
        let mut split = Vec::new();
        for step in 0..20_000u64 {
            let p = w.plan();
            run = if p.split { run + 1 } else { 0 };
            if p.timed {
                w.record(p, Duration::from_nanos(ns(p.split, run)), blocks);
            }
            if p.split {
                split.push(step);
            }
        }
        split
    }

    #[test]
    fn a_split_that_pays_once_its_worker_is_awake_is_chosen() {
        // as measured on a Sapphire Rapids guest, 32 blocks of `f64`: a
        // step alone 3.0 µs, split 2.3 µs while the worker is awake, but
        // the first split step after steps alone 60 µs, the second 4.3
        let w = Workers::new(1).unwrap();
        let split = split_steps(&w, 32, |split, run| match (split, run) {
            (false, _) => 3000,
            (true, 1) => 60_000,
            (true, 2) => 4300,
            (true, _) => 2300,
        });
        // every step of the second half split but its probes of the way alone
        let late = split.iter().filter(|&&s| s >= 10_000).count();
        assert!(late > 9_900, "{late}");
    }

    #[test]
    fn a_split_faster_by_less_than_a_sixteenth_on_average_is_left() {
        // a step alone 3.0 µs; split, once awake, 2.5 and 3.3 µs in turn
        // (a mean 3 % faster): the fastest step of a probe would pay, its
        // mean does not
        let w = Workers::new(1).unwrap();
        let split = split_steps(&w, 16, |split, run| match (split, run) {
            (false, _) => 3000,
            (true, 1) => 60_000,
            (true, r) if r % 2 == 0 => 2500,
            (true, _) => 3300,
        });
        // the second half (30 ms of steps): only its probes split, at
        // most two (20 ms apart), each some 200 µs of steps
        let late: Vec<u64> = split.into_iter().filter(|&s| s >= 10_000).collect();
        let probes = runs(&late);
        assert!(probes.len() <= 2, "{probes:?}");
        assert!(probes.iter().all(|&(_, len)| len <= 60), "{probes:?}");
    }

    #[test]
    fn the_crossover_is_the_one_measured_for_the_vendor() {
        let intel = std::fs::read_to_string("/proc/cpuinfo")
            .map(|info| info.contains("GenuineIntel"))
            .unwrap_or(false);
        let expected = if intel && cfg!(target_arch = "x86_64") {
            INTEL_MIN_BLOCKS
        } else {
            DEFAULT_MIN_BLOCKS
        };
        assert_eq!(default_min_blocks(), expected);
        assert_eq!(Workers::new(1).unwrap().min_blocks(), expected);
    }

    #[test]
    fn callers_on_two_threads_at_once_each_get_every_part_once() {
        // two banks stepped on two threads with the same `&Workers`: one
        // job at a time goes to the workers, the other runs on its caller
        let w = Workers::new(1).unwrap();
        thread::scope(|scope| {
            for _ in 0..2 {
                scope.spawn(|| {
                    for _ in 0..3000 {
                        let parts: [AtomicUsize; 2] = Default::default();
                        w.run(&|p| {
                            parts[p].fetch_add(1, Ordering::Relaxed);
                        });
                        assert!(parts.iter().all(|n| n.load(Ordering::Relaxed) == 1));
                    }
                });
            }
        });
        // and a job started while another holds the workers runs on its
        // own thread
        let (release, started) = (AtomicBool::new(false), AtomicBool::new(false));
        thread::scope(|scope| {
            let first = scope.spawn(|| {
                w.run(&|p| {
                    started.fetch_or(p == 1, Ordering::Release);
                    while !release.load(Ordering::Acquire) {
                        thread::yield_now();
                    }
                })
            });
            // the worker at work on the first job (so that its caller does
            // not take the part: a worker late on a loaded machine)
            while !(w.busy.load(Ordering::Acquire) && started.load(Ordering::Acquire)) {
                thread::yield_now();
            }
            let me = thread::current().id();
            // it tells its caller that the parts did not go to the workers
            assert!(!w.run(&|_| assert_eq!(thread::current().id(), me)));
            release.store(true, Ordering::Release);
            assert!(first.join().unwrap());
        });
    }
}
