//! A non-finite sample never enters a state. The compensator holds its
//! previous output and flags the sample as a fault (not as saturation); the
//! plant that receives the held value stays matched, so `W[W⁻¹[y]] = y`
//! resumes with the next finite target. `W` (and `H`, `C`) take a
//! non-finite input as the previous input held. The fast operators and the
//! naive references agree on all of it.

use mfcbeam::operators::nominal::nominal_model_file;
use mfcbeam::prelude::*;
use mfcbeam::suite::conformance::{heap_compensator, reference_compensator, CompensatorFactory};

/// Targets with NaN and ±inf at known places.
fn targets() -> (Vec<f64>, Vec<usize>) {
    let mut t: Vec<f64> = (0..3000)
        .map(|k| 300.0 * (k as f64 * 3e-3).sin() + 100.0 * (k as f64 * 0.011).cos())
        .collect();
    let bad = vec![0, 17, 18, 19, 500, 1999, 2999];
    for (i, &k) in bad.iter().enumerate() {
        t[k] = [f64::NAN, f64::INFINITY, f64::NEG_INFINITY][i % 3];
    }
    (t, bad)
}

fn check(factory: &CompensatorFactory, who: &str) -> Vec<f64> {
    let file = nominal_model_file();
    let mut comp = factory(&file, CompensatorSettings::default()).unwrap();
    let mut plant = HysteresisCreepModel::from_file(&file).unwrap();
    let (t, bad) = targets();
    let mut last_u = 0.0;
    let mut us = Vec::new();
    for (k, &target) in t.iter().enumerate() {
        let c = comp.compensate(target);
        assert!(c.u.is_finite(), "{who}: sample {k}");
        let y = plant.step(c.u);
        if bad.contains(&k) {
            assert!(c.fault && !c.saturated, "{who}: sample {k} not flagged");
            assert_eq!(
                c.u, last_u,
                "{who}: sample {k}: the previous output is held"
            );
        } else {
            assert!(!c.fault, "{who}: sample {k} flagged");
            // the identity holds again right after every bad sample
            assert!(
                (y - target).abs() < 1e-9,
                "{who}: sample {k}: {y} vs {target}"
            );
        }
        last_u = c.u;
        us.push(c.u);
    }
    us
}

#[test]
fn non_finite_targets_are_held_flagged_and_the_identity_resumes() {
    let fast = check(&heap_compensator, "fast");
    let naive = check(&reference_compensator, "reference");
    for (a, b) in fast.iter().zip(&naive) {
        assert!((a - b).abs() < 1e-9);
    }
}

#[test]
fn a_non_finite_input_to_w_is_the_previous_input_held() {
    let u: Vec<f64> = (0..2000).map(|k| 700.0 * (k as f64 * 4e-3).sin()).collect();
    let mut with_nan = u.clone();
    let mut held = u.clone();
    for k in [5usize, 6, 800, 1500] {
        with_nan[k] = if k % 2 == 0 {
            f64::NAN
        } else {
            f64::NEG_INFINITY
        };
        held[k] = held[k - 1];
    }
    let a = nominal_model().run(&with_nan);
    let b = nominal_model().run(&held);
    assert_eq!(a, b, "W");
    let h = nominal_model().hysteresis().clone();
    assert_eq!(h.clone().run(&with_nan), h.clone().run(&held), "H");
    let c = nominal_model().creep().unwrap().clone();
    assert_eq!(c.clone().run(&with_nan), c.clone().run(&held), "C");
    let mut naive =
        mfcbeam::suite::reference::NaiveModel::from_file(&nominal_model_file()).unwrap();
    let n = naive.run(&with_nan);
    assert!(
        n.iter().zip(&a).all(|(x, y)| (x - y).abs() < 1e-9),
        "reference W"
    );
    // and the state stays finite
    let mut w = nominal_model();
    w.run(&with_nan);
    assert!(w.state().hysteresis.iter().all(|x| x.is_finite()));
}
