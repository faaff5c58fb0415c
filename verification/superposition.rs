//! The superposition operator `S` of the modified PI model, `W = S[H + C] +
//! offset`: closed forms, the inverse rules against an inversion that does
//! not use them, the identities in `f64` and `f32` within the derived
//! bounds, exact odd symmetry of a mirrored `S`, the checks of the model
//! file, the bank, and injected faults of `S⁻¹` that conformance catches.

use mfcbeam::operators::bank::CompensatorBank;
use mfcbeam::operators::model::SuperpositionData;
use mfcbeam::prelude::*;
use mfcbeam::realtime::{
    nominal, ModelParameters, RoundingBounds, Superposition, SuperpositionParameters,
};
use mfcbeam::realtime::{Inline, Model, Real};
use mfcbeam::suite::conformance::{
    check_compensator, heap_compensator, random_superposition, CompensatorFactory,
    ConformanceSettings, Rng,
};
use mfcbeam::suite::reference::NaiveSuperposition;

/// `r = [−2, 0, 3]`, `w = [0.5, 1, −0.25]`: slope 1.5 below −2, 1 on
/// `[−2, 3]`, 0.75 above 3.
fn small() -> (Vec<f64>, Vec<f64>) {
    (vec![-2.0, 0.0, 3.0], vec![0.5, 1.0, -0.25])
}

fn parameters<'a>(r: &'a [f64], w: &'a [f64]) -> SuperpositionParameters<'a> {
    SuperpositionParameters {
        thresholds: r,
        weights: w,
    }
}

fn bounds<'a>(p: ModelParameters<'a>, eps: f64) -> RoundingBounds<'a> {
    RoundingBounds {
        parameters: p,
        state_max: 0.0,
        eps,
    }
}

/// The parameters of `S` alone as a model (`H` the identity), for bounds.
fn alone<'a>(s: &SuperpositionParameters<'a>) -> ModelParameters<'a> {
    ModelParameters {
        sample_time: 2e-4,
        hysteresis: mfcbeam::realtime::HysteresisParameters {
            thresholds: &[0.0],
            weights: &[1.0],
        },
        creep: None,
        superposition: Some(*s),
        dynamics: None,
        delay: 0,
        offset: 0.0,
        rate_gain: 0.0,
    }
}

#[test]
fn s_and_its_inverse_have_their_closed_forms() {
    let (r, w) = small();
    let s = Superposition::<f64, Heap>::new(&r, &w).unwrap();
    // on each segment, by hand
    assert_eq!(s.apply(1.0), 1.0);
    assert_eq!(s.apply(5.0), 5.0 - 0.25 * 2.0);
    assert_eq!(s.apply(-4.0), -4.0 + 0.5 * -2.0);
    // S⁻¹: thresholds S(r_i), w'_0 = 1/w_0, w'_i = −w_i/(σ_i σ_{i∓1})
    let inv = Superposition::<f64, Heap>::inverse_of(&parameters(&r, &w)).unwrap();
    assert_eq!(inv.thresholds(), &[-2.0, 0.0, 3.0]);
    let expected = [-0.5 / (1.5 * 1.0), 1.0, 0.25 / (0.75 * 1.0)];
    for (a, b) in inv.weights().iter().zip(expected) {
        assert!((a - b).abs() <= 2.0 * f64::EPSILON * b.abs(), "{a} vs {b}");
    }
    assert_eq!(inv.apply(4.5), 5.0);
    assert_eq!(inv.apply(-5.0), -4.0);
}

#[test]
fn the_inverse_rules_agree_with_inverting_the_segments() {
    let mut rng = Rng::new(22);
    for case in 0..300 {
        let scale = 10f64.powf(rng.uniform(0.0, 3.0));
        let sd = random_superposition(&mut rng, scale);
        let p = parameters(&sd.thresholds, &sd.weights);
        let inv = Superposition::<f64, Heap>::inverse_of(&p).unwrap();
        let naive = NaiveSuperposition::new(sd.thresholds.clone(), sd.weights.clone());
        let y_max = 2.0 * 2.0 * scale;
        // both are sums of k terms: each within the bound of S⁻¹'s rounding
        let tol = 2.0 * bounds(alone(&p), f64::EPSILON).inverse_superposition_sum(y_max);
        for i in 0..=40 {
            let y = -y_max + 2.0 * y_max * i as f64 / 40.0;
            let (a, b) = (inv.apply(y), naive.invert(y));
            assert!(
                (a - b).abs() <= tol,
                "case {case}, y = {y}: {a} vs {b} (tol {tol:e})"
            );
        }
    }
}

/// `S⁻¹[S[z]] − z` and `S[S⁻¹[y]] − y` in `T` against the first-order
/// bounds: `S`'s rounding through `S⁻¹` (slope ≤ 1/σ_min) plus `S⁻¹`'s own,
/// and the other way round through `S` (slope ≤ σ_max).
fn round_trips<T: Real>(seed: u64) -> (f64, f64) {
    let mut rng = Rng::new(seed);
    let mut worst = (0.0f64, 0.0f64);
    for _ in 0..200 {
        let scale = 10f64.powf(rng.uniform(0.0, 3.0));
        let sd = random_superposition(&mut rng, scale);
        let p = parameters(&sd.thresholds, &sd.weights);
        let s = Superposition::<T, Heap>::from_parameters(&p).unwrap();
        let inv = Superposition::<T, Heap>::inverse_of(&p).unwrap();
        let b = bounds(alone(&p), T::EPSILON.to_f64());
        let (lo, hi) = b.superposition_slopes();
        let z_max = 1.5 * scale;
        let y_max = hi * z_max;
        let left = b.superposition_sum(z_max) / lo + b.inverse_superposition_sum(y_max);
        let right = hi * b.inverse_superposition_sum(y_max) + b.superposition_sum(y_max / lo);
        for i in 0..=30 {
            let z = T::from_f64(-z_max + 2.0 * z_max * i as f64 / 30.0);
            let e = (inv.apply(s.apply(z)) - z).to_f64().abs();
            assert!(
                e <= left,
                "{}: S⁻¹[S[{z:?}]] off by {e:e} > {left:e}",
                T::NAME
            );
            worst.0 = worst.0.max(e / left);
            let y = T::from_f64(-y_max + 2.0 * y_max * i as f64 / 30.0);
            let e = (s.apply(inv.apply(y)) - y).to_f64().abs();
            assert!(
                e <= right,
                "{}: S[S⁻¹[{y:?}]] off by {e:e} > {right:e}",
                T::NAME
            );
            worst.1 = worst.1.max(e / right);
        }
    }
    worst
}

#[test]
fn s_inverse_is_the_inverse_to_rounding_in_f64_and_f32() {
    let f64_worst = round_trips::<f64>(1);
    let f32_worst = round_trips::<f32>(2);
    eprintln!("worst error / bound: f64 {f64_worst:?}, f32 {f32_worst:?}");
}

/// The nominal `H` and `C` with an asymmetric `S` scaled to their output.
fn asymmetric_nominal() -> ModelFile {
    let mut file = mfcbeam::operators::nominal::nominal_model_file();
    file.superposition = Some(SuperpositionData {
        thresholds: vec![-600.0, -250.0, 0.0, 200.0, 500.0],
        weights: vec![0.3, -0.2, 1.0, -0.35, -0.25],
    });
    file.offset = Some(0.7);
    file
}

/// `W[W⁻¹[y]] = y` through `S` on the Fig. 3 staircase, within
/// `RoundingBounds::identity` at the precision's `ε`.
fn identity<T: Real>() -> (f64, f64) {
    let file = asymmetric_nominal();
    type Size = Inline<12, 60, 5>;
    let mut comp = Compensator::<T, Size>::new(
        &file.parameters().validate().unwrap(),
        CompensatorSettings::unlimited(),
    )
    .unwrap();
    let mut plant = Model::<T, Size>::new(&file.parameters().validate().unwrap()).unwrap();
    let targets: Vec<f64> = mfcbeam::suite::scenarios::fig3_staircase(500.0);
    let (mut err, mut u_max) = (0.0f64, 0.0f64);
    for &y in &targets {
        let u = comp.compensate(T::from_f64(y)).u;
        u_max = u_max.max(u.to_f64().abs());
        err = err.max((plant.step(u).to_f64() - y).abs());
    }
    let bound = RoundingBounds {
        parameters: file.parameters(),
        state_max: 0.0,
        eps: T::EPSILON.to_f64(),
    }
    .identity(u_max, 500.0);
    assert!(err <= bound, "{}: {err:e} > {bound:e}", T::NAME);
    (err, bound)
}

#[test]
fn the_compensator_inverts_the_modified_model_in_f64_and_f32() {
    let (e64, b64) = identity::<f64>();
    let (e32, b32) = identity::<f32>();
    eprintln!("W[W⁻¹[y]] - y: f64 {e64:e} (bound {b64:e}), f32 {e32:e} (bound {b32:e})");
    // the asymmetry is real: without S⁻¹ the same targets miss by volts
    let file = asymmetric_nominal();
    let mut plain = file.clone();
    plain.superposition = None;
    let mut comp =
        Compensator::<f64, Heap>::from_file(&plain, CompensatorSettings::unlimited()).unwrap();
    let mut plant = HysteresisCreepModel::from_file(&file).unwrap();
    let miss = [300.0, -300.0]
        .iter()
        .map(|&y| (plant.step(comp.compensate(y).u) - y).abs())
        .fold(0.0, f64::max);
    assert!(miss > 10.0, "{miss}");
}

#[test]
fn a_mirrored_s_keeps_w_exactly_odd() {
    let mut file = mfcbeam::operators::nominal::nominal_model_file();
    file.superposition = Some(SuperpositionData {
        thresholds: vec![-400.0, -150.0, 0.0, 150.0, 400.0],
        weights: vec![-0.3, 0.2, 0.9, 0.2, -0.3],
    });
    let input: Vec<f64> = (0..4000)
        .map(|k| 800.0 * (k as f64 * 0.0021).sin())
        .collect();
    let neg: Vec<f64> = input.iter().map(|v| -v).collect();
    let a = HysteresisCreepModel::from_file(&file).unwrap().run(&input);
    let b = HysteresisCreepModel::from_file(&file).unwrap().run(&neg);
    assert!(a.iter().zip(&b).all(|(x, y)| *x == -*y));
    let mut ca =
        Compensator::<f64, Heap>::from_file(&file, CompensatorSettings::default()).unwrap();
    let mut cb =
        Compensator::<f64, Heap>::from_file(&file, CompensatorSettings::default()).unwrap();
    for (&y, &n) in a.iter().zip(&b) {
        assert_eq!(ca.compensate(y).u, -cb.compensate(n).u);
    }
}

#[test]
fn an_inadmissible_s_is_refused_naming_the_field_and_the_sum() {
    let check = |r: &[f64], w: &[f64]| parameters(r, w).validate().unwrap_err();
    let e = check(&[-1.0, 0.0, 2.0], &[0.5, 1.0, -1.0]);
    assert_eq!(
        e,
        ParameterError::SlopeNotPositive {
            field: "superposition.weights",
            index: 2,
            sum: 0.0
        }
    );
    assert!(e.to_string().starts_with("superposition.weights: "), "{e}");
    let e = check(&[-1.0, 0.0, 2.0], &[-1.5, 1.0, 0.0]);
    assert!(
        matches!(e, ParameterError::SlopeNotPositive { index: 0, .. }),
        "{e}"
    );
    let e = check(&[-1.0, 0.5, 2.0], &[0.1, 1.0, 0.0]);
    assert_eq!(
        e.to_string(),
        "superposition.thresholds: one threshold must be exactly 0"
    );
    let e = check(&[0.0, 2.0, 1.0], &[1.0, 0.1, 0.1]);
    assert!(
        matches!(e, ParameterError::ThresholdsNotIncreasing { index: 2, .. }),
        "{e}"
    );
    let e = check(&[0.0, 2.0], &[1.0]);
    assert!(matches!(e, ParameterError::LengthMismatch { .. }), "{e}");
    // from a model file, through ModelError
    let mut file = mfcbeam::operators::nominal::nominal_model_file();
    file.superposition = Some(SuperpositionData {
        thresholds: vec![0.0, 100.0],
        weights: vec![1.0, -1.0],
    });
    let e = HysteresisCreepModel::from_file(&file).unwrap_err();
    assert!(e.to_string().contains("superposition.weights"), "{e}");
    // too many terms for an inline capacity
    let file = asymmetric_nominal();
    let e =
        Model::<f64, Inline<12, 60, 3>>::new(&file.parameters().validate().unwrap()).unwrap_err();
    assert!(
        matches!(
            e,
            ParameterError::ExceedsCapacity {
                field: "superposition.thresholds",
                capacity: 3,
                found: 5
            }
        ),
        "{e}"
    );
}

#[test]
fn the_model_file_keeps_s_and_omits_it_when_absent() {
    let nominal = mfcbeam::operators::nominal::nominal_model_file();
    let json = serde_json::to_string(&nominal).unwrap();
    assert!(!json.contains("superposition"));
    let file = asymmetric_nominal();
    let back: ModelFile = serde_json::from_str(&serde_json::to_string(&file).unwrap()).unwrap();
    assert_eq!(back, file);
    let model = HysteresisCreepModel::from_file(&file).unwrap();
    assert_eq!(model.to_file().superposition, file.superposition);
}

#[test]
fn each_bank_channel_equals_its_single_compensator_with_s() {
    let asym = asymmetric_nominal();
    let plain = mfcbeam::operators::nominal::nominal_model_file();
    let files = [asym.clone(), plain, asym];
    let params: Vec<_> = files.iter().map(ModelFile::parameters).collect();
    let settings = CompensatorSettings::default();
    let mut bank = CompensatorBank::<f64>::new(&params, settings).unwrap();
    let mut singles: Vec<_> = files
        .iter()
        .map(|f| Compensator::<f64, Heap>::from_file(f, settings).unwrap())
        .collect();
    let mut out = vec![Compensated::default(); files.len()];
    for k in 0..3000 {
        let t = 900.0 * (k as f64 * 0.003).sin();
        let targets = [t, -t, 0.5 * t];
        bank.compensate(&targets, &mut out).unwrap();
        for (c, single) in singles.iter_mut().enumerate() {
            assert_eq!(
                out[c],
                single.compensate(targets[c]),
                "sample {k}, channel {c}"
            );
        }
    }
    let _ = nominal::PLAYS;
}

/// `W⁻¹` with a faulty `S⁻¹` put in front of a correct `H⁻¹ − C` stage.
struct FaultyInverse {
    inner: Compensator<f64, Heap>,
    inverse: NaiveSuperposition,
    offset: f64,
}

impl ActuatorCompensator for FaultyInverse {
    fn compensate(&mut self, target: f64) -> Compensated {
        let y = self.inverse.evaluate(target - self.offset) + self.offset;
        self.inner.compensate(y)
    }
    fn reset(&mut self) {
        self.inner.reset();
    }
}

/// `fault` applied to the correct `S⁻¹` parameters (thresholds, weights,
/// index of the zero threshold, the original thresholds).
fn faulty(
    fault: fn(&mut Vec<f64>, &mut Vec<f64>, usize, &[f64]),
) -> impl Fn(&ModelFile, CompensatorSettings) -> Result<Box<dyn ActuatorCompensator>, ModelError> + Sync
{
    move |file, settings| {
        let Some(sd) = &file.superposition else {
            return heap_compensator(file, settings);
        };
        let p = parameters(&sd.thresholds, &sd.weights);
        let inv = Superposition::<f64, Heap>::inverse_of(&p)?;
        let (mut r, mut w) = (inv.thresholds().to_vec(), inv.weights().to_vec());
        let zero = sd.thresholds.iter().position(|&x| x == 0.0).unwrap();
        fault(&mut r, &mut w, zero, &sd.thresholds);
        let mut plain = file.clone();
        plain.superposition = None;
        Ok(Box::new(FaultyInverse {
            inner: Compensator::from_file(&plain, settings)?,
            inverse: NaiveSuperposition::new(r, w),
            offset: file.offset.unwrap_or(0.0),
        }))
    }
}

#[test]
fn faults_in_the_inverse_rules_are_caught_with_small_counterexamples() {
    let s = ConformanceSettings {
        cases: 24,
        ..ConformanceSettings::default()
    };
    // the sign of one w'_i flipped (the outermost on the positive side, or
    // the negative side's if the positive one has none)
    let sign = faulty(|_, w, zero, _| {
        let j = if zero + 1 < w.len() { w.len() - 1 } else { 0 };
        w[j] = -w[j];
    });
    // r'_i taken as r_i instead of S(r_i)
    let threshold = faulty(|r, _, _, original| r.copy_from_slice(original));
    let faults: [(&CompensatorFactory, &str); 2] = [
        (&sign, "a sign error in one w'_i"),
        (&threshold, "r'_i computed as r_i"),
    ];
    for (fault, name) in faults {
        let report = check_compensator(fault, &s).unwrap();
        eprintln!("{name}:\n{report}");
        let failed = report.failed();
        assert!(!failed.is_empty(), "{name} was not caught");
        assert!(
            failed.iter().any(|p| p.name.starts_with("superposition_")),
            "{name}: no superposition property failed"
        );
        for p in failed {
            let c = p.counterexample.as_ref().unwrap();
            assert!(
                c.case.input.len() <= 50,
                "{name}: {} samples",
                c.case.input.len()
            );
        }
    }
}
