//! The closed loop's real-time cost: one step of each built-in feedback
//! design (what a controller adds to the compensator's step within the
//! 0.2 ms sample), and one whole run of the Fig. 14 loop (20 001 samples of
//! controller, compensator, `W` and the 15-mode beam) per design.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use mfcbeam::control::{run_loop, Benchmark, BuiltinController, Controller, LoopSample};

fn control(c: &mut Criterion) {
    let bench = Benchmark::nominal().unwrap();
    let setup = bench.setup("noise").unwrap();
    let mut g = c.benchmark_group("control");
    for kind in [BuiltinController::Pid, BuiltinController::StateFeedback] {
        let mut controller = bench.controller_file(kind).unwrap().build().unwrap();
        let mut k = 0usize;
        g.bench_function(format!("{}_step", kind.id()), |b| {
            b.iter(|| {
                k = (k + 1) % setup.reference.len();
                let s = LoopSample {
                    k,
                    t: k as f64 * setup.sample_time,
                    reference: setup.reference[k],
                    measurement: setup.reference[k] + setup.noise[k],
                };
                controller.step(black_box(&s)).unwrap()
            })
        });
    }
    g.sample_size(20);
    for kind in BuiltinController::ALL {
        g.bench_function(format!("{}_loop_fig14_20001_samples", kind.id()), |b| {
            b.iter(|| {
                let mut controller = bench.controller(kind).unwrap();
                run_loop(black_box(&setup), controller.as_mut()).unwrap()
            })
        });
    }
    g.finish();
}

criterion_group!(benches, control);
criterion_main!(benches);
