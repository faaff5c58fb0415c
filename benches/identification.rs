//! Identification of 40 s at 5 kHz (200 001 samples) at the paper's orders
//! (12 plays, 12 log(t)-creep operators, 5 eigenvalues), end to end with the
//! defaults (fit from where |u| reaches max|u|, offset fitted): the
//! regressor streamed through a chunked QR, the active-set solve, and the
//! final fit of the identified model.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use mfcbeam::identification::{identify, IdentificationSettings};
use mfcbeam::prelude::*;
use mfcbeam::suite::signal::Staircase;

fn identification(c: &mut Criterion) {
    let u = Staircase::shrinking_loops(1000.0, 4, 3, 0.1, 40.0 / 48.0 - 0.1).sample(2e-4);
    let y = nominal_model().run(&u);
    let settings = IdentificationSettings::default();
    let mut g = c.benchmark_group("identification");
    g.sample_size(20);
    g.bench_function("identify_40s_5khz_paper_orders", |b| {
        b.iter(|| identify(black_box(&u), black_box(&y), 2e-4, &settings).unwrap())
    });
    g.finish();
}

criterion_group!(benches, identification);
criterion_main!(benches);
