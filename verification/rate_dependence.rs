//! The PI operator with rate-dependent thresholds `r_i + g|Δu|` and its
//! exact inverse (docs/MATHEMATICS.md §4.3): with no rate it is `H`; each
//! step is continuous and non-decreasing in its input; the inverse reaches
//! the target and the state of the step it inverts, to rounding (on a flat
//! piece, where rounding decides which of its inputs it takes); a non-finite sample changes
//! nothing; bad parameters are refused.

use mfcbeam::operators::hysteresis::HysteresisOperator;
use mfcbeam::operators::rate_dependent::RateDependentHysteresis;
use mfcbeam::realtime::ParameterError;
use mfcbeam::suite::conformance::Rng;

const TS: f64 = 1e-4;

/// Increasing thresholds from 0 and non-negative weights with `w_0 > 0`.
fn random_parameters(rng: &mut Rng, n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut r = vec![0.0];
    for _ in 1..n {
        let last = *r.last().unwrap();
        r.push(last + rng.uniform(5.0, 80.0));
    }
    let w = (0..n)
        .map(|i| {
            if i == 0 {
                rng.uniform(0.05, 1.0)
            } else if rng.uniform(0.0, 1.0) < 0.2 {
                0.0
            } else {
                rng.uniform(0.0, 0.5)
            }
        })
        .collect();
    (r, w)
}

/// A jagged drive: ramps, jumps and reversals within ±amplitude.
fn random_input(rng: &mut Rng, len: usize, amplitude: f64) -> Vec<f64> {
    let mut u = 0.0f64;
    (0..len)
        .map(|_| {
            let step = if rng.uniform(0.0, 1.0) < 0.05 {
                rng.uniform(-0.5, 0.5) * amplitude
            } else {
                rng.uniform(-0.03, 0.03) * amplitude
            };
            u = (u + step).clamp(-amplitude, amplitude);
            u
        })
        .collect()
}

/// An operator of random parameters and rate gain after a random history.
fn random_operator(rng: &mut Rng) -> (RateDependentHysteresis, f64) {
    let n = 1 + (rng.uniform(0.0, 12.0) as usize);
    let (r, w) = random_parameters(rng, n);
    let beta = rng.uniform(0.0, 0.95) * TS;
    let mut h = RateDependentHysteresis::new(&r, &w, beta, TS).unwrap();
    let amplitude = 1.5 * r.last().unwrap() + 50.0;
    for u in random_input(rng, 200, amplitude) {
        h.step(u);
    }
    (h, amplitude)
}

/// A bound on the magnitude of a step's terms: the input or a state, plus
/// the largest threshold and the rate term `g|u − u_{k−1}|` (at most
/// `2g` times the largest input or state). The sum adds `n` of them, each
/// times a weight: its rounding is within `n ε Σ w_i` times this.
fn scale(h: &RateDependentHysteresis, r_max: f64, u: f64) -> f64 {
    let x = h
        .play_states()
        .iter()
        .chain(h.last_input().as_ref())
        .fold(u.abs(), |m, x| m.max(x.abs()));
    x + r_max + h.gain() * (2.0 * x)
}

#[test]
fn with_no_rate_it_is_h() {
    let mut rng = Rng::new(41);
    for _ in 0..20 {
        let (r, w) = random_parameters(&mut rng, 8);
        let mut rate = RateDependentHysteresis::new(&r, &w, 0.0, TS).unwrap();
        let mut h = HysteresisOperator::new(&r, &w).unwrap();
        // the same plays; the sums may round in another order
        let bound = 8.0 * f64::EPSILON * w.iter().sum::<f64>() * 1000.0;
        for u in random_input(&mut rng, 500, 400.0) {
            let (a, b) = (rate.step(u), h.step(u));
            assert!((a - b).abs() <= bound, "{a} vs {b}");
            assert_eq!(rate.play_states(), h.play_states());
        }
    }
}

#[test]
fn a_step_is_continuous_and_non_decreasing_in_its_input() {
    let mut rng = Rng::new(42);
    for _ in 0..50 {
        let (h, amplitude) = random_operator(&mut rng);
        let states = h.play_states().len() as f64;
        let points = 2000;
        let du = 2.0 * amplitude / points as f64;
        let mut previous = h.output_at(-amplitude);
        for k in 1..=points {
            let u = -amplitude + k as f64 * du;
            let y = h.output_at(u);
            // slopes lie in [0, Σ w_i (1 + g)]; each output carries n
            // roundings of the scale
            let weights_sum = h_weights_sum(&h);
            let r_max = *h.thresholds().last().unwrap();
            let rounding = 8.0 * states * f64::EPSILON * weights_sum * scale(&h, r_max, u);
            assert!(y >= previous - rounding, "u = {u}: {y} after {previous}");
            assert!(
                y - previous <= weights_sum * (1.0 + h.gain()) * du + rounding,
                "u = {u}: a jump of {}",
                y - previous
            );
            previous = y;
        }
    }
}

/// `Σ w_i`: the slope when every play moves, over `1 ± g`.
fn h_weights_sum(h: &RateDependentHysteresis) -> f64 {
    h.weights().iter().sum()
}

#[test]
fn the_inverse_reaches_the_target_and_the_state_of_the_step() {
    let mut rng = Rng::new(43);
    for _ in 0..40 {
        let (mut forward, amplitude) = random_operator(&mut rng);
        let n = forward.play_states().len() as f64;
        let r_max = *forward.thresholds().last().unwrap();
        let weights_sum = h_weights_sum(&forward);
        // the smallest slope off the flat pieces: one play's, w_i (1 − g)
        let slope = forward
            .weights()
            .iter()
            .filter(|&&w| w > 0.0)
            .fold(f64::INFINITY, |m, &w| m.min(w))
            * (1.0 - forward.gain());
        for u in random_input(&mut rng, 400, amplitude) {
            let mut inverse = forward.clone();
            let before = forward.clone();
            let y = forward.step(u);
            let found = inverse.invert(y);
            // y is known to n roundings of the scale; off a flat piece
            // the input to that over the smallest slope
            let s = scale(&before, r_max, u);
            let rounding = 8.0 * n * f64::EPSILON * weights_sum * s;
            let again = before.output_at(found);
            assert!(
                (again - y).abs() <= rounding,
                "y = {y}, W(W⁻¹(y)) = {again}"
            );
            // on a flat piece every weighted play is flat: the same states
            for ((a, b), w) in forward
                .play_states()
                .iter()
                .zip(inverse.play_states())
                .zip(forward.weights())
            {
                if *w > 0.0 {
                    assert!(
                        (a - b).abs() <= (1.0 + forward.gain()) * rounding / slope,
                        "{a} vs {b}"
                    );
                }
            }
        }
    }
}

#[test]
fn inverse_then_forward_reaches_any_target() {
    let mut rng = Rng::new(44);
    for _ in 0..40 {
        let (h, amplitude) = random_operator(&mut rng);
        let n = h.play_states().len() as f64;
        let weights_sum = h_weights_sum(&h);
        for _ in 0..50 {
            let y = rng.uniform(-1.2, 1.2) * weights_sum * amplitude;
            let mut inverse = h.clone();
            let u = inverse.invert(y);
            let s = scale(&h, *h.thresholds().last().unwrap(), u);
            let reached = h.output_at(u);
            assert!(
                (reached - y).abs() <= 8.0 * n * f64::EPSILON * weights_sum * s,
                "target {y}, reached {reached}"
            );
        }
    }
}

#[test]
fn a_non_finite_sample_changes_nothing() {
    let (r, w) = (vec![0.0, 10.0, 30.0], vec![0.5, 0.3, 0.2]);
    let mut h = RateDependentHysteresis::new(&r, &w, 0.5 * TS, TS).unwrap();
    for u in [5.0, 40.0, -12.0] {
        h.step(u);
    }
    h.invert(3.0);
    let before = h.clone();
    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        assert!(h.step(bad).is_nan());
        assert!(h.invert(bad).is_nan());
        assert_eq!(h, before);
    }
}

#[test]
fn bad_parameters_are_refused() {
    let r = [0.0, 10.0, 30.0];
    let refused =
        |r: &[f64], w: &[f64], beta: f64| RateDependentHysteresis::new(r, w, beta, TS).unwrap_err();
    assert!(matches!(
        refused(&r, &[0.5, -0.1, 0.2], 0.0),
        ParameterError::NegativeWeight { index: 1, .. }
    ));
    assert!(matches!(
        refused(&r, &[0.0, 0.1, 0.2], 0.0),
        ParameterError::PartialSumNotPositive { index: 0, .. }
    ));
    for beta in [-1e-6, TS, 2.0 * TS, f64::NAN] {
        let e = refused(&r, &[0.5, 0.1, 0.2], beta);
        assert!(
            matches!(
                e,
                ParameterError::OutOfHalfOpenRange {
                    field: "rate_gain",
                    ..
                }
            ),
            "{e}"
        );
    }
    assert!(matches!(
        refused(&[0.0, 10.0], &[0.5, 0.1, 0.2], 0.0),
        ParameterError::LengthMismatch { .. }
    ));
    assert!(matches!(
        refused(&[1.0, 10.0, 30.0], &[0.5, 0.1, 0.2], 0.0),
        ParameterError::FirstThresholdNotZero { .. }
    ));
}

// The rate gain in the model: the model file's `hysteresis.rate_gain`

use mfcbeam::identification::{
    identify_records, search_rate_gain, FitRecord, IdentificationSettings, SearchCriterion,
};
use mfcbeam::operators::model::{HysteresisCreepModel, ModelFile};
use mfcbeam::operators::traits::{Operator, Snapshot};
use mfcbeam::realtime::{Compensator, CompensatorSettings, DynamicsParameters};
use mfcbeam::suite::records::{generate, RecordSettings};

/// `H` of `h`'s parameters as a model file with rate gain `β`.
fn model_file(h: &RateDependentHysteresis, rate_gain: f64) -> ModelFile {
    serde_json::from_value(serde_json::json!({
        "sample_time": TS,
        "hysteresis": {
            "thresholds": h.thresholds(),
            "weights": h.weights(),
            "rate_gain": rate_gain,
        },
    }))
    .unwrap()
}

/// The model's `H` with a rate gain is the operator: the same play states
/// (the same operations), the outputs to the rounding of their sums.
#[test]
fn the_model_steps_the_rate_dependent_operator() {
    let mut rng = Rng::new(0x97);
    for _ in 0..40 {
        let (h, r_max) = random_operator(&mut rng);
        let beta = h.gain() * TS;
        let mut model = HysteresisCreepModel::from_file(&model_file(&h, beta)).unwrap();
        // both virgin
        let mut h = RateDependentHysteresis::new(h.thresholds(), h.weights(), beta, TS).unwrap();
        let sum = h_weights_sum(&h);
        for u in random_input(&mut rng, 300, 1.5 * r_max) {
            let (a, b) = (h.step(u), model.step(u));
            let scale = (h.thresholds().len() as f64) * sum * (u.abs() + r_max);
            assert!((a - b).abs() <= 4.0 * f64::EPSILON * scale, "{a} vs {b}");
            assert_eq!(h.play_states(), model.hysteresis().play_states());
        }
    }
}

/// Stopped, written out with its last input and read back, the model goes
/// on as if it had never stopped, bit for bit; without the last input its
/// next step has no rate.
#[test]
fn the_last_input_is_part_of_the_state() {
    let mut rng = Rng::new(0x98);
    let (h, r_max) = random_operator(&mut rng);
    let file = model_file(&h, 0.5 * TS);
    let u = random_input(&mut rng, 400, r_max);
    let mut whole = HysteresisCreepModel::from_file(&file).unwrap();
    let expected: Vec<f64> = u.iter().map(|&v| whole.step(v)).collect();
    let mut first = HysteresisCreepModel::from_file(&file).unwrap();
    for &v in &u[..200] {
        first.step(v);
    }
    let saved = first.to_file();
    assert_eq!(saved.hysteresis.last_input, Some(u[199]));
    let json = serde_json::to_string(&saved).unwrap();
    let mut resumed =
        HysteresisCreepModel::from_file(&serde_json::from_str(&json).unwrap()).unwrap();
    for (k, &v) in u.iter().enumerate().skip(200) {
        assert_eq!(
            resumed.step(v).to_bits(),
            expected[k].to_bits(),
            "sample {k}"
        );
    }
    // the snapshot carries it too
    let mut again = HysteresisCreepModel::from_file(&file).unwrap();
    again.set_state(&Snapshot::state(&first)).unwrap();
    assert_eq!(again.step(u[200]).to_bits(), expected[200].to_bits());
    // forgotten, the first step after the restart has no rate
    let mut forgot = saved.clone();
    forgot.hysteresis.last_input = None;
    let mut m = HysteresisCreepModel::from_file(&forgot).unwrap();
    let mut no_rate = HysteresisCreepModel::from_file(&saved.clone().hysteresis_part()).unwrap();
    no_rate.set_last_input(Some(u[200])).unwrap();
    assert_eq!(m.step(u[200]).to_bits(), no_rate.step(u[200]).to_bits());
}

#[test]
fn a_bad_rate_gain_or_last_input_is_refused() {
    let mut rng = Rng::new(0x99);
    let (h, _) = random_operator(&mut rng);
    for bad in [-1e-6, TS, 2.0 * TS, f64::NAN, f64::INFINITY] {
        // (JSON has no NaN: the parameters themselves)
        let file = model_file(&h, 0.0);
        let parameters = mfcbeam::realtime::ModelParameters {
            rate_gain: bad,
            ..file.parameters()
        };
        let e = parameters.validate().unwrap_err();
        assert!(e.to_string().contains("hysteresis.rate_gain"), "{e}");
        if bad.is_finite() {
            let e = HysteresisCreepModel::from_file(&model_file(&h, bad)).unwrap_err();
            assert!(e.to_string().contains("hysteresis.rate_gain"), "{e}");
        }
    }
    let mut file = model_file(&h, 0.0);
    file.hysteresis.last_input = Some(1.0);
    let e = HysteresisCreepModel::from_file(&file).unwrap_err();
    assert!(e.to_string().contains("hysteresis.last_input"), "{e}");
    let mut file = model_file(&h, 0.5 * TS);
    file.hysteresis.last_input = Some(f64::NAN);
    assert!(HysteresisCreepModel::from_file(&file).is_err());
    // the compensator inverts H by (22): not yet a rate-dependent H
    let file = model_file(&h, 0.5 * TS);
    let e = Compensator::<f64, mfcbeam::prelude::Heap>::from_file(
        &file,
        CompensatorSettings::default(),
    )
    .unwrap_err();
    assert!(e.to_string().contains("hysteresis.rate_gain"), "{e}");
}

/// The synthetic lab records (thresholds with `β = 2·10⁻⁵ s`, `T_s =
/// 10⁻⁴ s`, creep, an asymmetric `S`, a resonance and the sensor's
/// low-pass) at 20, 40 and 100 Hz: fitted on 20 and 40 Hz with `G` known,
/// the search finds `β` near the truth, and the model predicts the 100 Hz
/// record better than the rate-independent one.
#[test]
fn the_rate_gain_is_found_and_predicts_a_faster_record() {
    let settings = RecordSettings {
        cycles: 12,
        ..RecordSettings::default()
    };
    let records = generate(&settings);
    let ts = settings.sample_time;
    let fit: Vec<FitRecord> = records[..2]
        .iter()
        .map(|r| FitRecord {
            u: &r.u,
            y: &r.y,
            fit_from: Some(1000),
        })
        .collect();
    // the truth's thresholds, eigenvalues and (as S⁻¹'s kinks) the images
    // of S's: the class holds the actuator but for its last weight (−0.01,
    // where the fit keeps the weights non-negative)
    let actuator = settings.actuator_model();
    let creep = actuator.creep.as_ref().unwrap();
    let s = actuator.superposition.as_ref().unwrap();
    let truth_s = mfcbeam::realtime::Superposition::<f64, mfcbeam::prelude::Heap>::new(
        &s.thresholds,
        &s.weights,
    )
    .unwrap();
    let kinks = s
        .thresholds
        .iter()
        .filter(|&&r| r != 0.0)
        .map(|&r| truth_s.apply(r))
        .collect();
    let identification = IdentificationSettings {
        hysteresis_thresholds: Some(actuator.hysteresis.thresholds.clone()),
        creep_thresholds: Some(creep.thresholds.clone()),
        eigenvalues: Some(creep.eigenvalues.clone()),
        superposition_kinks: Some(kinks),
        offset_per_record: true,
        dynamics: Some(DynamicsParameters {
            low_pass: settings.sensor_low_pass,
            resonance: settings.resonance,
            delay_fraction: 0.0,
        }),
        ..IdentificationSettings::default()
    };
    let start = std::time::Instant::now();
    let (found, search) = search_rate_gain(&fit, ts, &identification, &[]).unwrap();
    eprintln!("{search}{:.1} s", start.elapsed().as_secs_f64());
    assert_eq!(search.criterion, SearchCriterion::Fit);
    let without = identify_records(&fit, ts, &identification).unwrap();
    // 100 Hz from its own start: each model's offset set on the record
    let fast = &records[2];
    let error = |model: &HysteresisCreepModel| {
        let from = (settings.hold / ts) as usize;
        let y = model.clone().run(&fast.u);
        let e: Vec<f64> = (from..y.len()).map(|k| y[k] - fast.y[k]).collect();
        let mean = e.iter().sum::<f64>() / e.len() as f64;
        let rms = (e.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / e.len() as f64).sqrt();
        100.0 * rms / (2.0 * settings.amplitude)
    };
    let (with_rate, rate_independent) = (error(&found.model), error(&without.model));
    eprintln!(
        "100 Hz: {with_rate:.4} % with β = {:e} s, {rate_independent:.4} % without",
        search.chosen
    );
    // What remains of the fit (0.12 % against 0.05 % of noise; 0.09–0.10 %
    // without noise) is the model class's: the creep's unknown past and
    // the records' offsets, which move S's kinks on the output axis. Found
    // to 2 % of the truth without noise and history, to 16 % with them
    // (this seed); the 100 Hz error falls from 0.27–0.28 % to 0.18–0.20 %.
    assert!(
        (0.75..=1.25).contains(&(search.chosen / settings.rate_gain)),
        "{}",
        search.chosen
    );
    assert!(with_rate < 0.8 * rate_independent);
}
