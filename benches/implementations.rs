//! Every implementation of a kind, timed through the same trait object on the
//! same input: the project's fast operators, the naive references of
//! `mfcbeam::suite::reference`, and for the compensator a numerical inverse
//! (bisection on `W` every sample, the way a hysteresis model without an
//! analytic inverse must be inverted) — the contrast the paper draws for the
//! analytic PI inverse (22). The real-time core's fixed-capacity operators
//! (`Compensator`, `Model` in `nominal::Capacity`) in f64 and f32 beside them. Nominal
//! model, paper's order.

use std::hint::black_box;

mod common;

use common::test_input;
use criterion::{criterion_group, criterion_main, Criterion};
use mfcbeam::operators::nominal::nominal_model_file;
use mfcbeam::prelude::*;
use mfcbeam::realtime::nominal;
use mfcbeam::suite::conformance::{
    bisection_compensator, heap_compensator, heap_inverse_hysteresis, heap_model,
    inline_compensator, inline_model, reference_compensator, reference_inverse_hysteresis,
    reference_model, CompensatorFactory, InverseHysteresisFactory, ModelFactory,
};

const N: usize = nominal::PLAYS;
const K: usize = nominal::CREEP;

const LEN: usize = 4096;

fn models(c: &mut Criterion) {
    let input = test_input(LEN);
    let file = nominal_model_file();
    let mut g = c.benchmark_group("model_w_step");
    let candidates: [(&str, &ModelFactory); 4] = [
        ("fast", &heap_model),
        ("fixed_f64", &inline_model::<f64, N, K>),
        ("fixed_f32", &inline_model::<f32, N, K>),
        ("naive_reference", &reference_model),
    ];
    for (name, factory) in candidates {
        let mut w = factory(&file).unwrap();
        let w: &mut dyn ActuatorModel = w.as_mut();
        let mut k = 0usize;
        g.bench_function(name, |b| {
            b.iter(|| {
                k = (k + 1) & (LEN - 1);
                w.step(black_box(input[k]))
            })
        });
    }
    g.finish();
}

fn compensators(c: &mut Criterion) {
    let file = nominal_model_file();
    // reachable targets: W of the test input
    let targets = heap_model(&file).unwrap().run(&test_input(LEN));
    let mut g = c.benchmark_group("compensator_step");
    let candidates: [(&str, &CompensatorFactory); 5] = [
        ("fast", &heap_compensator),
        ("fixed_f64", &inline_compensator::<f64, N, K>),
        ("fixed_f32", &inline_compensator::<f32, N, K>),
        ("naive_reference", &reference_compensator),
        ("bisection", &bisection_compensator),
    ];
    for (name, factory) in candidates {
        let mut comp = factory(&file, CompensatorSettings::default()).unwrap();
        let comp: &mut dyn ActuatorCompensator = comp.as_mut();
        let mut k = 0usize;
        g.bench_function(name, |b| {
            b.iter(|| {
                k = (k + 1) & (LEN - 1);
                comp.compensate(black_box(targets[k]))
            })
        });
    }
    g.finish();
}

fn inverse_hysteresis(c: &mut Criterion) {
    let file = nominal_model_file();
    let mut h = file.clone();
    h.creep = None;
    let targets = heap_model(&h).unwrap().run(&test_input(LEN));
    let mut g = c.benchmark_group("inverse_hysteresis_step");
    let candidates: [(&str, &InverseHysteresisFactory); 2] = [
        ("fast", &heap_inverse_hysteresis),
        ("naive_reference", &reference_inverse_hysteresis),
    ];
    for (name, factory) in candidates {
        let mut inv = factory(&file).unwrap();
        let inv: &mut dyn InverseHysteresis = inv.as_mut();
        let mut k = 0usize;
        g.bench_function(name, |b| {
            b.iter(|| {
                k = (k + 1) & (LEN - 1);
                inv.step(black_box(targets[k]))
            })
        });
    }
    g.finish();
}

criterion_group!(benches, models, compensators, inverse_hysteresis);
criterion_main!(benches);
