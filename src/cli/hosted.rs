//! `mfcbeam conform --fmu` and `conform --library`: an FMU or a step
//! library checked through the conformance properties, in a host process
//! of its own ([`mfcbeam::isolation`]). A candidate that crashes, exits
//! or hangs ends the run with one line naming what it was doing, the
//! sample and the case, its model and input up to that sample written to
//! `OUT/crash/`, `OUT/exit/` or `OUT/hang/`, and exit code 1.

use std::path::Path;
use std::sync::Arc;

use anyhow::{bail, Context, Result};

use mfcbeam::io::{format_f64, write_atomic, Trace};
use mfcbeam::isolation::{
    model_error, CandidateSpec, Finding, HostError, HostedCandidate, HostedCompensator,
    HostedInverseHysteresis, HostedModel, Role,
};
use mfcbeam::prelude::*;
use mfcbeam::suite::conformance::explain::{explain, Hint};
use mfcbeam::suite::conformance::external::WIDE_LIMITS;
use mfcbeam::suite::conformance::{fixed, ConformanceSettings, Counterexample, PropertyResult};

use super::args::{ConformArgs, ConformKind};
use super::conform::{
    compared_line, explain_kind, input_column, output_column, run, write_expected, Candidate,
    Factories,
};
use super::Exit;

/// Parse `--fmu-variable OURS=THEIRS`.
pub(super) fn variable_map(items: &[String]) -> Result<Vec<(String, String)>> {
    const OURS: [&str; 7] = ["u", "y", "y_d", "saturated", "fault", "u_min", "u_max"];
    items
        .iter()
        .map(|item| {
            let Some((ours, theirs)) = item.split_once('=') else {
                bail!("--fmu-variable '{item}': expected OURS=THEIRS");
            };
            if !OURS.contains(&ours) {
                bail!(
                    "--fmu-variable '{item}': '{ours}' is none of ours ({})",
                    OURS.join(", ")
                );
            }
            Ok((ours.to_string(), theirs.to_string()))
        })
        .collect()
}

fn role(kind: ConformKind) -> Role {
    match kind {
        ConformKind::Model | ConformKind::Hysteresis => Role::Model,
        ConformKind::Compensator => Role::Compensator,
        ConformKind::InverseHysteresis => Role::InverseHysteresis,
    }
}

/// The one line of a candidate that took its host down, and exit code 1
/// (a finding about the candidate, not a usage error).
pub fn took_down(option: &str, e: &HostError) -> anyhow::Error {
    eprintln!("mfcbeam: {option}: {e}");
    Exit(1).into()
}

/// `conform --fmu X.fmu --model M.json` or `conform --library L.so
/// [--model M.json]`.
pub fn conform_hosted(a: &ConformArgs, settings: ConformanceSettings) -> Result<()> {
    let role = role(a.kind);
    let fixed_model = settings.fixed_model.clone();
    let (option, spec) = match (&a.fmu, &a.library.library) {
        (Some(path), _) => {
            let fixed_model = fixed_model.as_ref().context("--fmu needs --model")?;
            (
                format!("--fmu {}", path.display()),
                CandidateSpec::Fmu {
                    path: path.display().to_string(),
                    role,
                    variables: variable_map(&a.fmu_variable)?,
                    sample_time: fixed_model.sample_time,
                },
            )
        }
        (None, Some(path)) => {
            let option = format!("--library {}", path.display());
            let absolute = path.canonicalize().with_context(|| option.clone())?;
            (
                option,
                CandidateSpec::Library {
                    path: absolute.display().to_string(),
                    role,
                    symbol_prefix: a.library.symbol_prefix.clone(),
                    precision: a.library.precision.precision(),
                },
            )
        }
        (None, None) => bail!("conform: one of --exec, --fmu, --library"),
    };
    let is_fmu = matches!(spec, CandidateSpec::Fmu { .. });
    let host = a.host.settings(a.timeout)?;
    let candidate = HostedCandidate::start(&host, spec).map_err(|e| match e {
        e if e.is_fatal() => took_down(&option, &e),
        e => anyhow::anyhow!("{option}: {e}"),
    })?;
    if let (Some(step), Some(m)) = (candidate.loaded.step_size, &fixed_model) {
        let ts = m.sample_time;
        if (step - ts).abs() > 1e-9 * ts {
            eprintln!(
                "note: the FMU's default step size is {step} s, the model's sample time {ts} s; one step per sample of the model is used"
            );
        }
    }
    // limits built in (an FMU without u_min, u_max): the cases keep inside
    // them
    let mut settings = settings;
    let own_limits = match (candidate.loaded.takes_limits, a.limits) {
        (true, Some(_)) => {
            bail!(
                "--limits: the candidate takes its limits (u_min, u_max); every case sets its own"
            )
        }
        (true, None) => None,
        (false, given) => {
            let d = CompensatorSettings::default();
            Some(given.unwrap_or((d.lower_limit, d.upper_limit)))
        }
    };
    if a.kind == ConformKind::Compensator {
        settings.fixed_limits = own_limits;
    }
    let hosted = Hosted {
        candidate: candidate.clone(),
        option: option.clone(),
        fixed: fixed_model.clone(),
        is_fmu,
    };
    hosted.smoke_test(a.kind, &a.out)?;

    let c = candidate.clone();
    let fmu_limits = move |lo: f64, hi: f64| {
        if is_fmu {
            (lo.max(WIDE_LIMITS.0), hi.min(WIDE_LIMITS.1))
        } else {
            (lo, hi)
        }
    };
    let limits_ok = move |s: &CompensatorSettings| -> Result<(f64, f64), ModelError> {
        if let Some((lo, hi)) = own_limits {
            let unlimited = s.lower_limit == f64::NEG_INFINITY && s.upper_limit == f64::INFINITY;
            if !unlimited && (s.lower_limit, s.upper_limit) != (lo, hi) {
                return Err(ModelError::Unsupported {
                    part: "limits other than the candidate's own (it has no u_min, u_max)".into(),
                });
            }
        }
        Ok(fmu_limits(s.lower_limit, s.upper_limit))
    };
    match fixed_model {
        Some(fixed_model) => {
            let delay = mfcbeam::suite::conformance::delay_of(&fixed_model);
            let model = fixed::fixed_model_factory(fixed_model.clone(), {
                let c = c.clone();
                move || {
                    let m: Box<dyn ActuatorModel> =
                        Box::new(HostedModel::new(&c, None).map_err(model_error)?);
                    Ok(m)
                }
            });
            let compensator = fixed::fixed_compensator_factory(fixed_model.clone(), {
                let c = c.clone();
                move |s: CompensatorSettings| {
                    let limits = limits_ok(&s)?;
                    let m: Box<dyn ActuatorCompensator> = Box::new(
                        HostedCompensator::new(&c, None, Some(limits), delay)
                            .map_err(model_error)?,
                    );
                    Ok(m)
                }
            });
            let inverse = fixed::fixed_inverse_hysteresis_factory(fixed_model.clone(), {
                let c = c.clone();
                move || {
                    let m: Box<dyn InverseHysteresis> =
                        Box::new(HostedInverseHysteresis::new(&c, None).map_err(model_error)?);
                    Ok(m)
                }
            });
            let factories = Factories {
                model: &model,
                compensator: &compensator,
                inverse: &inverse,
            };
            run(a, &hosted, &factories, settings)
        }
        None => {
            let model = {
                let c = c.clone();
                move |f: &ModelFile| -> Result<Box<dyn ActuatorModel>, ModelError> {
                    Ok(Box::new(
                        HostedModel::new(&c, Some(f)).map_err(model_error)?,
                    ))
                }
            };
            let compensator = {
                let c = c.clone();
                move |f: &ModelFile,
                      s: CompensatorSettings|
                      -> Result<Box<dyn ActuatorCompensator>, ModelError> {
                    let limits = limits_ok(&s)?;
                    let delay = mfcbeam::suite::conformance::delay_of(f);
                    Ok(Box::new(
                        HostedCompensator::new(&c, Some(f), Some(limits), delay)
                            .map_err(model_error)?,
                    ))
                }
            };
            let inverse = {
                let c = c.clone();
                move |f: &ModelFile| -> Result<Box<dyn InverseHysteresis>, ModelError> {
                    Ok(Box::new(
                        HostedInverseHysteresis::new(&c, Some(f)).map_err(model_error)?,
                    ))
                }
            };
            let factories = Factories {
                model: &model,
                compensator: &compensator,
                inverse: &inverse,
            };
            run(a, &hosted, &factories, settings)
        }
    }
    // the host ends, and its scratch directories go, as `candidate` drops
}

/// An FMU or a library as `conform`'s candidate.
struct Hosted {
    candidate: Arc<HostedCandidate>,
    /// `--fmu X` or `--library L`, for messages.
    option: String,
    /// The model of a fixed candidate.
    fixed: Option<ModelFile>,
    is_fmu: bool,
}

impl Hosted {
    /// The candidate's whole output on `signal` from its initial state
    /// (with `model` unless fixed).
    fn output(
        &self,
        kind: ConformKind,
        model: &ModelFile,
        limits: Option<(f64, f64)>,
        signal: &[f64],
    ) -> Result<Vec<f64>> {
        let m = self.fixed.is_none().then_some(model);
        // the host's error kept, so that a refusal can be told apart
        let fail = |e: HostError| anyhow::Error::new(e).context(self.option.clone());
        Ok(match kind {
            ConformKind::Model | ConformKind::Hysteresis => HostedModel::new(&self.candidate, m)
                .map_err(fail)?
                .run(signal),
            ConformKind::InverseHysteresis => HostedInverseHysteresis::new(&self.candidate, m)
                .map_err(fail)?
                .run(signal),
            ConformKind::Compensator => {
                let delay = mfcbeam::suite::conformance::delay_of(model);
                HostedCompensator::new(
                    &self.candidate,
                    m,
                    Some(limits.unwrap_or(WIDE_LIMITS)),
                    delay,
                )
                .map_err(fail)?
                .compensate_all(signal)
                .iter()
                .map(|c| c.u)
                .collect()
            }
        })
    }

    /// Fifty samples of a ramp on the nominal model (or the fixed one):
    /// the candidate instantiates, steps and gives finite numbers.
    fn smoke_test(&self, kind: ConformKind, out_dir: &Path) -> Result<()> {
        let file = self
            .fixed
            .clone()
            .unwrap_or_else(mfcbeam::operators::nominal::nominal_model_file);
        let file = match kind {
            ConformKind::Hysteresis | ConformKind::InverseHysteresis => file.hysteresis_part(),
            _ => file,
        };
        let input: Vec<f64> = (0..50).map(|k| 10.0 * k as f64).collect();
        let mut out = self.output(kind, &file, None, &input);
        // a library that declines the nominal model (create returns NULL)
        // is tried on its hysteresis part, as a program that exits 3 is:
        // it implements part of the model, and cases with the rest are
        // skipped
        let refused = |r: &Result<Vec<f64>>| {
            r.as_ref()
                .err()
                .and_then(|e| e.downcast_ref::<HostError>())
                .is_some_and(|e| matches!(e, HostError::Refused(_)))
        };
        if self.fixed.is_none() && refused(&out) {
            let h = file.clone().hysteresis_part();
            if h != file {
                out = self.output(kind, &h, None, &input);
                if refused(&out) {
                    bail!(
                        "{}: unusable on a first, simple case: it declines (create returns NULL) even the nominal model's hysteresis part",
                        self.option
                    );
                }
            }
        }
        let out = out.context("unusable on a first, simple case");
        if let Some(line) = self.write_finding(out_dir, true)? {
            eprintln!("mfcbeam: {line}");
            return Err(Exit(1).into());
        }
        let out = out?;
        if let Some(e) = self.candidate.first_error() {
            bail!("{}: unusable on a first, simple case: {e}", self.option);
        }
        if let Some(k) = out.iter().position(|v| !v.is_finite()) {
            bail!(
                "{}: unusable on a first, simple case: sample {k}: a non-finite output",
                self.option
            );
        }
        self.candidate.clear_errors();
        Ok(())
    }

    /// The line of a candidate that took its host down, its model and
    /// input written to `out/<crash|exit|hang>/` when `write` is set.
    fn write_finding(&self, out: &Path, write: bool) -> Result<Option<String>> {
        let Some(f) = self.candidate.finding() else {
            return Ok(None);
        };
        let Finding {
            error,
            case,
            model,
            limits,
            input,
        } = &f;
        let (what, how) = match error {
            HostError::Ended { how, during, .. } => (
                if how.starts_with("crashed") {
                    "crash"
                } else {
                    "exit"
                },
                format!("{how} {}", during.describe()),
            ),
            HostError::Timeout {
                seconds, during, ..
            } => (
                "hang",
                format!(
                    "did not answer within {seconds} s (killed) {}",
                    during.describe()
                ),
            ),
            e => ("crash", e.to_string()),
        };
        let n_in = self.candidate.role().inputs();
        let samples = input.len() / n_in;
        let at = match error.sample() {
            Some(_) => format!(" at sample {} of its input", samples.saturating_sub(1)),
            None => String::new(),
        };
        let case_text = match case {
            Some((p, i)) => format!(", in property {p} (case {i})"),
            None => ", on the first, simple case".into(),
        };
        let stderr = match error {
            HostError::Ended {
                stderr: Some(l), ..
            } => format!(" (its last words on stderr: {l})"),
            _ => String::new(),
        };
        let mut line = format!(
            "{}: the candidate {how}{at}{case_text}{stderr}",
            self.option
        );
        if !write {
            return Ok(Some(line));
        }
        let dir = out.join(what);
        std::fs::create_dir_all(&dir).with_context(|| dir.display().to_string())?;
        let model = model.clone().or_else(|| self.fixed.clone());
        if let Some(m) = &model {
            let text = serde_json::to_string_pretty(m)?;
            write_atomic(&dir.join("model.json"), (text + "\n").as_bytes())?;
        }
        let ts = model.as_ref().map_or(1.0, |m| m.sample_time);
        let t: Vec<f64> = (0..samples).map(|k| k as f64 * ts).collect();
        let path = dir.join("input.csv");
        let column = match self.candidate.role() {
            Role::Compensator => "y_d",
            Role::InverseHysteresis => "y",
            _ => "u",
        };
        Trace::from_columns(&path, &[("t", &t), (column, input)]).write(&path)?;
        let mut text = vec![line.clone()];
        if let Some((lo, hi)) = limits {
            text.push(format!("limits: {}, {}", format_f64(*lo), format_f64(*hi)));
        }
        text.push(format!(
            "input.csv: the instance's input from its start up to and including the sample it {}",
            if what == "hang" {
                "hung at"
            } else {
                "ended the process at"
            }
        ));
        write_atomic(
            &dir.join("failure.txt"),
            (text.join("\n") + "\n").as_bytes(),
        )?;
        line.push_str(&format!("; its model and input in {}", dir.display()));
        Ok(Some(line))
    }
}

impl Candidate for Hosted {
    fn summary(&self, cases: usize, seconds: f64) -> String {
        let what = if self.is_fmu {
            "the FMU"
        } else {
            "the library"
        };
        format!("{cases} cases on {what} in {seconds:.1} s")
    }

    fn first_error(&self) -> Option<String> {
        self.candidate
            .first_error()
            .map(|e| format!("the candidate failed on some run: {e}"))
    }

    fn took_down(&self, a: &ConformArgs) -> Result<Option<String>> {
        self.write_finding(&a.out, true)
    }

    fn write_counterexample(
        &self,
        a: &ConformArgs,
        p: &PropertyResult,
        c: &Counterexample,
        dir: &Path,
        _: &Factories<'_>,
        _: &ConformanceSettings,
    ) -> Result<(String, Vec<Hint>)> {
        std::fs::create_dir_all(dir).with_context(|| dir.display().to_string())?;
        let f = &c.failure;
        let signal = &f.signal;
        let found = self.output(a.kind, &c.case.model, c.case.limits, signal)?;
        let model_json = serde_json::to_string_pretty(&c.case.model)?;
        write_atomic(&dir.join("model.json"), (model_json + "\n").as_bytes())?;
        let t: Vec<f64> = (0..signal.len())
            .map(|k| k as f64 * c.case.model.sample_time)
            .collect();
        let input_path = dir.join("input.csv");
        Trace::from_columns(&input_path, &[("t", &t), (input_column(a.kind), signal)])
            .write(&input_path)?;
        let out_path = dir.join("candidate.csv");
        Trace::from_columns(&out_path, &[("t", &t), (output_column(a.kind), &found)])
            .write(&out_path)?;
        write_expected(dir, f)?;
        let explanation = explain(
            explain_kind(a.kind),
            &c.case.model,
            signal,
            c.case.limits,
            &found,
            f.tolerance,
        );
        let what = if self.is_fmu {
            format!(
                "one doStep of {} s per sample",
                format_f64(c.case.model.sample_time)
            )
        } else {
            "one step per sample".into()
        };
        let mut text = vec![
            format!("property: {}", p.name),
            p.description.to_string(),
            f.message.clone(),
            compared_line(f),
            format!(
                "candidate.csv: the candidate's output on input.csv from its initial state, {what}"
            ),
            format!(
                "before shrinking (case {}): {} samples; sample {}: error {}",
                c.case_index,
                c.unshrunk_failure.signal.len(),
                c.unshrunk_failure.sample,
                format_f64(c.unshrunk_failure.error)
            ),
        ];
        text.extend(explanation.lines());
        write_atomic(
            &dir.join("failure.txt"),
            (text.join("\n") + "\n").as_bytes(),
        )?;
        let line = format!(
            "{}: counterexample in {} ({} samples)",
            p.name,
            dir.display(),
            signal.len()
        );
        Ok((line, explanation.hints))
    }
}
