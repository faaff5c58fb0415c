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
use mfcbeam::suite::conformance::external::{
    ExternalCandidate, ExternalCompensator, ExternalInverseHysteresis, ExternalModel, Invocation,
    WIDE_LIMITS,
};
use mfcbeam::suite::conformance::{
    compensator_properties, inverse_hysteresis_properties, model_properties, Case,
    ConformanceSettings, Counterexample, Outcome,
};

use super::args::{ConformArgs, ConformKind};

/// Shrink budget for a candidate that runs as a process (each evaluation
/// starts it a few times).
const EXTERNAL_SHRINK_BUDGET: usize = 300;

pub fn conform(a: &ConformArgs) -> Result<()> {
    let settings = ConformanceSettings {
        cases: a.cases,
        seed: a.seed,
        tolerance_scale: a.tolerance_scale,
        shrink_budget: EXTERNAL_SHRINK_BUDGET,
        // a kind's model files hold only what the kind implements
        hysteresis_only: matches!(
            a.kind,
            ConformKind::Hysteresis | ConformKind::InverseHysteresis
        ),
        ..ConformanceSettings::default()
    };
    // the library's checks, named as the options are
    if let Err(ModelError::Inconsistent { field, reason }) = settings.validate() {
        bail!("--{}: {reason}", field.replace('_', "-"));
    }
    if !(a.timeout.is_finite() && a.timeout > 0.0) {
        bail!(
            "--timeout: must be a finite number > 0, found {}",
            a.timeout
        );
    }
    let candidate = Arc::new(
        ExternalCandidate::new(&a.exec, Duration::from_secs_f64(a.timeout))
            .with_context(|| format!("--exec '{}'", a.exec))?,
    );
    smoke_test(&candidate, a.kind).with_context(|| {
        format!(
            "--exec '{}': the candidate is unusable on a first, simple case",
            a.exec
        )
    })?;

    let settings = settings.spread(
        a.cases,
        match a.kind {
            ConformKind::Model | ConformKind::Hysteresis => model_properties().len(),
            ConformKind::Compensator => compensator_properties().len(),
            ConformKind::InverseHysteresis => inverse_hysteresis_properties().len(),
        },
    );
    let start = Instant::now();
    let progress = Progress::start(&candidate);
    let cand = candidate.clone();
    let model_factory = move |f: &ModelFile| -> Result<Box<dyn ActuatorModel>, ModelError> {
        Ok(Box::new(ExternalModel::new(cand.clone(), f)))
    };
    let cand = candidate.clone();
    let compensator_factory = move |f: &ModelFile,
                                    s: CompensatorSettings|
          -> Result<Box<dyn ActuatorCompensator>, ModelError> {
        Ok(Box::new(ExternalCompensator::new(cand.clone(), f, s)))
    };
    let cand = candidate.clone();
    let inverse_factory = move |f: &ModelFile| -> Result<Box<dyn InverseHysteresis>, ModelError> {
        Ok(Box::new(ExternalInverseHysteresis::new(cand.clone(), f)))
    };
    let report = match a.kind {
        ConformKind::Model | ConformKind::Hysteresis => {
            model_properties().check(&model_factory, &settings)?
        }
        ConformKind::Compensator => {
            compensator_properties().check(&compensator_factory, &settings)?
        }
        ConformKind::InverseHysteresis => {
            inverse_hysteresis_properties().check(&inverse_factory, &settings)?
        }
    };
    progress.finish();
    let runs = candidate.runs.load(Ordering::Relaxed);
    let total_cases: usize = report.properties.iter().map(|p| p.cases).sum();
    println!("{report}");
    println!(
        "{total_cases} cases, {runs} runs of the candidate in {:.1} s",
        start.elapsed().as_secs_f64()
    );
    if report.passed() {
        return Ok(());
    }
    if let Some(e) = candidate.first_error() {
        println!("the candidate failed on some run: {e}");
    }
    for p in report.failed() {
        if let Some(c) = &p.counterexample {
            let dir = a.out.join(format!("{}-{}", p.name, c.case_index));
            let recheck = |case: &Case| match a.kind {
                ConformKind::Model | ConformKind::Hysteresis => {
                    model_properties().recheck(p.name, case, &model_factory, &settings)
                }
                ConformKind::Compensator => {
                    compensator_properties().recheck(p.name, case, &compensator_factory, &settings)
                }
                ConformKind::InverseHysteresis => inverse_hysteresis_properties().recheck(
                    p.name,
                    case,
                    &inverse_factory,
                    &settings,
                ),
            };
            let column = input_column(a.kind);
            write_counterexample(&candidate, &dir, column, p.name, p.description, c, recheck)
                .with_context(|| dir.display().to_string())?;
            println!(
                "{}: counterexample in {} ({} samples, {} plays): cd there and run the command in command.txt",
                p.name,
                dir.display(),
                c.failure.signal.len(),
                c.case.model.hysteresis.thresholds.len()
            );
        }
    }
    std::process::exit(1);
}

/// The input column of a kind's traces.
fn input_column(kind: ConformKind) -> &'static str {
    match kind {
        ConformKind::Model | ConformKind::Hysteresis => "u",
        ConformKind::Compensator => "y_d",
        ConformKind::InverseHysteresis => "y",
    }
}

/// One run on the nominal model (its hysteresis part for the kinds of `H`
/// and `H⁻¹`) and a short ramp: the command starts, follows the protocol
/// and writes finite numbers in the expected columns.
fn smoke_test(candidate: &ExternalCandidate, kind: ConformKind) -> Result<()> {
    let file = nominal_model_file();
    let h = Case {
        model: file.clone(),
        input: Vec::new(),
        limits: None,
    }
    .hysteresis_part()
    .model;
    let input: Vec<f64> = (0..50).map(|k| 10.0 * k as f64).collect();
    let out = match kind {
        ConformKind::Model => candidate.simulate(&file, &input)?,
        ConformKind::Hysteresis => candidate.simulate(&h, &input)?,
        ConformKind::InverseHysteresis => candidate.invert(&h, &input)?,
        ConformKind::Compensator => candidate
            .compensate(&file, WIDE_LIMITS, &input)?
            .into_iter()
            .map(|c| c.u)
            .collect(),
    };
    if let Some(k) = out.iter().position(|v| !v.is_finite()) {
        bail!("row {}: a non-finite output", k + 1);
    }
    candidate.clear_log();
    Ok(())
}

/// Write `DIR/model.json`, `input.csv`, `candidate.csv` (the candidate's
/// output, rerun), `expected.csv` (what the property required at the compared
/// samples), `command.txt` (the one-line command that reproduces it) and
/// `failure.txt`.
fn write_counterexample(
    candidate: &ExternalCandidate,
    dir: &Path,
    column: &str,
    name: &str,
    description: &str,
    c: &Counterexample,
    recheck: impl Fn(&mfcbeam::suite::conformance::Case) -> Option<Outcome>,
) -> Result<()> {
    fs::create_dir_all(dir)?;
    candidate.clear_log();
    let outcome = recheck(&c.case);
    let log = candidate.log();
    // the run whose input ends with the failing signal, else the last one
    let signal = &c.failure.signal;
    let run: Option<&Invocation> = log
        .iter()
        .rev()
        .find(|i| !signal.is_empty() && i.input.ends_with(signal))
        .or(log.last());
    let Some(run) = run else {
        bail!("the property did not run the candidate again");
    };
    // model.json, input.csv and candidate.csv, by running it once more here
    let rerun = candidate.run_in(dir, &run.model, column, &run.input, run.limits);
    let _ = fs::remove_file(dir.join("stderr.txt"));
    let f = &c.failure;
    let n = f.expected.len().min(f.found.len());
    let mut expected = Trace::from_columns(
        &dir.join("expected.csv"),
        &[("expected", &f.expected[..n]), ("candidate", &f.found[..n])],
    );
    // the compared sample's index, as an integer
    expected.push_text_column("compared", (0..n).map(|k| k.to_string()))?;
    expected.write(&dir.join("expected.csv"))?;
    let quote = |w: &str| {
        if w.chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_./=,".contains(c))
        {
            w.to_string()
        } else {
            format!("'{}'", w.replace('\'', "'\\''"))
        }
    };
    let mut words: Vec<String> = candidate.command().iter().map(|w| quote(w)).collect();
    words.extend(ExternalCandidate::file_arguments(
        Path::new("model.json"),
        Path::new("input.csv"),
        Path::new("candidate.csv"),
        run.limits,
    ));
    write_atomic(
        &dir.join("command.txt"),
        format!("{}\n", words.join(" ")).as_bytes(),
    )?;
    let still = matches!(outcome, Some(Outcome::Failed(_)));
    let text = format!(
        "property: {name}\n{description}\n{}\nsample {}: error {}, tolerance {}\n{}\n{}",
        f.message,
        f.sample,
        format_f64(f.error),
        format_f64(f.tolerance),
        if still {
            "reproduced: the property fails again on this case"
        } else {
            "NOT reproduced on rerun: the candidate is not deterministic?"
        },
        match rerun {
            Ok(_) => String::new(),
            Err(e) => format!("the rerun that writes candidate.csv failed: {e}\n"),
        }
    );
    write_atomic(&dir.join("failure.txt"), text.as_bytes())?;
    Ok(())
}

/// A progress line on stderr while the candidate runs (hidden when stderr is
/// not a terminal).
struct Progress {
    bar: indicatif::ProgressBar,
    stop: Arc<std::sync::atomic::AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
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
            thread: Some(thread),
        }
    }

    fn finish(mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
        self.bar.finish_and_clear();
    }
}
