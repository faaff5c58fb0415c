//! When a bank's step runs split over the workers and when on the calling
//! thread alone: the adaptive choice of [`Workers`](super::workers::Workers).
//!
//! Whether a split pays is measured while the bank runs: a split costs a
//! hand-over, and on a virtual machine that cost and the worker's speed
//! depend on where the host puts the virtual CPUs, so the same bank can be
//! faster split at one moment and slower the next. Every 64th step is
//! timed the way in use (a slow one counted as twice its estimate at
//! most), the other way is probed now and then (the mean of at least
//! 100 µs of its steps, after 100 µs that wake the workers; at least ten
//! times that apart, less often while it stays the slower, and once
//! confirmed at most every 20 ms), and the steps run split where that was
//! faster by more than a sixteenth. A step planned split is handed to the
//! workers only while each will spin a while longer
//! (`Workers::plan_now`): else it runs alone, untimed, so a probe of the
//! split waits until they are awake, and its warm-up steps no longer pay
//! a parked worker's wake-up.
//! Here are the rules, as functions of the times so far, and the counters
//! they read ([`Choice`]); `Workers` times the steps and updates them.

use std::sync::atomic::AtomicU64;

/// Steps between two timings of the way in use, and the first and
/// shortest interval between two probes of the other way.
pub(crate) const PROBE_EVERY: u64 = 64;

/// The longest interval between two probes, in steps, for steps shorter
/// than [`PROBE_SPACING_PS`] / 1024: a probe that confirms the choice
/// doubles the interval up to this or [`longest_interval`].
pub(crate) const LONGEST_PROBE_INTERVAL: u64 = 1024;

/// Steps a probe of the way not in use runs before those it counts, at
/// least, and over [`PROBE_WARM_UP_PS`] at least: a parked worker wakes in
/// the first, and the next ones can still be slow. On a 2-vCPU Sapphire
/// Rapids guest, 32 blocks of `f64` (3.0 µs a step alone, 2.2–2.5 split
/// while the worker is awake), the first split step after a park took
/// 35–73 µs and the second 4.2–4.5; most of the time the third ran at the
/// split's speed, but once the steps took 4–7 µs for 130 µs more. Timing
/// the second step alone, the choice never split there.
pub(crate) const PROBE_WARM_UP: u64 = 2;

/// The least time a probe's warm-up takes (100 µs, in picoseconds).
pub(crate) const PROBE_WARM_UP_PS: u64 = 100_000_000;

/// Steps a probe counts at least, after its warm-up, each timed, over
/// [`PROBE_LENGTH_PS`] at least: their mean is its sample (the fastest
/// of them, tried, chose a split 4 % slower than one thread at 16
/// blocks, where a split gains 4 %).
pub(crate) const PROBE_STEPS: u64 = 4;

/// The least time a probe counts (100 µs, in picoseconds). With its
/// warm-up about 1 % of [`PROBE_SPACING_PS`]: where the way probed does
/// not pay and its steps take, say, a fifth longer, a probe costs 0.2 %.
pub(crate) const PROBE_LENGTH_PS: u64 = 100_000_000;

/// The time that confirmed probes keep between them at least (20 ms, in
/// picoseconds). A probe of the split wakes a parked worker, which took
/// tens of microseconds on a 2-vCPU Zen 4 guest; every 1024 steps of about
/// a microsecond that made `compensate_on` some 3 % slower than one thread
/// where the split did not pay (16 and 32 blocks of `f64`, `bank_limit`).
pub(crate) const PROBE_SPACING_PS: u64 = 20_000_000_000;

/// How one step above the crossover runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Plan {
    /// Split over the workers (else on the calling thread alone).
    pub split: bool,
    /// Timed, its time recorded with
    /// [`Workers::record`](super::workers::Workers::record).
    pub timed: bool,
    /// The timed step of a probe of the way not in use.
    pub probe: bool,
}

/// The plan for step number `step` from the times per block so far of a
/// step alone and split (0: not timed yet) and the step of the next probe.
/// Each way is timed first (the split after one step that wakes the
/// workers); then the faster way runs (the split only if [`split_pays`]),
/// timed every `PROBE_EVERY` steps, and from `next_probe` on the other
/// way, every step timed, until its probe is recorded ([`PROBE_WARM_UP`],
/// [`PROBE_WARM_UP_PS`], [`PROBE_STEPS`], [`PROBE_LENGTH_PS`]: a parked
/// worker's wake-up is not the split's cost).
pub(crate) fn plan(step: u64, alone: u64, split: u64, next_probe: u64) -> Plan {
    if split == 0 {
        return Plan {
            split: true,
            timed: step >= 1,
            probe: false,
        };
    }
    if alone == 0 {
        return Plan {
            split: false,
            timed: true,
            probe: false,
        };
    }
    let faster_split = split_pays(split, alone);
    // from `next_probe` on until a probe is recorded (a step that panicked
    // records nothing)
    if step >= next_probe {
        return Plan {
            split: !faster_split,
            timed: true,
            probe: true,
        };
    }
    Plan {
        split: faster_split,
        timed: step % PROBE_EVERY == PROBE_EVERY / 2,
        probe: false,
    }
}

/// Whether a split pays, from the times per block of a step split and
/// alone: faster by more than 1/16. Where the two are about equal, a
/// choice that followed every difference would change often, and each
/// change back to the split wakes a parked worker (tens of microseconds
/// on a 2-vCPU Zen 4 guest); kept alone there, a step gives up at most a
/// sixteenth.
pub(crate) fn split_pays(split: u64, alone: u64) -> bool {
    split.saturating_add(split / 16) < alone
}

/// The interval to the next probe after one that changed the choice
/// (`changed`: back to `shortest`) or confirmed it (doubled, from
/// `shortest` up to `longest`).
pub(crate) fn next_interval(interval: u64, changed: bool, shortest: u64, longest: u64) -> u64 {
    if changed {
        shortest
    } else {
        (2 * interval).clamp(shortest, longest.max(shortest))
    }
}

/// Probes keep at least this many times their least length between them
/// ([`shortest_interval`]).
pub(crate) const PROBE_QUIET: u64 = 10;

/// The shortest interval between probes for steps of `step_ps`
/// picoseconds the way in use: [`PROBE_EVERY`] steps, or as many as keep
/// [`PROBE_QUIET`] times a probe's least length ([`PROBE_WARM_UP_PS`] and
/// [`PROBE_LENGTH_PS`]) between two, so that probing takes a tenth of the
/// steps at most. Where the two ways are about as fast, each change moves
/// half the bank's state between the cores' caches and makes the way
/// changed to look slower for a while, and the choice changed back and
/// forth: on a Sapphire Rapids guest, at 16 blocks of `f64` (a split
/// 0.96–1.06 of one thread), probes every 64 steps took half of them and
/// `compensate_on` ran 1.05–1.07 times one thread.
pub(crate) fn shortest_interval(step_ps: u64) -> u64 {
    PROBE_EVERY.max(PROBE_QUIET * (PROBE_WARM_UP_PS + PROBE_LENGTH_PS) / step_ps.max(1))
}

/// The longest interval between probes for steps of `step_ps` picoseconds
/// the way in use: [`LONGEST_PROBE_INTERVAL`] steps, or as many as keep
/// [`PROBE_SPACING_PS`] between probes.
pub(crate) fn longest_interval(step_ps: u64) -> u64 {
    LONGEST_PROBE_INTERVAL.max(PROBE_SPACING_PS / step_ps.max(1))
}

/// A time per block folded into its running estimate `old` (0: none yet):
/// weight ¼, and a sample more than four times the estimate counted as
/// four times it, so that one step delayed by the operating system does
/// not turn the choice for long.
pub(crate) fn fold(old: u64, sample: u64) -> u64 {
    if old == 0 {
        capped(old, sample)
    } else {
        ((3 * old + capped(old, sample)) / 4).max(1)
    }
}

/// A time per block of the way in use folded into its estimate: as
/// [`fold`], but a sample counted as at most twice the estimate. Where a
/// split is 0.65 of one thread, one slow split step counted four times
/// raised its estimate by 75 % and changed the choice to one thread until
/// the next probe (20 ms of steps at most); counted twice, it takes two
/// slow samples in a row.
pub(crate) fn fold_in_use(old: u64, sample: u64) -> u64 {
    if old == 0 {
        capped(old, sample)
    } else {
        ((3 * old + sample.clamp(1, 2 * old)) / 4).max(1)
    }
}

/// `sample` at least 1 and at most four times the estimate `old` (any,
/// while there is none).
pub(crate) fn capped(old: u64, sample: u64) -> u64 {
    if old == 0 {
        sample.max(1)
    } else {
        sample.clamp(1, 4 * old)
    }
}

/// The adaptive choice's counters (atomics: `Workers` is shared by
/// reference; one caller at a time is the expected use, and a race between
/// two only blurs an estimate).
pub(crate) struct Choice {
    /// Steps planned so far.
    pub steps: AtomicU64,
    /// Picoseconds per block of a step on the calling thread alone.
    pub alone: AtomicU64,
    /// Picoseconds per block of a split step.
    pub split: AtomicU64,
    /// The step at which the next probe of the way not in use starts.
    pub next_probe: AtomicU64,
    /// Steps from the last probe to the next ([`next_interval`]).
    pub interval: AtomicU64,
    /// The sum of the probe's counted steps, picoseconds per block.
    pub probe_sum: AtomicU64,
    /// The probe's steps so far: of its warm-up while `probe_counted` is
    /// 0, then counted.
    pub probe_steps: AtomicU64,
    /// The probe's time so far, picoseconds: of its warm-up, then counted.
    pub probe_ps: AtomicU64,
    /// Whether the probe's warm-up is over (1) or not (0).
    pub probe_counted: AtomicU64,
}

impl Choice {
    /// A probe's step of `step_ps` picoseconds, `ps` per block, counted:
    /// the probe's sample (the mean per block of the steps after its
    /// warm-up) once it has run long enough, `None` before. Then it starts
    /// over for the next probe.
    pub(crate) fn probe_sample(&self, step_ps: u64, ps: u64) -> Option<u64> {
        use std::sync::atomic::Ordering::Relaxed;
        let steps = self.probe_steps.fetch_add(1, Relaxed) + 1;
        let probed = self
            .probe_ps
            .fetch_add(step_ps, Relaxed)
            .saturating_add(step_ps);
        if self.probe_counted.load(Relaxed) == 0 {
            if steps >= PROBE_WARM_UP && probed >= PROBE_WARM_UP_PS {
                // warm: count from the next step
                self.probe_steps.store(0, Relaxed);
                self.probe_ps.store(0, Relaxed);
                self.probe_counted.store(1, Relaxed);
            }
            return None;
        }
        let sum = self.probe_sum.fetch_add(ps, Relaxed).saturating_add(ps);
        if steps < PROBE_STEPS || probed < PROBE_LENGTH_PS {
            return None;
        }
        self.probe_sum.store(0, Relaxed);
        self.probe_steps.store(0, Relaxed);
        self.probe_ps.store(0, Relaxed);
        self.probe_counted.store(0, Relaxed);
        Some(sum / steps)
    }
}

impl Default for Choice {
    fn default() -> Self {
        Self {
            steps: AtomicU64::new(0),
            alone: AtomicU64::new(0),
            split: AtomicU64::new(0),
            next_probe: AtomicU64::new(PROBE_EVERY),
            interval: AtomicU64::new(PROBE_EVERY),
            probe_sum: AtomicU64::new(0),
            probe_steps: AtomicU64::new(0),
            probe_ps: AtomicU64::new(0),
            probe_counted: AtomicU64::new(0),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_choice_times_both_ways_and_then_follows_the_faster() {
        let no = |split, timed| Plan {
            split,
            timed,
            probe: false,
        };
        // nothing timed yet: a split that wakes the workers, one timed,
        // then one alone, timed
        assert_eq!(plan(0, 0, 0, 64), no(true, false));
        assert_eq!(plan(1, 0, 0, 64), no(true, true));
        assert_eq!(plan(2, 0, 500, 64), no(false, true));
        // split slower: alone, timed every PROBE_EVERY steps; from 64 the
        // probe, split, each step timed until it is recorded
        for step in 3..70 {
            let p = plan(step, 100, 300, 64);
            match step {
                64..=69 => assert_eq!(
                    p,
                    Plan {
                        split: true,
                        timed: true,
                        probe: true
                    }
                ),
                s if s % PROBE_EVERY == PROBE_EVERY / 2 => assert_eq!(p, no(false, true)),
                _ => assert_eq!(p, no(false, false)),
            }
        }
        // after the probe (recorded: the next one at 194)
        assert_eq!(plan(96, 100, 300, 194), no(false, true));
        assert_eq!(plan(100, 100, 300, 194), no(false, false));
        // a probe not recorded: every later step probes until one is
        assert_eq!(
            plan(90, 100, 300, 64),
            Plan {
                split: true,
                timed: true,
                probe: true
            }
        );
        // split faster: the other way round
        assert_eq!(plan(69, 300, 100, 70), no(true, false));
        assert_eq!(
            plan(70, 300, 100, 70),
            Plan {
                split: false,
                timed: true,
                probe: true
            }
        );
        assert_eq!(plan(75, 300, 100, 200), no(true, false));
    }

    #[test]
    fn a_probe_counts_the_mean_of_its_steps_after_its_warm_up() {
        let c = Choice::default();
        let us = 1_000_000; // a microsecond, in picoseconds
                            // warm-up: two steps and 100 µs (a 60 µs wake-up, then 4.3 µs and
                            // 2.3 µs steps), none counted
        assert_eq!(c.probe_sample(60 * us, 6000), None);
        assert_eq!(c.probe_sample(43 * us / 10, 430), None);
        let mut warm = 64 * us + 3 * us / 10;
        while warm < PROBE_WARM_UP_PS {
            assert_eq!(c.probe_sample(23 * us / 10, 230), None);
            warm += 23 * us / 10;
        }
        // then 100 µs and four steps at least, their mean per block
        let mut counted = 0;
        let sample = loop {
            counted += 1;
            let ps = if counted % 2 == 0 { 200 } else { 260 };
            if let Some(mean) = c.probe_sample(23 * us / 10, ps) {
                break mean;
            }
        };
        assert_eq!(counted, 44); // 44 steps of 2.3 µs: 101.2 µs
        assert_eq!(sample, 230);
        // and the next probe starts over with its warm-up
        assert_eq!(c.probe_sample(200 * us, 100), None);
        assert_eq!(c.probe_sample(200 * us, 100), None);
        for _ in 0..3 {
            assert_eq!(c.probe_sample(200 * us, 100), None);
        }
        assert_eq!(c.probe_sample(200 * us, 100), Some(100));
    }

    #[test]
    fn a_split_pays_when_it_is_faster_by_more_than_a_sixteenth() {
        assert!(split_pays(900, 1000));
        assert!(split_pays(1600, 1701));
        assert!(!split_pays(1600, 1700));
        assert!(!split_pays(950, 1000));
        assert!(!split_pays(1000, 1000));
        assert!(!split_pays(1100, 1000));
        assert!(!plan(500, 1000, 950, 10_000).split);
        assert!(plan(500, 1000, 900, 10_000).split);
    }

    #[test]
    fn a_probe_that_confirms_the_choice_doubles_the_interval() {
        assert_eq!(next_interval(64, false, 64, 1024), 128);
        assert_eq!(next_interval(4096, false, 64, 1024), 1024);
        assert_eq!(next_interval(4096, false, 64, 20_000), 8192);
        assert_eq!(next_interval(16_384, false, 64, 20_000), 20_000);
        assert_eq!(next_interval(1024, true, 64, 20_000), PROBE_EVERY);
        // a change goes back to the shortest, a confirmation doubles from it
        assert_eq!(next_interval(1024, true, 400, 20_000), 400);
        assert_eq!(next_interval(64, false, 400, 20_000), 400);
        assert_eq!(next_interval(400, false, 400, 20_000), 800);
        // probes a tenth of the time at most: 2 ms between two for their
        // least 200 µs; 64 steps at least
        assert_eq!(shortest_interval(1_000_000), 2000);
        assert_eq!(shortest_interval(5_000_000), 400);
        assert_eq!(shortest_interval(100_000_000), PROBE_EVERY);
        assert_eq!(shortest_interval(0), PROBE_QUIET * 200_000_000);
        // at least every 1024 steps, and never closer than 20 ms once
        // confirmed: 1024 steps of 50 µs, 20 000 of 1 µs
        assert_eq!(longest_interval(50_000_000), LONGEST_PROBE_INTERVAL);
        assert_eq!(longest_interval(1_000_000), 20_000);
        assert_eq!(longest_interval(0), PROBE_SPACING_PS);
    }

    #[test]
    fn an_estimate_follows_its_samples_and_one_outlier_moves_it_little() {
        assert_eq!(fold(0, 800), 800);
        assert_eq!(fold(800, 400), 700);
        // a step a thousand times slower counts as four times the estimate
        assert_eq!(fold(800, 800_000), 1400);
        // a run of samples converges to them
        let mut e = 1000;
        for _ in 0..40 {
            e = fold(e, 200);
        }
        assert!(e <= 201, "{e}");
        assert_eq!(fold(0, 0), 1);
        // the way in use: one slow step counts twice the estimate at most
        assert_eq!(fold_in_use(0, 800), 800);
        assert_eq!(fold_in_use(800, 400), 700);
        assert_eq!(fold_in_use(800, 800_000), 1000);
        // a split at 0.65 of one thread stays split after one slow step,
        // not after two in a row (counted four times: not after one)
        let (alone, mut split) = (1000, 650);
        assert!(!split_pays(fold(split, 100_000), alone));
        for slow in 1..=2 {
            split = fold_in_use(split, 100_000);
            assert_eq!(split_pays(split, alone), slow < 2, "{slow}: {split}");
        }
        // a probe's sample replaces the estimate, capped the same way
        assert_eq!(capped(800, 300), 300);
        assert_eq!(capped(800, 800_000), 3200);
        assert_eq!(capped(0, 0), 1);
    }
}
