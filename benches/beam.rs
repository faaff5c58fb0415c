//! Beam model budget checks: building the `modal` model (240 cubic-Hermite
//! elements, reduced to 15 modes) and the `ritz` model (n = 15), one exact-ZOH
//! simulation step, and a 10 s step response at 5 kHz (50 000 samples).

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use mfcbeam::beam::fe::FiniteElementModel;
use mfcbeam::beam::ritz::RitzModel;
use mfcbeam::beam::simulation::DiscreteBeam;
use mfcbeam::beam::BeamParameters;

fn beam(c: &mut Criterion) {
    let b = BeamParameters::nominal();
    let mut g = c.benchmark_group("beam");
    g.sample_size(20);
    g.bench_function("build_modal_240_elements_15_modes", |bch| {
        bch.iter(|| {
            FiniteElementModel::new(black_box(&b), 240)
                .unwrap()
                .modal(15)
                .unwrap()
        })
    });
    g.bench_function("build_ritz_15", |bch| {
        bch.iter(|| RitzModel::new(black_box(&b), 15).unwrap().modal().unwrap())
    });
    let modal = FiniteElementModel::new(&b, 240).unwrap().modal(15).unwrap();
    g.bench_function("discretize_zoh_15_modes", |bch| {
        bch.iter(|| DiscreteBeam::new(black_box(&modal), 2e-4).unwrap())
    });
    let mut d = DiscreteBeam::new(&modal, 2e-4).unwrap();
    let mut k = 0u32;
    g.bench_function("simulation_step", |bch| {
        bch.iter(|| {
            k = k.wrapping_add(1);
            d.step(black_box(if k & 1024 == 0 { 1.0 } else { 0.0 }))
        })
    });
    let u: Vec<f64> = (0..50_000)
        .map(|k| if k < 500 { 0.0 } else { 1.0 })
        .collect();
    g.bench_function("step_response_10s_50000_samples", |bch| {
        bch.iter(|| d.simulate(black_box(&u)))
    });
    g.finish();
}

criterion_group!(benches, beam);
criterion_main!(benches);
