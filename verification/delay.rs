//! Dead time: `y_k = S[H + C]_{max(k−d, 0)} + offset`. The delayed output is
//! the undelayed one shifted, bit for bit, in every storage and precision; a
//! run resumed from the model file (its `delay_state`) continues the whole
//! run; a planned target previewed by `d` is met from sample `d` on within
//! the derived rounding bound; bad files and capacities are refused by
//! name; the identification finds a known delay (by the validation
//! records, the held-out samples or the fit) with the symmetric model and
//! with a superposition operator.

use crate::common;

use common::{gaussian, Lcg};
use mfcbeam::identification::{
    identify, search_delay, thresholds_23, IdentificationSettings, Record, SearchCriterion,
};
use mfcbeam::operators::model::SuperpositionData;
use mfcbeam::prelude::*;
use mfcbeam::realtime::{preview_into, Inline, ParameterError, RoundingBounds};
use mfcbeam::realtime::{Model, Real};

/// The nominal model with an asymmetric `S`, an offset and dead time `d`.
fn delayed_nominal(d: usize) -> ModelFile {
    let mut file = nominal_model().to_file().without_state();
    file.superposition = Some(SuperpositionData {
        thresholds: vec![-600.0, -250.0, 0.0, 200.0, 500.0],
        weights: vec![0.3, -0.2, 1.0, -0.35, -0.25],
    });
    file.offset = Some(0.7);
    file.delay = (d > 0).then_some(d);
    file
}

/// Reversals of shrinking amplitude with holds, 3000 samples.
fn input() -> Vec<f64> {
    (0..3000)
        .map(|k| {
            let t = k as f64 / 3000.0;
            let v = 900.0 * (1.0 - 0.8 * t) * (2.0 * std::f64::consts::PI * 5.0 * t).sin();
            if (k / 250) % 4 == 3 {
                (v / 100.0).round() * 100.0
            } else {
                v
            }
        })
        .collect()
}

fn shifted(z: &[f64], d: usize) -> Vec<f64> {
    (0..z.len()).map(|k| z[k.saturating_sub(d)]).collect()
}

#[test]
fn the_output_is_the_memory_part_d_samples_later_bit_for_bit() {
    let u = input();
    let z = HysteresisCreepModel::from_file(&delayed_nominal(0))
        .unwrap()
        .run(&u);
    let z32 = Model::<f32, Inline<12, 60, 5, 4>>::from_file(&delayed_nominal(0))
        .unwrap()
        .run(&u);
    for d in [1, 3, 4] {
        let file = delayed_nominal(d);
        let heap = HysteresisCreepModel::from_file(&file).unwrap().run(&u);
        let inline = Model::<f64, Inline<12, 60, 5, 4>>::from_file(&file)
            .unwrap()
            .run(&u);
        let single = Model::<f32, Inline<12, 60, 5, 4>>::from_file(&file)
            .unwrap()
            .run(&u);
        assert_eq!(heap, shifted(&z, d), "heap, d = {d}");
        assert_eq!(inline, heap, "inline, d = {d}");
        assert_eq!(single, shifted(&z32, d), "f32, d = {d}");
        // and what the naive reference (a queue, not a ring) gives
        let naive = mfcbeam::suite::reference::NaiveModel::from_file(&file)
            .unwrap()
            .run(&u);
        let scale = 1e-12 * naive.iter().fold(1.0f64, |m, v| m.max(v.abs()));
        for (a, b) in naive.iter().zip(&heap) {
            assert!((a - b).abs() <= scale, "{a} vs {b}");
        }
    }
}

#[test]
fn a_run_resumed_from_the_model_file_continues_the_whole_run() {
    let u = input();
    for d in [1, 2, 7] {
        let file = delayed_nominal(d);
        let whole = HysteresisCreepModel::from_file(&file).unwrap().run(&u);
        for split in [1, d, 1000] {
            let mut first = HysteresisCreepModel::from_file(&file).unwrap();
            first.run(&u[..split]);
            let saved = first.to_file();
            assert_eq!(saved.delay_state.as_ref().map(Vec::len), Some(d));
            // through JSON, as a program that resumes would read it
            let text = serde_json::to_string(&saved).unwrap();
            let back: ModelFile = serde_json::from_str(&text).unwrap();
            let rest = HysteresisCreepModel::from_file(&back)
                .unwrap()
                .run(&u[split..]);
            assert_eq!(rest, whole[split..], "d = {d}, split at {split}");
        }
    }
    // reset forgets the line: the next run starts as the first did
    let mut m = HysteresisCreepModel::from_file(&delayed_nominal(2)).unwrap();
    let first = m.run(&u[..50]);
    m.reset();
    assert_eq!(m.run(&u[..50]), first);
    assert_eq!(m.delay_state(), m.clone().to_file().delay_state);
}

#[test]
fn bad_dead_times_are_refused_by_name() {
    let mut file = delayed_nominal(3);
    file.delay_state = Some(vec![1.0, 2.0]);
    let e = HysteresisCreepModel::from_file(&file).unwrap_err();
    assert!(e.to_string().contains("delay_state"), "{e}");
    file.delay_state = Some(vec![1.0, f64::NAN, 2.0]);
    let e = HysteresisCreepModel::from_file(&file).unwrap_err();
    assert!(e.to_string().contains("delay_state"), "{e}");
    file.delay_state = None;
    let e = Model::<f64, Inline<12, 60, 5, 2>>::new(&file.parameters().validate().unwrap())
        .unwrap_err();
    assert_eq!(
        e,
        ParameterError::ExceedsCapacity {
            field: "delay",
            capacity: 2,
            found: 3
        }
    );
    for bad in ["-1", "1.5", "\"2\""] {
        let text = format!(
            r#"{{"sample_time": 2e-4, "hysteresis": {{"thresholds": [0], "weights": [1]}}, "delay": {bad}}}"#
        );
        assert!(
            serde_json::from_str::<ModelFile>(&text).is_err(),
            "{bad} accepted"
        );
    }
}

#[test]
fn a_non_finite_input_never_enters_the_line() {
    let file = delayed_nominal(2);
    let mut m = HysteresisCreepModel::from_file(&file).unwrap();
    let mut held = m.clone();
    m.run(&[100.0, 200.0]);
    held.run(&[100.0, 200.0]);
    let a = m.run(&[f64::NAN, f64::INFINITY, 150.0]);
    let b = held.run(&[200.0, 200.0, 150.0]);
    assert_eq!(a, b);
    assert!(a.iter().all(|y| y.is_finite()));
}

/// `W[W⁻¹[y_d]] = y_d` from sample `d` on for a target previewed by `d`,
/// within `RoundingBounds::identity` at each precision's `ε` (the dead time
/// moves values, it adds no rounding).
#[test]
fn a_previewed_target_is_met_from_sample_d_on() {
    fn worst<T: Real>(file: &ModelFile, y_d: &[f64]) -> f64 {
        type Size = Inline<12, 60, 5, 4>;
        let d = file.delay.unwrap_or(0);
        let settings = CompensatorSettings::unlimited();
        let mut comp =
            Compensator::<T, Size>::new(&file.parameters().validate().unwrap(), settings).unwrap();
        assert_eq!(comp.delay(), d);
        let mut plant = Model::<T, Size>::new(&file.parameters().validate().unwrap()).unwrap();
        let mut targets = vec![0.0; y_d.len()];
        preview_into(y_d, d, &mut targets).unwrap();
        let u: Vec<T> = targets
            .iter()
            .map(|&t| comp.compensate(T::from_f64(t)).u)
            .collect();
        let y: Vec<f64> = u.iter().map(|&v| plant.step(v).to_f64()).collect();
        (d..y.len())
            .map(|k| (y[k] - y_d[k]).abs())
            .fold(0.0, f64::max)
    }
    let y_d: Vec<f64> = mfcbeam::suite::signal::Staircase::full_loop(500.0, 4, 0.05, 0.2)
        .sample(2e-4)
        .iter()
        .map(|v| v + 0.7)
        .collect();
    let file = delayed_nominal(3);
    let u_max = 1000.0;
    let y_max = y_d.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for (eps, found) in [
        (f64::EPSILON, worst::<f64>(&file, &y_d)),
        (f32::EPSILON as f64, worst::<f32>(&file, &y_d)),
    ] {
        let bound = RoundingBounds {
            parameters: file.parameters(),
            state_max: u_max,
            eps,
        }
        .identity(u_max, y_max);
        eprintln!("ε = {eps:e}: worst {found:e}, bound {bound:e}");
        assert!(found <= bound, "{found} > {bound}");
    }
    // without the preview the first d samples of each step are missed
    let mut comp = HysteresisCreepModel::from_file(&file)
        .unwrap()
        .compensator(CompensatorSettings::unlimited())
        .unwrap();
    let u: Vec<f64> = y_d.iter().map(|&t| comp.compensate(t).u).collect();
    let y = HysteresisCreepModel::from_file(&file).unwrap().run(&u);
    let late = (3..y.len())
        .map(|k| (y[k] - y_d[k]).abs())
        .fold(0.0, f64::max);
    assert!(late > 1e-3, "{late}");
}

// ---- identification ----

const TS: f64 = 2e-4;

/// Triangles between ±900 V at `rate` Hz for `seconds`, at 5 kHz.
fn triangles(rate: f64, seconds: f64) -> Vec<f64> {
    let n = (seconds / TS) as usize;
    (0..n)
        .map(|k| {
            let phase = (k as f64 * TS * rate) % 1.0;
            900.0
                * if phase < 0.5 {
                    4.0 * phase - 1.0
                } else {
                    3.0 - 4.0 * phase
                }
        })
        .collect()
}

/// A model the default identification represents exactly: 12 plays on the
/// thresholds (23) of `r_max = 900` V, no creep, an offset, dead time 2.
fn representable() -> HysteresisCreepModel {
    let r = thresholds_23(12, 900.0);
    let w = vec![
        0.45, 0.09, 0.08, 0.06, 0.05, 0.04, 0.03, 0.03, 0.02, 0.02, 0.01, -0.01,
    ];
    let parameters = mfcbeam::realtime::ModelParameters {
        sample_time: TS,
        hysteresis: mfcbeam::realtime::HysteresisParameters {
            thresholds: &r,
            weights: &w,
        },
        creep: None,
        superposition: None,
        dynamics: None,
        delay: 2,
        offset: 3.0,
        rate_gain: 0.0,
    };
    HysteresisCreepModel::new(&parameters.validate().unwrap()).unwrap()
}

fn measure(model: &HysteresisCreepModel, u: &[f64], sigma: f64, seed: u64) -> Vec<f64> {
    let clean = model.clone().run(u);
    let noise = gaussian(&mut Lcg(seed), u.len(), sigma);
    clean.iter().zip(&noise).map(|(y, e)| y + e).collect()
}

fn no_creep() -> IdentificationSettings {
    IdentificationSettings {
        creep_operators: 0,
        ..IdentificationSettings::default()
    }
}

/// Exact data and the true dead time: the weights are the truth's to the
/// rounding of a least-squares solve (`ε` times the regressor's condition
/// number and size); one sample off, the fit is orders of magnitude worse.
#[test]
fn a_known_dead_time_gives_the_true_weights() {
    let truth = representable();
    let u = triangles(20.0, 0.5);
    let y = measure(&truth, &u, 0.0, 1);
    let at = |d| {
        identify(
            &u,
            &y,
            TS,
            &IdentificationSettings {
                delay: d,
                ..no_creep()
            },
        )
        .unwrap()
    };
    let right = at(2);
    assert_eq!(right.model.delay(), 2);
    assert_eq!(right.report.delay, 2);
    let tol = right.report.condition_number * f64::EPSILON * u.len() as f64;
    for (a, b) in right
        .model
        .hysteresis()
        .weights()
        .iter()
        .zip(truth.hysteresis().weights())
    {
        assert!((a - b).abs() <= tol, "{a} vs {b} (tol {tol:e})");
    }
    assert!((right.model.offset() - 3.0).abs() <= tol * 900.0);
    let wrong = at(1);
    eprintln!(
        "rms: d = 2 {:e}, d = 1 {:e}",
        right.report.fit.rms, wrong.report.fit.rms
    );
    assert!(wrong.report.fit.rms > 1e6 * right.report.fit.rms.max(1e-12));
    // d beyond the record is refused by name
    let e = identify(
        &u[..5],
        &y[..5],
        TS,
        &IdentificationSettings {
            delay: 5,
            ..no_creep()
        },
    )
    .unwrap_err();
    assert!(e.to_string().starts_with("delay:"), "{e}");
}

/// `auto` with noise: the validation records at 40 and 100 Hz choose the
/// true dead time, so do the held-out samples and, on noisy but faithful
/// data, the fit itself; the table has one row per candidate.
#[test]
fn auto_finds_a_known_dead_time_by_validation_holdout_and_fit() {
    let truth = representable();
    let u20 = triangles(20.0, 1.0);
    let y20 = measure(&truth, &u20, 0.5, 2);
    let (u40, u100) = (triangles(40.0, 0.5), triangles(100.0, 0.5));
    let (y40, y100) = (
        measure(&truth, &u40, 0.5, 3),
        measure(&truth, &u100, 0.5, 4),
    );
    let records = [
        Record {
            name: "40 Hz",
            u: &u40,
            y: &y40,
            from: 0,
            zero: None,
        },
        Record {
            name: "100 Hz",
            u: &u100,
            y: &y100,
            from: 0,
            zero: None,
        },
    ];
    let (id, search) = search_delay(&u20, &y20, TS, &no_creep(), 6, &records).unwrap();
    eprintln!("{search}");
    assert_eq!(search.criterion, SearchCriterion::Validation);
    assert_eq!(search.chosen, 2);
    assert_eq!(id.model.delay(), 2);
    assert_eq!(search.rows.len(), 7);
    assert!(search.rows.iter().all(|r| r.validations.len() == 2));
    // the chosen row's validation errors are within the noise
    let best = &search.rows[2];
    assert!(best.validations.iter().all(|e| e.rms < 0.6), "{search}");
    assert!(search.to_string().contains("* "));

    let holdout = IdentificationSettings {
        holdout: u20.len() / 5,
        ..no_creep()
    };
    let (_, search) = search_delay(&u20, &y20, TS, &holdout, 6, &[]).unwrap();
    assert_eq!(search.criterion, SearchCriterion::Holdout);
    assert_eq!(search.chosen, 2, "{search}");
    let (_, search) = search_delay(&u20, &y20, TS, &no_creep(), 6, &[]).unwrap();
    assert_eq!(search.criterion, SearchCriterion::Fit);
    assert_eq!(search.chosen, 2, "{search}");
}

/// The same with an asymmetric actuator (the nominal `H` and an `S`, no
/// creep: stationary triangles at one rate do not determine creep, and its
/// error at other rates would swamp one sample of delay) fitted with
/// `superposition: 4` on other thresholds and kinks than the truth's: the
/// model class approximates, and the fast record still tells the dead time.
#[test]
fn auto_finds_a_dead_time_with_a_superposition_operator() {
    let mut file = delayed_nominal(2);
    file.creep = None;
    let truth = HysteresisCreepModel::from_file(&file).unwrap();
    let u20 = triangles(20.0, 1.0);
    let y20 = measure(&truth, &u20, 0.5, 5);
    let u100 = triangles(100.0, 0.5);
    let y100 = measure(&truth, &u100, 0.5, 6);
    let settings = IdentificationSettings {
        superposition: 4,
        fit_from: Some(1000),
        ..no_creep()
    };
    let records = [Record {
        name: "100 Hz",
        u: &u100,
        y: &y100,
        from: 1000,
        zero: None,
    }];
    let (id, search) = search_delay(&u20, &y20, TS, &settings, 5, &records).unwrap();
    eprintln!("{}{search}", id.report);
    assert_eq!(search.chosen, 2, "{search}");
    assert!(id.model.superposition().is_some());
}

/// A bank's channels may have different dead times: it reports each, and
/// each channel inverts its memory part as a single compensator does, bit
/// for bit.
#[test]
fn a_bank_reports_each_channels_dead_time() {
    use mfcbeam::operators::bank::CompensatorBank;
    let files = [delayed_nominal(0), delayed_nominal(3)];
    let parameters: Vec<_> = files.iter().map(|f| f.parameters()).collect();
    let settings = CompensatorSettings::unlimited();
    let mut bank = CompensatorBank::<f64>::new(&parameters, settings).unwrap();
    assert_eq!(bank.delays(), &[0, 3]);
    let mut singles: Vec<_> = files
        .iter()
        .map(|f| {
            Compensator::<f64, Heap>::new(&f.parameters().validate().unwrap(), settings).unwrap()
        })
        .collect();
    let mut out = [mfcbeam::realtime::Compensated::<f64>::default(); 2];
    for k in 0..2000 {
        let t = 400.0 * (k as f64 * 3e-3).sin();
        bank.compensate(&[t, t], &mut out).unwrap();
        for (c, single) in singles.iter_mut().enumerate() {
            assert_eq!(out[c], single.compensate(t), "channel {c}, sample {k}");
        }
    }
}
