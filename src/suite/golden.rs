//! Golden traces: the scenarios of [`crate::suite::scenarios`] stored in `golden/`
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

use thiserror::Error;

use crate::io::{format_f64, read_json, write_atomic, FileError, Trace};
use crate::operators::nominal::SAMPLE_TIME;
use crate::suite::scenarios::{
    run, scenario, Column, ScenarioContext, ScenarioError, ScenarioTrace, SCENARIOS,
};

/// What can go wrong writing, checking or comparing golden traces.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum GoldenError {
    #[error(transparent)]
    File(#[from] FileError),
    #[error(transparent)]
    Scenario(#[from] ScenarioError),
    /// The manifest lacks an entry, or an entry lacks a column.
    #[error("{path}: {reason}")]
    Manifest { path: PathBuf, reason: String },
    /// The candidate shares no column with the golden trace.
    #[error("{candidate}: shares no column with {golden}")]
    NoCommonColumn { candidate: PathBuf, golden: PathBuf },
}

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

impl From<Column> for ColumnSpec {
    fn from(c: Column) -> Self {
        ColumnSpec {
            name: c.name.into(),
            unit: c.unit.into(),
            abs_tol: c.abs_tol,
            rel_tol: c.rel_tol,
            justification: c.justification.into(),
        }
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

/// Run every scenario on `ctx` and return (file name, decimated trace, decimation).
pub fn compute_all(
    ctx: &ScenarioContext,
) -> Result<Vec<(String, ScenarioTrace, usize)>, ScenarioError> {
    SCENARIOS
        .iter()
        .map(|s| {
            let trace = run(s, ctx)?;
            Ok((
                format!("{}.csv", s.id),
                trace.decimated(s.decimation),
                s.decimation,
            ))
        })
        .collect()
}

/// Regenerate every golden trace and the manifest in `dir`.
pub fn write_golden(dir: &Path) -> Result<Manifest, GoldenError> {
    let ctx = ScenarioContext::nominal();
    let mut traces = Vec::new();
    for (s, (file, trace, k)) in SCENARIOS.iter().zip(compute_all(&ctx)?) {
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
            columns: s.columns.iter().copied().map(ColumnSpec::from).collect(),
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

/// Compare candidate columns with golden ones row by row. Every golden
/// column must be declared in the manifest entry: there is no fallback
/// tolerance.
pub fn compare_columns(
    golden: &[(String, Vec<f64>)],
    candidate: &[(String, Vec<f64>)],
    spec: &TraceManifest,
) -> Result<Vec<ColumnReport>, GoldenError> {
    golden
        .iter()
        .map(|(name, g)| {
            let cs = spec
                .columns
                .iter()
                .find(|c| &c.name == name)
                .ok_or_else(|| GoldenError::Manifest {
                    path: PathBuf::from("manifest.json"),
                    reason: format!("{}: column '{name}' has no declared tolerance", spec.file),
                })?;
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
                return Ok(rep);
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
            Ok(rep)
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
    // saturating: the decimation comes from a manifest, which may be hostile
    let full_rate = (golden_rows.max(1) - 1)
        .saturating_mul(decimation)
        .saturating_add(1);
    if decimation > 1 && golden_rows > 0 && rows == full_rate {
        return Ok(candidate
            .into_iter()
            .map(|(n, v)| (n, v.into_iter().step_by(decimation).collect()))
            .collect());
    }
    Err(FileError::Csv {
        path: path.to_path_buf(),
        message: format!(
            "{rows} rows: expected {golden_rows} (as stored) or {full_rate} (every sample at 5 kHz, decimation {decimation})"
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

/// One difference `golden --check` found.
#[derive(Debug, Clone, PartialEq)]
pub struct GoldenDifference {
    pub file: String,
    pub what: String,
}

/// Recompute every scenario on `ctx` and compare with the golden files in
/// `dir`: each file's SHA-256 against the manifest, the row count, and every
/// column within its tolerance. Returns the differences (none: all reproduce).
pub fn check_golden(
    dir: &Path,
    ctx: &ScenarioContext,
) -> Result<Vec<GoldenDifference>, GoldenError> {
    let manifest_path = dir.join("manifest.json");
    let manifest = read_manifest(&manifest_path)?;
    let mut out = Vec::new();
    for (file, trace, _) in compute_all(ctx)? {
        let entry = manifest
            .entry_for_file(&file)
            .ok_or_else(|| GoldenError::Manifest {
                path: manifest_path.clone(),
                reason: format!("no entry for {file}"),
            })?;
        let path = dir.join(&file);
        let bytes = std::fs::read(&path).map_err(|error| FileError::Io {
            path: path.clone(),
            error,
        })?;
        let diff = |what: String| GoldenDifference {
            file: file.clone(),
            what,
        };
        if sha256_hex(&bytes) != entry.sha256 {
            out.push(diff("SHA-256 differs from the manifest".into()));
        }
        let stored = numeric_columns(&Trace::read(&path)?)?;
        let fresh: Vec<(String, Vec<f64>)> = trace
            .columns
            .iter()
            .map(|(n, v)| (n.to_string(), v.clone()))
            .collect();
        if fresh.first().map(|c| c.1.len()) != stored.first().map(|c| c.1.len()) {
            out.push(diff("row count differs".into()));
            continue;
        }
        for r in compare_columns(&stored, &fresh, entry)? {
            if !r.compared || !r.pass() {
                out.push(diff(format!(
                    "column {} differs (max abs {:.3e}, tolerance {:.1e})",
                    r.name, r.max_abs, r.abs_tol
                )));
            }
        }
    }
    Ok(out)
}

/// The comparison of a candidate trace with a golden trace.
#[derive(Debug, Clone, PartialEq)]
pub struct VerifyReport {
    pub golden: PathBuf,
    pub candidate: PathBuf,
    pub entry: TraceManifest,
    pub columns: Vec<ColumnReport>,
}

impl VerifyReport {
    /// Columns compared (present in both).
    pub fn compared(&self) -> usize {
        self.columns.iter().filter(|r| r.compared).count()
    }

    /// Compared columns outside tolerance.
    pub fn failed(&self) -> usize {
        self.columns
            .iter()
            .filter(|r| r.compared && !r.pass())
            .count()
    }
}

impl std::fmt::Display for VerifyReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "golden {} ({} {}), candidate {}",
            self.golden.display(),
            self.entry.id,
            self.entry.paper,
            self.candidate.display()
        )?;
        writeln!(
            f,
            "{:<12} {:>12} {:>12} {:>12} {:>10} {:>10}  result",
            "column", "max abs", "rms", "max rel", "abs tol", "rel tol"
        )?;
        for r in &self.columns {
            if !r.compared {
                writeln!(
                    f,
                    "{:<12} {:>12} {:>12} {:>12} {:>10.1e} {:>10.1e}  not in candidate",
                    r.name, "-", "-", "-", r.abs_tol, r.rel_tol
                )?;
                continue;
            }
            let verdict = match r.first_failure {
                None => "pass".to_string(),
                Some(row) => format!("FAIL (first at row {row})"),
            };
            writeln!(
                f,
                "{:<12} {:>12.3e} {:>12.3e} {:>12.3e} {:>10.1e} {:>10.1e}  {verdict}",
                r.name, r.max_abs, r.rms, r.max_rel, r.abs_tol, r.rel_tol
            )?;
        }
        write!(
            f,
            "{} of {} columns compared, {}",
            self.compared(),
            self.columns.len(),
            match self.failed() {
                0 => "all within tolerance".to_string(),
                n => format!("{n} outside tolerance"),
            }
        )
    }
}

/// Compare a candidate trace with a golden trace (its manifest is read from
/// the golden file's directory): per column max-abs, RMS and max-relative
/// error against the declared tolerances. A candidate at the full rate is
/// aligned to the stored rows.
pub fn verify(golden: &Path, candidate: &Path) -> Result<VerifyReport, GoldenError> {
    let manifest_path = manifest_path_for(golden);
    let manifest = read_manifest(&manifest_path)?;
    let file = golden
        .file_name()
        .map(|f| f.to_string_lossy().into_owned())
        .unwrap_or_default();
    let entry = manifest
        .entry_for_file(&file)
        .ok_or_else(|| GoldenError::Manifest {
            path: manifest_path.clone(),
            reason: format!("no entry for {file}"),
        })?
        .clone();
    let stored = numeric_columns(&Trace::read(golden)?)?;
    let cand = numeric_columns(&Trace::read(candidate)?)?;
    let rows = stored.first().map_or(0, |c| c.1.len());
    let cand = align(cand, rows, entry.decimation, candidate)?;
    let columns = compare_columns(&stored, &cand, &entry)?;
    let report = VerifyReport {
        golden: golden.to_path_buf(),
        candidate: candidate.to_path_buf(),
        entry,
        columns,
    };
    if report.compared() == 0 {
        return Err(GoldenError::NoCommonColumn {
            candidate: candidate.to_path_buf(),
            golden: golden.to_path_buf(),
        });
    }
    Ok(report)
}

/// The declared columns of a scenario, as the manifest stores them.
pub fn declared_columns(id: &str) -> Option<Vec<ColumnSpec>> {
    scenario(id).map(|s| s.columns.iter().copied().map(ColumnSpec::from).collect())
}
