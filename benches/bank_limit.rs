//! The compensator bank against the arithmetic the CPU can do.
//!
//! Per channel-step the bank's block step does a fixed number of vector-lane
//! operations (adds, subtractions, multiplies, fused multiply-adds, `min`,
//! `max`, compares and selects; loads and stores not counted): `24 + 8 n +
//! n_C (2 + 5 m)` — 444 at the paper's order (12 plays, 12 creep thresholds
//! × 5 eigenvalues): a play's bounds (`(t ∓ r) − C`, two operations each),
//! clamp, fault select and weighted term (one fused operation with its
//! sum); a creep threshold's bounds, weighted term and the `m − 1`
//! additions of its rows, and per eigenvalue the clamp and the update's two
//! fused operations. The CPU's rate for that kind of work is measured here,
//! on the registers of every vector kernel set it runs, with a loop of independent
//! creep-element updates (`min`, `max`, the two fused operations of
//! `g c + (χ − g χ)`, the row's addition) that has no loads, stores or
//! dependencies to wait for, in three forms: the row's addition as an add,
//! fused on the multiplier (`b · 1 + a`, the same sum), or the one in even
//! chains and the other in odd ones. A Zen core runs adds, `min` and `max`
//! on one pair of pipes and fused operations on the other, so only the
//! last form balances them (the AVX-512 kernels fuse half their rows'
//! additions; on a Zen 4 it ran 9 % faster than the other two, which were
//! all the bound had before). The fastest of the rates (each the best of
//! seven runs, with 4, 8 and 16 independent chains: 16 spill on AVX2's
//! registers) divided by 444 is the bound in channel-steps per second on
//! one core. A bank must also load and store its state at every step (a
//! row per update); the same updates with each one's row loaded from and
//! stored to L1 (`mix::streamed`, in each form, the best of seven runs
//! with each chain count) give the rate a bank can reach at best, and each
//! row is printed as a share of that too ("state in L1"). Where that rate
//! is the higher (AVX2, whose register mix cannot both hide its latency and
//! fit in sixteen registers), it is the set's bound. The CPU's bound, which
//! the table's rows are a share of, is the fastest set's: a CPU that does
//! the work faster on its 256-bit registers than on its 512-bit ones (a
//! Zen 4, in some runs) can do it that fast, whichever set the bank runs.
//!
//! Everything runs inside a rayon pool of two threads. First a crossover
//! scan: 2 to 64 blocks on one thread against a split over two
//! (`compensate_on(Par::rayon(2), …)`), and the smallest block count where
//! the split is faster: the figure a caller needs to choose its `Par`. Then
//! the bank at 1, 8, 64, 128, 256, 1024 and 4096 channels, `f64` and `f32`,
//! on one thread and split over two.
//! One thread and two (and, in the scan, one and the split) are timed in
//! alternating batches of steps on the same banks, so that a busy minute
//! and a bank's placement in memory fall on both: the
//! median time of each and the median and 10–90 % of two's time over one's
//! in the same round; printed with the CPU, its
//! bound, the ratio, the cycles per channel-step at the clock measured here,
//! and the share of a core a 4000-actuator mirror at 10 kHz needs; each
//! one-thread row also as a share of the state's traffic bound at its size
//! (`common::state_stream`: a pass that loads and stores the state's rows
//! as a step does, with one add per lane), marked where that is the lower
//! of the two bounds: a bank whose state has left L1 may be bound by the
//! cache, not by the arithmetic. Then the bank at 64 and 1024 channels
//! on one thread against its bound measured in the same rounds: batches of
//! the bank of about 32 ms alternating with runs of the mix that gave the
//! bound, as long, and the median of the bank's rate over the bound's in
//! each round; the same for a planned signal in one call
//! (`compensate_frames`: 64 frames at 64 and 1024 channels, 2048 frames at
//! 1024, beyond L2). The bound above is the best of seven runs; on a
//! shared machine a core has slow stretches, and a row that falls into
//! one is a share of a rate the core did not have then. Then each
//! kernel set on one thread (the vector sets at 64 and 1024 channels, the
//! portable one at 64), in batches alternating with the dispatched set's
//! and over its time in the same rounds, against the bound measured on its
//! own registers: on a CPU with AVX-512 the AVX2 set is measured against a
//! 256-bit mix, which is what a CPU with AVX2 only would give it.
//! Last, with `MFCBEAM_C_BANK` naming the library of the hand-written C bank
//! (`benches/peers/bank.c`, built by `benches/peers/run.sh`), the bank
//! against it in alternating batches at 8, 64, 1024 and 4096 channels
//! (`f64`).
//!
//! `cargo bench --features internals --bench bank_limit`

use std::hint::black_box;
use std::time::Instant;

mod common;

use common::{bank_rows, nominal_bank, state_stream};
use mfcbeam::internals::Kernels;
use mfcbeam::operators::bank::{CompensatorBank, Par};
use mfcbeam::realtime::{Compensated, Real};

/// The figures `benches/results` keeps: name, unit, value.
static FIGURES: std::sync::Mutex<Vec<(String, &'static str, f64)>> =
    std::sync::Mutex::new(Vec::new());

/// Keeps a figure for [`common::results::record`].
fn keep(name: String, unit: &'static str, value: f64) {
    if let Ok(mut f) = FIGURES.lock() {
        f.push((name, unit, value));
    }
}

/// State rows of a block at the paper's orders (`2 n + n_C m + 3`).
const STATE_ROWS: usize = 2 * 12 + 12 * 5 + 3;

/// Vector-lane operations per channel-step of the bank's block step.
fn lane_operations(n: usize, nc: usize, m: usize) -> usize {
    24 + 8 * n + nc * (2 + 5 * m)
}

/// The core's clock while it runs this, in GHz: a chain of dependent
/// integer additions (one cycle each on every x86-64 core), median of
/// five runs; elsewhere the nominal clock of `/proc/cpuinfo`. The nominal
/// clock a VM reports can be far from the one the core runs at (2.60
/// against 3.6 GHz on a Zen 4 guest). The added one is a register, not an
/// immediate: a Golden Cove core (Sapphire Rapids) folds chains of
/// immediate adds in its renamer, about four a cycle.
fn clock_ghz() -> (f64, &'static str) {
    #[cfg(target_arch = "x86_64")]
    {
        const ROUNDS: u64 = 10_000_000;
        let mut ghz: Vec<f64> = (0..5)
            .map(|_| {
                let mut x = 0u64;
                let one = black_box(1u64);
                let t0 = Instant::now();
                for _ in 0..ROUNDS {
                    // SAFETY: four additions between registers.
                    unsafe {
                        core::arch::asm!(
                            "add {0}, {1}", "add {0}, {1}", "add {0}, {1}", "add {0}, {1}",
                            inout(reg) x,
                            in(reg) one,
                            options(nomem, nostack)
                        )
                    };
                }
                black_box(x);
                (4 * ROUNDS) as f64 / t0.elapsed().as_nanos() as f64
            })
            .collect();
        ghz.sort_by(f64::total_cmp);
        (ghz[2], "measured")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let info = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
        let mhz = info
            .lines()
            .find(|l| l.starts_with("cpu MHz"))
            .and_then(|l| l.split(':').nth(1))
            .and_then(|s| s.trim().parse::<f64>().ok())
            .unwrap_or(f64::NAN);
        (mhz / 1e3, "nominal")
    }
}

/// How a creep update's row addition is done in a mix: as an add (on the
/// adder's pipes, with `min` and `max`), as the fused `b · 1 + a` (the same
/// sum, on the multiplier's pipes, with the two fused operations), or the
/// one way in even chains and the other in odd ones. A Zen core has two
/// pipes of each kind, so only the last balances them (five operations
/// of each kind in two updates); which form is fastest depends on the CPU,
/// and the bound takes the fastest. Its number is the kernels' const
/// parameter.
#[derive(Clone, Copy, Debug)]
#[repr(u8)]
enum Form {
    Adds = 0,
    Fused = 1,
    HalfFused = 2,
}

impl Form {
    const ALL: [Form; 3] = [Form::Adds, Form::Fused, Form::HalfFused];

    fn describe(self) -> &'static str {
        match self {
            Form::Adds => "its row additions as adds",
            Form::Fused => "its row additions fused on the multiplier",
            Form::HalfFused => "half its row additions fused on the multiplier",
        }
    }
}

/// A mix that was measured: its rate (lane operations per ns), form and
/// chain count, and whether each update's state was in L1.
#[derive(Clone, Copy)]
struct Mix {
    rate: f64,
    form: Form,
    chains: usize,
    streamed: bool,
}

/// The fastest of `rates` (a chain count and its rate, `None` where not
/// measured) and its chain count, printed with the others as `what` on
/// `k`'s registers.
fn fastest<T: Real>(
    k: Kernels,
    what: &str,
    rates: &[(usize, Option<f64>)],
) -> Option<(f64, usize)> {
    let (chains, rate) = rates
        .iter()
        .filter_map(|&(c, r)| Some((c, r?)))
        .max_by(|a, b| a.1.total_cmp(&b.1))?;
    let each: Vec<String> = rates
        .iter()
        .filter_map(|&(c, r)| Some(format!("{c} chains {:.1}", r?)))
        .collect();
    println!(
        "{} on {}'s registers: {what}: {rate:.1} lane-operations/ns ({chains} chains; {})",
        T::NAME,
        k.name(),
        each.join(", ")
    );
    Some((rate, chains))
}

/// Lane operations per nanosecond of the creep-element update on the
/// registers the bank's kernels use for `T` (measured: for each form and
/// chain count the best of seven runs — the CPU can do at least that; a
/// slower run is a neighbour's on a shared machine, and a median once came
/// out 18 % low on a Zen 4 — and the best over them, [`mix::run`]).
fn peak_lane_operations_per_ns<T: Real>(k: Kernels) -> Option<Mix> {
    fastest_form::<T>(k, "the creep mix with ", false, |form| {
        [
            (4, peak_with_chains::<T, 4>(k, form)),
            (8, peak_with_chains::<T, 8>(k, form)),
            (16, peak_with_chains::<T, 16>(k, form)),
        ]
    })
}

/// The fastest over the forms of a mix, each form's rates at 4, 8 and 16
/// chains from `rates` (with their state in L1 if `streamed`) and printed
/// as `what` followed by the form.
fn fastest_form<T: Real>(
    k: Kernels,
    what: &str,
    streamed: bool,
    rates: impl Fn(Form) -> [(usize, Option<f64>); 3],
) -> Option<Mix> {
    Form::ALL
        .into_iter()
        .filter_map(|form| {
            let what = format!("{what}{}", form.describe());
            let (rate, chains) = fastest::<T>(k, &what, &rates(form))?;
            Some(Mix {
                rate,
                form,
                chains,
                streamed,
            })
        })
        .max_by(|a, b| a.rate.total_cmp(&b.rate))
}

/// [`peak_lane_operations_per_ns`] for one chain count and form.
fn peak_with_chains<T: Real, const CHAINS: usize>(k: Kernels, form: Form) -> Option<f64> {
    // the same number of updates for every count
    let iterations = 32_000_000 / CHAINS;
    best_of_seven(|| registers_rate::<T, CHAINS>(k, form, iterations))
}

/// One timed run of `iterations` of [`mix::run`]: lane operations per ns.
fn registers_rate<T: Real, const CHAINS: usize>(
    k: Kernels,
    form: Form,
    iterations: usize,
) -> Option<f64> {
    let t0 = Instant::now();
    let lanes = mix::run::<T, CHAINS>(k, iterations, form)?;
    let ns = t0.elapsed().as_nanos() as f64;
    Some((iterations * CHAINS * 5 * lanes) as f64 / ns)
}

/// One timed run of `passes` of [`mix::streamed`] over `rows`: lane
/// operations per ns (a pass updates every value of the rows once, five
/// operations each).
fn streamed_rate<T: Real, const CHAINS: usize>(
    k: Kernels,
    form: Form,
    rows: &mut mix::Rows,
    passes: usize,
) -> Option<f64> {
    let t0 = Instant::now();
    mix::streamed::<T, CHAINS>(k, rows, passes, form)?;
    let ns = t0.elapsed().as_nanos() as f64;
    Some((passes * streamed_pass_operations::<T>()) as f64 / ns)
}

/// Lane operations of one pass of [`mix::streamed`].
fn streamed_pass_operations<T: Real>() -> usize {
    mix::STREAMED_ROWS * 64 / std::mem::size_of::<T>() * 5
}

/// The highest of seven rates `rate` measures (`None` if it gives none).
fn best_of_seven(mut rate: impl FnMut() -> Option<f64>) -> Option<f64> {
    (0..7)
        .map(|_| rate())
        .try_fold(0.0f64, |best, r| Some(best.max(r?)))
}

/// Lane operations per nanosecond of the same updates with each one's
/// state loaded from and stored to L1 (for each form and chain count the
/// best of seven runs, and the best over them; `None` where the bank's
/// kernels `k` have no vector registers).
fn streamed_lane_operations_per_ns<T: Real>(k: Kernels) -> Option<Mix> {
    fastest_form::<T>(k, "the creep mix with its state in L1, ", true, |form| {
        [
            (4, streamed_with_chains::<T, 4>(k, form)),
            (8, streamed_with_chains::<T, 8>(k, form)),
            (16, streamed_with_chains::<T, 16>(k, form)),
        ]
    })
}

/// [`streamed_lane_operations_per_ns`] for one chain count and form.
fn streamed_with_chains<T: Real, const CHAINS: usize>(k: Kernels, form: Form) -> Option<f64> {
    const ITERATIONS: usize = 200_000;
    let mut rows = mix::Rows::new::<T>();
    let best = best_of_seven(|| streamed_rate::<T, CHAINS>(k, form, &mut rows, ITERATIONS));
    black_box(&rows);
    best
}

mod mix {
    //! Independent chains of the creep-element update, on registers or
    //! with their state in L1.
    use super::Form;
    use mfcbeam::internals::Kernels;
    use mfcbeam::realtime::Real;

    /// `$kernel::<CHAINS, FORM>($args)` of module `x86` with the form
    /// `$form` made a constant (the kernels take it as a const parameter).
    #[cfg(target_arch = "x86_64")]
    macro_rules! each_form {
        ($form:expr, $kernel:ident::<$chains:ident>($($arg:expr),*)) => {
            match $form {
                Form::Adds => x86::$kernel::<$chains, { Form::Adds as u8 }>($($arg),*),
                Form::Fused => x86::$kernel::<$chains, { Form::Fused as u8 }>($($arg),*),
                Form::HalfFused => x86::$kernel::<$chains, { Form::HalfFused as u8 }>($($arg),*),
            }
        };
    }

    /// Runs `iterations` of `CHAINS` chains on the registers of kernel set
    /// `k` for `T`, their rows added in `form`; returns the lanes per
    /// register. The callers try 4, 8 and 16 chains (each divides the
    /// streamed rows of every register width): a chain holds two
    /// registers, its state and its row sum, so 16 chains spill on AVX2's
    /// 16 registers (on a Zen 1 at half the rate of 4) and a little on
    /// AVX-512's 32, while 4 may not hide the latency on a CPU with more or
    /// wider pipes. `None` for a fused form without vector registers.
    pub fn run<T: Real, const CHAINS: usize>(
        k: Kernels,
        iterations: usize,
        form: Form,
    ) -> Option<usize> {
        let f64_ = T::NAME == "f64";
        #[cfg(target_arch = "x86_64")]
        {
            // SAFETY: a `Kernels` value exists only where the CPU has its
            // features.
            unsafe {
                if k.is_avx512() {
                    return Some(if f64_ {
                        each_form!(form, avx512_f64::<CHAINS>(iterations))
                    } else {
                        each_form!(form, avx512_f32::<CHAINS>(iterations))
                    });
                }
                if k.is_avx2() {
                    return Some(if f64_ {
                        each_form!(form, avx2_f64::<CHAINS>(iterations))
                    } else {
                        each_form!(form, avx2_f32::<CHAINS>(iterations))
                    });
                }
            }
        }
        let _ = (f64_, k);
        matches!(form, Form::Adds).then(|| scalar::<T, CHAINS>(iterations))
    }

    /// Rows of state for [`streamed`]: 64 cache lines (4 KiB, in L1).
    #[repr(C, align(64))]
    pub struct Rows([[u64; 8]; STREAMED_ROWS]);

    pub const STREAMED_ROWS: usize = 64;

    impl Rows {
        pub fn new<T: Real>() -> Box<Self> {
            let mut rows = Box::new(Rows([[0; 8]; STREAMED_ROWS]));
            let half = T::from_f64(0.5);
            let n = STREAMED_ROWS * 64 / std::mem::size_of::<T>();
            // SAFETY: the rows are n values of T's size, aligned for it.
            let values =
                unsafe { std::slice::from_raw_parts_mut(rows.0.as_mut_ptr().cast::<T>(), n) };
            values.fill(half);
            rows
        }
    }

    /// [`run`]'s updates with each chain's state in memory: every update
    /// loads its row of `rows` and stores it back, as the bank does with its
    /// creep rows; `iterations` passes over the rows. The lanes per
    /// register, or `None` where the set `k` has no vector registers.
    pub fn streamed<T: Real, const CHAINS: usize>(
        k: Kernels,
        rows: &mut Rows,
        iterations: usize,
        form: Form,
    ) -> Option<usize> {
        let f64_ = T::NAME == "f64";
        let p = rows.0.as_mut_ptr().cast::<u8>();
        #[cfg(target_arch = "x86_64")]
        {
            // SAFETY: a `Kernels` value exists only where the CPU has its
            // features; the rows are STREAMED_ROWS cache lines.
            unsafe {
                if k.is_avx512() {
                    return Some(if f64_ {
                        each_form!(form, avx512_f64_streamed::<CHAINS>(p.cast(), iterations))
                    } else {
                        each_form!(form, avx512_f32_streamed::<CHAINS>(p.cast(), iterations))
                    });
                }
                if k.is_avx2() {
                    return Some(if f64_ {
                        each_form!(form, avx2_f64_streamed::<CHAINS>(p.cast(), iterations))
                    } else {
                        each_form!(form, avx2_f32_streamed::<CHAINS>(p.cast(), iterations))
                    });
                }
            }
        }
        let _ = (f64_, p, iterations, k, form);
        None
    }

    fn scalar<T: Real, const CHAINS: usize>(iterations: usize) -> usize {
        let mut x = [T::from_f64(0.5); CHAINS];
        let mut r = [T::ZERO; CHAINS];
        let (lo, hi, g) = (T::from_f64(-1.0), T::from_f64(1.0), T::from_f64(0.25));
        for _ in 0..iterations {
            for k in 0..CHAINS {
                let c = x[k];
                let c = if c < hi { c } else { hi };
                let c = if c > lo { c } else { lo };
                x[k] = g.fused_mul_add(c, (-g).fused_mul_add(x[k], x[k]));
                r[k] += x[k];
            }
        }
        std::hint::black_box((x, r));
        1
    }

    #[cfg(target_arch = "x86_64")]
    mod x86 {
        use core::arch::x86_64::*;

        /// Chain `k`'s row sum `r` with `x` added in form `FORM` (see
        /// [`super::Form`]): `b · 1 + a` fused, or an add.
        macro_rules! row_add {
            ($form:ident, $k:expr, $r:expr, $x:expr, $one:expr, $add:ident, $fma:ident) => {
                if $form == super::Form::Fused as u8
                    || ($form == super::Form::HalfFused as u8 && $k % 2 == 1)
                {
                    $fma($x, $one, $r)
                } else {
                    $add($r, $x)
                }
            };
        }

        // `CHAINS` independent updates on registers, their rows added in
        // form `FORM`. The `1` of the fused form is hidden from the
        // compiler, which would otherwise make it an add.
        macro_rules! chains {
            ($name:ident, $feature:literal, $t:ty, $set1:ident, $min:ident, $max:ident, $add:ident, $fma:ident, $fnma:ident, $lanes:expr) => {
                #[target_feature(enable = $feature)]
                pub unsafe fn $name<const CHAINS: usize, const FORM: u8>(
                    iterations: usize,
                ) -> usize {
                    let mut x: [$t; CHAINS] = [$set1(std::hint::black_box(0.5)); CHAINS];
                    let mut r: [$t; CHAINS] = [$set1(0.0); CHAINS];
                    let (lo, hi, g) = ($set1(-1.0), $set1(1.0), $set1(std::hint::black_box(0.25)));
                    let one = $set1(std::hint::black_box(1.0));
                    for _ in 0..iterations {
                        for k in 0..CHAINS {
                            let c = $max($min(x[k], hi), lo);
                            x[k] = $fma(g, c, $fnma(g, x[k], x[k]));
                            r[k] = row_add!(FORM, k, r[k], x[k], one, $add, $fma);
                        }
                    }
                    std::hint::black_box((x, r));
                    $lanes
                }
            };
        }
        // The same updates with each chain's row loaded and stored at
        // every update, `CHAINS` rows at a time, over all the rows.
        macro_rules! streamed {
            ($name:ident, $feature:literal, $e:ty, $t:ty, $set1:ident, $load:ident, $store:ident, $min:ident, $max:ident, $add:ident, $fma:ident, $fnma:ident, $lanes:expr) => {
                #[target_feature(enable = $feature)]
                pub unsafe fn $name<const CHAINS: usize, const FORM: u8>(
                    p: *mut $e,
                    iterations: usize,
                ) -> usize {
                    // SAFETY (all): `p` is STREAMED_ROWS aligned cache lines.
                    let rows = super::STREAMED_ROWS * 64 / (std::mem::size_of::<$e>() * $lanes);
                    let mut r: [$t; CHAINS] = [$set1(0.0); CHAINS];
                    let (lo, hi, g) = ($set1(-1.0), $set1(1.0), $set1(std::hint::black_box(0.25)));
                    let one = $set1(std::hint::black_box(1.0));
                    for _ in 0..iterations {
                        for j in (0..rows).step_by(CHAINS) {
                            for k in 0..CHAINS {
                                let at = unsafe { p.add((j + k) * $lanes) };
                                let x = unsafe { $load(at) };
                                let c = $max($min(x, hi), lo);
                                let x = $fma(g, c, $fnma(g, x, x));
                                unsafe { $store(at, x) };
                                r[k] = row_add!(FORM, k, r[k], x, one, $add, $fma);
                            }
                        }
                    }
                    std::hint::black_box(r);
                    $lanes
                }
            };
        }
        streamed!(
            avx512_f64_streamed,
            "avx2,fma,avx512f",
            f64,
            __m512d,
            _mm512_set1_pd,
            _mm512_load_pd,
            _mm512_store_pd,
            _mm512_min_pd,
            _mm512_max_pd,
            _mm512_add_pd,
            _mm512_fmadd_pd,
            _mm512_fnmadd_pd,
            8
        );
        streamed!(
            avx512_f32_streamed,
            "avx2,fma,avx512f",
            f32,
            __m512,
            _mm512_set1_ps,
            _mm512_load_ps,
            _mm512_store_ps,
            _mm512_min_ps,
            _mm512_max_ps,
            _mm512_add_ps,
            _mm512_fmadd_ps,
            _mm512_fnmadd_ps,
            16
        );
        streamed!(
            avx2_f64_streamed,
            "avx2,fma",
            f64,
            __m256d,
            _mm256_set1_pd,
            _mm256_load_pd,
            _mm256_store_pd,
            _mm256_min_pd,
            _mm256_max_pd,
            _mm256_add_pd,
            _mm256_fmadd_pd,
            _mm256_fnmadd_pd,
            4
        );
        streamed!(
            avx2_f32_streamed,
            "avx2,fma",
            f32,
            __m256,
            _mm256_set1_ps,
            _mm256_load_ps,
            _mm256_store_ps,
            _mm256_min_ps,
            _mm256_max_ps,
            _mm256_add_ps,
            _mm256_fmadd_ps,
            _mm256_fnmadd_ps,
            8
        );
        chains!(
            avx512_f64,
            "avx2,fma,avx512f",
            __m512d,
            _mm512_set1_pd,
            _mm512_min_pd,
            _mm512_max_pd,
            _mm512_add_pd,
            _mm512_fmadd_pd,
            _mm512_fnmadd_pd,
            8
        );
        chains!(
            avx512_f32,
            "avx2,fma,avx512f",
            __m512,
            _mm512_set1_ps,
            _mm512_min_ps,
            _mm512_max_ps,
            _mm512_add_ps,
            _mm512_fmadd_ps,
            _mm512_fnmadd_ps,
            16
        );
        chains!(
            avx2_f64,
            "avx2,fma",
            __m256d,
            _mm256_set1_pd,
            _mm256_min_pd,
            _mm256_max_pd,
            _mm256_add_pd,
            _mm256_fmadd_pd,
            _mm256_fnmadd_pd,
            4
        );
        chains!(
            avx2_f32,
            "avx2,fma",
            __m256,
            _mm256_set1_ps,
            _mm256_min_ps,
            _mm256_max_ps,
            _mm256_add_ps,
            _mm256_fmadd_ps,
            _mm256_fnmadd_ps,
            8
        );
    }
}

/// How a timed step runs.
#[derive(Clone, Copy)]
enum Mode {
    /// On the calling thread: `CompensatorBank::compensate`.
    Alone,
    /// On the calling thread and these kernels.
    Kernels(Kernels),
    /// Split over the threads of the pool the bench runs in.
    Split(Par),
    /// On the calling thread, all the rows in one call:
    /// `CompensatorBank::compensate_frames`.
    Frames,
}

/// One bank of `channels` channels stepped in batches of about 2 ms.
struct Timed<T: Real> {
    bank: CompensatorBank<T>,
    out: Vec<Compensated<T>>,
    k: usize,
    /// [`Mode::Frames`]'s targets (the rows one after the other) and
    /// outputs, made at its first batch.
    frames: Option<(Vec<T>, Vec<Compensated<T>>)>,
}

impl<T: Real> Timed<T> {
    const ROWS: usize = 64;

    fn new(channels: usize) -> Self {
        Timed {
            bank: nominal_bank::<T>(channels),
            out: vec![Compensated::<T>::default(); channels],
            k: 0,
            frames: None,
        }
    }

    fn steps(channels: usize) -> usize {
        (2_000_000 / (channels * 8).max(1)).clamp(20, 200_000)
    }

    fn step(&mut self, rows: &[Vec<T>], mode: Mode) {
        self.k = (self.k + 1) % Self::ROWS;
        let row = black_box(&rows[self.k]);
        match mode {
            Mode::Alone => self.bank.compensate(row, &mut self.out),
            Mode::Kernels(kernels) => self.bank.compensate_using(kernels, row, &mut self.out),
            Mode::Split(par) => self.bank.compensate_on(par, row, &mut self.out),
            Mode::Frames => unreachable!("a batch of frames steps in `frames_batch`"),
        }
        .unwrap();
    }

    /// Nanoseconds per step of one batch of about 2 ms.
    fn batch(&mut self, rows: &[Vec<T>], mode: Mode) -> f64 {
        self.batch_of(rows, mode, Self::steps(self.out.len())).0
    }

    /// Nanoseconds per step of one batch of `steps` steps, and the steps
    /// timed (for [`Mode::Frames`] whole calls of all the rows, at least
    /// one). Its first two steps are not timed: after the other way's
    /// batch a sleeping thread of the pool wakes in them, which a bank
    /// stepped every sample does not pay.
    fn batch_of(&mut self, rows: &[Vec<T>], mode: Mode, steps: usize) -> (f64, usize) {
        if let Mode::Frames = mode {
            return self.frames_batch(rows, steps);
        }
        self.step(rows, mode);
        self.step(rows, mode);
        let t0 = Instant::now();
        for _ in 0..steps {
            self.step(rows, mode);
        }
        black_box(&self.out);
        (t0.elapsed().as_nanos() as f64 / steps as f64, steps)
    }
}

impl<T: Real> Timed<T> {
    /// [`Timed::batch_of`] of [`Mode::Frames`]: `steps` steps or more (at
    /// least one call), in calls of all the rows, the first call not timed.
    fn frames_batch(&mut self, rows: &[Vec<T>], steps: usize) -> (f64, usize) {
        let (targets, out) = self.frames.get_or_insert_with(|| {
            let targets: Vec<T> = rows.iter().flatten().copied().collect();
            let out = vec![Compensated::<T>::default(); targets.len()];
            (targets, out)
        });
        let calls = steps.div_ceil(rows.len());
        let mut call = |bank: &mut CompensatorBank<T>| {
            bank.compensate_frames(black_box(targets), out).unwrap();
        };
        call(&mut self.bank);
        let t0 = Instant::now();
        for _ in 0..calls {
            call(&mut self.bank);
        }
        black_box(&*out);
        let steps = calls * rows.len();
        (t0.elapsed().as_nanos() as f64 / steps as f64, steps)
    }
}

/// Banks in [`time_pair`]. A bank's speed depends on where its memory
/// lands: on a Zen 4, of 64 banks of 8 channels made in turn and timed
/// alike, a few took 1.08–1.34× the median (three in one process, six in
/// another), with the same code and inputs; which ones changed from
/// process to process, at the same low 12 address bits, and one allocation
/// for the parameters and the state did not remove it. Rotating a few banks puts the median over placements, not
/// one placement's luck.
const PLACEMENTS: usize = 3;

/// Two ways of stepping `channels` channels, timed in alternating batches
/// on the same bank (both give the same bits and leave the same state, and
/// on one bank they share its placement), in [`alternating`] rounds, the
/// round's bank one of [`PLACEMENTS`] in turn: the median nanoseconds per
/// step of each, and the median, 10 % and 90 % of `b`'s time over `a`'s in
/// the same round.
fn time_pair<T: Real>(channels: usize, a: Mode, b: Mode) -> (f64, f64, [f64; 3]) {
    let rows = bank_rows::<T>(channels, Timed::<T>::ROWS);
    let mut banks: Vec<Timed<T>> = (0..PLACEMENTS).map(|_| Timed::new(channels)).collect();
    alternating(|round, second| {
        let mode = if second { b } else { a };
        banks[round % PLACEMENTS].batch(&rows, mode)
    })
}

/// Two figures timed in alternating order, `run(round, second)` giving the
/// first (`second` false) or the second, the order swapped every round, 61
/// rounds after 60 ms of warm-up: the median of each, and the median, 10 % and 90 % of the second over
/// the first in the same round. Timed one after the other, a busy minute
/// would fall on one of them only.
fn alternating(mut run: impl FnMut(usize, bool) -> f64) -> (f64, f64, [f64; 3]) {
    let warm = Instant::now();
    let mut round = 0;
    while warm.elapsed().as_millis() < 60 {
        run(round, false);
        run(round, true);
        round += 1;
    }
    let (mut ta, mut tb, mut ratio) = (Vec::new(), Vec::new(), Vec::new());
    for round in 0..61 {
        let (x, y) = if round % 2 == 0 {
            let x = run(round, false);
            (x, run(round, true))
        } else {
            let y = run(round, true);
            (run(round, false), y)
        };
        ta.push(x);
        tb.push(y);
        ratio.push(y / x);
    }
    for v in [&mut ta, &mut tb, &mut ratio] {
        v.sort_by(f64::total_cmp);
    }
    (ta[30], tb[30], [ratio[30], ratio[6], ratio[54]])
}

/// One run of the mix `m` on `k`'s registers for `T`, about `ns`
/// nanoseconds long at its measured rate: its rate now, lane operations
/// per ns (`None` where `k` cannot run it).
fn mix_rate<T: Real>(k: Kernels, m: Mix, rows: &mut mix::Rows, ns: f64) -> Option<f64> {
    let operations = m.rate * ns;
    if m.streamed {
        let passes = ((operations / streamed_pass_operations::<T>() as f64) as usize).max(1);
        return match m.chains {
            4 => streamed_rate::<T, 4>(k, m.form, rows, passes),
            8 => streamed_rate::<T, 8>(k, m.form, rows, passes),
            _ => streamed_rate::<T, 16>(k, m.form, rows, passes),
        };
    }
    fn timed<T: Real, const CHAINS: usize>(k: Kernels, form: Form, operations: f64) -> Option<f64> {
        let lanes = mix::run::<T, CHAINS>(k, 1, form)?;
        let iterations = ((operations / (CHAINS * 5 * lanes) as f64) as usize).max(1);
        registers_rate::<T, CHAINS>(k, form, iterations)
    }
    match m.chains {
        4 => timed::<T, 4>(k, m.form, operations),
        8 => timed::<T, 8>(k, m.form, operations),
        _ => timed::<T, 16>(k, m.form, operations),
    }
}

/// How many times a batch of [`Timed::steps`] (about 2 ms) a batch of the
/// bank against its bound in the same rounds is. On a Sapphire Rapids
/// guest, in rounds of 2 ms batches and runs of the mix, the mix ran
/// at 108–110 M channel-steps/s and a 64-channel `f64` bank at 86 % of it;
/// in rounds of 8 ms at 124, the bank at 79 %; of 32 ms at 124–126, the
/// bank at 78 %, the mix's best of seven at the start 132: a run of the
/// mix right after the bank is slow for a while, the bank after the mix
/// much less so, and short rounds favoured the bank.
const SAME_ROUNDS_BATCHES: usize = 16;

/// The bank of `channels` channels on one thread against its bound
/// measured in the same rounds: batches of the bank (as [`time_pair`]'s,
/// [`SAME_ROUNDS_BATCHES`] times as long, about 32 ms; the banks of
/// [`PLACEMENTS`] in turn) in [`alternating`] rounds with runs of the
/// bound's mix `m` on `k`'s registers (each as long as the bank's last
/// batch; 32 ms before the first). The median rate of each in M
/// channel-steps/s (the mix's as the bound of `ops` lane operations a
/// channel-step) and the median, 10 % and 90 % of the bank's rate over the
/// bound's in the same round (`None` where `k` cannot run the mix). The
/// bound above is the best of seven runs at the start; on a shared machine
/// the core is slower in some stretches than in others (on a Sapphire
/// Rapids guest, a third of the 2 ms batches of a 64-channel bank 12 %
/// slower, at 32 to 128 channels alike, in stretches of tens of
/// milliseconds, its clock as measured unchanged): where a row of the
/// table falls into one, it is a share of a bound the core did not have
/// then. Here both see the same stretch.
fn against_bound_in_same_rounds<T: Real>(
    channels: usize,
    (mode, frames): (Mode, usize),
    k: Kernels,
    m: Mix,
    ops: usize,
) -> Option<(f64, f64, [f64; 3])> {
    let rows = bank_rows::<T>(channels, frames);
    let mut banks: Vec<Timed<T>> = (0..PLACEMENTS).map(|_| Timed::new(channels)).collect();
    let mut state = mix::Rows::new::<T>();
    mix_rate::<T>(k, m, &mut state, 1e3)?;
    let steps = SAME_ROUNDS_BATCHES * Timed::<T>::steps(channels);
    let mut batch_ns = 2e6 * SAME_ROUNDS_BATCHES as f64;
    let (bound, bank, ratio) = alternating(|round, bank_now| {
        if bank_now {
            let (ns, steps) = banks[round % PLACEMENTS].batch_of(&rows, mode, steps);
            batch_ns = ns * steps as f64;
            channels as f64 / ns * 1e3
        } else {
            let rate = mix_rate::<T>(k, m, &mut state, batch_ns).unwrap_or(f64::NAN);
            rate * 1e3 / ops as f64
        }
    });
    black_box(&state);
    Some((bank, bound, ratio))
}

/// `rate` as a percentage of `of`, or "n/a" where there is no `of` (no
/// state-in-L1 rate on a CPU whose bank kernels have no vector registers).
fn share(rate: f64, of: f64) -> String {
    if of.is_finite() && of > 0.0 {
        format!("{:.0} %", 100.0 * rate / of)
    } else {
        "n/a".to_string()
    }
}

/// The bank's bound on kernel set `k`'s registers for a step of `ops`
/// lane operations per channel.
struct Bound {
    /// The creep mix's rate, lane operations per ns: the faster of the
    /// register and streamed mixes, each in its fastest form (see
    /// [`bound_on`]).
    peak: f64,
    /// The same updates with their state in memory: what a bank, which
    /// must load and store its state, can reach at best (`None` where `k`
    /// has no vector registers).
    streamed: Option<f64>,
    /// `peak` in M channel-steps/s on one core.
    per_core: f64,
    /// `streamed` in M channel-steps/s on one core (NaN if `None`).
    in_l1: f64,
    /// The mix that gave `peak` (`None` if none was measured).
    mix: Option<Mix>,
}

/// The bound: the register mix's rate, or the streamed mix's where that is
/// faster. On AVX2's sixteen registers the register mix's chains are too
/// few to hide their latency at 8 and spill at 16, and the same updates
/// with their state in L1 ran faster (52 lane-operations/ns against 44 in
/// `f64` on a Zen 4): a rate the CPU reached is no bound if it can go faster.
fn bound_on<T: Real>(k: Kernels, ops: usize) -> Bound {
    let in_registers = peak_lane_operations_per_ns::<T>(k);
    let streamed_mix = streamed_lane_operations_per_ns::<T>(k);
    let mix = [in_registers, streamed_mix]
        .into_iter()
        .flatten()
        .max_by(|a, b| a.rate.total_cmp(&b.rate));
    let peak = mix.map_or(0.0, |m| m.rate);
    let streamed = streamed_mix.map(|m| m.rate);
    if mix.is_some_and(|m| m.streamed) {
        println!(
            "{} on {}'s registers: the mix with its state in L1 ran faster ({peak:.1} lane-operations/ns): it is the bound",
            T::NAME,
            k.name()
        );
    }
    let per_core = |rate: f64| rate * 1e3 / ops as f64;
    Bound {
        peak,
        streamed,
        per_core: per_core(peak),
        in_l1: streamed.map_or(f64::NAN, per_core),
        mix,
    }
}

/// The table of `T`; returns the bound (M channel-steps/s on one core).
fn report<T: Real>(ghz: f64) -> f64 {
    let ops = lane_operations(12, 12, 5);
    let dispatched = Kernels::detect();
    // each vector set's bound on its own registers (the portable set's
    // where the CPU has none), and the CPU's: the fastest of them. On a
    // Zen 4 the 256-bit mix with its state in L1 came out above the
    // 512-bit one in three runs of six in f64 and four in f32 (at best
    // 56.2 against 53.3 lane-operations/ns, and 112.7 against 106.4): a
    // bank on AVX-512 is measured against what the CPU does on any of its
    // registers.
    let own: Vec<(Kernels, Bound)> = {
        let vector: Vec<Kernels> = Kernels::all().filter(|&k| k != Kernels::Portable).collect();
        let sets = if vector.is_empty() {
            vec![dispatched]
        } else {
            vector
        };
        sets.into_iter()
            .map(|k| (k, bound_on::<T>(k, ops)))
            .collect()
    };
    let (fastest_set, fastest) = own
        .iter()
        .max_by(|a, b| a.1.peak.total_cmp(&b.1.peak))
        .expect("at least one kernel set");
    let peak = fastest.peak;
    let bound = fastest.per_core;
    // the rate a bank can reach at best: the fastest streamed mix
    let streamed = own
        .iter()
        .filter_map(|(k, b)| Some((*k, b.streamed?)))
        .max_by(|a, b| a.1.total_cmp(&b.1));
    let in_l1 = streamed.map_or(f64::NAN, |(_, rate)| rate * 1e3 / ops as f64);
    println!(
        "{}: the bound is {}'s mix ({peak:.1} lane-operations/ns), the fastest on this CPU's registers{}",
        T::NAME,
        fastest_set.name(),
        own.iter()
            .filter(|(k, _)| k != fastest_set)
            .map(|(k, b)| format!("; {}'s {:.1}", k.name(), b.peak))
            .collect::<String>()
    );
    if let Some((set, rate)) = streamed {
        println!(
            "{}: the creep mix with each update's state loaded from and stored to L1, fastest on {}'s registers: {rate:.1} lane-operations/ns ({:.0} % of the bound) -> {in_l1:.1} M channel-steps/s per core",
            T::NAME,
            set.name(),
            100.0 * rate / peak
        );
    }
    println!(
        "\n{}: measured peak {peak:.1} lane-operations/ns of the creep mix; {ops} per channel-step \
         -> bound {bound:.1} M channel-steps/s per core ({:.1} cycles per channel-step at {ghz:.2} GHz)",
        T::NAME,
        ops as f64 / peak * ghz
    );
    println!(
        "{:>8} {:>8} {:>14} {:>12} {:>14} {:>16} {:>10} {:>22}",
        "channels",
        "threads",
        "ns per step",
        "M ch-steps/s",
        "cycles/ch-step",
        "bound (per core)",
        "state in L1",
        "state's traffic (M)"
    );
    // the crossover: one thread against a split in two, by blocks
    let two = Par::rayon(2);
    let lanes = 64 / std::mem::size_of::<T>(); // a block: one cache line of lanes
    let mut crossover = None;
    for blocks in [2usize, 4, 8, 12, 16, 24, 32, 64] {
        let (one, both, [ratio, low, high]) =
            time_pair::<T>(blocks * lanes, Mode::Alone, Mode::Split(two));
        println!(
            "crossover scan: {blocks:>3} blocks ({:>4} channels): one thread {one:>9.1} ns, split {both:>9.1} ns, split / one {ratio:.3} ({low:.3}-{high:.3})",
            blocks * lanes
        );
        if crossover.is_none() && ratio < 1.0 {
            crossover = Some(blocks);
            keep(
                format!("bank_{}_crossover_blocks", T::NAME),
                "count",
                blocks as f64,
            );
        }
    }
    println!(
        "two threads pay from {} blocks here",
        crossover.map_or("more than 64".to_string(), |b| b.to_string()),
    );
    let mut at_4096 = f64::NAN;
    for channels in [1usize, 8, 64, 128, 256, 1024, 4096] {
        let (one, two_ns, [ratio, low, high]) =
            time_pair::<T>(channels, Mode::Alone, Mode::Split(two));
        if channels == 256 || channels == 1024 {
            keep(
                format!("bank_{}_two_threads_over_one_{channels}", T::NAME),
                "ratio",
                ratio,
            );
        }
        for (threads, ns) in [(1, one), (2, two_ns)] {
            let rate = channels as f64 / ns * 1e3;
            print!(
                "{channels:>8} {threads:>8} {ns:>14.1} {rate:>12.1} {:>14.1} {:>17} {:>10}",
                ns * ghz / channels as f64,
                share(rate, bound * threads as f64),
                share(rate, in_l1 * threads as f64)
            );
            if threads == 2 {
                print!("   two / one {ratio:.3} ({low:.3}-{high:.3})");
            } else {
                // the memory side: where the state's traffic is the lower
                // bound, the row's share of it
                let traffic = state_stream::bound(channels, lanes, STATE_ROWS, 12);
                print!(
                    " {:>5} of {traffic:>7.1}{}",
                    share(rate, traffic),
                    if traffic < bound { " (the lower)" } else { "" }
                );
                if channels == 4096 {
                    at_4096 = rate;
                }
            }
            println!();
        }
    }
    // the bank against its bound with both in the same stretch of time
    if let Some(m) = fastest.mix {
        // a frame a call, and a planned signal: 64 frames (in cache), and
        // at 1024 channels 2048 frames (in `f64` 48 MB, far beyond L2)
        let rows = Timed::<T>::ROWS;
        let ways = [
            ((Mode::Alone, rows), &[64usize, 1024][..], String::new()),
            (
                (Mode::Frames, rows),
                &[64, 1024],
                format!(", {rows} frames a call (compensate_frames)"),
            ),
            (
                (Mode::Frames, 2048),
                &[1024],
                ", 2048 frames a call (compensate_frames, beyond L2)".to_string(),
            ),
        ];
        for (mode, sizes, calls) in &ways {
            for &channels in *sizes {
                let Some((rate, of, [ratio, low, high])) =
                    against_bound_in_same_rounds::<T>(channels, *mode, *fastest_set, m, ops)
                else {
                    continue;
                };
                let frames = if calls.is_empty() { "" } else { "_frames" };
                if mode.1 == rows {
                    keep(
                        format!("bank_{}_{channels}{frames}_of_bound", T::NAME),
                        "fraction",
                        ratio,
                    );
                }
                println!(
                "{channels} channels, one thread{calls}, in the same rounds as the bound's mix ({}'s registers, {}{}, {} chains): \
                 the bank {rate:.1} M channel-steps/s, the bound {of:.1} M (the best at the start {bound:.1} M); \
                 the bank / the bound in the same round {:.1} % ({:.1}-{:.1} %)",
                fastest_set.name(),
                if m.streamed { "state in L1, " } else { "" },
                m.form.describe(),
                m.chains,
                100.0 * ratio,
                100.0 * low,
                100.0 * high
            );
            }
        }
    }
    // every kernel set against the mix on its own registers (a CPU with
    // AVX-512 runs the AVX2 set at 256 bits, as a CPU with AVX2 only does);
    // the vector sets at 1024 channels too. The portable set beside a
    // vector one has no bound of its own: each of its fused operations is
    // a call to the C library's `fma`.
    for kernels in Kernels::all() {
        let bounds = own
            .iter()
            .find(|(k, _)| *k == kernels && kernels != Kernels::Portable)
            .map(|(_, own)| (own.per_core, own.in_l1));
        let sizes: &[usize] = if kernels == Kernels::Portable {
            &[64]
        } else {
            &[64, 1024]
        };
        for &channels in sizes {
            // in rounds alternating with the dispatched set, as the table's
            // rows are: timed alone in a row, a busy stretch fell on one
            // set (the AVX2 set's line moved from 44 to 72 % between runs)
            let (dispatched_ns, ns, [ratio, low, high]) =
                time_pair::<T>(channels, Mode::Alone, Mode::Kernels(kernels));
            let rate = channels as f64 / ns * 1e3;
            let of_bound = bounds.map_or("no bound of its own".to_string(), |(bound, in_l1)| {
                format!(
                    "{} of its registers' bound {bound:.1}, {} with the state in L1",
                    share(rate, bound),
                    share(rate, in_l1)
                )
            });
            // the dispatched set against itself: the rounds' noise
            let against = if kernels == dispatched {
                "itself (the rounds' noise)"
            } else {
                "the dispatched set's"
            };
            println!(
                "{channels} channels, one thread, {}: {rate:.1} M channel-steps/s ({of_bound}); \
                 its time over {against} ({:.1} M) in the same rounds {ratio:.3} ({low:.3}-{high:.3})",
                kernels.name(),
                channels as f64 / dispatched_ns * 1e3
            );
        }
    }
    println!(
        "a 4000-actuator mirror at 10 kHz (40 M channel-steps/s) needs {:.2} of one core in {}",
        40.0 / at_4096,
        T::NAME
    );
    bound
}

/// The bank against the hand-written C bank of `benches/peers/bank.c`
/// (`f64`, AVX-512F, built by `benches/peers/run.sh` as `libbank.so` and
/// loaded from `MFCBEAM_C_BANK`), in alternating batches on one thread at 8,
/// 64, 1024 and 4096 channels: the same targets, the same bits (checked
/// after the warm-up), the median time of each, and the median and 10–90 %
/// spread of mfcbeam's time over the C's in the same round.
#[cfg(target_os = "linux")]
fn against_c_bank(path: &str, ghz: f64, bound: f64) {
    use std::ffi::c_void;
    type New = unsafe extern "C" fn(i64) -> *mut c_void;
    type Run =
        unsafe extern "C" fn(*mut c_void, *const f64, i64, *mut i64, i64, *mut c_void) -> f64;
    // SAFETY: the library is benches/peers/bank.c built with -DPEER_LIB;
    // its symbols have the signatures above.
    let (new, run) = unsafe {
        let [new, run] = common::c_symbols(path, ["bank_new", "bank_run"]);
        (
            std::mem::transmute::<*mut c_void, New>(new),
            std::mem::transmute::<*mut c_void, Run>(run),
        )
    };
    const ROWS: usize = 64;
    println!("\nagainst the hand-written C bank (benches/peers/bank.c, f64, AVX-512F), one thread, 41 rounds:");
    println!(
        "{:>8} {:>12} {:>12} {:>14} {:>14} {:>16}",
        "channels", "mfcbeam ns", "C ns", "mfcbeam / C", "10-90 %", "C of the bound"
    );
    for channels in [8usize, 64, 1024, 4096] {
        let rows = bank_rows::<f64>(channels, ROWS);
        let flat: Vec<f64> = rows.iter().flatten().copied().collect();
        let mut bank = nominal_bank::<f64>(channels);
        let mut out = vec![Compensated::<f64>::default(); channels];
        let mut c_out = vec![Compensated::<f64>::default(); channels];
        // SAFETY: bank_new returns a bank of `channels` channels or null.
        let c_bank = unsafe { new(channels as i64) };
        assert!(!c_bank.is_null(), "the C bank refused {channels} channels");
        let steps = (2_000_000 / (channels * 8)).clamp(20, 200_000);
        let (mut k, mut c_k) = (0usize, 0i64);
        let mut ours = |bank: &mut CompensatorBank<f64>, out: &mut [Compensated<f64>]| {
            let t0 = Instant::now();
            for _ in 0..steps {
                k = (k + 1) % ROWS;
                bank.compensate(black_box(&rows[k]), out).unwrap();
            }
            t0.elapsed().as_nanos() as f64 / steps as f64
        };
        let mut theirs = |out: &mut [Compensated<f64>]| {
            let t0 = Instant::now();
            // SAFETY: `flat` holds ROWS rows of `channels` targets, `out`
            // `channels` entries of the C bank's (and Compensated's) layout.
            unsafe {
                run(
                    c_bank,
                    flat.as_ptr(),
                    ROWS as i64,
                    &mut c_k,
                    steps as i64,
                    out.as_mut_ptr().cast(),
                )
            };
            t0.elapsed().as_nanos() as f64 / steps as f64
        };
        for _ in 0..5 {
            ours(&mut bank, &mut out);
            theirs(&mut c_out);
        }
        let same = out.iter().zip(&c_out).all(|(a, b)| {
            (a.u.to_bits(), a.saturated, a.fault) == (b.u.to_bits(), b.saturated, b.fault)
        });
        assert!(
            same,
            "the C bank's voltages differ from mfcbeam's at {channels} channels"
        );
        let (mut mine, mut c, mut ratio) = (Vec::new(), Vec::new(), Vec::new());
        for round in 0..41 {
            let (a, b) = if round % 2 == 0 {
                let a = ours(&mut bank, &mut out);
                (a, theirs(&mut c_out))
            } else {
                let b = theirs(&mut c_out);
                (ours(&mut bank, &mut out), b)
            };
            mine.push(a);
            c.push(b);
            ratio.push(a / b);
        }
        for v in [&mut mine, &mut c, &mut ratio] {
            v.sort_by(f64::total_cmp);
        }
        let c_rate = channels as f64 / c[20] * 1e3;
        println!(
            "{channels:>8} {:>12.1} {:>12.1} {:>14.3} {:>7.3}-{:<6.3} {:>15.0} %   ({:.1} and {:.1} M channel-steps/s, {:.1} and {:.1} cycles per channel-step)",
            mine[20],
            c[20],
            ratio[20],
            ratio[4],
            ratio[36],
            100.0 * c_rate / bound,
            channels as f64 / mine[20] * 1e3,
            c_rate,
            mine[20] * ghz / channels as f64,
            c[20] * ghz / channels as f64,
        );
    }
}

fn main() {
    if std::env::args().any(|a| a == "--list") {
        return; // nothing for `cargo test --benches` to list
    }
    let (ghz, how) = clock_ghz();
    println!(
        "CPU: {}, {ghz:.2} GHz ({how}); kernels: {}",
        mfcbeam::internals::cpu_description(),
        Kernels::detect().name()
    );
    // every row runs on a thread of a pool of two, the one-thread rows on
    // one of them, so that a split step hands its part to the pool's other
    // thread as a control loop run in `install` would
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .expect("a pool of two threads");
    let bound = pool.install(|| {
        let bound = report::<f64>(ghz);
        report::<f32>(ghz);
        bound
    });
    let figures = FIGURES.lock().map(|f| f.clone()).unwrap_or_default();
    let figures: Vec<common::results::Figure> = figures
        .into_iter()
        .map(|(name, unit, value)| common::results::Figure {
            name,
            unit,
            values: vec![value],
        })
        .collect();
    common::results::record("bank_limit", &figures);
    match std::env::var("MFCBEAM_C_BANK") {
        #[cfg(target_os = "linux")]
        Ok(path) => against_c_bank(&path, ghz, bound),
        _ => println!(
            "\nMFCBEAM_C_BANK is not set: no C bank to compare (benches/peers/run.sh builds one)"
        ),
    }
}
