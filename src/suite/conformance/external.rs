//! A candidate in any language, run through the file contract
//! (`docs/FILES.md`): for each run the model file and an input trace are
//! written to a temporary directory and the candidate's command is run as
//!
//! ```text
//! CMD ARGS… --model M.json --input IN.csv --output OUT.csv [--limits=LO,HI]
//! ```
//!
//! (`--limits` always for a compensator: wide limits where a case wants
//! none). A model reads column `u` and writes the input's columns plus `y`; a
//! compensator reads `y_d` and writes `u` and `saturated`.
//!
//! A candidate that implements only part of the model (most published PI
//! code has `H` alone) exits with [`UNSUPPORTED_EXIT_CODE`] (3) on a model
//! with a part it does not implement, its reason on the first line of
//! stderr: the case is counted as skipped, not failed.
//!
//! [`ExternalModel`] and [`ExternalCompensator`] adapt such a command to the
//! traits the conformance checks take. A process cannot keep its state
//! between runs, so each adapter keeps the whole input it has been given and
//! reruns the candidate on all of it, returning the new part: for a
//! deterministic candidate that is the same as continuing.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use thiserror::Error;

use crate::io::scratch::{self, ScratchDir};
use crate::io::{format_f64, Trace};
use crate::operators::compensator::CompensatorSettings;
use crate::operators::model::ModelFile;
use crate::operators::traits::{
    ActuatorCompensator, ActuatorModel, Compensated, InverseHysteresis, Operator,
};

/// The exit code by which a candidate declines a model with a part it does
/// not implement (creep, the superposition operator, a dead time, an
/// offset): the case is skipped. Any other non-zero code is a failure.
pub const UNSUPPORTED_EXIT_CODE: i32 = 3;

/// Limits passed to a compensator where a case wants none.
pub const WIDE_LIMITS: (f64, f64) = (-1e300, 1e300);

/// What went wrong running a candidate.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum ExternalError {
    #[error("the command is empty")]
    EmptyCommand,
    #[error("'{program}' is not an executable file (nor found on PATH)")]
    NotExecutable { program: String },
    #[error("could not start '{program}': {reason}")]
    Spawn { program: String, reason: String },
    #[error("the candidate exceeded the timeout of {seconds} s and was killed")]
    Timeout { seconds: f64 },
    #[error("the candidate exited with {status}: {stderr}")]
    Failed { status: String, stderr: String },
    #[error("the candidate declined the model (exit code 3): {reason}")]
    Unsupported { reason: String },
    #[error("the candidate's output: {reason}")]
    BadOutput { reason: String },
    #[error("{path}: {reason}")]
    Io { path: String, reason: String },
}

/// One run of the candidate, kept so that a failing case can be written out.
#[derive(Debug, Clone, PartialEq)]
pub struct Invocation {
    pub model: ModelFile,
    /// The input column (`u` or `y_d`).
    pub input: Vec<f64>,
    /// `--limits` given to a compensator.
    pub limits: Option<(f64, f64)>,
}

/// Split a command line into words: whitespace separates, single and double
/// quotes group, a backslash escapes the next character.
pub fn split_command(line: &str) -> Vec<String> {
    let mut words = Vec::new();
    let mut word = String::new();
    let mut in_word = false;
    let mut quote: Option<char> = None;
    let mut chars = line.chars();
    while let Some(c) = chars.next() {
        match (quote, c) {
            (Some(q), c) if c == q => quote = None,
            (None, '\'' | '"') => {
                quote = Some(c);
                in_word = true;
            }
            (_, '\\') => {
                if let Some(n) = chars.next() {
                    word.push(n);
                    in_word = true;
                }
            }
            (None, c) if c.is_whitespace() => {
                if in_word {
                    words.push(std::mem::take(&mut word));
                    in_word = false;
                }
            }
            (_, c) => {
                word.push(c);
                in_word = true;
            }
        }
    }
    if in_word {
        words.push(word);
    }
    words
}

fn executable(path: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        fs::metadata(path).is_ok_and(|m| m.is_file() && m.permissions().mode() & 0o111 != 0)
    }
    #[cfg(not(unix))]
    {
        path.is_file()
    }
}

/// Where `program` would be run from: a path as given, or the first
/// executable match on `PATH`.
fn resolve(program: &str) -> Option<PathBuf> {
    if program.contains('/') {
        let p = PathBuf::from(program);
        return executable(&p).then_some(p);
    }
    std::env::var_os("PATH").and_then(|paths| {
        std::env::split_paths(&paths)
            .map(|d| d.join(program))
            .find(|p| executable(p))
    })
}

/// A command that follows the file contract.
#[derive(Debug)]
pub struct ExternalCandidate {
    words: Vec<String>,
    timeout: Duration,
    dir: ScratchDir,
    counter: AtomicUsize,
    /// Runs so far (for progress display).
    pub runs: AtomicUsize,
    log: Mutex<Vec<Invocation>>,
    first_error: Mutex<Option<ExternalError>>,
    /// The fixed mode: the candidate implements one model and is run
    /// without `--model`.
    fixed: bool,
}

impl ExternalCandidate {
    /// A candidate from a command line (`CMD ARGS…`); each run may take at
    /// most `timeout`. Refuses a command whose program is not executable.
    pub fn new(command: &str, timeout: Duration) -> Result<Self, ExternalError> {
        let words = split_command(command);
        let program = words.first().ok_or(ExternalError::EmptyCommand)?;
        if resolve(program).is_none() {
            return Err(ExternalError::NotExecutable {
                program: program.clone(),
            });
        }
        // unique per process and per candidate, removed on every way out
        let dir = ScratchDir::new("mfcbeam-conform").map_err(|e| ExternalError::Io {
            path: std::env::temp_dir().display().to_string(),
            reason: e.to_string(),
        })?;
        Ok(Self {
            words,
            timeout,
            dir,
            counter: AtomicUsize::new(0),
            runs: AtomicUsize::new(0),
            log: Mutex::new(Vec::new()),
            first_error: Mutex::new(None),
            fixed: false,
        })
    }

    /// The fixed mode: the candidate implements one model, compiled in,
    /// and is run without `--model` (the model file is still written
    /// beside the input, for the record).
    pub fn fixed(mut self) -> Self {
        self.fixed = true;
        self
    }

    /// Whether the candidate runs without `--model`.
    pub fn is_fixed(&self) -> bool {
        self.fixed
    }

    /// The command words.
    pub fn command(&self) -> &[String] {
        &self.words
    }

    /// The first error any run met, if any.
    pub fn first_error(&self) -> Option<ExternalError> {
        self.first_error.lock().expect("not poisoned").clone()
    }

    /// Forget the logged runs.
    pub fn clear_log(&self) {
        self.log.lock().expect("not poisoned").clear();
    }

    /// The runs since the log was last cleared.
    pub fn log(&self) -> Vec<Invocation> {
        self.log.lock().expect("not poisoned").clone()
    }

    fn note(&self, e: &ExternalError) {
        if let ExternalError::Unsupported { reason } = e {
            // the check running on this thread skips the case
            super::decline_case(reason);
            return;
        }
        let mut first = self.first_error.lock().expect("not poisoned");
        if first.is_none() {
            *first = Some(e.clone());
        }
    }

    /// The arguments after `CMD ARGS…` for a run (no `--model` for a
    /// fixed candidate: `model` is `None`).
    pub fn file_arguments(
        model: Option<&Path>,
        input: &Path,
        output: &Path,
        limits: Option<(f64, f64)>,
    ) -> Vec<String> {
        let mut args = Vec::new();
        if let Some(model) = model {
            args.extend(["--model".to_string(), model.display().to_string()]);
        }
        args.extend([
            "--input".to_string(),
            input.display().to_string(),
            "--output".to_string(),
            output.display().to_string(),
        ]);
        if let Some((lo, hi)) = limits {
            args.push(format!("--limits={},{}", format_f64(lo), format_f64(hi)));
        }
        args
    }

    /// Run the candidate on `model` and the input column `column` (with a
    /// time column `t = k T_s`) in `dir`; return the output trace.
    pub fn run_in(
        &self,
        dir: &Path,
        model: &ModelFile,
        column: &str,
        input: &[f64],
        limits: Option<(f64, f64)>,
    ) -> Result<Trace, ExternalError> {
        let io = |path: &Path, e: &dyn std::fmt::Display| ExternalError::Io {
            path: path.display().to_string(),
            reason: e.to_string(),
        };
        let (m, i, o) = (
            dir.join("model.json"),
            dir.join("input.csv"),
            dir.join("candidate.csv"),
        );
        let json = serde_json::to_string_pretty(model).map_err(|e| io(&m, &e))?;
        fs::write(&m, json).map_err(|e| io(&m, &e))?;
        let t: Vec<f64> = (0..input.len())
            .map(|k| k as f64 * model.sample_time)
            .collect();
        Trace::from_columns(&i, &[("t", &t), (column, input)])
            .write(&i)
            .map_err(|e| io(&i, &e))?;
        let _ = fs::remove_file(&o);
        let stderr_path = dir.join("stderr.txt");
        let stderr = fs::File::create(&stderr_path).map_err(|e| io(&stderr_path, &e))?;
        self.runs.fetch_add(1, Ordering::Relaxed);
        let mut child = Command::new(&self.words[0])
            .args(&self.words[1..])
            .args(Self::file_arguments(
                (!self.fixed).then_some(m.as_path()),
                &i,
                &o,
                limits,
            ))
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(stderr)
            .spawn()
            .map_err(|e| ExternalError::Spawn {
                program: self.words[0].clone(),
                reason: e.to_string(),
            })?;
        let start = Instant::now();
        scratch::register_child(child.id());
        let status = loop {
            match child.try_wait() {
                Ok(Some(status)) => break Ok(status),
                Ok(None) if start.elapsed() > self.timeout => {
                    let _ = child.kill();
                    let _ = child.wait();
                    break Err(ExternalError::Timeout {
                        seconds: self.timeout.as_secs_f64(),
                    });
                }
                Ok(None) => std::thread::sleep(Duration::from_micros(200)),
                Err(e) => break Err(io(&o, &e)),
            }
        };
        scratch::unregister_child(child.id());
        let status = status?;
        if !status.success() {
            let text = fs::read_to_string(&stderr_path).unwrap_or_default();
            if status.code() == Some(UNSUPPORTED_EXIT_CODE) {
                let reason = text.lines().next().unwrap_or("").trim();
                return Err(ExternalError::Unsupported {
                    reason: if reason.is_empty() {
                        "no reason given".into()
                    } else {
                        reason.into()
                    },
                });
            }
            return Err(ExternalError::Failed {
                status: status.to_string(),
                stderr: text.lines().next().unwrap_or("").to_string(),
            });
        }
        read_output(&o, input.len())
    }

    /// A fresh scratch directory for one run.
    fn scratch(&self) -> Result<PathBuf, ExternalError> {
        let d = self
            .dir
            .path()
            .join(self.counter.fetch_add(1, Ordering::Relaxed).to_string());
        fs::create_dir_all(&d).map_err(|e| ExternalError::Io {
            path: d.display().to_string(),
            reason: e.to_string(),
        })?;
        Ok(d)
    }

    fn finish<T>(
        &self,
        dir: PathBuf,
        result: Result<T, ExternalError>,
    ) -> Result<T, ExternalError> {
        let _ = fs::remove_dir_all(dir);
        if let Err(e) = &result {
            self.note(e);
        }
        result
    }

    /// `y = W[u]` from the candidate (`simulate` kind).
    pub fn simulate(&self, model: &ModelFile, u: &[f64]) -> Result<Vec<f64>, ExternalError> {
        self.log.lock().expect("not poisoned").push(Invocation {
            model: model.clone(),
            input: u.to_vec(),
            limits: None,
        });
        let dir = self.scratch()?;
        let result = self.run_in(&dir, model, "u", u, None).and_then(|t| {
            let y = t.column("y").map_err(|e| ExternalError::BadOutput {
                reason: e.to_string(),
            })?;
            check_rows(y.len(), u.len())?;
            Ok(y)
        });
        self.finish(dir, result)
    }

    /// `(u, saturated) = W⁻¹[y_d]` from the candidate (`compensate` kind).
    pub fn compensate(
        &self,
        model: &ModelFile,
        limits: (f64, f64),
        targets: &[f64],
    ) -> Result<Vec<Compensated>, ExternalError> {
        self.log.lock().expect("not poisoned").push(Invocation {
            model: model.clone(),
            input: targets.to_vec(),
            limits: Some(limits),
        });
        let dir = self.scratch()?;
        let result = self
            .run_in(&dir, model, "y_d", targets, Some(limits))
            .and_then(|t| {
                let bad = |e: crate::io::FileError| ExternalError::BadOutput {
                    reason: e.to_string(),
                };
                let u = t.column("u").map_err(bad)?;
                let s = t.column("saturated").map_err(bad)?;
                check_rows(u.len(), targets.len())?;
                Ok(u.into_iter()
                    .zip(s)
                    .map(|(u, s)| Compensated {
                        u,
                        saturated: s != 0.0,
                        fault: false,
                    })
                    .collect())
            });
        self.finish(dir, result)
    }
}

impl ExternalCandidate {
    /// `u = H⁻¹[y]` from the candidate (`inverse-hysteresis` kind): column
    /// `y` in, `u` out; the model file holds `H`.
    pub fn invert(&self, model: &ModelFile, y: &[f64]) -> Result<Vec<f64>, ExternalError> {
        self.log.lock().expect("not poisoned").push(Invocation {
            model: model.clone(),
            input: y.to_vec(),
            limits: None,
        });
        let dir = self.scratch()?;
        let result = self.run_in(&dir, model, "y", y, None).and_then(|t| {
            let u = t.column("u").map_err(|e| ExternalError::BadOutput {
                reason: e.to_string(),
            })?;
            check_rows(u.len(), y.len())?;
            Ok(u)
        });
        self.finish(dir, result)
    }
}

/// The most a candidate's output may take for `rows` rows: a generous
/// kilobyte per row (its input's columns and one or two of its own are a
/// few dozen bytes) and a megabyte for the header and the rest, so that a
/// runaway candidate's file is refused, not read into memory.
pub fn max_output_bytes(rows: usize) -> u64 {
    (1 << 20) + 1024 * rows as u64
}

/// Read a candidate's output for an input of `rows` rows.
pub fn read_output(path: &Path, rows: usize) -> Result<Trace, ExternalError> {
    let bad = |reason: String| ExternalError::BadOutput { reason };
    let size = fs::metadata(path)
        .map_err(|e| bad(format!("{}: {e}", path.display())))?
        .len();
    check_output_size(path, size, rows)?;
    let bytes = fs::read(path).map_err(|e| bad(format!("{}: {e}", path.display())))?;
    parse_output(path, &bytes, rows)
}

fn check_output_size(path: &Path, size: u64, rows: usize) -> Result<(), ExternalError> {
    if size > max_output_bytes(rows) {
        return Err(ExternalError::BadOutput {
            reason: format!(
                "{}: {size} bytes for {rows} rows (at most {} are read)",
                path.display(),
                max_output_bytes(rows)
            ),
        });
    }
    Ok(())
}

/// A candidate's output (the bytes of `path`) for an input of `rows` rows:
/// what [`read_output`] does once the file is read.
pub fn parse_output(path: &Path, bytes: &[u8], rows: usize) -> Result<Trace, ExternalError> {
    check_output_size(path, bytes.len() as u64, rows)?;
    Trace::parse(path, bytes).map_err(|e| ExternalError::BadOutput {
        reason: e.to_string(),
    })
}

fn check_rows(found: usize, expected: usize) -> Result<(), ExternalError> {
    if found == expected {
        Ok(())
    } else {
        Err(ExternalError::BadOutput {
            reason: format!("{found} rows for {expected} input rows"),
        })
    }
}

/// `W` of an external candidate.
pub struct ExternalModel {
    candidate: Arc<ExternalCandidate>,
    file: ModelFile,
    history: Vec<f64>,
}

impl ExternalModel {
    /// The candidate configured by `file`.
    pub fn new(candidate: Arc<ExternalCandidate>, file: &ModelFile) -> Self {
        Self {
            candidate,
            file: file.clone(),
            history: Vec::new(),
        }
    }
}

impl Operator for ExternalModel {
    fn step(&mut self, v: f64) -> f64 {
        self.run(&[v])[0]
    }

    fn reset(&mut self) {
        self.history.clear();
    }

    /// The whole history through the candidate; the part for `input` is
    /// returned (NaN where the candidate failed: every property then fails).
    fn run(&mut self, input: &[f64]) -> Vec<f64> {
        self.history.extend_from_slice(input);
        match self.candidate.simulate(&self.file, &self.history) {
            Ok(y) => y[y.len() - input.len()..].to_vec(),
            Err(_) => vec![f64::NAN; input.len()],
        }
    }
}

impl ActuatorModel for ExternalModel {}

/// `H⁻¹` of an external candidate (the `inverse-hysteresis` kind).
pub struct ExternalInverseHysteresis {
    candidate: Arc<ExternalCandidate>,
    file: ModelFile,
    history: Vec<f64>,
}

impl ExternalInverseHysteresis {
    /// The candidate configured by `file` (its hysteresis part).
    pub fn new(candidate: Arc<ExternalCandidate>, file: &ModelFile) -> Self {
        Self {
            candidate,
            file: file.clone(),
            history: Vec::new(),
        }
    }
}

impl Operator for ExternalInverseHysteresis {
    fn step(&mut self, y: f64) -> f64 {
        self.run(&[y])[0]
    }

    fn reset(&mut self) {
        self.history.clear();
    }

    /// As [`ExternalModel::run`], through `invert`.
    fn run(&mut self, input: &[f64]) -> Vec<f64> {
        self.history.extend_from_slice(input);
        match self.candidate.invert(&self.file, &self.history) {
            Ok(u) => u[u.len() - input.len()..].to_vec(),
            Err(_) => vec![f64::NAN; input.len()],
        }
    }
}

impl InverseHysteresis for ExternalInverseHysteresis {}

/// `W⁻¹` of an external candidate. Each `compensate_all` call previews
/// its own targets by the model's dead time `d`, as the library's
/// compensators do; the candidate, run on the whole history, previews the
/// file it is given, so it is given the file whose preview is the history
/// of those previewed targets (the targets shifted back by `d`).
pub struct ExternalCompensator {
    candidate: Arc<ExternalCandidate>,
    file: ModelFile,
    limits: (f64, f64),
    /// The targets each sample was compensated for (after each call's
    /// preview).
    history: Vec<f64>,
}

impl ExternalCompensator {
    /// The candidate configured by `file` with `settings`' limits (wide
    /// limits for none).
    pub fn new(
        candidate: Arc<ExternalCandidate>,
        file: &ModelFile,
        settings: CompensatorSettings,
    ) -> Self {
        let limits = (
            settings.lower_limit.max(WIDE_LIMITS.0),
            settings.upper_limit.min(WIDE_LIMITS.1),
        );
        Self {
            candidate,
            file: file.clone(),
            limits,
            history: Vec::new(),
        }
    }
}

impl ActuatorCompensator for ExternalCompensator {
    fn compensate(&mut self, target: f64) -> Compensated {
        self.compensate_all(&[target])[0]
    }

    fn reset(&mut self) {
        self.history.clear();
    }

    fn compensate_all(&mut self, targets: &[f64]) -> Vec<Compensated> {
        let d = self.file.delay.unwrap_or(0);
        self.history
            .extend((0..targets.len()).map(|k| crate::realtime::preview(targets, d, k)));
        // the file whose preview by d is the history: z[k + d] = history[k]
        // (the last d samples hold the last call's last target either way)
        let n = self.history.len();
        let file: Vec<f64> = (0..n)
            .map(|k| self.history[k.saturating_sub(d).min(n - 1)])
            .collect();
        match self.candidate.compensate(&self.file, self.limits, &file) {
            Ok(c) => c[c.len() - targets.len()..].to_vec(),
            Err(_) => vec![
                Compensated {
                    u: f64::NAN,
                    saturated: false,
                    fault: false,
                };
                targets.len()
            ],
        }
    }
}
