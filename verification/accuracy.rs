//! Every fast implementation against a naive "control" implementation written
//! straight from the paper's formulas (as RustFFT's `tests/accuracy.rs` does),
//! on seeded random models and signals of several sizes.
//!
//! The control implementations use `f64::max`/`f64::min`, sequential sums in
//! the paper's order, the direct O(n²) sums of (22) and a nested
//! threshold-then-eigenvalue creep loop; they share no code with the library
//! beyond the parameter accessors.

mod common;

use common::*;
use mfcbeam::prelude::*;

/// (10) with (20), textbook form.
struct NaivePi {
    r: Vec<f64>,
    w: Vec<f64>,
    x: Vec<f64>,
}

impl NaivePi {
    fn step(&mut self, v: f64) -> f64 {
        let mut y = 0.0;
        for i in 0..self.r.len() {
            self.x[i] = (v - self.r[i]).max((v + self.r[i]).min(self.x[i]));
            y += self.w[i] * self.x[i];
        }
        y
    }

    /// (22) by its direct sums.
    fn inverse(&self) -> NaivePi {
        let n = self.r.len();
        let s = |j: usize| (0..=j).map(|i| self.w[i]).sum::<f64>();
        let r = (0..n)
            .map(|j| (0..=j).map(|i| self.w[i] * (self.r[j] - self.r[i])).sum())
            .collect();
        let w = (0..n)
            .map(|j| {
                if j == 0 {
                    1.0 / self.w[0]
                } else {
                    -self.w[j] / (s(j) * s(j - 1))
                }
            })
            .collect();
        let x = (0..n)
            .map(|j| s(j) * self.x[j] + (j + 1..n).map(|i| self.w[i] * self.x[i]).sum::<f64>())
            .collect();
        NaivePi { r, w, x }
    }
}

/// (16) with (15) and (20), textbook form.
struct NaiveCreep {
    r: Vec<f64>,
    w: Vec<f64>,
    a: Vec<f64>,
    ts: f64,
    chi: Vec<Vec<f64>>,
}

impl NaiveCreep {
    fn output(&self) -> f64 {
        let m = self.a.len() as f64;
        (0..self.r.len())
            .map(|i| self.w[i] * self.chi[i].iter().sum::<f64>() / m)
            .sum()
    }

    fn advance(&mut self, v: f64) {
        for i in 0..self.r.len() {
            for j in 0..self.a.len() {
                let z = v - self.chi[i][j];
                let d = (z - self.r[i]).max((z + self.r[i]).min(0.0));
                self.chi[i][j] += -(-self.a[j] * self.ts).exp_m1() * d;
            }
        }
    }
}

fn random_model(rng: &mut Lcg, plays: usize, m: usize) -> HysteresisCreepModel {
    let inc: Vec<f64> = (1..plays).map(|_| rng.uniform(10.0, 150.0)).collect();
    let sums: Vec<f64> = (0..plays).map(|_| rng.uniform(0.05, 1.0)).collect();
    let h = HysteresisOperator::new(
        thresholds_from_increments(&inc),
        weights_from_partial_sums(&sums),
    )
    .unwrap();
    let csums: Vec<f64> = (0..plays).map(|_| rng.uniform(0.0, 0.1)).collect();
    let a: Vec<f64> = (0..m).map(|_| 10f64.powf(rng.uniform(-2.0, 3.0))).collect();
    let c = CreepOperator::new(
        thresholds_from_increments(&inc),
        weights_from_partial_sums(&csums),
        a,
        2e-4,
    )
    .unwrap();
    HysteresisCreepModel::new(2e-4, h, Some(c)).unwrap()
}

fn random_walk(rng: &mut Lcg, len: usize, amplitude: f64) -> Vec<f64> {
    let mut v = 0.0f64;
    (0..len)
        .map(|_| {
            v = (v + rng.uniform(-0.05, 0.05) * amplitude).clamp(-amplitude, amplitude);
            v
        })
        .collect()
}

fn naive_parts(w: &HysteresisCreepModel) -> (NaivePi, NaiveCreep) {
    let h = w.hysteresis();
    let c = w.creep().unwrap();
    (
        NaivePi {
            r: h.thresholds().to_vec(),
            w: h.weights().to_vec(),
            x: h.play_states().to_vec(),
        },
        NaiveCreep {
            r: c.thresholds().to_vec(),
            w: c.weights().to_vec(),
            a: c.eigenvalues().to_vec(),
            ts: c.sample_time(),
            chi: c.state(),
        },
    )
}

const SIZES: [(usize, usize); 5] = [(1, 1), (2, 3), (5, 2), (12, 5), (20, 7)];

/// `W = H + C` against the control implementation.
#[test]
fn model_matches_naive_control_implementation() {
    let mut rng = Lcg(20110015016);
    for &(plays, m) in &SIZES {
        for _ in 0..4 {
            let mut w = random_model(&mut rng, plays, m);
            let (mut h, mut c) = naive_parts(&w);
            let v = random_walk(&mut rng, 5000, 1200.0);
            let tol = {
                let n = (plays * (m + 1)) as f64;
                let wsum: f64 = w
                    .hysteresis()
                    .weights()
                    .iter()
                    .chain(w.creep().unwrap().weights())
                    .map(|x| x.abs())
                    .sum();
                8.0 * n * EPS * wsum * 2400.0
            };
            for &vk in &v {
                let fast = w.step(vk);
                let control = h.step(vk) + c.output();
                c.advance(vk);
                assert!(
                    (fast - control).abs() <= tol,
                    "plays {plays}, m {m}: {fast} vs {control}"
                );
            }
        }
    }
}

/// The compensator against a control compensator built from the direct sums
/// of (22) and the naive creep operator.
#[test]
fn compensator_matches_naive_control_implementation() {
    let mut rng = Lcg(0x5eed);
    for &(plays, m) in &SIZES {
        for _ in 0..4 {
            let mut w = random_model(&mut rng, plays, m);
            // a random admissible state first
            w.run(&random_walk(&mut rng, 300, 800.0));
            let (h, mut c) = naive_parts(&w);
            let mut inv = h.inverse();
            let mut comp = Compensator::new(&w, CompensatorSettings::unlimited()).unwrap();
            let targets = random_walk(&mut rng, 5000, 400.0);
            let tol = inverse_rounding(w.hysteresis(), 4000.0, 1000.0);
            for &t in &targets {
                let fast = comp.compensate(t).u;
                let control = inv.step(t - c.output());
                c.advance(control);
                assert!(
                    (fast - control).abs() <= tol,
                    "plays {plays}, m {m}: {fast} vs {control} (tol {tol:e})"
                );
            }
        }
    }
}

/// The inverse's parameters (recursive `r'`) against the direct sums of (22).
#[test]
fn inverse_parameters_match_direct_sums() {
    let mut rng = Lcg(7);
    for &(plays, _) in &SIZES {
        let w = random_model(&mut rng, plays, 1);
        let fast = w.hysteresis().inverse();
        let (h, _) = naive_parts(&w);
        let control = h.inverse();
        let cond = 1.0 / min_slope(w.hysteresis());
        for (a, b) in fast.thresholds().iter().zip(&control.r) {
            assert!((a - b).abs() <= 4.0 * plays as f64 * EPS * b.abs());
        }
        for (a, b) in fast.weights().iter().zip(&control.w) {
            assert!((a - b).abs() <= 4.0 * EPS * b.abs() * cond);
        }
    }
}
