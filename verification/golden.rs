//! The golden regression net: every scenario recomputed and compared with
//! `golden/` within the manifest's tolerances, the files' SHA-256 checked,
//! and proof that the net catches small real faults — injected through the
//! scenario context's plant factory, as any alternative implementation of
//! `W` would be.
//!
//! Regenerating the golden files is explicit: `mfcbeam golden --write`.

use std::path::Path;

use mfcbeam::operators::creep::CreepOperator;
use mfcbeam::operators::hysteresis::HysteresisOperator;
use mfcbeam::prelude::*;
use mfcbeam::suite::conformance::heap_model;
use mfcbeam::suite::golden::{
    check_golden, declared_columns, read_manifest, sha256_hex, ColumnSpec,
};
use mfcbeam::suite::scenarios::{ScenarioContext, SCENARIOS};

const DIR: &str = "golden";

/// Files (and columns) that differ when `ctx` recomputes the scenarios.
fn differences(ctx: &ScenarioContext) -> Vec<String> {
    check_golden(Path::new(DIR), ctx)
        .unwrap()
        .into_iter()
        .map(|d| format!("{}: {}", d.file, d.what))
        .collect()
}

#[test]
fn golden_traces_reproduce_within_their_tolerances() {
    let m = read_manifest(&Path::new(DIR).join("manifest.json")).unwrap();
    assert_eq!(m.traces.len(), SCENARIOS.len());
    let mut total = 0u64;
    for t in &m.traces {
        let bytes = std::fs::read(Path::new(DIR).join(&t.file)).unwrap();
        total += bytes.len() as u64;
        assert_eq!(
            sha256_hex(&bytes),
            t.sha256,
            "{}: file differs from its manifest entry",
            t.file
        );
        assert!(t.provenance.contains("mfcbeam"));
        // the manifest's columns are exactly those the scenario declares
        let declared: Vec<ColumnSpec> = declared_columns(&t.id).unwrap();
        assert_eq!(t.columns, declared, "{}: manifest columns", t.id);
        assert!(t.columns.iter().all(|c| !c.justification.is_empty()));
    }
    assert!(total < 20 << 20, "golden/ must stay under 20 MB");
    let failed = differences(&ScenarioContext::nominal());
    assert!(failed.is_empty(), "golden differences: {failed:?}");
}

/// The creep step with `v_k` instead of `v_{k−1}`: a `W` that advances the
/// creep state before reading its output.
struct CreepWithoutDelay {
    h: HysteresisOperator,
    c: CreepOperator,
}

impl Operator for CreepWithoutDelay {
    fn step(&mut self, v: f64) -> f64 {
        self.h.step(v) + self.c.advance(v)
    }
    fn reset(&mut self) {
        self.h.reset();
        self.c.reset();
    }
}
impl ActuatorModel for CreepWithoutDelay {}

/// A context whose plant `W` is built from a perturbed model file.
fn perturbed(f: fn(&mut ModelFile)) -> ScenarioContext {
    let mut ctx = ScenarioContext::nominal();
    ctx.plant = Box::new(move |file: &ModelFile| {
        let mut file = file.clone();
        f(&mut file);
        heap_model(&file)
    });
    ctx
}

/// Small deliberate faults each make at least one golden comparison fail.
#[test]
fn the_golden_net_catches_small_faults() {
    // 1. creep using v_k instead of v_{k−1}
    let mut ctx = ScenarioContext::nominal();
    ctx.plant = Box::new(|file: &ModelFile| {
        let w = HysteresisCreepModel::from_file(file)?;
        Ok(Box::new(CreepWithoutDelay {
            h: w.hysteresis().clone(),
            c: w.creep().unwrap().clone(),
        }) as Box<dyn ActuatorModel>)
    });
    let failed = differences(&ctx);
    eprintln!("creep with v_k: {failed:?}");
    assert!(!failed.is_empty());
    // 2. one threshold moved by 1e-6 relative
    let failed = differences(&perturbed(|m| m.hysteresis.thresholds[5] *= 1.0 + 1e-6));
    eprintln!("threshold r_5 (1 + 1e-6): {failed:?}");
    assert!(!failed.is_empty());
    // 3. one weight's sign flipped (w_11 = −0.01 → +0.01 keeps (11))
    let failed = differences(&perturbed(|m| {
        m.hysteresis.weights[11] = -m.hysteresis.weights[11]
    }));
    eprintln!("weight w_11 sign: {failed:?}");
    assert!(!failed.is_empty());
}
