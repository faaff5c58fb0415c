//! Real-time budget checks: one step of H, C, W (also with a dead time) and
//! the compensator at the paper's order (12 plays; 12 thresholds × 5 creep
//! eigenvalues), and a whole
//! 90 s trace at 5 kHz (450 000 samples). The board's budget is Ts = 0.2 ms.

use std::hint::black_box;

mod common;

use common::test_input;
use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use mfcbeam::internals::Kernels;
use mfcbeam::prelude::*;

fn single_steps(c: &mut Criterion) {
    const LEN: usize = 4096;
    let input = test_input(LEN);
    let model = nominal_model();
    let mut g = c.benchmark_group("step");

    let mut h = model.hysteresis().clone();
    let mut k = 0usize;
    g.bench_function("hysteresis_step", |b| {
        b.iter(|| {
            k = (k + 1) & (LEN - 1);
            h.step(black_box(input[k]))
        })
    });

    let mut cr = model.creep().unwrap().clone();
    g.bench_function("creep_step", |b| {
        b.iter(|| {
            k = (k + 1) & (LEN - 1);
            cr.step(black_box(input[k]))
        })
    });

    let mut w = model.clone();
    g.bench_function("model_w_step", |b| {
        b.iter(|| {
            k = (k + 1) & (LEN - 1);
            w.step(black_box(input[k]))
        })
    });

    // the same model with a dead time of 3 samples: what the ring buffer costs
    let mut w = model.clone().with_delay(3).unwrap();
    g.bench_function("model_w_step_delayed", |b| {
        b.iter(|| {
            k = (k + 1) & (LEN - 1);
            w.step(black_box(input[k]))
        })
    });

    // Targets the compensator can reach: W of the test input.
    let targets = nominal_model().run(&input);
    let mut comp = model.compensator(CompensatorSettings::default()).unwrap();
    g.bench_function("compensator_step", |b| {
        b.iter(|| {
            k = (k + 1) & (LEN - 1);
            comp.compensate(black_box(targets[k]))
        })
    });
    // the same step on each kernel set this CPU has (portable: without
    // run-time dispatch), named by the set
    for kernels in Kernels::all() {
        let mut comp = model.compensator(CompensatorSettings::default()).unwrap();
        let name = format!("compensator_step_{}", kernels.name());
        g.bench_function(name.as_str(), |b| {
            b.iter(|| {
                k = (k + 1) & (LEN - 1);
                comp.compensate_using(kernels, black_box(targets[k]))
            })
        });
    }
    g.finish();
}

fn whole_trace(c: &mut Criterion) {
    const LEN: usize = 450_000; // 90 s at 5 kHz
    let input = test_input(LEN);
    let targets = nominal_model().run(&input);
    let model = nominal_model();
    let mut g = c.benchmark_group("trace_90s");
    g.throughput(Throughput::Elements(LEN as u64));
    g.sample_size(20);
    let mut out = vec![0.0; LEN];
    g.bench_function("model_w_trace", |b| {
        b.iter(|| {
            let mut w = model.clone();
            w.run_into(black_box(&input), &mut out).unwrap();
        })
    });
    let mut u = vec![0.0; LEN];
    let mut sat = vec![false; LEN];
    let mut fault = vec![false; LEN];
    g.bench_function("compensator_trace", |b| {
        b.iter(|| {
            let mut comp = model.compensator(CompensatorSettings::default()).unwrap();
            comp.compensate_into(black_box(&targets), &mut u, &mut sat, &mut fault)
                .unwrap()
        })
    });
    g.finish();
}

criterion_group!(benches, single_steps, whole_trace);
criterion_main!(benches);
