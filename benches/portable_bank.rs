//! The bank on the portable kernels, the set a CPU without x86 vector units
//! runs (64-bit ARM, an x86-64 without AVX2), against what a user without
//! the bank would do: a loop of single compensators on the same kernels.
//! And against the dispatched set on this CPU, for scale.
//!
//! At 64 and 1024 channels, `f64` and `f32`: the three run in alternating
//! batches of steps (about 20 ms each) on the same targets, for seven
//! rounds; printed is each one's median rate in channel-steps per second
//! and, per round, the bank's rate over the loop's and over the dispatched
//! set's (median and range). With `MFCBEAM_RESULTS` the two ratios'
//! medians are written as data (`benches/common/results.rs`).
//!
//! On x86-64 the portable kernels are compiled without FMA: a single
//! compensator's fused multiply-adds (about 144 a step at the paper's
//! order) are each a call to an `fma` routine, while the bank's, where the
//! CPU has FMA, are the instruction on the 128-bit registers its blocks'
//! other operations use (SSE2). On 64-bit ARM FMA is an instruction and
//! the bank's lanes are NEON vectors
//! (`verification/platforms/neon_bank.sh`). Timing under an emulator says
//! nothing about the hardware it emulates: run this on the CPU whose
//! figures you want.
//!
//! `cargo bench --features internals --bench portable_bank`

use std::hint::black_box;
use std::time::Instant;

mod common;

use common::results::{record, Figure};
use common::{bank_rows, nominal_bank};
use mfcbeam::internals::Kernels;
use mfcbeam::realtime::nominal::{Capacity, PARAMETERS};
use mfcbeam::realtime::{Compensated, Compensator, CompensatorSettings, Real};

const ROWS: usize = 64;
const ROUNDS: usize = 7;

/// Seconds per channel-step of `step` (one step of every channel), timed
/// over enough steps to last about `seconds`.
fn rate(channels: usize, seconds: f64, mut step: impl FnMut(usize)) -> f64 {
    // calibrate on a few steps, then time the batch
    let start = Instant::now();
    let mut steps = 0;
    while start.elapsed().as_secs_f64() < 0.002 {
        step(steps);
        steps += 1;
    }
    let per_step = start.elapsed().as_secs_f64() / steps as f64;
    let batch = ((seconds / per_step) as usize).max(1);
    let start = Instant::now();
    for k in 0..batch {
        step(k);
    }
    (batch * channels) as f64 / start.elapsed().as_secs_f64()
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn run<T: Real>(channels: usize, figures: &mut Vec<Figure>) {
    let rows = bank_rows::<T>(channels, ROWS);
    let mut portable = nominal_bank::<T>(channels);
    let mut dispatched = nominal_bank::<T>(channels);
    let settings = CompensatorSettings::with_limits(-1000.0, 1000.0);
    let checked = PARAMETERS.validate().unwrap();
    let mut singles: Vec<Compensator<T, Capacity>> = (0..channels)
        .map(|_| Compensator::new(&checked, settings).unwrap())
        .collect();
    let mut out = vec![Compensated::<T>::default(); channels];
    let (mut bank, mut loop_, mut best) = (Vec::new(), Vec::new(), Vec::new());
    for _ in 0..ROUNDS {
        bank.push(rate(channels, 0.02, |k| {
            portable
                .compensate_using(Kernels::Portable, black_box(&rows[k % ROWS]), &mut out)
                .unwrap();
            black_box(&out);
        }));
        loop_.push(rate(channels, 0.02, |k| {
            for ((c, &t), o) in singles.iter_mut().zip(&rows[k % ROWS]).zip(&mut out) {
                *o = c.compensate_using(Kernels::Portable, black_box(t));
            }
            black_box(&out);
        }));
        best.push(rate(channels, 0.02, |k| {
            dispatched
                .compensate(black_box(&rows[k % ROWS]), &mut out)
                .unwrap();
            black_box(&out);
        }));
    }
    let over = |a: &[f64], b: &[f64]| -> Vec<f64> { a.iter().zip(b).map(|(x, y)| x / y).collect() };
    let (vs_loop, vs_best) = (over(&bank, &loop_), over(&bank, &best));
    let range = |v: &[f64]| {
        let (lo, hi) = v
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(a, b), &x| (a.min(x), b.max(x)));
        format!("{lo:.2}–{hi:.2}")
    };
    println!(
        "{:>4} {:>5} ch: portable bank {:>7.2} M/s, loop of portable compensators {:>7.2} M/s, dispatched bank ({}) {:>7.2} M/s; bank/loop {:.2} ({}), bank/dispatched {:.3} ({})",
        T::NAME,
        channels,
        median(bank.clone()) / 1e6,
        median(loop_.clone()) / 1e6,
        Kernels::detect().name(),
        median(best.clone()) / 1e6,
        median(vs_loop.clone()),
        range(&vs_loop),
        median(vs_best.clone()),
        range(&vs_best),
    );
    // a run's figure: the median over its rounds (three runs, their spread)
    for (what, values) in [("over_loop", vs_loop), ("over_dispatched", vs_best)] {
        figures.push(Figure {
            name: format!("portable_bank_{}_{channels}_{what}", T::NAME),
            unit: "ratio",
            values: vec![median(values)],
        });
    }
}

fn main() {
    // `cargo bench` passes `--bench`; a filter or `--test` runs nothing
    if std::env::args().any(|a| a == "--test") {
        return;
    }
    println!("{}", mfcbeam::internals::cpu_description());
    let mut figures = Vec::new();
    for channels in [64, 1024] {
        run::<f64>(channels, &mut figures);
        run::<f32>(channels, &mut figures);
    }
    record("portable_bank", &figures);
}
