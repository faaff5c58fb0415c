//! The paper's nominal setting: the nominal model file, the state count of
//! section 3, and the compensated staircase of Fig. 10 (`W[W⁻¹[ς]] = ς` over
//! a 20 s staircase at the paper's order).

use std::path::Path;

use mfcbeam::io::read_model_file;
use mfcbeam::operators::nominal::{nominal_model_file, SAMPLE_TIME};
use mfcbeam::prelude::*;
use mfcbeam::suite::signal::Staircase;

/// `golden/nominal_model.json` is the nominal model (`docs/MATHEMATICS.md` §8), bit for
/// bit (regenerate with `mfcbeam nominal --output golden/nominal_model.json`).
#[test]
fn golden_nominal_model_file_is_spec_section_8() {
    let file = read_model_file(Path::new("golden/nominal_model.json")).unwrap();
    assert_eq!(file, nominal_model_file());
    let w = HysteresisCreepModel::from_file(&file).unwrap();
    let r = w.hysteresis().thresholds();
    for (i, &ri) in r.iter().enumerate() {
        assert_eq!(
            ri,
            (i as f64 * 1000.0) / 12.0,
            "(23) evaluated as (i r_max)/(n+1)"
        );
    }
    assert_eq!(
        w.creep().unwrap().eigenvalues(),
        &[500.0, 50.0, 5.0, 0.5, 0.05]
    );
    assert_eq!(w.sample_time(), 2e-4);
}

/// Section 3: `(n_C+1) m + n_H + 1` states, `n_H + n_C + 2` thresholds and
/// weights, `m` eigenvalues — 72, 24 and 5 at the paper's order.
#[test]
fn paper_order_state_count() {
    let w = nominal_model();
    let s = w.state();
    let creep_states: usize = s.creep.as_ref().unwrap().iter().map(Vec::len).sum();
    assert_eq!(creep_states + s.hysteresis.len(), 72);
    assert_eq!(
        w.hysteresis().thresholds().len() + w.creep().unwrap().thresholds().len(),
        24
    );
}

/// Fig. 10: the paper-order compensator in front of `W` reproduces a 20 s
/// staircase through the full loop with max error below 1e-9 V, inside the
/// supply limits (no sample saturated).
#[test]
fn compensated_staircase_is_reproduced_through_w() {
    let w = nominal_model();
    // 16 steps of 1.25 s (0.1 s transitions) = 20 s: 0 → 500 → −500 → 0 V.
    let stairs = Staircase::full_loop(500.0, 4, 0.1, 1.15);
    assert!((stairs.duration() - 20.0).abs() < 1e-9);
    let target = stairs.sample(SAMPLE_TIME);
    let mut comp = w.compensator(CompensatorSettings::default()).unwrap();
    let mut plant = w.clone();
    let mut max_err = 0.0f64;
    let mut max_u = 0.0f64;
    for &t in &target {
        let c = comp.compensate(t);
        assert!(!c.saturated);
        max_u = max_u.max(c.u.abs());
        max_err = max_err.max((plant.step(c.u) - t).abs());
    }
    assert!(max_err < 1e-9, "max error {max_err:e} V");
    // the loop needs most of the supply range: the test exercises every play
    assert!(max_u > 600.0 && max_u < 1000.0, "{max_u}");
    // and without compensation the same staircase is far off (hysteresis and creep)
    let raw = w.clone().run(&target);
    let raw_err = raw
        .iter()
        .zip(&target)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(raw_err > 50.0, "{raw_err}");
}
