//! `mfcbeam fmu` (package an FMU) and `mfcbeam conform --fmu` (check one
//! through the conformance properties in the fixed mode).

use std::path::Path;

use anyhow::{bail, Context, Result};

use mfcbeam::fmi::import::{
    bind, Fmu, FmuCandidate, FmuCompensator, FmuInverseHysteresis, FmuModel, ImportKind,
};
use mfcbeam::fmi::package::{build_command, FmuPackage, ReleaseFolder};
use mfcbeam::fmi::Platform;
use mfcbeam::fmi::{FmiVersion, FmuKind};
use mfcbeam::io::{format_f64, read_beam, read_model_file, write_atomic, Trace};
use mfcbeam::prelude::*;
use mfcbeam::suite::conformance::explain::explain;
use mfcbeam::suite::conformance::explain::Hint;
use mfcbeam::suite::conformance::external::WIDE_LIMITS;
use mfcbeam::suite::conformance::{fixed, ConformanceSettings, Counterexample, PropertyResult};

use super::args::{ConformArgs, ConformKind, FmuArgs, FmuKindArg};

use super::conform::{
    compared_line, explain_kind, input_column, output_column, run, Candidate, Factories,
};

pub fn fmu(a: &FmuArgs) -> Result<()> {
    let model = match (&a.model, a.kind) {
        (Some(_), FmuKindArg::Controller) => {
            bail!("--model: a controller FMU holds no model (its design is for the benchmark's)")
        }
        (Some(m), _) => read_model_file(m)?,
        (None, _) => mfcbeam::operators::nominal::nominal_model_file(),
    };
    let beam = match (&a.beam, a.kind) {
        (Some(b), FmuKindArg::Plant | FmuKindArg::Controller) => Some(read_beam(b)?),
        (Some(_), _) => bail!("--beam: only the plant and the controller have a beam"),
        (None, _) => None,
    };
    if a.controller.is_some() && a.kind != FmuKindArg::Controller {
        bail!("--controller: only with --kind controller");
    }
    let controller = match a.controller.as_deref() {
        None => None,
        Some(id) => {
            use mfcbeam::control::{Benchmark, BuiltinController};
            let kind = match BuiltinController::from_id(id) {
                Some(k) if k != BuiltinController::Open => k,
                _ => bail!("--controller '{id}': not one of pid, lq"),
            };
            let bench = match &beam {
                None => Benchmark::nominal()?,
                Some(b) => {
                    let kind = super::args::BeamModelArgs::kind_of(a.beam_model, a.elements);
                    let modal =
                        mfcbeam::beam::step_response_fit::modal_model(b, kind).context("--beam")?;
                    Benchmark::new(mfcbeam::operators::nominal::nominal_model(), modal)?
                }
            };
            Some(bench.controller_file(kind)?)
        }
    };
    let beam = if a.kind == FmuKindArg::Controller {
        None
    } else {
        beam
    };
    let libraries = libraries(a)?;
    let package = FmuPackage {
        kind: match a.kind {
            FmuKindArg::Compensator => FmuKind::Compensator,
            FmuKindArg::Model => FmuKind::Model,
            FmuKindArg::Plant => FmuKind::Plant,
            FmuKindArg::Controller => FmuKind::Controller,
        },
        version: if a.fmi == "2" {
            FmiVersion::Fmi2
        } else {
            FmiVersion::Fmi3
        },
        model,
        beam,
        beam_model: super::args::BeamModelArgs::kind_of(a.beam_model, a.elements),
        controller,
        libraries,
    };
    package
        .write(&a.output)
        .with_context(|| format!("--output {}", a.output.display()))?;
    let platforms: Vec<_> = package.platforms().iter().map(|p| p.name()).collect();
    eprintln!(
        "wrote {} (FMI {}, {}; platforms {})",
        a.output.display(),
        package.version.as_str(),
        package.kind.name(),
        platforms.join(", ")
    );
    Ok(())
}

/// The libraries to pack: those given, each platform read from its
/// header, or those of the release folder.
fn libraries(a: &FmuArgs) -> Result<Vec<(Platform, std::path::PathBuf)>> {
    if !a.library.is_empty() {
        let mut found = Vec::new();
        for path in &a.library {
            let bytes =
                std::fs::read(path).with_context(|| format!("--library {}", path.display()))?;
            let platform = Platform::of_library(&bytes)
                .map_err(|what| anyhow::anyhow!("--library {}: {what}", path.display()))?;
            found.push((platform, path.clone()));
        }
        return Ok(found);
    }
    let folder = match &a.release_folder {
        Some(dir) => ReleaseFolder::new(dir),
        None => ReleaseFolder::of_this_program()
            .context("--release-folder: cannot tell where this program runs from; give it")?,
    };
    let chosen = !a.platforms.is_empty();
    let wanted: Vec<Platform> = if !chosen || a.platforms.iter().any(|p| p == "all") {
        Platform::ALL.to_vec()
    } else {
        a.platforms
            .iter()
            .map(|name| {
                Platform::from_name(name).with_context(|| {
                    let names: Vec<_> = Platform::ALL.iter().map(|p| p.name()).collect();
                    format!("--platforms: '{name}' is none of {}", names.join(", "))
                })
            })
            .collect::<Result<_>>()?
    };
    let (mut found, mut missing) = folder.find(&wanted);
    // the platforms asked for are built where the folder is a checkout's
    if chosen && !missing.is_empty() {
        if let Some(source) = source_tree(&folder.target) {
            for &p in &missing {
                build_library(&source, &folder.target, p)?;
            }
            (found, missing) = folder.find(&wanted);
        }
    }
    let how = |p: &Platform| format!("{p} (`{}`)", build_command(*p));
    if chosen && !missing.is_empty() {
        let list: Vec<_> = missing.iter().map(how).collect();
        bail!(
            "--platforms: no library in {} for {}",
            folder.target.display(),
            list.join(", ")
        );
    }
    if found.is_empty() {
        bail!(
            "--release-folder: no mfcbeam-fmu library in {}; build it with `{}`",
            folder.target.display(),
            Platform::host().map_or("cargo build --release -p mfcbeam-fmu".into(), build_command)
        );
    }
    // macOS libraries are built on a Mac: not finding them is expected
    let missing: Vec<_> = missing
        .into_iter()
        .filter(|p| Platform::BUILT_HERE.contains(p))
        .collect();
    if !missing.is_empty() {
        let list: Vec<_> = missing.iter().map(|p| p.name()).collect();
        eprintln!(
            "not packed, no library in {}: {} (--platforms names the ones required)",
            folder.target.display(),
            list.join(", ")
        );
    }
    Ok(found)
}

/// The mfcbeam checkout whose cargo target folder `target` is, if it is
/// one (the FMU library's crate beside it).
fn source_tree(target: &Path) -> Option<std::path::PathBuf> {
    let source = target.canonicalize().ok()?.parent()?.to_path_buf();
    (source.join("Cargo.toml").is_file() && source.join("fmu").join("Cargo.toml").is_file())
        .then_some(source)
}

/// Build `platform`'s FMU library from the checkout `source` into
/// `target` with the cargo on the path; its first error in one line if
/// that fails (no toolchain, no target, no linker).
fn build_library(source: &Path, target: &Path, platform: Platform) -> Result<()> {
    let command = build_command(platform);
    eprintln!("building the {platform} library: {command}");
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let mut cmd = std::process::Command::new(cargo);
    cmd.args(["build", "--release", "-p", "mfcbeam-fmu", "--target-dir"])
        .arg(target)
        .current_dir(source);
    if Platform::host() != Some(platform) {
        cmd.args(["--target", platform.rust_target()]);
    }
    let out = cmd
        .output()
        .with_context(|| format!("--platforms: {platform}: running `{command}`"))?;
    if !out.status.success() {
        let stderr = String::from_utf8_lossy(&out.stderr);
        let first = stderr
            .lines()
            .find(|l| l.trim_start().starts_with("error"))
            .or_else(|| stderr.lines().last())
            .unwrap_or("no message")
            .trim();
        bail!("--platforms: {platform}: `{command}` failed: {first}");
    }
    Ok(())
}

/// Parse `--fmu-variable OURS=THEIRS`.
fn variable_map(items: &[String]) -> Result<Vec<(String, String)>> {
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

/// `conform --fmu X.fmu --model M.json`: the FMU is the candidate, fixed
/// to the model M.
pub fn conform_fmu(a: &ConformArgs, path: &Path, settings: ConformanceSettings) -> Result<()> {
    let fixed_model = settings
        .fixed_model
        .clone()
        .context("--fmu needs --model")?;
    let fmu = Fmu::load(path).with_context(|| format!("--fmu {}", path.display()))?;
    let import_kind = match a.kind {
        ConformKind::Model | ConformKind::Hysteresis => ImportKind::Model,
        ConformKind::Compensator => ImportKind::Compensator,
        ConformKind::InverseHysteresis => ImportKind::InverseHysteresis,
    };
    let map = variable_map(&a.fmu_variable)?;
    let bindings = bind(&fmu.description, import_kind, &map)
        .with_context(|| format!("--fmu {}", path.display()))?;
    if let Some(step) = fmu.description.step_size {
        let ts = fixed_model.sample_time;
        if (step - ts).abs() > 1e-9 * ts {
            eprintln!(
                "note: the FMU's default step size is {step} s, the model's sample time {ts} s; one step per sample of the model is used"
            );
        }
    }
    let delay = mfcbeam::suite::conformance::delay_of(&fixed_model);
    // limits built in: the cases keep inside them
    let mut settings = settings;
    let own_limits = match (bindings.limits, a.limits) {
        (Some(_), Some(_)) => {
            bail!("--limits: the FMU has limit parameters (u_min, u_max); every case sets its own")
        }
        (Some(_), None) => None,
        (None, given) => {
            let d = CompensatorSettings::default();
            Some(given.unwrap_or((d.lower_limit, d.upper_limit)))
        }
    };
    if a.kind == ConformKind::Compensator {
        settings.fixed_limits = own_limits;
    }
    let candidate = FmuCandidate::new(fmu, bindings, fixed_model.sample_time);
    smoke_test(&candidate, import_kind)
        .with_context(|| format!("--fmu {}: unusable on a first, simple case", path.display()))?;

    let c = candidate.clone();
    let model = fixed::fixed_model_factory(fixed_model.clone(), move || {
        let m: Box<dyn ActuatorModel> = Box::new(FmuModel::new(&c).map_err(instance_failed)?);
        Ok(m)
    });
    let c = candidate.clone();
    let compensator =
        fixed::fixed_compensator_factory(fixed_model.clone(), move |s: CompensatorSettings| {
            if let Some((lo, hi)) = own_limits {
                let unlimited =
                    s.lower_limit == f64::NEG_INFINITY && s.upper_limit == f64::INFINITY;
                if !unlimited && (s.lower_limit, s.upper_limit) != (lo, hi) {
                    return Err(ModelError::Unsupported {
                        part: "limits other than the FMU's own (it has no u_min, u_max)".into(),
                    });
                }
            }
            let limits = (
                s.lower_limit.max(WIDE_LIMITS.0),
                s.upper_limit.min(WIDE_LIMITS.1),
            );
            let m: Box<dyn ActuatorCompensator> =
                Box::new(FmuCompensator::new(&c, Some(limits), delay).map_err(instance_failed)?);
            Ok(m)
        });
    let c = candidate.clone();
    let inverse = fixed::fixed_inverse_hysteresis_factory(fixed_model.clone(), move || {
        let m: Box<dyn InverseHysteresis> =
            Box::new(FmuInverseHysteresis::new(&c).map_err(instance_failed)?);
        Ok(m)
    });
    let factories = Factories {
        model: &model,
        compensator: &compensator,
        inverse: &inverse,
    };
    run(a, &OneFmu { candidate, delay }, &factories, settings)
    // the candidate's scratch directories are removed as it is dropped
}

/// An FMU as `conform`'s candidate, fixed to its model.
struct OneFmu {
    candidate: FmuCandidate,
    /// The preview of its compensator (the model's dead time and lag).
    delay: usize,
}

impl Candidate for OneFmu {
    fn summary(&self, cases: usize, seconds: f64) -> String {
        format!("{cases} cases on the FMU in {seconds:.1} s")
    }

    fn first_error(&self) -> Option<String> {
        self.candidate
            .first_error
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .clone()
            .map(|e| format!("the FMU failed on some run: {e}"))
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
        write_counterexample(a, &self.candidate, p, c, dir, self.delay)
    }
}

/// An instance that could not be made: the case counts as failed (a
/// refusal of the model it claims to implement).
fn instance_failed(e: mfcbeam::fmi::import::ImportError) -> ModelError {
    ModelError::Inconsistent {
        field: "fmu".into(),
        reason: e.to_string(),
    }
}

/// Fifty samples of a ramp: the FMU instantiates, steps and gives finite
/// numbers.
fn smoke_test(candidate: &FmuCandidate, kind: ImportKind) -> Result<()> {
    let input: Vec<f64> = (0..50).map(|k| 10.0 * k as f64).collect();
    let out: Vec<f64> = match kind {
        ImportKind::Model => FmuModel::new(candidate)?.run(&input),
        ImportKind::InverseHysteresis => FmuInverseHysteresis::new(candidate)?.run(&input),
        ImportKind::Compensator => FmuCompensator::new(candidate, Some(WIDE_LIMITS), 0)?
            .compensate_all(&input)
            .iter()
            .map(|c| c.u)
            .collect(),
    };
    if let Some(e) = candidate
        .first_error
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .take()
    {
        return Err(e.into());
    }
    if let Some(k) = out.iter().position(|v| !v.is_finite()) {
        bail!("sample {k}: a non-finite output");
    }
    Ok(())
}

/// A failing property's shrunk case in `dir`: the model, the input, the
/// FMU's output from its initial state, what the property expected, and
/// `failure.txt` with the reference by parts and the hints.
fn write_counterexample(
    a: &ConformArgs,
    candidate: &FmuCandidate,
    p: &PropertyResult,
    c: &Counterexample,
    dir: &Path,
    delay: usize,
) -> Result<(String, Vec<Hint>)> {
    std::fs::create_dir_all(dir).with_context(|| dir.display().to_string())?;
    let f = &c.failure;
    let signal = &f.signal;
    // the FMU's whole output on the signal from its initial state
    let found: Vec<f64> = match a.kind {
        ConformKind::Model | ConformKind::Hysteresis => FmuModel::new(candidate)?.run(signal),
        ConformKind::InverseHysteresis => FmuInverseHysteresis::new(candidate)?.run(signal),
        ConformKind::Compensator => {
            let limits = c.case.limits.unwrap_or(WIDE_LIMITS);
            FmuCompensator::new(candidate, Some(limits), delay)?
                .compensate_all(signal)
                .iter()
                .map(|c| c.u)
                .collect()
        }
    };
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
    let n = f.expected.len().min(f.found.len());
    let exp_path = dir.join("expected.csv");
    let mut expected = Trace::from_columns(
        &exp_path,
        &[("expected", &f.expected[..n]), ("candidate", &f.found[..n])],
    );
    expected.push_text_column("compared", (0..n).map(|k| k.to_string()))?;
    expected.write(&exp_path)?;
    let explanation = explain(
        explain_kind(a.kind),
        &c.case.model,
        signal,
        c.case.limits,
        &found,
        f.tolerance,
    );
    let mut text = vec![
        format!("property: {}", p.name),
        p.description.to_string(),
        f.message.clone(),
        compared_line(f),
        format!(
            "candidate.csv: the FMU's output on input.csv from its initial state, one doStep of {} s per sample",
            format_f64(c.case.model.sample_time)
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
