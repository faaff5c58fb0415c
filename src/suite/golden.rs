//! Golden traces: the scenarios of [`crate::scenarios`] stored in `golden/`
//! with a manifest, and the comparison that `mfcbeam verify` and the golden
//! regression test apply.
//!
//! `golden/manifest.json` holds, per trace, its provenance (the command that
//! regenerates it), the decimation `k` (every `k`-th row of the 5 kHz run is
//! stored), the SHA-256 of the file and, per column, an absolute and a
//! relative tolerance with a one-line justification. A row passes when
//! `|candidate − golden| ≤ abs + rel · |golden|`.
//!
//! Regenerating is explicit (`mfcbeam golden --write`); tests only compare.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use crate::io::{format_f64, read_json, write_atomic, FileError, Trace};
use crate::operators::nominal::SAMPLE_TIME;
use crate::suite::scenarios::{run, ScenarioContext, ScenarioTrace, SCENARIOS};

/// Tolerance of one column.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ColumnSpec {
    pub name: String,
    pub unit: String,
    pub abs_tol: f64,
    pub rel_tol: f64,
    pub justification: String,
}

/// One golden trace in the manifest.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TraceManifest {
    pub id: String,
    pub file: String,
    pub paper: String,
    pub description: String,
    pub provenance: String,
    pub models: Vec<String>,
    pub sample_time: f64,
    pub decimation: usize,
    pub rows: usize,
    pub sha256: String,
    pub columns: Vec<ColumnSpec>,
}

/// `golden/manifest.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    pub generator: String,
    pub traces: Vec<TraceManifest>,
}

impl Manifest {
    /// The entry of a golden file, by file name.
    pub fn entry_for_file(&self, file: &str) -> Option<&TraceManifest> {
        self.traces.iter().find(|t| t.file == file)
    }
}

fn spec(name: &str, unit: &str, abs_tol: f64, rel_tol: f64, why: &str) -> ColumnSpec {
    ColumnSpec {
        name: name.into(),
        unit: unit.into(),
        abs_tol,
        rel_tol,
        justification: why.into(),
    }
}

const WHY_INPUT: &str = "generated input: closed-form samples, equal to rounding (1e-12 of 1000 V)";
const WHY_W: &str = "W: sums of at most 72 terms of at most 1000 V round to < 2e-11 V; 50x margin for another summation order";
const WHY_COMP: &str = "W^-1: the W rounding amplified by the steepest inverse slope 1/s_min (2.2) and the creep term; 1e-8 V";
const WHY_TIP: &str =
    "beam: exact ZOH by diagonalization, rounding ~1e-11 of the 1 mm scale; 1e-12 m";
const WHY_TIME: &str = "k Ts in double precision";

/// The tolerance of a column of a scenario.
pub fn column_spec(scenario: &str, column: &str) -> ColumnSpec {
    match (scenario, column) {
        (_, "t") => spec(column, "s", 1e-9, 0.0, WHY_TIME),
        (_, "saturated") => spec(column, "0/1", 0.0, 0.0, "a flag: must match exactly"),
        (_, "tip" | "tip_raw") => spec(column, "m", 1e-12, 1e-9, WHY_TIP),
        ("compensated" | "step" | "feedforward", "u" | "u_fs" | "u_bs") => {
            spec(column, "V", 1e-8, 1e-11, WHY_COMP)
        }
        ("compensated", "y_d") | ("step", "v") => spec(column, "V", 1e-9, 0.0, WHY_INPUT),
        ("feedforward", "y_d") => spec(
            column,
            "m",
            1e-15,
            1e-10,
            "N(d/dt) z_d from order-30 derivatives accurate to 1e-10 of their scale",
        ),
        ("feedforward", "u_d") => spec(
            column,
            "V",
            1e-8,
            1e-10,
            "D(d/dt) z_d: derivatives to 1e-10 of their scale, 30 factors applied",
        ),
        ("identification", "y_fit") => spec(
            column,
            "V",
            1e-6,
            0.0,
            "model identified by QR + QP + polish: weights to ~1e-11, outputs to 1e-8 V; 1e-6 V leaves room for another QP solver",
        ),
        (_, "u" | "u_a" | "u_b" | "u_c") => spec(column, "V", 1e-9, 0.0, WHY_INPUT),
        _ => spec(column, "V", 1e-9, 1e-12, WHY_W),
    }
}

/// SHA-256 of bytes, lower-case hex.
pub fn sha256_hex(bytes: &[u8]) -> String {
    Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// A scenario trace as CSV text (shortest round-trip numbers).
pub fn csv_bytes(trace: &ScenarioTrace) -> Vec<u8> {
    let mut out = String::new();
    let names: Vec<&str> = trace.columns.iter().map(|c| c.0).collect();
    out.push_str(&names.join(","));
    out.push('\n');
    for k in 0..trace.len() {
        let row: Vec<String> = trace.columns.iter().map(|c| format_f64(c.1[k])).collect();
        out.push_str(&row.join(","));
        out.push('\n');
    }
    out.into_bytes()
}

/// Run every scenario on `ctx` and return (file name, decimated trace).
pub fn compute_all(ctx: &ScenarioContext) -> Vec<(String, ScenarioTrace, usize)> {
    SCENARIOS
        .iter()
        .map(|s| {
            let trace = run(s.id, ctx).expect("nominal scenarios run");
            (
                format!("{}.csv", s.id),
                trace.decimated(s.decimation),
                s.decimation,
            )
        })
        .collect()
}

/// Regenerate every golden trace and the manifest in `dir`.
pub fn write_golden(dir: &Path) -> Result<Manifest, FileError> {
    let ctx = ScenarioContext::nominal();
    let mut traces = Vec::new();
    for (s, (file, trace, k)) in SCENARIOS.iter().zip(compute_all(&ctx)) {
        let bytes = csv_bytes(&trace);
        write_atomic(&dir.join(&file), &bytes)?;
        traces.push(TraceManifest {
            id: s.id.into(),
            file: file.clone(),
            paper: s.paper.into(),
            description: s.description.into(),
            provenance: format!(
                "mfcbeam scenario {} --output golden/{file} (all at once: mfcbeam golden --write)",
                s.id
            ),
            models: vec!["nominal_model.json".into(), "nominal_beam.json".into()],
            sample_time: SAMPLE_TIME,
            decimation: k,
            rows: trace.len(),
            sha256: sha256_hex(&bytes),
            columns: trace
                .columns
                .iter()
                .map(|c| column_spec(s.id, c.0))
                .collect(),
        });
    }
    let manifest = Manifest {
        generator: format!("mfcbeam {}", env!("CARGO_PKG_VERSION")),
        traces,
    };
    let mut text = serde_json::to_string_pretty(&manifest).expect("manifest serializes");
    text.push('\n');
    write_atomic(&dir.join("manifest.json"), text.as_bytes())?;
    Ok(manifest)
}

/// Read `manifest.json`.
pub fn read_manifest(path: &Path) -> Result<Manifest, FileError> {
    read_json(path)
}

/// The comparison of one column.
#[derive(Debug, Clone, PartialEq)]
pub struct ColumnReport {
    pub name: String,
    /// Whether the candidate has the column.
    pub compared: bool,
    pub max_abs: f64,
    pub rms: f64,
    pub max_rel: f64,
    pub abs_tol: f64,
    pub rel_tol: f64,
    /// Row (1-based, in the golden file) of the worst violation, if any.
    pub first_failure: Option<usize>,
}

impl ColumnReport {
    /// Within tolerance (columns the candidate lacks are not failures).
    pub fn pass(&self) -> bool {
        self.first_failure.is_none()
    }
}

/// Compare candidate columns with golden ones row by row.
pub fn compare_columns(
    golden: &[(String, Vec<f64>)],
    candidate: &[(String, Vec<f64>)],
    spec: &TraceManifest,
) -> Vec<ColumnReport> {
    golden
        .iter()
        .map(|(name, g)| {
            let cs = spec
                .columns
                .iter()
                .find(|c| &c.name == name)
                .cloned()
                .unwrap_or_else(|| column_spec(&spec.id, name));
            let mut rep = ColumnReport {
                name: name.clone(),
                compared: false,
                max_abs: 0.0,
                rms: 0.0,
                max_rel: 0.0,
                abs_tol: cs.abs_tol,
                rel_tol: cs.rel_tol,
                first_failure: None,
            };
            let Some((_, c)) = candidate.iter().find(|(n, _)| n == name) else {
                return rep;
            };
            rep.compared = true;
            let mut sq = 0.0;
            for (k, (a, b)) in c.iter().zip(g).enumerate() {
                let e = (a - b).abs();
                sq += e * e;
                rep.max_abs = rep.max_abs.max(e);
                if *b != 0.0 {
                    rep.max_rel = rep.max_rel.max(e / b.abs());
                }
                let ok = e <= cs.abs_tol + cs.rel_tol * b.abs();
                if !ok && rep.first_failure.is_none() {
                    rep.first_failure = Some(k + 1);
                }
            }
            rep.rms = (sq / g.len().max(1) as f64).sqrt();
            rep
        })
        .collect()
}

/// Columns of a trace as numbers.
pub fn numeric_columns(trace: &Trace) -> Result<Vec<(String, Vec<f64>)>, FileError> {
    trace
        .header()
        .iter()
        .map(|h| Ok((h.clone(), trace.column(h)?)))
        .collect()
}

/// Candidate rows aligned with the golden rows: equal counts, or a full-rate
/// candidate whose every `k`-th row is kept.
pub fn align(
    candidate: Vec<(String, Vec<f64>)>,
    golden_rows: usize,
    decimation: usize,
    path: &Path,
) -> Result<Vec<(String, Vec<f64>)>, FileError> {
    let rows = candidate.first().map_or(0, |c| c.1.len());
    if rows == golden_rows {
        return Ok(candidate);
    }
    if decimation > 1 && golden_rows > 0 && rows == (golden_rows - 1) * decimation + 1 {
        return Ok(candidate
            .into_iter()
            .map(|(n, v)| (n, v.into_iter().step_by(decimation).collect()))
            .collect());
    }
    Err(FileError::Csv {
        path: path.to_path_buf(),
        message: format!(
            "{rows} rows: expected {golden_rows} (as stored) or {} (every sample at 5 kHz, decimation {decimation})",
            (golden_rows.max(1) - 1) * decimation + 1
        ),
    })
}

/// The golden directory next to a golden file.
pub fn manifest_path_for(golden_file: &Path) -> PathBuf {
    golden_file
        .parent()
        .map(|p| p.join("manifest.json"))
        .unwrap_or_else(|| PathBuf::from("manifest.json"))
}
