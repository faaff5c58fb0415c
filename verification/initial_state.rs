//! The unknown initial memory: on synthetic records whose history is known
//! (a random drive, then a hold near 0 V that keeps its memory in the
//! plays), the state estimated from the hold and the first 0.2 s of motion
//! predicts the rest of the record to the noise level, where the virgin
//! state does not; the estimated state is admissible and the compensator
//! started in it inverts the model to rounding.

use mfcbeam::identification::{estimate_state, StateEstimate, StateSettings};
use mfcbeam::operators::model::{HysteresisCreepModel, ModelFile};
use mfcbeam::prelude::*;
use mfcbeam::realtime::preview;
use mfcbeam::suite::conformance::tolerance;
use mfcbeam::suite::records::{generate, Drive, RecordSettings, SyntheticRecord};

fn rms(x: impl Iterator<Item = f64>) -> f64 {
    let (s, n) = x.fold((0.0, 0usize), |(s, n), v| (s + v * v, n + 1));
    (s / n as f64).sqrt()
}

/// Records of the lab protocol with an unknown past: a random history,
/// 1 s held at 0 V, then 2 s of tracking; rate-independent (the model
/// class holds the truth).
fn records(noise: f64) -> (RecordSettings, Vec<SyntheticRecord>) {
    let settings = RecordSettings {
        rates: vec![20.0, 40.0],
        rate_gain: 0.0,
        hold: 1.0,
        hold_level: Some(0.0),
        drive: Drive::Tracking,
        tracking_range: 0.3,
        noise,
        seed: 97,
        ..RecordSettings::default()
    };
    let records = generate(&settings);
    (settings, records)
}

/// `model` run over `u`, the offset added.
fn run(model: &ModelFile, u: &[f64]) -> Vec<f64> {
    let mut m = HysteresisCreepModel::from_file(model).unwrap();
    u.iter().map(|&v| m.step(v)).collect()
}

#[test]
fn the_start_state_of_a_record_is_its_actuator() {
    let (_, records) = records(0.0);
    for r in &records {
        let y = run(&r.start, &r.u);
        // noise 0: the record is the model from its start state, plus the
        // offset, to the rounding of outputs of size 100 over the record
        let tolerance = 1e3 * f64::EPSILON * 100.0;
        for (k, (a, b)) in y.iter().zip(&r.y).enumerate() {
            assert!(
                (a + r.offset - b).abs() <= tolerance,
                "{} Hz, sample {k}",
                r.rate
            );
        }
    }
}

/// The window: the hold and the first 0.2 s of motion.
fn window(settings: &RecordSettings) -> usize {
    ((settings.hold + 0.2) / settings.sample_time).round() as usize
}

fn estimate(r: &SyntheticRecord, until: usize) -> StateEstimate {
    estimate_state(
        &r.start.clone().without_state(),
        &r.u,
        &r.y,
        &StateSettings {
            until: Some(until),
            ..StateSettings::default()
        },
    )
    .unwrap()
}

#[test]
fn the_estimated_memory_predicts_the_rest_of_the_record() {
    let (settings, records) = records(5e-4);
    let sigma = settings.noise * 2.0 * settings.amplitude;
    let until = window(&settings);
    for r in &records {
        let estimate = estimate(r, until);
        let truth: Vec<f64> = run(&r.start, &r.u).iter().map(|y| y + r.offset).collect();
        let predicted = run(&estimate.model, &r.u);
        // the virgin state, with the estimated offset: what the record's
        // memory is worth
        let mut virgin = r.start.clone().without_state();
        virgin.offset = estimate.model.offset;
        let virgin = run(&virgin, &r.u);
        let after = |x: &[f64]| rms((until..r.u.len()).map(|k| x[k] - truth[k]));
        eprintln!(
            "{} Hz: window rms {:.4} (prior {:.4}), noise {sigma:.4}; after the window, against the noise-free truth: estimate {:.4}, virgin {:.4}; {} iterations",
            r.rate,
            estimate.rms,
            estimate.prior_rms,
            after(&predicted),
            after(&virgin),
            estimate.iterations,
        );
        // the window is fitted to its noise
        assert!(estimate.rms <= 1.05 * sigma, "window rms {}", estimate.rms);
        // after it, the prediction is within the noise of the noise-free
        // output (the truth's own class: rate gain 0)
        assert!(after(&predicted) <= sigma, "{}", after(&predicted));
        // where the virgin state misses by several noise levels
        assert!(after(&virgin) >= 2.0 * sigma, "{}", after(&virgin));
        // the plays the run stays inside keep their memory: those the
        // history moved beyond the run's reach
        assert!(!estimate.unwiped.is_empty());
    }
}

#[test]
fn the_compensator_started_in_the_estimate_inverts_the_model() {
    let (settings, records) = records(5e-4);
    let until = window(&settings);
    let r = &records[0];
    let estimate = estimate(r, until);
    // W[u] from the estimated state, and W⁻¹ from the same state on it
    // (previewed by the lag of G)
    let targets = run(&estimate.model, &r.u);
    let d = HysteresisCreepModel::from_file(&estimate.model)
        .unwrap()
        .preview();
    let a = settings.amplitude;
    let mut compensator = Compensator::<f64, Heap>::from_file(
        &estimate.model,
        CompensatorSettings::with_limits(-2.0 * a, 2.0 * a),
    )
    .unwrap();
    let y_max = targets.iter().fold(0.0f64, |m, y| m.max(y.abs()));
    let tolerance = tolerance::compensator(&estimate.model, a, y_max);
    for k in 0..r.u.len() - d {
        let v = compensator.compensate(preview(&targets, d, k)).u;
        assert!(
            (v - r.u[k]).abs() <= tolerance,
            "sample {k}: {v} against {} (tolerance {tolerance})",
            r.u[k]
        );
    }
}
