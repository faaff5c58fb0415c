//! Generating the paper's feedforward: 1 mm in 75 ms from 2.9 s, σ = 1.1,
//! 4 s at 5 kHz (20 001 samples), order-30 derivatives, on the `modal` beam
//! (15 modes). The beam model is built once outside the timed loop.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use mfcbeam::beam::fe::FiniteElementModel;
use mfcbeam::beam::BeamParameters;
use mfcbeam::feedforward::{compensate, design, FeedforwardSettings, FlatParametrization};
use mfcbeam::operators::nominal::nominal_model;
use mfcbeam::operators::supply::Supply;

fn feedforward(c: &mut Criterion) {
    let modal = FiniteElementModel::new(&BeamParameters::nominal(), 240)
        .unwrap()
        .modal(15)
        .unwrap();
    let settings = FeedforwardSettings::default();
    let mut g = c.benchmark_group("feedforward");
    g.sample_size(20);
    g.bench_function("paper_feedforward_4s_5khz_order30", |b| {
        b.iter(|| {
            let flat = FlatParametrization::new(black_box(&modal)).unwrap();
            design(&flat, black_box(&settings)).unwrap()
        })
    });
    let flat = FlatParametrization::new(&modal).unwrap();
    let ff = design(&flat, &settings).unwrap();
    let w = nominal_model();
    g.bench_function("paper_feedforward_compensated_4s", |b| {
        b.iter(|| compensate(black_box(&ff.u_d), &w, &Supply::default()).unwrap())
    });
    g.finish();
}

criterion_group!(benches, feedforward);
criterion_main!(benches);
