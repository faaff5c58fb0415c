//! Worst-case latency of one compensator step: the real-time budget check.
//!
//! `cargo bench --features internals --bench latency [-- STEPS]` times 10⁷ single steps of the
//! paper-order compensator (`Compensator<_, nominal::Capacity>`, f64 and f32, and the heap
//! `Compensator`) under adversarial targets and prints the median, the 99.9th
//! percentile and the maximum per step, in ns and as a fraction of the
//! sample time `Ts = 0.2 ms`.
//!
//! Adversarial targets: the sign alternates every sample with magnitudes
//! drawn from [500, 900] V, so the plays of `H⁻¹` switch branch every sample;
//! every 4th target is beyond reach (1200–1500 V), so the compensator
//! saturates and re-seats its inverse plays by (22) and recovers on the next
//! sample; every 13th target is NaN or ±∞ (the hold path). The magnitudes
//! are random, so branch predictors get no pattern to learn.
//!
//! Method: each step is bracketed by `lfence; rdtsc` (x86-64; elsewhere
//! `Instant`), converted to ns with the TSC frequency calibrated against
//! `Instant` over 200 ms. The thread is pinned to the last CPU
//! (`sched_setaffinity`); `MFCBEAM_FIFO=1` asks for `SCHED_FIFO` too (on a
//! stock kernel its RT throttling then adds a 50 ms stop every second).
//! The timer's own cost (median of empty brackets) is reported and not
//! subtracted: the figures are upper bounds.

use std::hint::black_box;
use std::time::Duration;

use mfcbeam::internals as simd;
use mfcbeam::isolation::timer::{calibrate, ticks};
use mfcbeam::prelude::*;
use mfcbeam::realtime::{nominal, Compensated, Compensator, CompensatorSettings, Real};

const TS_NS: f64 = 2e5;

#[cfg(target_os = "linux")]
fn pin() -> String {
    // SAFETY: plain system calls on this thread with initialised arguments.
    unsafe {
        let cpus = libc::sysconf(libc::_SC_NPROCESSORS_ONLN).max(1) as usize;
        let mut set: libc::cpu_set_t = std::mem::zeroed();
        libc::CPU_SET(cpus - 1, &mut set);
        let pinned = libc::sched_setaffinity(0, std::mem::size_of_val(&set), &set) == 0;
        // SCHED_FIFO only on request: under the kernel's default RT
        // throttling (sched_rt_runtime_us = 950000) a spinning FIFO thread is
        // stopped for 50 ms every second, which is all its maximum shows.
        let fifo = if std::env::var_os("MFCBEAM_FIFO").is_some() {
            let param = libc::sched_param {
                sched_priority: libc::sched_get_priority_max(libc::SCHED_FIFO),
            };
            if libc::sched_setscheduler(0, libc::SCHED_FIFO, &param) == 0 {
                "SCHED_FIFO"
            } else {
                "SCHED_FIFO refused, SCHED_OTHER"
            }
        } else {
            "SCHED_OTHER (MFCBEAM_FIFO=1 asks for SCHED_FIFO)"
        };
        format!(
            "pinned to CPU {}: {}; {fifo}",
            cpus - 1,
            if pinned { "yes" } else { "refused" },
        )
    }
}

#[cfg(not(target_os = "linux"))]
fn pin() -> String {
    "not pinned (not Linux)".into()
}

fn adversarial(len: usize) -> Vec<f64> {
    let mut state: u64 = 0x2545_F491_4F6C_DD1D;
    (0..len)
        .map(|k| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let unit = (state >> 11) as f64 / (1u64 << 53) as f64;
            let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
            match (k % 13, k % 4) {
                (12, _) => [f64::NAN, f64::INFINITY, f64::NEG_INFINITY][(state % 3) as usize],
                (_, 3) => sign * (1200.0 + 300.0 * unit),
                _ => sign * (500.0 + 400.0 * unit),
            }
        })
        .collect()
}

struct Summary {
    median: f64,
    p999: f64,
    p99999: f64,
    max: f64,
}

fn summarize(samples: &mut [u64], ns_per_tick: f64) -> Summary {
    samples.sort_unstable();
    let at =
        |q: f64| samples[((samples.len() - 1) as f64 * q).round() as usize] as f64 * ns_per_tick;
    Summary {
        median: at(0.5),
        p999: at(0.999),
        p99999: at(0.99999),
        max: at(1.0),
    }
}

/// Time `steps` calls of `step` on the cycled `targets`.
fn measure(
    steps: usize,
    targets: &[f64],
    samples: &mut [u64],
    mut step: impl FnMut(f64) -> (bool, bool),
) -> (usize, usize) {
    let (mut saturated, mut faults) = (0, 0);
    for (k, s) in samples.iter_mut().enumerate().take(steps) {
        let t = targets[k % targets.len()];
        let t0 = ticks();
        let (sat, fault) = black_box(step(black_box(t)));
        *s = ticks() - t0;
        saturated += usize::from(sat);
        faults += usize::from(fault);
    }
    (saturated, faults)
}

fn fixed<T: Real>(steps: usize, targets: &[f64], samples: &mut [u64]) -> (usize, usize) {
    let mut c = Compensator::<T, nominal::Capacity>::new(
        &nominal::PARAMETERS.validate().unwrap(),
        CompensatorSettings::with_limits(-1000.0, 1000.0),
    )
    .unwrap();
    measure(steps, targets, samples, |t| {
        let Compensated {
            saturated, fault, ..
        } = c.compensate(T::from_f64(t));
        (saturated, fault)
    })
}

fn main() {
    let steps: usize = std::env::args()
        .skip(1)
        .find_map(|a| a.parse().ok())
        .unwrap_or(10_000_000);
    let placement = pin();
    let ns_per_tick = calibrate(Duration::from_millis(200));
    let targets = adversarial(1 << 16);
    let mut samples = vec![0u64; steps];

    let mut empty = vec![0u64; 1_000_000];
    for e in &mut empty {
        let t0 = ticks();
        *e = ticks() - t0;
    }
    let timer = summarize(&mut empty, ns_per_tick);

    println!("latency of one compensator step, {steps} steps each, adversarial targets");
    println!(
        "timer: lfence+rdtsc, {:.3} ns per tick (calibrated against Instant), empty bracket median {:.1} ns (included below); {placement}; AVX2 path: {}",
        ns_per_tick,
        timer.median,
        simd::Kernels::detect().is_avx2()
    );
    println!(
        "{:<28} {:>10} {:>10} {:>11} {:>10} {:>12} {:>10} {:>8}",
        "compensator",
        "median ns",
        "p99.9 ns",
        "p99.999 ns",
        "max ns",
        "max / Ts",
        "saturated",
        "faults"
    );
    let report = |name: &str, (sat, faults): (usize, usize), samples: &mut [u64]| {
        let s = summarize(&mut samples[..steps], ns_per_tick);
        println!(
            "{name:<28} {:>10.1} {:>10.1} {:>11.0} {:>10.0} {:>11.4}% {:>10} {:>8}",
            s.median,
            s.p999,
            s.p99999,
            s.max,
            100.0 * s.max / TS_NS,
            sat,
            faults
        );
    };
    let counts = fixed::<f64>(steps, &targets, &mut samples);
    let f64_summary = summarize(&mut samples[..steps], ns_per_tick);
    report("Compensator<f64, nominal::Capacity>", counts, &mut samples);
    let figure = |name: &str, values| common::results::Figure {
        name: name.to_string(),
        unit: "ns",
        values,
    };
    common::results::record(
        "latency",
        &[
            figure("latency_f64_median_ns", vec![f64_summary.median]),
            figure("latency_f64_p999_ns", vec![f64_summary.p999]),
        ],
    );
    let counts = fixed::<f32>(steps, &targets, &mut samples);
    report("Compensator<f32, nominal::Capacity>", counts, &mut samples);
    let model = nominal_model();
    let mut heap = model.compensator(CompensatorSettings::default()).unwrap();
    let counts = measure(steps, &targets, &mut samples, |t| {
        let c = heap.compensate(t);
        (c.saturated, c.fault)
    });
    report("Compensator (heap, f64)", counts, &mut samples);
}

mod common;
