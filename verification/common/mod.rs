//! Shared generators and tolerances of the verification targets.
//!
//! Randomness is seeded: proptest runs with a fixed RNG seed (and keeps its
//! regression files in `proptest-regressions/`), plain tests use [`Lcg`].
#![allow(dead_code)]

use mfcbeam::prelude::*;
use proptest::prelude::*;
use proptest::test_runner::{Config, FileFailurePersistence, RngSeed};

/// The proptest configuration of every property: fixed seed, `cases` cases,
/// failures persisted to `regressions` (a file under `proptest-regressions/`).
pub fn config(cases: u32, regressions: &'static str) -> Config {
    Config {
        cases,
        rng_seed: RngSeed::Fixed(0x6d66_6362_6561_6d00),
        failure_persistence: Some(Box::new(FileFailurePersistence::Direct(regressions))),
        ..Config::default()
    }
}

/// Machine epsilon.
pub const EPS: f64 = f64::EPSILON;

/// A small seeded generator for plain tests (Knuth's MMIX LCG, top bits).
pub struct Lcg(pub u64);

impl Lcg {
    /// Uniform in [0, 1).
    pub fn next_f64(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in [lo, hi).
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next_f64()
    }
}

/// Gaussian noise of standard deviation `sigma` from the seeded LCG
/// (Box–Muller).
pub fn gaussian(rng: &mut Lcg, len: usize, sigma: f64) -> Vec<f64> {
    (0..len)
        .map(|_| {
            let (a, b) = (rng.next_f64().max(1e-300), rng.next_f64());
            sigma * (-2.0 * a.ln()).sqrt() * (2.0 * std::f64::consts::PI * b).cos()
        })
        .collect()
}

/// Thresholds `0 = r_0 < r_1 < …` from positive increments.
pub fn thresholds_from_increments(inc: &[f64]) -> Vec<f64> {
    let mut r = vec![0.0];
    for &d in inc {
        let last = *r.last().unwrap();
        r.push(last + d);
    }
    r
}

/// Weights whose partial sums are the given positive numbers: `w_0 = s_0`,
/// `w_j = s_j − s_{j−1}` (negative wherever the sums decrease).
pub fn weights_from_partial_sums(sums: &[f64]) -> Vec<f64> {
    let mut prev = 0.0;
    sums.iter()
        .map(|&s| {
            let w = s - prev;
            prev = s;
            w
        })
        .collect()
}

/// A random admissible PI hysteresis operator with 1..=max_plays plays in the
/// virgin state: threshold increments in [0.05, 1], partial sums in [0.05, 2]
/// (so single weights are often negative, but (11) holds).
pub fn hysteresis_operator(max_plays: usize) -> impl Strategy<Value = HysteresisOperator> {
    (1..=max_plays).prop_flat_map(|n| {
        (
            prop::collection::vec(0.05f64..1.0, n - 1),
            prop::collection::vec(0.05f64..2.0, n),
        )
            .prop_map(|(inc, sums)| {
                HysteresisOperator::new(
                    thresholds_from_increments(&inc),
                    weights_from_partial_sums(&sums),
                )
                .expect("generated operator satisfies (11), (12)")
            })
    })
}

/// A random PI creep operator: 1..=max_thresholds thresholds, non-negative
/// partial sums (17), 1..=5 eigenvalues log-uniform in [0.01, 1000] s⁻¹ and a
/// sample time in [1e-4, 1e-2] s.
pub fn creep_operator(max_thresholds: usize) -> impl Strategy<Value = CreepOperator> {
    creep_operator_at(max_thresholds).prop_map(|(c, _)| c)
}

/// [`creep_operator`] with its sample time (the same draws).
pub fn creep_operator_at(max_thresholds: usize) -> impl Strategy<Value = (CreepOperator, f64)> {
    (1..=max_thresholds, 1usize..=5).prop_flat_map(|(n, m)| {
        (
            prop::collection::vec(0.05f64..1.0, n - 1),
            prop::collection::vec(0.0f64..0.3, n),
            prop::collection::vec(-2.0f64..3.0, m),
            -4.0f64..-2.0,
        )
            .prop_map(|(inc, sums, log_a, log_ts)| {
                let ts = 10f64.powf(log_ts);
                let c = CreepOperator::new(
                    thresholds_from_increments(&inc),
                    weights_from_partial_sums(&sums),
                    log_a.iter().map(|&l| 10f64.powf(l)).collect::<Vec<_>>(),
                    ts,
                )
                .expect("generated creep operator satisfies (17), (18)");
                (c, ts)
            })
    })
}

/// The model `W = H + C` at `sample_time` of the parameters of `h` and `c`
/// (virgin).
#[allow(dead_code)] // not every test target uses it
pub fn model_of(
    sample_time: f64,
    h: &HysteresisOperator,
    c: Option<&CreepOperator>,
) -> HysteresisCreepModel {
    let parameters = mfcbeam::realtime::ModelParameters {
        sample_time,
        hysteresis: mfcbeam::realtime::HysteresisParameters {
            thresholds: h.thresholds(),
            weights: h.weights(),
        },
        creep: c.map(|c| mfcbeam::realtime::CreepParameters {
            thresholds: c.thresholds(),
            weights: c.weights(),
            eigenvalues: c.eigenvalues(),
        }),
        superposition: None,
        dynamics: None,
        delay: 0,
        offset: 0.0,
        rate_gain: 0.0,
    };
    HysteresisCreepModel::new(&parameters.validate().expect("the parts are valid"))
        .expect("heap storage holds any size")
}

/// A random model `W = H + C` at the creep operator's sample time.
pub fn model(max_plays: usize) -> impl Strategy<Value = HysteresisCreepModel> {
    (hysteresis_operator(max_plays), creep_operator_at(max_plays))
        .prop_map(|(h, (c, ts))| model_of(ts, &h, Some(&c)))
}

/// A random signal of `len` samples in [-amplitude, amplitude].
pub fn signal(len: std::ops::Range<usize>, amplitude: f64) -> impl Strategy<Value = Vec<f64>> {
    prop::collection::vec(-amplitude..amplitude, len)
}

/// The largest threshold: inputs of about this size excite every play.
pub fn reach(h: &HysteresisOperator) -> f64 {
    *h.thresholds().last().unwrap()
}

/// `max |x|` of a slice.
pub fn max_abs(x: &[f64]) -> f64 {
    x.iter().fold(0.0f64, |m, v| m.max(v.abs()))
}

/// `max − min` of a slice (at least `f64::MIN_POSITIVE`).
pub fn range(x: &[f64]) -> f64 {
    let (lo, hi) = x
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    (hi - lo).max(f64::MIN_POSITIVE)
}

/// Rounding bound of one PI output `Σ w_i x_i` with `|x_i| ≤ x_max`:
/// `(n+1) ε Σ|w_i| x_max`, times a safety factor 4 for the play clamps.
pub fn pi_rounding(h: &HysteresisOperator, x_max: f64) -> f64 {
    let n = h.len() as f64;
    let w_abs: f64 = h.weights().iter().map(|w| w.abs()).sum();
    4.0 * (n + 1.0) * EPS * w_abs * x_max
}

/// Smallest partial sum (the smallest branch slope).
pub fn min_slope(h: &HysteresisOperator) -> f64 {
    h.partial_sums().into_iter().fold(f64::INFINITY, f64::min)
}

/// Rounding bound of `H⁻¹∘H` or `H∘H⁻¹` on inputs with `|v| ≤ v_max` and
/// outputs `|y| ≤ y_max`: the forward sum's rounding, amplified by the
/// steepest inverse slope `1/s_min`, plus the inverse sum's own rounding.
pub fn inverse_rounding(h: &HysteresisOperator, v_max: f64, y_max: f64) -> f64 {
    let inv = h.inverse();
    let x = v_max + reach(h);
    let xi = y_max + reach(&inv);
    pi_rounding(h, x) / min_slope(h) + pi_rounding(&inv, xi) + pi_rounding(h, x)
}

/// The rms error (first number) of an `identify` report's `rms error` line.
pub fn report_rms(report: &str) -> f64 {
    report
        .lines()
        .find(|l| l.starts_with("rms error"))
        .and_then(|l| l.split_whitespace().nth(2))
        .and_then(|x| x.parse().ok())
        .unwrap_or_else(|| panic!("no rms error in the report:\n{report}"))
}
