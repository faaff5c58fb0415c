//! The compensator step as its chain is written (`realtime::compensator_step`):
//! every kernel set gives the portable bits at every order (the vector
//! kernels keep up to 32 or 64 plays in registers and pad the last register;
//! beyond, they fall back), the running creep output stays within its
//! derived rounding bound of the output summed from the state, and a
//! snapshot carries the running output, so a resumed compensator continues
//! bit for bit.

use mfcbeam::operators::traits::Snapshot;
use mfcbeam::realtime::{simd, Compensator, CompensatorSettings, Real, RESUM};
use mfcbeam::suite::conformance::{random_model, ModelShape, Rng};

type Heap = mfcbeam::operators::heap::Heap;

/// A walk of targets over most of the range, some beyond it (clipped
/// samples), some not finite (held samples).
fn targets(rng: &mut Rng, len: usize, reach: f64) -> Vec<f64> {
    let mut y = 0.0f64;
    (0..len)
        .map(|_| {
            if rng.chance(0.01) {
                return [f64::NAN, f64::INFINITY][rng.int(0, 1)];
            }
            y = (y + rng.uniform(-0.08, 0.08) * reach).clamp(-1.3 * reach, 1.3 * reach);
            y
        })
        .collect()
}

fn bits<T: Real>(c: mfcbeam::realtime::Compensated<T>) -> (u64, bool, bool) {
    (c.u.to_f64().to_bits(), c.saturated, c.fault)
}

/// Orders up to 48 plays and 48 × 6 creep operators: whole registers,
/// partial ones, the padding of the sums, more plays than the registers
/// keep; in `f64` and `f32`, every step compared bit for bit.
#[test]
fn every_kernel_set_gives_the_portable_bits_at_every_order() {
    eprintln!("CPU: {}", simd::cpu_description());
    let kernels: Vec<_> = simd::Kernels::all().collect();
    eprintln!("kernel sets: {kernels:?}");
    let mut rng = Rng::new(35);
    for case in 0..60 {
        let max_plays = [4, 12, 20, 48][case % 4];
        let file = random_model(&mut rng, max_plays, ModelShape::Any);
        let p = file.parameters();
        let settings = CompensatorSettings::with_limits(-600.0, 600.0);
        let portable = Compensator::<f64, Heap>::new(&p, settings).unwrap();
        let portable32 = Compensator::<f32, Heap>::new(&p, settings).unwrap();
        let mut runs: Vec<_> = kernels
            .iter()
            .map(|&k| (k, portable.clone(), portable32.clone()))
            .collect();
        let (mut portable, mut portable32) = (portable, portable32);
        for (k_step, t) in targets(&mut rng, 3 * RESUM as usize + 7, 500.0)
            .into_iter()
            .enumerate()
        {
            let expected = bits(portable.compensate_portable(t));
            let expected32 = bits(portable32.compensate_portable(t as f32));
            for (k, c, c32) in &mut runs {
                let what = || {
                    format!(
                        "case {case}, step {k_step}, {k:?}, plays {}",
                        p.hysteresis.thresholds.len()
                    )
                };
                assert_eq!(bits(c.compensate_using(*k, t)), expected, "{}", what());
                assert_eq!(
                    bits(c32.compensate_using(*k, t as f32)),
                    expected32,
                    "{} (f32)",
                    what()
                );
            }
        }
    }
}

/// The running creep output `C_k = B + Δ` against the output summed from
/// the state, in `f64` (for `f32` compensators) and with compensated
/// summation (for `f64`). The bound (docs/MATHEMATICS.md §4.4): one step
/// adds at most `u [(N + 4) Σ_e |q_e d_e| + Σ_e (w_i/m)|χ_e| + |C|]`
/// (`u = ε/2`, `N` elementary operators), each term at most
/// `u X [2(N + 4) Σ|q| + 2 Σ_i |w_i|]` with `X ≥ max |χ|, |u|`; the error
/// of a re-sum is the model's own, and at most `RESUM` steps add up.
#[test]
fn the_running_creep_output_stays_within_its_bound() {
    fn check<T: Real>(eps: f64) {
        let mut rng = Rng::new(2011);
        let mut worst = 0.0f64;
        for case in 0..30 {
            let file = random_model(&mut rng, 14, ModelShape::Virgin);
            let Some(creep) = &file.creep else {
                continue;
            };
            let p = file.parameters();
            let settings = CompensatorSettings::with_limits(-800.0, 800.0);
            let mut c = Compensator::<T, Heap>::new(&p, settings).unwrap();
            let m = creep.eigenvalues.len() as f64;
            let n_ops = (creep.thresholds.len() * creep.eigenvalues.len()) as f64;
            let sum_w: f64 = creep.weights.iter().map(|w| w.abs()).sum();
            let sum_q: f64 = creep
                .weights
                .iter()
                .map(|w| {
                    creep
                        .eigenvalues
                        .iter()
                        .map(|&a| w.abs() / m * -(-a * file.sample_time).exp_m1())
                        .sum::<f64>()
                })
                .sum();
            let x_max = 800.0 + creep.thresholds.last().unwrap();
            let per_step = eps / 2.0 * x_max * (2.0 * (n_ops + 4.0) * sum_q + 2.0 * sum_w);
            // the re-sum's own rounding (the model's sum, n_ops terms)
            let resum = eps * n_ops * sum_w * x_max;
            let bound = f64::from(RESUM) * per_step + resum;
            for t in targets(&mut rng, 5 * RESUM as usize, 500.0) {
                c.compensate(T::from_f64(t));
                let state = c.state();
                let running = c.running_creep_state().unwrap();
                let rows = state.creep.unwrap();
                // Σ_i (w_i/m) Σ_j χ_ij, compensated (Neumaier)
                let (mut s, mut comp) = (0.0f64, 0.0f64);
                for (i, row) in rows.iter().enumerate() {
                    let w = T::from_f64(creep.weights[i] / m).to_f64();
                    for &x in row {
                        let term = w * x;
                        let t = s + term;
                        comp += if s.abs() >= term.abs() {
                            (s - t) + term
                        } else {
                            (term - t) + s
                        };
                        s = t;
                    }
                }
                let exact = s + comp;
                let err = (running.base + running.delta - exact).abs();
                worst = worst.max(err / bound);
                assert!(
                    err <= bound,
                    "{} case {case}: running {} vs summed {exact}: {err:e} > bound {bound:e}",
                    T::NAME,
                    running.base + running.delta
                );
            }
        }
        eprintln!(
            "{}: worst running-sum error {worst:.2e} of its bound",
            T::NAME
        );
    }
    check::<f64>(f64::EPSILON);
    check::<f32>(f32::EPSILON as f64);
}

/// A snapshot carries the running output: a compensator restored from it
/// continues bit for bit across re-sums; without it (a model file's state)
/// the output is summed from the state and continues within rounding.
#[test]
fn a_snapshot_resumes_the_running_output_bit_for_bit() {
    let mut rng = Rng::new(99);
    for _ in 0..20 {
        let file = random_model(&mut rng, 12, ModelShape::Virgin);
        if file.creep.is_none() {
            continue;
        }
        let p = file.parameters();
        let settings = CompensatorSettings::with_limits(-800.0, 800.0);
        let mut whole = Compensator::<f64, Heap>::new(&p, settings).unwrap();
        let signal = targets(&mut rng, 4 * RESUM as usize, 400.0);
        let split = rng.int(1, signal.len() - 1);
        let mut first = whole.clone();
        for &t in &signal[..split] {
            first.compensate(t);
        }
        let mut resumed = Compensator::<f64, Heap>::new(&p, settings).unwrap();
        resumed.set_state(&first.state()).unwrap();
        let expected: Vec<_> = signal.iter().map(|&t| bits(whole.compensate(t))).collect();
        for (k, &t) in signal.iter().enumerate().skip(split) {
            assert_eq!(bits(resumed.compensate(t)), expected[k], "step {k}");
        }
    }
}
