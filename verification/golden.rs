//! The golden regression net: every scenario recomputed and compared with
//! `golden/` within the manifest's tolerances, the files' SHA-256 checked,
//! and proof that the net catches small real faults.
//!
//! Regenerating the golden files is explicit: `mfcbeam golden --write`.

use std::path::Path;

use mfcbeam::io::Trace;
use mfcbeam::operators::creep::CreepOperator;
use mfcbeam::operators::hysteresis::HysteresisOperator;
use mfcbeam::prelude::*;
use mfcbeam::suite::golden::{
    compare_columns, compute_all, numeric_columns, read_manifest, sha256_hex, Manifest,
};
use mfcbeam::suite::scenarios::{ScenarioContext, Siso, SCENARIOS};

fn manifest() -> Manifest {
    read_manifest(Path::new("golden/manifest.json")).unwrap()
}

/// Columns (per file) outside tolerance when `ctx` recomputes the scenarios.
fn failing_columns(ctx: &ScenarioContext, m: &Manifest) -> Vec<String> {
    let mut failed = Vec::new();
    for (file, trace, _) in compute_all(ctx) {
        let entry = m
            .entry_for_file(&file)
            .expect("manifest lists every scenario");
        let stored =
            numeric_columns(&Trace::read(&Path::new("golden").join(&file)).unwrap()).unwrap();
        let fresh: Vec<(String, Vec<f64>)> = trace
            .columns
            .iter()
            .map(|(n, v)| (n.to_string(), v.clone()))
            .collect();
        assert_eq!(fresh[0].1.len(), entry.rows, "{file}: row count");
        for r in compare_columns(&stored, &fresh, entry) {
            assert!(r.compared, "{file}: column {} missing", r.name);
            if !r.pass() {
                failed.push(format!("{file}:{}", r.name));
            }
        }
    }
    failed
}

#[test]
fn golden_traces_reproduce_within_their_tolerances() {
    let m = manifest();
    assert_eq!(m.traces.len(), SCENARIOS.len());
    let mut total = 0u64;
    for t in &m.traces {
        let bytes = std::fs::read(Path::new("golden").join(&t.file)).unwrap();
        total += bytes.len() as u64;
        assert_eq!(
            sha256_hex(&bytes),
            t.sha256,
            "{}: file differs from its manifest entry",
            t.file
        );
        assert!(t.columns.iter().all(|c| !c.justification.is_empty()));
        assert!(t.provenance.contains("mfcbeam"));
    }
    assert!(total < 20 << 20, "golden/ must stay under 20 MB");
    let failed = failing_columns(&ScenarioContext::nominal(), &m);
    assert!(failed.is_empty(), "golden differences: {failed:?}");
}

/// The creep step with `v_k` instead of `v_{k−1}`: a `W` that advances the
/// creep state before reading its output.
struct CreepWithoutDelay {
    h: HysteresisOperator,
    c: CreepOperator,
}

impl Siso for CreepWithoutDelay {
    fn step(&mut self, v: f64) -> f64 {
        Operator::step(&mut self.h, v) + self.c.advance(v)
    }
}

fn perturbed(f: impl Fn(&mut Vec<f64>, &mut Vec<f64>)) -> ScenarioContext {
    let mut ctx = ScenarioContext::nominal();
    let h = ctx.model.hysteresis();
    let (mut r, mut w) = (h.thresholds().to_vec(), h.weights().to_vec());
    f(&mut r, &mut w);
    let h = HysteresisOperator::new(r, w).unwrap();
    ctx.model =
        HysteresisCreepModel::new(ctx.model.sample_time(), h, ctx.model.creep().cloned()).unwrap();
    ctx
}

/// Small deliberate faults each make at least one golden comparison fail.
#[test]
fn the_golden_net_catches_small_faults() {
    let m = manifest();
    // 1. creep using v_k instead of v_{k−1}
    let mut ctx = ScenarioContext::nominal();
    ctx.plant = Box::new(|w: &HysteresisCreepModel| {
        Box::new(CreepWithoutDelay {
            h: w.hysteresis().clone(),
            c: w.creep().unwrap().clone(),
        }) as Box<dyn Siso>
    });
    let failed = failing_columns(&ctx, &m);
    eprintln!("creep with v_k: {failed:?}");
    assert!(!failed.is_empty());
    // 2. one threshold moved by 1e-6 relative
    let failed = failing_columns(&perturbed(|r, _| r[5] *= 1.0 + 1e-6), &m);
    eprintln!("threshold r_5 (1 + 1e-6): {failed:?}");
    assert!(!failed.is_empty());
    // 3. one weight's sign flipped (w_11 = −0.01 → +0.01 keeps (11))
    let failed = failing_columns(&perturbed(|_, w| w[11] = -w[11]), &m);
    eprintln!("weight w_11 sign: {failed:?}");
    assert!(!failed.is_empty());
}
