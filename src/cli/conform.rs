//! `mfcbeam conform`: the conformance properties of
//! `mfcbeam::suite::conformance`, run on a program in any language through the
//! file contract, with shrunk counterexamples written to disk.

use std::fs;
use std::path::Path;
use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{bail, Context, Result};

use mfcbeam::io::{format_f64, write_atomic, Trace};
use mfcbeam::operators::nominal::nominal_model_file;
use mfcbeam::prelude::*;
use mfcbeam::suite::conformance::explain::{explain, Explanation, Hint, Kind};
use mfcbeam::suite::conformance::external::{
    ExternalCandidate, ExternalCompensator, ExternalError, ExternalInverseHysteresis,
    ExternalModel, WIDE_LIMITS,
};
use mfcbeam::suite::conformance::{
    compensator_properties, fixed, inverse_hysteresis_properties, model_properties, Case,
    CompensatorFactory, ConformanceReport, ConformanceSettings, Counterexample,
    InverseHysteresisFactory, ModelFactory, Outcome, PropertyResult,
};

use super::args::{ConformArgs, ConformKind};

/// Shrink budget for a candidate that runs as a process (each evaluation
/// starts it a few times).
const EXTERNAL_SHRINK_BUDGET: usize = 300;

/// The settings of `conform` from its arguments, each checked: the fixed
/// model (read and built), the library's conditions named as the options
/// are, the timeout.
pub fn settings(a: &ConformArgs) -> Result<ConformanceSettings> {
    // the fixed mode: the model the candidate claims to be (for the kinds
    // of H and H⁻¹ its hysteresis part)
    let hysteresis_kind = matches!(
        a.kind,
        ConformKind::Hysteresis | ConformKind::InverseHysteresis
    );
    let fixed_model = match &a.model {
        Some(path) => {
            let file = mfcbeam::io::read_model_file(path)?;
            HysteresisCreepModel::from_file(&file)
                .with_context(|| format!("--model {}", path.display()))?;
            Some(if hysteresis_kind {
                file.hysteresis_part()
            } else {
                file
            })
        }
        None => None,
    };
    let settings = ConformanceSettings {
        cases: a.cases,
        seed: a.seed,
        tolerance_scale: a.tolerance_scale,
        shrink_budget: EXTERNAL_SHRINK_BUDGET,
        // a kind's model files hold only what the kind implements
        hysteresis_only: hysteresis_kind,
        dynamics: a.with_dynamics,
        fixed_model: fixed_model.clone(),
        ..ConformanceSettings::default()
    };
    // the library's checks, named as the options are
    match settings.validate() {
        Ok(()) => {}
        Err(ModelError::Inconsistent { field, reason }) => {
            bail!("--{}: {reason}", field.replace('_', "-"))
        }
        // a count option above its limit (the fixed model was read and
        // checked before, with its path)
        Err(e) => bail!("--{e}"),
    }
    let longest = mfcbeam::realtime::limits::MAX_CANDIDATE_TIMEOUT;
    if !(a.timeout.is_finite() && a.timeout > 0.0 && a.timeout <= longest) {
        bail!(
            "--timeout: must be a number of seconds in (0, {longest}], found {}",
            a.timeout
        );
    }
    Ok(settings)
}

/// `conform --exec`: a program through the file contract.
pub fn conform_program(a: &ConformArgs, settings: ConformanceSettings) -> Result<()> {
    let fixed_model = settings.fixed_model.clone();
    let exec = a.exec.as_deref().unwrap_or_default();
    let mut candidate = ExternalCandidate::new(exec, Duration::from_secs_f64(a.timeout))
        .with_context(|| format!("--exec '{exec}'"))?;
    if fixed_model.is_some() {
        candidate = candidate.fixed();
    }
    let candidate = Arc::new(candidate);
    smoke_test(&candidate, a.kind, fixed_model.as_ref()).with_context(|| {
        format!("--exec '{exec}': the candidate is unusable on a first, simple case")
    })?;

    let progress = Progress::start(&candidate);
    // a fixed candidate is built for its model only; every other is declined
    let fixed_ok = move |f: &ModelFile| match &fixed_model {
        Some(m) => fixed::accepts(m, f),
        None => Ok(()),
    };
    let (cand, ok) = (candidate.clone(), fixed_ok.clone());
    let model = move |f: &ModelFile| -> Result<Box<dyn ActuatorModel>, ModelError> {
        ok(f)?;
        Ok(Box::new(ExternalModel::new(cand.clone(), f)))
    };
    let (cand, ok) = (candidate.clone(), fixed_ok.clone());
    let compensator = move |f: &ModelFile,
                            s: CompensatorSettings|
          -> Result<Box<dyn ActuatorCompensator>, ModelError> {
        ok(f)?;
        Ok(Box::new(ExternalCompensator::new(cand.clone(), f, s)))
    };
    let cand = candidate.clone();
    let inverse = move |f: &ModelFile| -> Result<Box<dyn InverseHysteresis>, ModelError> {
        fixed_ok(f)?;
        Ok(Box::new(ExternalInverseHysteresis::new(cand.clone(), f)))
    };
    let program = Program {
        candidate,
        progress,
    };
    let factories = Factories {
        model: &model,
        compensator: &compensator,
        inverse: &inverse,
    };
    run(a, &program, &factories, settings)
    // the candidate's scratch directories are removed as it is dropped
}

/// The three factories of a candidate: one per kind, the run uses the
/// kind's.
pub(super) struct Factories<'a> {
    pub(super) model: &'a ModelFactory<'a>,
    pub(super) compensator: &'a CompensatorFactory<'a>,
    pub(super) inverse: &'a InverseHysteresisFactory<'a>,
}

/// What the one conformance run needs of a candidate beyond its
/// factories: a program through the file contract ([`Program`]) or an
/// FMU (`fmu.rs`).
pub(super) trait Candidate {
    /// The properties have been checked (a progress line ends).
    fn checked(&self) {}
    /// The line after the report: the cases run and the time taken.
    fn summary(&self, cases: usize, seconds: f64) -> String;
    /// The first run that failed, as a line, if any did.
    fn first_error(&self) -> Option<String>;
    /// The line of a candidate that took its host process down (a crash,
    /// an exit, a hang), its case written to `a.out`; `None` if it did not.
    fn took_down(&self, _a: &ConformArgs) -> Result<Option<String>> {
        Ok(None)
    }
    /// The counterexample of property `p` written to `dir`: the line that
    /// names it, and the hints.
    fn write_counterexample(
        &self,
        a: &ConformArgs,
        p: &PropertyResult,
        c: &Counterexample,
        dir: &Path,
        factories: &Factories<'_>,
        settings: &ConformanceSettings,
    ) -> Result<(String, Vec<Hint>)>;
}

/// The conformance run of `a.kind`'s properties on a candidate, and its
/// report: the table, the summary, the first failed run, and each failed
/// property's counterexample in `OUT/<property>-<case>/`. Exits 1 (as
/// [`super::Exit`]) when a property fails.
pub(super) fn run(
    a: &ConformArgs,
    candidate: &dyn Candidate,
    factories: &Factories<'_>,
    settings: ConformanceSettings,
) -> Result<()> {
    let settings = settings.spread(a.cases, properties_count(a.kind));
    let start = Instant::now();
    let report = check_kind(
        a.kind,
        factories.model,
        factories.compensator,
        factories.inverse,
        &settings,
    )?;
    candidate.checked();
    // a candidate that ended its host: every later case failed at once,
    // so the finding is the report
    if let Some(line) = candidate.took_down(a)? {
        eprintln!("mfcbeam: {line}");
        return Err(super::Exit(1).into());
    }
    let cases: usize = report.properties.iter().map(|p| p.cases).sum();
    println!("{report}");
    println!(
        "{}",
        candidate.summary(cases, start.elapsed().as_secs_f64())
    );
    if report.passed() {
        return Ok(());
    }
    if let Some(e) = candidate.first_error() {
        println!("{e}");
    }
    for p in report.failed() {
        if let Some(c) = &p.counterexample {
            let dir = a.out.join(format!("{}-{}", p.name, c.case_index));
            let (line, hints) = candidate
                .write_counterexample(a, p, c, &dir, factories, &settings)
                .with_context(|| dir.display().to_string())?;
            println!("{line}");
            for h in hints {
                println!("  hint: {h}");
            }
        }
    }
    Err(super::Exit(1).into())
}

/// A program through the file contract.
struct Program {
    candidate: Arc<ExternalCandidate>,
    progress: Progress,
}

impl Candidate for Program {
    fn checked(&self) {
        self.progress.finish();
    }

    fn summary(&self, cases: usize, seconds: f64) -> String {
        let runs = self.candidate.runs.load(Ordering::Relaxed);
        format!("{cases} cases, {runs} runs of the candidate in {seconds:.1} s")
    }

    fn first_error(&self) -> Option<String> {
        self.candidate
            .first_error()
            .map(|e| format!("the candidate failed on some run: {e}"))
    }

    fn write_counterexample(
        &self,
        a: &ConformArgs,
        p: &PropertyResult,
        c: &Counterexample,
        dir: &Path,
        factories: &Factories<'_>,
        settings: &ConformanceSettings,
    ) -> Result<(String, Vec<Hint>)> {
        let recheck = |case: &Case| match a.kind {
            ConformKind::Model | ConformKind::Hysteresis => {
                model_properties().recheck(p.name, case, factories.model, settings)
            }
            ConformKind::Compensator => {
                compensator_properties().recheck(p.name, case, factories.compensator, settings)
            }
            ConformKind::InverseHysteresis => {
                inverse_hysteresis_properties().recheck(p.name, case, factories.inverse, settings)
            }
        };
        let hints = write_counterexample(
            &self.candidate,
            dir,
            a.kind,
            p.name,
            p.description,
            c,
            recheck,
        )?;
        let line = format!(
            "{}: counterexample in {} ({} samples, {} plays): cd there and run the command in command.txt",
            p.name,
            dir.display(),
            c.failure.signal.len(),
            c.case.model.hysteresis.thresholds.len()
        );
        Ok((line, hints))
    }
}

/// The failure's compared sample, its error and its tolerance, as every
/// counterexample's `failure.txt` states them.
pub(super) fn compared_line(f: &mfcbeam::suite::conformance::Failure) -> String {
    format!(
        "compared sample {}: error {}, tolerance {}",
        f.sample,
        format_f64(f.error),
        format_f64(f.tolerance)
    )
}

/// `DIR/expected.csv`: what the property required at the compared
/// samples, what the candidate gave, and the compared sample's index.
pub(super) fn write_expected(dir: &Path, f: &mfcbeam::suite::conformance::Failure) -> Result<()> {
    let n = f.expected.len().min(f.found.len());
    let path = dir.join("expected.csv");
    let mut expected = Trace::from_columns(
        &path,
        &[("expected", &f.expected[..n]), ("candidate", &f.found[..n])],
    );
    expected.push_text_column("compared", (0..n).map(|k| k.to_string()))?;
    expected.write(&path)?;
    Ok(())
}

/// The input column of a kind's traces.
pub(super) fn input_column(kind: ConformKind) -> &'static str {
    match kind {
        ConformKind::Model | ConformKind::Hysteresis => "u",
        ConformKind::Compensator => "y_d",
        ConformKind::InverseHysteresis => "y",
    }
}

/// One run on the nominal model (its hysteresis part for the kinds of `H`
/// and `H⁻¹`) and a short ramp: the command starts, follows the protocol
/// and writes finite numbers in the expected columns. A candidate that
/// declines the nominal model (exit code 3) is tried on its hysteresis part:
/// it implements part of the model, and cases with the rest are skipped.
fn smoke_test(
    candidate: &ExternalCandidate,
    kind: ConformKind,
    fixed: Option<&ModelFile>,
) -> Result<()> {
    let file = fixed.cloned().unwrap_or_else(nominal_model_file);
    let h = file.clone().hysteresis_part();
    let input: Vec<f64> = (0..50).map(|k| 10.0 * k as f64).collect();
    let run = |m: &ModelFile| match kind {
        ConformKind::Model | ConformKind::Hysteresis => candidate.simulate(m, &input),
        ConformKind::InverseHysteresis => candidate.invert(m, &input),
        ConformKind::Compensator => candidate
            .compensate(m, WIDE_LIMITS, &input)
            .map(|c| c.into_iter().map(|c| c.u).collect()),
    };
    let full = match kind {
        ConformKind::Model | ConformKind::Compensator => &file,
        ConformKind::Hysteresis | ConformKind::InverseHysteresis => &h,
    };
    let out = match run(full) {
        Err(ExternalError::Unsupported { .. }) if full != &h => run(&h).map_err(|e| match e {
            ExternalError::Unsupported { reason } => anyhow::anyhow!(
                "it declines (exit code 3) even the nominal model's hysteresis part: {reason}"
            ),
            e => e.into(),
        })?,
        r => r?,
    };
    if let Some(k) = out.iter().position(|v| !v.is_finite()) {
        bail!("row {}: a non-finite output", k + 1);
    }
    candidate.clear_log();
    Ok(())
}

/// The reference the explanations compare with.
pub(super) fn explain_kind(kind: ConformKind) -> Kind {
    match kind {
        ConformKind::Model | ConformKind::Hysteresis => Kind::Model,
        ConformKind::Compensator => Kind::Compensator,
        ConformKind::InverseHysteresis => Kind::InverseHysteresis,
    }
}

/// The output column of a kind's traces.
pub(super) fn output_column(kind: ConformKind) -> &'static str {
    match kind {
        ConformKind::Model | ConformKind::Hysteresis => "y",
        ConformKind::Compensator | ConformKind::InverseHysteresis => "u",
    }
}

/// Write a counterexample to `DIR`: the shrunk case (see [`write_case`]),
/// the case before shrinking in `DIR/before-shrinking/` when shrinking
/// changed it, and `failure.txt` (the failure, the reference by parts,
/// hints, and how shrinking changed it). Returns the hints.
fn write_counterexample(
    candidate: &ExternalCandidate,
    dir: &Path,
    kind: ConformKind,
    name: &str,
    description: &str,
    c: &Counterexample,
    recheck: impl Fn(&Case) -> Option<Outcome>,
) -> Result<Vec<Hint>> {
    let shrunk = write_case(candidate, dir, kind, &c.case, &c.failure, &recheck)?;
    let mut text = vec![format!("property: {name}"), description.to_string()];
    text.extend(shrunk.lines(&c.failure));
    if c.unshrunk_case != c.case {
        let before_dir = dir.join("before-shrinking");
        let before = write_case(
            candidate,
            &before_dir,
            kind,
            &c.unshrunk_case,
            &c.unshrunk_failure,
            &recheck,
        )?;
        let mut before_text = vec![
            format!("property: {name} (case {} before shrinking)", c.case_index),
            description.to_string(),
        ];
        before_text.extend(before.lines(&c.unshrunk_failure));
        write_atomic(
            &before_dir.join("failure.txt"),
            (before_text.join("\n") + "\n").as_bytes(),
        )?;
        let f = &c.unshrunk_failure;
        text.push(format!(
            "before shrinking (case {}, in before-shrinking/): {} samples, {} plays; sample {}: error {}, tolerance {}",
            c.case_index,
            f.signal.len(),
            c.unshrunk_case.model.hysteresis.thresholds.len(),
            f.sample,
            format_f64(f.error),
            format_f64(f.tolerance)
        ));
        if c.shrinking_changed_failure() || before.explanation.hints != shrunk.explanation.hints {
            text.push(
                "SHRINKING CHANGED THE FAILURE: the shrunk case fails in another way than the case \
                 generated (another error size or another likely cause); before-shrinking/ holds the first failure"
                    .into(),
            );
        }
    }
    write_atomic(
        &dir.join("failure.txt"),
        (text.join("\n") + "\n").as_bytes(),
    )?;
    Ok(shrunk.explanation.hints)
}

/// What [`write_case`] learnt.
struct WrittenCase {
    reproduced: bool,
    rerun_error: Option<String>,
    explanation: Explanation,
    /// The directories of the property's other runs of the candidate.
    others: Vec<String>,
}

impl WrittenCase {
    fn lines(&self, f: &mfcbeam::suite::conformance::Failure) -> Vec<String> {
        let mut out = vec![
            f.message.clone(),
            compared_line(f),
            if self.reproduced {
                "reproduced: the property fails again on this case".into()
            } else {
                "NOT reproduced on rerun: the candidate is not deterministic?".into()
            },
        ];
        if let Some(e) = &self.rerun_error {
            out.push(format!("the rerun that writes candidate.csv failed: {e}"));
        }
        if !self.others.is_empty() {
            out.push(format!(
                "the property compares this run with the candidate's run in {} (its model, input, output and command)",
                self.others.join(", ")
            ));
        }
        out.extend(self.explanation.lines());
        out
    }
}

/// Write one case to `dir`: `model.json`, `input.csv`, `candidate.csv` (the
/// candidate's output, rerun), `expected.csv` (what the property required
/// at the compared samples), `command.txt` (the one-line command that
/// reproduces it) and, for a property that compares two runs of the
/// candidate, the other run in `other-run/`.
fn write_case(
    candidate: &ExternalCandidate,
    dir: &Path,
    kind: ConformKind,
    case: &Case,
    f: &mfcbeam::suite::conformance::Failure,
    recheck: &impl Fn(&Case) -> Option<Outcome>,
) -> Result<WrittenCase> {
    fs::create_dir_all(dir)?;
    candidate.clear_log();
    let outcome = recheck(case);
    let log = candidate.log();
    // the run whose input ends with the failing signal, else the last one
    let signal = &f.signal;
    let primary = log
        .iter()
        .rposition(|i| !signal.is_empty() && i.input.ends_with(signal))
        .or(log.len().checked_sub(1));
    let Some(primary) = primary else {
        bail!("the property did not run the candidate again");
    };
    let run = &log[primary];
    let column = input_column(kind);
    let rerun = candidate.run_in(dir, &run.model, column, &run.input, run.limits);
    let _ = fs::remove_file(dir.join("stderr.txt"));
    write_expected(dir, f)?;
    write_command(candidate, dir, run.limits)?;
    // the other runs: those that are not a prefix of a longer one (an
    // adapter reruns the whole history on each call)
    let covered = |i: usize| {
        let r = &log[i];
        i == primary
            || log.iter().enumerate().any(|(j, q)| {
                j != i
                    && q.model == r.model
                    && q.limits == r.limits
                    && q.input.starts_with(&r.input)
                    && (q.input.len() > r.input.len() || j > i)
            })
    };
    let others: Vec<usize> = (0..log.len()).filter(|&i| !covered(i)).take(3).collect();
    let mut other_dirs = Vec::new();
    for (n, &i) in others.iter().enumerate() {
        let name = if others.len() == 1 {
            "other-run".to_string()
        } else {
            format!("other-run-{}", n + 1)
        };
        let d = dir.join(&name);
        fs::create_dir_all(&d)?;
        let o = &log[i];
        // a failure here shows in the missing candidate.csv
        let _ = candidate.run_in(&d, &o.model, column, &o.input, o.limits);
        let _ = fs::remove_file(d.join("stderr.txt"));
        write_command(candidate, &d, o.limits)?;
        other_dirs.push(format!("{name}/"));
    }
    let (explanation, rerun_error) = match rerun {
        Ok(t) => match t.column(output_column(kind)) {
            Ok(found) => (
                explain(
                    explain_kind(kind),
                    &run.model,
                    &run.input,
                    run.limits,
                    &found,
                    f.tolerance,
                ),
                None,
            ),
            Err(e) => (Explanation::default(), Some(e.to_string())),
        },
        Err(e) => (Explanation::default(), Some(e.to_string())),
    };
    Ok(WrittenCase {
        reproduced: matches!(outcome, Some(Outcome::Failed(_))),
        rerun_error,
        explanation,
        others: other_dirs,
    })
}

/// `DIR/command.txt`: the candidate's command on the files in `DIR`.
fn write_command(
    candidate: &ExternalCandidate,
    dir: &Path,
    limits: Option<(f64, f64)>,
) -> Result<()> {
    let quote = |w: &str| {
        if w.chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_./=,".contains(c))
        {
            w.to_string()
        } else {
            format!("'{}'", w.replace('\'', "'\\''"))
        }
    };
    // a relative path to a file (the script a candidate runs) made absolute,
    // so that the command runs from the counterexample's directory
    let absolute = |w: &String| {
        let p = Path::new(w);
        match (
            w.contains('/') && p.is_relative() && p.is_file(),
            fs::canonicalize(p),
        ) {
            (true, Ok(a)) => a.display().to_string(),
            _ => w.clone(),
        }
    };
    let mut words: Vec<String> = candidate
        .command()
        .iter()
        .map(|w| quote(&absolute(w)))
        .collect();
    words.extend(ExternalCandidate::file_arguments(
        (!candidate.is_fixed()).then_some(Path::new("model.json")),
        Path::new("input.csv"),
        Path::new("candidate.csv"),
        limits,
    ));
    write_atomic(
        &dir.join("command.txt"),
        format!("{}\n", words.join(" ")).as_bytes(),
    )?;
    Ok(())
}

/// Run the properties of `kind` on its factory (the other two unused).
pub(super) fn check_kind(
    kind: ConformKind,
    model: &ModelFactory,
    compensator: &CompensatorFactory,
    inverse: &InverseHysteresisFactory,
    settings: &ConformanceSettings,
) -> Result<ConformanceReport> {
    Ok(match kind {
        ConformKind::Model | ConformKind::Hysteresis => {
            model_properties().check(model, settings)?
        }
        ConformKind::Compensator => compensator_properties().check(compensator, settings)?,
        ConformKind::InverseHysteresis => {
            inverse_hysteresis_properties().check(inverse, settings)?
        }
    })
}

/// How many properties a kind has.
pub(super) fn properties_count(kind: ConformKind) -> usize {
    match kind {
        ConformKind::Model | ConformKind::Hysteresis => model_properties().len(),
        ConformKind::Compensator => compensator_properties().len(),
        ConformKind::InverseHysteresis => inverse_hysteresis_properties().len(),
    }
}

/// A progress line on stderr while the candidate runs (hidden when stderr is
/// not a terminal).
struct Progress {
    bar: indicatif::ProgressBar,
    stop: Arc<std::sync::atomic::AtomicBool>,
    thread: std::sync::Mutex<Option<std::thread::JoinHandle<()>>>,
}

impl Progress {
    fn start(candidate: &Arc<ExternalCandidate>) -> Self {
        let bar = indicatif::ProgressBar::new_spinner();
        bar.set_style(
            indicatif::ProgressStyle::with_template("{spinner} {elapsed} {msg}")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner()),
        );
        let stop = Arc::new(std::sync::atomic::AtomicBool::new(false));
        let (b, s, c) = (bar.clone(), stop.clone(), candidate.clone());
        let thread = std::thread::spawn(move || {
            while !s.load(Ordering::Relaxed) {
                b.set_message(format!(
                    "{} runs of the candidate",
                    c.runs.load(Ordering::Relaxed)
                ));
                b.tick();
                std::thread::sleep(Duration::from_millis(100));
            }
        });
        Self {
            bar,
            stop,
            thread: std::sync::Mutex::new(Some(thread)),
        }
    }

    fn finish(&self) {
        self.stop.store(true, Ordering::Relaxed);
        let thread = self.thread.lock().map(|mut t| t.take());
        if let Ok(Some(t)) = thread {
            let _ = t.join();
        }
        self.bar.finish_and_clear();
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        self.finish();
    }
}
