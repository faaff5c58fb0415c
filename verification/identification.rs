//! Identification (23)–(25): exact recovery from noise-free data, graceful
//! degradation with noise, constraints that always hold, unexcited operators
//! reported, and a property test on random admissible models.

use crate::common;

use common::*;
use mfcbeam::identification::{
    identify, thresholds_23, IdentificationError, IdentificationSettings,
};
use mfcbeam::operators::creep::LogCreepOperator;
use mfcbeam::operators::nominal::{CREEP_WEIGHTS, HYSTERESIS_WEIGHTS, SAMPLE_TIME};
use mfcbeam::prelude::*;
use mfcbeam::realtime::Superposition;
use mfcbeam::suite::signal::Staircase;
use proptest::prelude::*;

/// The paper's identification input (section 4.1): 4 periods of a staircase
/// through ±A, shrinking each period; `duration` seconds in all.
fn staircase_input(amplitude: f64, duration: f64) -> Vec<f64> {
    let segments = 4.0 * 12.0;
    Staircase::shrinking_loops(amplitude, 4, 3, 0.1, duration / segments - 0.1).sample(SAMPLE_TIME)
}

fn rms(x: &[f64]) -> f64 {
    (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt()
}

/// Every partial sum of `h` is ≥ `eps_h` and of `c` ≥ 0, as the operators
/// recompute them.
fn assert_constraints(w: &HysteresisCreepModel, eps_h: f64) {
    for s in w.hysteresis().partial_sums() {
        assert!(s >= eps_h, "hysteresis partial sum {s} < {eps_h}");
    }
    let mut s = 0.0;
    for &c in w.creep().unwrap().weights() {
        s += c;
        assert!(s >= 0.0);
    }
}

/// Noise-free data from the nominal model on the 40 s identification
/// staircase: the weights come back to 1e-6 relative (each weight, relative
/// to itself), and the identified model inverts.
#[test]
fn noise_free_data_recover_the_nominal_weights() {
    let u = staircase_input(1000.0, 40.0);
    let y = nominal_model().run(&u);
    let id = identify(&u, &y, SAMPLE_TIME, &IdentificationSettings::default()).unwrap();
    let w = &id.model;
    assert_eq!(
        w.hysteresis().thresholds(),
        thresholds_23(12, 1000.0).as_slice()
    );
    let worst = w
        .hysteresis()
        .weights()
        .iter()
        .zip(HYSTERESIS_WEIGHTS)
        .chain(w.creep().unwrap().weights().iter().zip(CREEP_WEIGHTS))
        .map(|(a, b)| ((a - b) / b).abs())
        .fold(0.0, f64::max);
    eprintln!(
        "worst relative weight error {worst:e}, offset {:e}",
        id.report.offset
    );
    for (a, b) in w.hysteresis().weights().iter().zip(HYSTERESIS_WEIGHTS) {
        assert!(((a - b) / b).abs() <= 1e-6, "hysteresis weight {a} vs {b}");
    }
    for (a, b) in w.creep().unwrap().weights().iter().zip(CREEP_WEIGHTS) {
        assert!(((a - b) / b).abs() <= 1e-6, "creep weight {a} vs {b}");
    }
    assert!(id.report.active_constraints.is_empty());
    assert!(id.report.unexcited.is_empty());
    assert!(id.report.fit.rms <= 1e-9 * id.report.fit.output_range);
    // the identified model inverts: W[W⁻¹[ς]] = ς
    let mut comp = w.compensator(CompensatorSettings::default()).unwrap();
    let mut plant = w.clone();
    for &t in &Staircase::full_loop(400.0, 4, 0.1, 0.2).sample(SAMPLE_TIME) {
        assert!((plant.step(comp.compensate(t).u) - t).abs() < 1e-9);
    }
}

/// White measurement noise of 1 % of the output range: on a different
/// validation input the identified model's error against the (noisy)
/// measurement stays within 2× the noise RMS, its error against the true
/// output well below the noise, and the result is reproducible from the seed.
#[test]
fn noisy_data_degrade_gracefully_on_a_validation_input() {
    let u = staircase_input(1000.0, 20.0);
    let y_true = nominal_model().run(&u);
    let sigma = 0.01 * range(&y_true);
    let noisy = |seed: u64, y: &[f64]| -> Vec<f64> {
        let n = gaussian(&mut Lcg(seed), y.len(), sigma);
        y.iter().zip(&n).map(|(a, b)| a + b).collect()
    };
    let y = noisy(42, &y_true);
    let id = identify(&u, &y, SAMPLE_TIME, &IdentificationSettings::default()).unwrap();
    let again = identify(&u, &y, SAMPLE_TIME, &IdentificationSettings::default()).unwrap();
    assert_eq!(id.model, again.model, "reproducible");
    assert_constraints(&id.model, id.report.epsilon_h);

    // validation: a different shape — 3 shrinking loops of 800 V, other plateaus
    let v = Staircase::shrinking_loops(800.0, 3, 5, 0.05, 0.3).sample(SAMPLE_TIME);
    let v_true = nominal_model().run(&v);
    let v_meas = noisy(7, &v_true);
    let fit = id.model.clone().run(&v);
    let err_meas: Vec<f64> = fit.iter().zip(&v_meas).map(|(a, b)| a - b).collect();
    let err_true: Vec<f64> = fit.iter().zip(&v_true).map(|(a, b)| a - b).collect();
    assert!(
        rms(&err_meas) <= 2.0 * sigma,
        "{} vs noise {sigma}",
        rms(&err_meas)
    );
    assert!(
        rms(&err_true) <= 0.5 * sigma,
        "{} vs noise {sigma}",
        rms(&err_true)
    );
    // the compensator of the identified model exists
    assert!(id.model.compensator(CompensatorSettings::default()).is_ok());
}

/// An input reaching only 500 V with thresholds fixed for 1000 V: the upper
/// half of the operators is never excited. The constraints still hold, the
/// report names exactly those operators, and the model still inverts.
#[test]
fn partial_excitation_names_the_unexcited_operators() {
    let u = staircase_input(500.0, 8.0);
    let y = nominal_model().run(&u);
    let settings = IdentificationSettings {
        hysteresis_thresholds: Some(thresholds_23(12, 1000.0)),
        creep_thresholds: Some(thresholds_23(12, 1000.0)),
        ..Default::default()
    };
    let id = identify(&u, &y, SAMPLE_TIME, &settings).unwrap();
    let named: Vec<(&str, usize)> = id
        .report
        .unexcited
        .iter()
        .map(|o| (o.group, o.index))
        .collect();
    let expected: Vec<(&str, usize)> = (6..12)
        .map(|i| ("hysteresis", i))
        .chain((6..12).map(|i| ("creep", i)))
        .collect();
    assert_eq!(named, expected);
    assert!(id
        .report
        .to_string()
        .contains("hysteresis operator 6 (threshold 500) was never excited"));
    assert_constraints(&id.model, id.report.epsilon_h);
    assert!(id.model.hysteresis().weights()[6..]
        .iter()
        .all(|&w| w == 0.0));
    // on the excited range the model reproduces the data
    assert!(id.report.fit.max <= 1e-8 * id.report.fit.output_range);
    assert!(id.model.compensator(CompensatorSettings::default()).is_ok());
}

/// Data no model of this structure fits with positive slopes (a falling
/// hysteresis): the constraints bind, are reported active, and still hold.
#[test]
fn active_constraints_hold_and_are_reported() {
    let u = staircase_input(1000.0, 8.0);
    let y: Vec<f64> = nominal_model().run(&u).iter().map(|v| -v).collect();
    let id = identify(&u, &y, SAMPLE_TIME, &IdentificationSettings::default()).unwrap();
    assert!(!id.report.active_constraints.is_empty());
    assert_constraints(&id.model, id.report.epsilon_h);
    assert!(id.model.compensator(CompensatorSettings::default()).is_ok());
}

/// Bad data gets a clear error.
#[test]
fn bad_data_is_refused() {
    let s = IdentificationSettings::default();
    let u: Vec<f64> = (0..1000).map(|k| (k as f64).sin()).collect();
    assert!(matches!(
        identify(&u, &u[..999], 2e-4, &s),
        Err(IdentificationError::LengthMismatch { .. })
    ));
    assert!(matches!(
        identify(&u[..20], &u[..20], 2e-4, &s),
        Err(IdentificationError::TooFewSamples { .. })
    ));
    assert!(matches!(
        identify(&[3.0; 100], &[1.0; 100], 2e-4, &s),
        Err(IdentificationError::ConstantInput { .. })
    ));
    let mut bad = u.clone();
    bad[17] = f64::NAN;
    let e = identify(&u, &bad, 2e-4, &s).unwrap_err();
    assert_eq!(e.to_string(), "y[17]: NaN is not a finite number");
    assert!(identify(&u, &u, 0.0, &s).is_err());
}

fn rich_input(seed: u64, len: usize, amplitude: f64) -> Vec<f64> {
    // a random walk with random reversals, drifting slowly, reaching ±amplitude
    let mut rng = Lcg(seed);
    let mut v = 0.0f64;
    let mut dir = 1.0;
    let mut out: Vec<f64> = (0..len)
        .map(|_| {
            if rng.next_f64() < 0.01 {
                dir = -dir;
            }
            v = (v + dir * rng.uniform(0.0, 0.03) * amplitude).clamp(-amplitude, amplitude);
            v
        })
        .collect();
    out[len / 2] = amplitude; // reach r_max exactly
    out
}

proptest! {
    #![proptest_config(config(24, "proptest-regressions/identification.txt"))]

    /// For random admissible models whose thresholds are (23) of the input
    /// and eigenvalues (24), identification reproduces the model's output to
    /// 1e-8 of its range, and the result satisfies (11) and (17).
    #[test]
    fn identification_reproduces_random_admissible_models(
        nh in 1usize..8,
        nc in 1usize..6,
        m in 1usize..4,
        sums_h in prop::collection::vec(0.05f64..2.0, 8),
        sums_c in prop::collection::vec(0.0f64..0.2, 6),
        seed in any::<u64>(),
    ) {
        let ts = 1e-3;
        let amplitude = 10.0;
        let u = rich_input(seed, 4000, amplitude);
        let h = HysteresisOperator::new(thresholds_23(nh, amplitude), weights_from_partial_sums(&sums_h[..nh])).unwrap();
        let c = CreepOperator::new(
            thresholds_23(nc, amplitude),
            weights_from_partial_sums(&sums_c[..nc]),
            mfcbeam::operators::creep::log_spaced_eigenvalues(m, ts),
            ts,
        ).unwrap();
        let truth = model_of(ts, &h, Some(&c));
        let y = truth.clone().run(&u);
        let settings = IdentificationSettings {
            hysteresis_operators: nh,
            creep_operators: nc,
            creep_eigenvalues: m,
            epsilon_h: Some(0.01),
            ..Default::default()
        };
        let id = identify(&u, &y, ts, &settings).unwrap();
        let fit = id.model.clone().run(&u);
        let err = fit.iter().zip(&y).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        prop_assert!(err <= 1e-8 * range(&y), "error {err:e}, range {}", range(&y));
        for s in id.model.hysteresis().partial_sums() {
            prop_assert!(s >= 0.01);
        }
    }
}

/// Solve the small dense system `A x = b` by Gaussian elimination with
/// partial pivoting (the reference below must not share code with the
/// library's QR path).
#[allow(clippy::needless_range_loop)] // textbook index form, on purpose
fn gauss_solve(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Option<Vec<f64>> {
    let n = b.len();
    for k in 0..n {
        let piv = (k..n).max_by(|&i, &j| a[i][k].abs().total_cmp(&a[j][k].abs()))?;
        if a[piv][k].abs() < 1e-300 {
            return None;
        }
        a.swap(k, piv);
        b.swap(k, piv);
        for i in k + 1..n {
            let f = a[i][k] / a[k][k];
            for j in k..n {
                a[i][j] -= f * a[k][j];
            }
            b[i] -= f * b[k];
        }
    }
    let mut x = vec![0.0; n];
    for k in (0..n).rev() {
        x[k] = (b[k] - (k + 1..n).map(|j| a[k][j] * x[j]).sum::<f64>()) / a[k][k];
    }
    Some(x)
}

/// The constrained optimum against a brute-force reference: every active set
/// of the bounds on the partial sums is tried with the normal equations of
/// `Φ` (built from the library's play and log(t)-creep operators, not from the
/// identification code), and the best feasible point is the global optimum of
/// the convex QP. Data from weights that break (11) and (17) force binding
/// constraints.
#[test]
fn constrained_optimum_matches_brute_force_active_set_enumeration() {
    let ts = 1e-3;
    let u = rich_input(99, 3000, 10.0);
    let (nh, nc, m) = (3, 2, 2);
    let r_h = thresholds_23(nh, 10.0);
    let r_c = thresholds_23(nc, 10.0);
    let eig = mfcbeam::operators::creep::log_spaced_eigenvalues(m, ts);
    // columns of Φ
    let mut cols: Vec<Vec<f64>> = Vec::new();
    for &r in &r_h {
        cols.push(PlayOperator::new(r).unwrap().run(&u));
    }
    for &r in &r_c {
        cols.push(LogCreepOperator::new(r, &eig, ts).unwrap().run(&u));
    }
    let p = nh + nc;
    // true weights with partial sums (0.5, -0.2, 0.3) and (0.1, -0.05): infeasible
    let w_true = [0.5, -0.7, 0.5, 0.1, -0.15];
    let y: Vec<f64> = (0..u.len())
        .map(|k| (0..p).map(|j| w_true[j] * cols[j][k]).sum())
        .collect();
    let eps_h = 0.01;
    let bounds: Vec<f64> = (0..p).map(|j| if j < nh { eps_h } else { 0.0 }).collect();
    // Ψ = Φ D: columns in partial-sum coordinates
    let psi: Vec<Vec<f64>> = (0..p)
        .map(|j| {
            let next_same = (j + 1 < nh && j < nh) || (j >= nh && j + 1 < p);
            (0..u.len())
                .map(|k| cols[j][k] - if next_same { cols[j + 1][k] } else { 0.0 })
                .collect()
        })
        .collect();
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
    let objective = |s: &[f64]| -> f64 {
        (0..u.len())
            .map(|k| {
                let e = (0..p).map(|j| psi[j][k] * s[j]).sum::<f64>() - y[k];
                e * e
            })
            .sum()
    };
    let mut best = (f64::INFINITY, vec![]);
    for mask in 0u32..(1 << p) {
        let free: Vec<usize> = (0..p).filter(|j| mask & (1 << j) == 0).collect();
        let mut s = bounds.clone();
        if !free.is_empty() {
            let rhs_vec: Vec<f64> = (0..u.len())
                .map(|k| {
                    y[k] - (0..p)
                        .filter(|j| mask & (1 << j) != 0)
                        .map(|j| psi[j][k] * bounds[j])
                        .sum::<f64>()
                })
                .collect();
            let a: Vec<Vec<f64>> = free
                .iter()
                .map(|&i| free.iter().map(|&j| dot(&psi[i], &psi[j])).collect())
                .collect();
            let b: Vec<f64> = free.iter().map(|&i| dot(&psi[i], &rhs_vec)).collect();
            let Some(x) = gauss_solve(a, b) else { continue };
            for (k, &j) in free.iter().enumerate() {
                s[j] = x[k];
            }
        }
        if s.iter().zip(&bounds).all(|(a, b)| *a >= b - 1e-12) {
            let f = objective(&s);
            if f < best.0 {
                best = (f, s);
            }
        }
    }
    // the reference fits every sample from the virgin state, without offset
    let settings = IdentificationSettings {
        hysteresis_operators: nh,
        creep_operators: nc,
        creep_eigenvalues: m,
        epsilon_h: Some(eps_h),
        fit_offset: false,
        fit_from: Some(0),
        ..Default::default()
    };
    let id = identify(&u, &y, ts, &settings).unwrap();
    assert!(!id.report.active_constraints.is_empty());
    let mut w = id.model.hysteresis().weights().to_vec();
    w.extend_from_slice(id.model.creep().unwrap().weights());
    let mut s_id = Vec::new();
    for (j, &wj) in w.iter().enumerate() {
        let prev = if j == 0 || j == nh { 0.0 } else { s_id[j - 1] };
        s_id.push(prev + wj);
    }
    let f_id = objective(&s_id);
    let f_ref = best.0;
    assert!(
        f_id <= f_ref * (1.0 + 1e-9) + 1e-12,
        "identify {f_id} vs reference {f_ref}"
    );
    for (a, b) in s_id.iter().zip(&best.1) {
        assert!(
            (a - b).abs() <= 1e-7 * (1.0 + b.abs()),
            "partial sums {s_id:?} vs {:?}",
            best.1
        );
    }
}

/// The nominal `H` and `C` followed by an asymmetric superposition operator
/// (slope 1 on `[−200, 150]`, 0.75 and 1.0 below, 0.8, 0.65 and 0.95
/// above) and an offset of 3 V.
fn asymmetric_truth() -> HysteresisCreepModel {
    let mut file = mfcbeam::operators::nominal::nominal_model_file();
    file.superposition = Some(mfcbeam::operators::model::SuperpositionData {
        thresholds: vec![-500.0, -200.0, 0.0, 150.0, 400.0, 700.0],
        weights: vec![0.25, -0.25, 1.0, -0.2, -0.15, 0.3],
    });
    file.offset = Some(3.0);
    HysteresisCreepModel::from_file(&file).unwrap()
}

/// The kinks of the truth's `S⁻¹` on the output axis: `S(r_i) + offset`.
fn truth_kinks(truth: &HysteresisCreepModel) -> Vec<f64> {
    let s = truth.superposition().unwrap();
    let r = s.thresholds();
    r.iter()
        .filter(|&&x| x != 0.0)
        .map(|&x| s.apply(x) + truth.offset())
        .collect()
}

/// Kuhnen's error model on a noise-free record of a modified PI model, with
/// `S⁻¹`'s kinks where the truth has them: the model class holds the truth
/// up to its one ambiguity (`H`, `C` scaled by `λ`, `S`'s input by `1/λ`),
/// and every weight comes back to rounding: the norm-wise relative error of
/// a zero-residual least-squares solution is at most `p κ ε` (first order).
#[test]
fn an_asymmetric_record_gives_back_its_superposition_operator() {
    let truth = asymmetric_truth();
    let u = staircase_input(1000.0, 40.0);
    let y = truth.clone().run(&u);
    let settings = IdentificationSettings {
        superposition_kinks: Some(truth_kinks(&truth)),
        ..Default::default()
    };
    let id = identify(&u, &y, SAMPLE_TIME, &settings).unwrap();
    let r = &id.report;
    let tol = r.unknowns as f64 * r.condition_number * f64::EPSILON;
    let m = &id.model;
    let lambda = m.hysteresis().weights()[0] / truth.hysteresis().weights()[0];
    let s_id = m.superposition().unwrap();
    let s_true = truth.superposition().unwrap();
    // stacked: H and C weights / λ, S thresholds / λ, S weights · λ, offset
    let stack = |h: &[f64], c: &[f64], sr: &[f64], sw: &[f64], off: f64, l: f64| -> Vec<f64> {
        let mut v: Vec<f64> = h.iter().chain(c).map(|x| x / l).collect();
        v.extend(sr.iter().map(|x| x / l));
        v.extend(sw.iter().map(|x| x * l));
        v.push(off);
        v
    };
    let found = stack(
        m.hysteresis().weights(),
        m.creep().unwrap().weights(),
        s_id.thresholds(),
        s_id.weights(),
        m.offset(),
        lambda,
    );
    let expected = stack(
        truth.hysteresis().weights(),
        truth.creep().unwrap().weights(),
        s_true.thresholds(),
        s_true.weights(),
        truth.offset(),
        1.0,
    );
    let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
    let diff: Vec<f64> = found.iter().zip(&expected).map(|(a, b)| a - b).collect();
    let rel = norm(&diff) / norm(&expected);
    eprintln!("{r}λ = {lambda}, relative error {rel:e} (bound p κ ε = {tol:e})");
    assert!(rel <= tol, "{rel:e} > {tol:e}");
    assert!(r.fit.rms <= 1e-9 * r.fit.output_range);
    assert!(r.superposition.is_some());
    // the identified model inverts through S: W[W⁻¹[ς]] = ς
    let mut comp = m.compensator(CompensatorSettings::unlimited()).unwrap();
    let mut plant = m.clone();
    for &t in &Staircase::full_loop(400.0, 4, 0.1, 0.2).sample(SAMPLE_TIME) {
        assert!((plant.step(comp.compensate(t).u) - t).abs() < 1e-9);
    }
}

/// Two records of the asymmetric truth, the second with a sensor offset,
/// fitted with one offset per record: each record's report row is the
/// errors of that record's own model, and with `S` that model is not the
/// first record's with another offset (an offset shifts `S`'s input).
#[test]
fn with_s_each_record_has_its_own_model() {
    let truth = asymmetric_truth();
    let u1 = staircase_input(1000.0, 20.0);
    let u2: Vec<f64> = staircase_input(900.0, 20.0);
    let y1 = truth.clone().run(&u1);
    let y2: Vec<f64> = truth.clone().run(&u2).iter().map(|v| v - 40.0).collect();
    let records = [
        mfcbeam::identification::FitRecord {
            u: &u1,
            y: &y1,
            fit_from: None,
        },
        mfcbeam::identification::FitRecord {
            u: &u2,
            y: &y2,
            fit_from: None,
        },
    ];
    let settings = IdentificationSettings {
        superposition_kinks: Some(truth_kinks(&truth)),
        offset_per_record: true,
        ..Default::default()
    };
    let id = mfcbeam::identification::identify_records(&records, SAMPLE_TIME, &settings).unwrap();
    assert_eq!(id.record_models.len(), 2);
    assert_eq!(
        serde_json::to_string(&id.record_models[0].to_file()).unwrap(),
        serde_json::to_string(&id.model.to_file()).unwrap()
    );
    for ((record, model), row) in records
        .iter()
        .zip(&id.record_models)
        .zip(&id.report.records)
    {
        let fit = model.clone().run(record.u);
        let e: Vec<f64> = row.fitted.clone().map(|k| fit[k] - record.y[k]).collect();
        assert_eq!(rms(&e).to_bits(), row.fit.rms.to_bits());
    }
    // the first record's model with the second's offset is another model
    let own = id.record_models[1].clone().run(&u2);
    let shifted = id
        .model
        .clone()
        .with_offset(id.report.records[1].offset)
        .unwrap()
        .run(&u2);
    let apart = own
        .iter()
        .zip(&shifted)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    eprintln!("apart by {apart}, rms {:?}", id.report.records[1].fit);
    assert!(
        apart > 1e-3 * id.report.records[1].fit.output_range,
        "{apart}"
    );
}

/// The same record with white noise (σ = 0.5 V, about 0.04 % of the range)
/// and `S⁻¹`'s kinks by the default rule (4 per side, not where the truth
/// has them): the modified model fits the asymmetric actuator far better
/// than the symmetric one, every constraint holds (`S` is admissible by
/// construction), and the fit's error against the true output stays near
/// the noise floor, not at the symmetric model's structural error.
#[test]
fn the_superposition_operator_captures_an_asymmetric_loop_under_noise() {
    let truth = asymmetric_truth();
    let u = staircase_input(1000.0, 40.0);
    let y_true = truth.clone().run(&u);
    let sigma = 0.5;
    let noise = gaussian(&mut Lcg(2211), y_true.len(), sigma);
    let y: Vec<f64> = y_true.iter().zip(&noise).map(|(a, b)| a + b).collect();
    let fit_with = |m: usize| {
        let s = IdentificationSettings {
            superposition: m,
            ..Default::default()
        };
        identify(&u, &y, SAMPLE_TIME, &s).unwrap()
    };
    let (sym, asym) = (fit_with(0), fit_with(4));
    let clean_error = |id: &mfcbeam::identification::Identification| {
        let fit = id.model.clone().run(&u);
        let k0 = id.report.fitted.start;
        rms(&fit[k0..]
            .iter()
            .zip(&y_true[k0..])
            .map(|(a, b)| a - b)
            .collect::<Vec<_>>())
    };
    let (e_sym, e_asym) = (clean_error(&sym), clean_error(&asym));
    eprintln!("{}", asym.report);
    eprintln!(
        "rms error against the true output: symmetric {e_sym:.4} V, with S {e_asym:.4} V (noise σ = {sigma} V)"
    );
    assert!(e_asym < 0.25 * e_sym, "{e_asym} vs {e_sym}");
    assert!(asym.report.fit.rms < sym.report.fit.rms);
    assert_constraints(&asym.model, asym.report.epsilon_h);
}

/// With noise (σ = 0.5 V) and the truth's kinks, every weight of `H`, `C`
/// and `S⁻¹` lies within 5 standard errors of the truth. The noise enters
/// the error model through `S⁻¹`'s dead zones as well (errors in
/// variables): to first order it is the noise scaled by the local slope of
/// `S⁻¹`, zero-mean, which the standard errors from the residual include;
/// the second-order part, the dead zone rounding off the noise within a
/// few σ of its kink, biases a column by at most 0.4 σ there and is below
/// the standard errors here (checked by the same inequality).
#[test]
fn with_noise_every_weight_lies_within_its_standard_errors() {
    let truth = asymmetric_truth();
    let u = staircase_input(1000.0, 40.0);
    let y_true = truth.clone().run(&u);
    let sigma = 0.5;
    let noise = gaussian(&mut Lcg(3022), y_true.len(), sigma);
    let y: Vec<f64> = y_true.iter().zip(&noise).map(|(a, b)| a + b).collect();
    let settings = IdentificationSettings {
        superposition_kinks: Some(truth_kinks(&truth)),
        ..Default::default()
    };
    let id = identify(&u, &y, SAMPLE_TIME, &settings).unwrap();
    let r = &id.report;
    assert!(r.active_constraints.is_empty(), "{r}");
    // the truth in the regressor's parameters: S⁻¹'s weights at its kinks
    // (slope changes outward; the mid-point lies on the segment of slope 1,
    // so the scale is the truth's), above outward, then below outward
    let s = truth.superposition().unwrap();
    let inv = Superposition::<f64, Heap>::inverse_of(&s.parameters()).unwrap();
    let zero = inv.thresholds().iter().position(|&x| x == 0.0).unwrap();
    let w_inv = inv.weights();
    let mut expected: Vec<f64> = truth
        .hysteresis()
        .weights()
        .iter()
        .chain(truth.creep().unwrap().weights())
        .copied()
        .collect();
    expected.extend(&w_inv[zero + 1..]);
    expected.extend(w_inv[..zero].iter().rev());
    assert_eq!(expected.len(), r.weights.len());
    let worst = r
        .weights
        .iter()
        .zip(&expected)
        .zip(&r.standard_errors)
        .map(|((a, b), se)| (a - b).abs() / se)
        .fold(0.0, f64::max);
    eprintln!("worst |weight − truth| / standard error: {worst:.2}");
    assert!(worst <= 5.0, "{worst}");
}

/// The creep penalty with `λ` by generalized cross-validation, chosen from
/// the fitted record alone: on 2 s of the paper's staircase with 1 %
/// noise, eight seeds, the model's error on another input against the
/// noise-free truth falls (the creep columns are nearly collinear, so
/// least squares alone fits noise with large weights of opposite signs).
/// `λ = 0` is least squares, and a larger `λ` leaves fewer effective
/// parameters.
#[test]
fn the_creep_penalty_lowers_the_error_on_another_input() {
    use mfcbeam::identification::CreepRegularisation;
    let v = Staircase::shrinking_loops(800.0, 3, 5, 0.05, 0.3).sample(SAMPLE_TIME);
    let v_true = nominal_model().run(&v);
    let u = staircase_input(1000.0, 2.0);
    let y_true = nominal_model().run(&u);
    let sigma = 0.01 * range(&y_true);
    let settings = |creep_regularisation| IdentificationSettings {
        creep_regularisation,
        ..IdentificationSettings::default()
    };
    let held_out = |m: &HysteresisCreepModel| {
        let fit = m.clone().run(&v);
        let e: Vec<f64> = fit
            .iter()
            .zip(&v_true)
            .map(|(a, b)| a - m.offset() - b)
            .collect();
        rms(&e)
    };
    let (mut plain, mut penalised) = (0.0, 0.0);
    for seed in 0..8u64 {
        let n = gaussian(&mut Lcg(seed + 100), y_true.len(), sigma);
        let y: Vec<f64> = y_true.iter().zip(&n).map(|(a, b)| a + b).collect();
        let none = identify(&u, &y, SAMPLE_TIME, &settings(CreepRegularisation::None)).unwrap();
        let gcv = identify(&u, &y, SAMPLE_TIME, &settings(CreepRegularisation::Gcv)).unwrap();
        assert!(none.report.creep_regularisation.is_none());
        let (lambda, df) = gcv.report.creep_regularisation.unwrap();
        assert!(
            lambda > 0.0 && df < gcv.report.unknowns as f64,
            "λ {lambda}, {df}"
        );
        assert_constraints(&gcv.model, gcv.report.epsilon_h);
        assert!(gcv
            .model
            .compensator(CompensatorSettings::default())
            .is_ok());
        plain += held_out(&none.model) / 8.0;
        penalised += held_out(&gcv.model) / 8.0;
        if seed == 0 {
            // λ = 0 is least squares; more λ, fewer effective parameters
            let zero = identify(
                &u,
                &y,
                SAMPLE_TIME,
                &settings(CreepRegularisation::Fixed(0.0)),
            );
            let zero = zero.unwrap();
            assert!((held_out(&zero.model) - held_out(&none.model)).abs() <= 1e-9 * sigma);
            let mut last = f64::INFINITY;
            for lambda in [1e-6, 1e-4, 1e-2, 1.0] {
                let id = identify(
                    &u,
                    &y,
                    SAMPLE_TIME,
                    &settings(CreepRegularisation::Fixed(lambda)),
                );
                let (_, df) = id.unwrap().report.creep_regularisation.unwrap();
                assert!(df < last, "λ {lambda}: {df} after {last}");
                last = df;
            }
        }
    }
    eprintln!("error on another input, mean of 8 seeds: least squares {plain:.4e}, penalised {penalised:.4e} (noise {sigma:.4e})");
    assert!(penalised < 0.8 * plain, "{penalised} against {plain}");
    // a λ that is not a number at least 0 is refused, named
    for bad in [-1.0, f64::NAN, f64::INFINITY] {
        match identify(
            &u,
            &y_true,
            SAMPLE_TIME,
            &settings(CreepRegularisation::Fixed(bad)),
        ) {
            Err(IdentificationError::InvalidSetting { field, .. }) => {
                assert_eq!(field, "creep_regularisation")
            }
            other => panic!("{bad}: {other:?}"),
        }
    }
}
