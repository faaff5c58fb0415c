//! A bank of compensators (`operators::bank::CompensatorBank`) at the paper's order:
//! one step of 1, 8, 64, 1024 and 4096 channels sharing the nominal model, in
//! `f64` and `f32`. Throughput is in channel-steps per second.

use std::hint::black_box;

mod common;

use common::{bank_rows, nominal_bank};
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use mfcbeam::realtime::{Compensated, Real};

const ROWS: usize = 64;

fn bank<T: Real>(c: &mut Criterion) {
    let mut g = c.benchmark_group(format!("bank_{}", T::NAME));
    for channels in [1usize, 8, 64, 1024, 4096] {
        let rows = bank_rows::<T>(channels, ROWS);
        let mut bank = nominal_bank::<T>(channels);
        let mut out = vec![Compensated::<T>::default(); channels];
        g.throughput(Throughput::Elements(channels as u64));
        let mut k = 0usize;
        g.bench_function(BenchmarkId::from_parameter(channels), |b| {
            b.iter(|| {
                k = (k + 1) % ROWS;
                bank.compensate(black_box(&rows[k]), &mut out).unwrap();
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bank::<f64>, bank::<f32>);
criterion_main!(benches);
