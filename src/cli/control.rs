//! `mfcbeam benchmark-control`: a controller in every scenario of the
//! closed-loop benchmark, the open loop alongside, and the score table.

use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

use anyhow::{bail, Context, Result};

use mfcbeam::beam::step_response_fit::modal_model;
use mfcbeam::beam::BeamParameters;
use mfcbeam::control::process::ProcessController;
use mfcbeam::control::{
    Benchmark, BenchmarkRun, BuiltinController, Controller, BENCHMARK_SCENARIOS,
};
use mfcbeam::io::{read_beam, read_model, write_atomic, Trace};
use mfcbeam::isolation::{CandidateSpec, HostedCandidate, HostedController, Role};
use mfcbeam::operators::nominal::SAMPLE_TIME;
use mfcbeam::suite::conformance::external::split_command;
use mfcbeam::suite::plots::{panel, scaled, series, write_figure, Figure, COLORS, GREY};

use super::args::BenchmarkControlArgs;

/// Who runs: a built-in design or the program.
enum Entrant {
    Builtin(BuiltinController),
    Program(Vec<String>),
    /// An FMU in its host process, and its file name.
    Fmu(Arc<HostedCandidate>, String),
}

impl Entrant {
    fn id(&self) -> String {
        match self {
            Self::Builtin(b) => b.id().into(),
            Self::Program(_) => "program".into(),
            Self::Fmu(..) => "fmu".into(),
        }
    }
}

pub fn benchmark_control(a: &BenchmarkControlArgs) -> Result<()> {
    if !(a.timeout.is_finite() && a.timeout > 0.0 && a.timeout <= 86_400.0) {
        bail!("--timeout: must be a number of seconds in (0, 86400]");
    }
    let mut entrants = vec![Entrant::Builtin(BuiltinController::Open)];
    for id in &a.controller {
        match BuiltinController::from_id(id) {
            Some(BuiltinController::Open) => {}
            Some(b) => entrants.push(Entrant::Builtin(b)),
            None => bail!("--controller '{id}': not one of pid, lq, open"),
        }
    }
    if let Some(exec) = &a.exec {
        let words = split_command(exec);
        if words.is_empty() {
            bail!("--exec: the command line is empty");
        }
        entrants.push(Entrant::Program(words));
    } else if let Some(path) = &a.fmu {
        let mut variables = Vec::new();
        for item in &a.fmu_variable {
            let Some((ours, theirs)) = item.split_once('=') else {
                bail!("--fmu-variable '{item}': expected OURS=THEIRS");
            };
            if !["reference", "measurement", "correction"].contains(&ours) {
                bail!(
                    "--fmu-variable '{item}': '{ours}' is none of ours (reference, measurement, correction)"
                );
            }
            variables.push((ours.to_string(), theirs.to_string()));
        }
        // loaded and bound once now, in its host process, so that a wrong
        // FMU fails before any scenario runs
        let option = format!("--fmu {}", path.display());
        let spec = CandidateSpec::Fmu {
            path: path.display().to_string(),
            role: Role::Controller,
            variables,
            sample_time: SAMPLE_TIME,
        };
        let candidate = HostedCandidate::start(&a.host.settings(a.timeout)?, spec)
            .map_err(|e| anyhow::anyhow!("{option}: {e}"))?;
        let name = path
            .file_name()
            .map_or("FMU".into(), |n| n.to_string_lossy().into_owned());
        entrants.push(Entrant::Fmu(candidate, name));
    } else if a.controller.is_empty() {
        entrants.push(Entrant::Builtin(BuiltinController::Pid));
        entrants.push(Entrant::Builtin(BuiltinController::StateFeedback));
    }
    let scenarios: Vec<&str> = if a.scenario.is_empty() {
        BENCHMARK_SCENARIOS.iter().map(|s| s.id).collect()
    } else {
        for id in &a.scenario {
            if let Err(mfcbeam::control::ControlError::Invalid { reason, .. }) =
                Benchmark::scenario(id)
            {
                bail!("--scenario: {reason}");
            }
        }
        a.scenario.iter().map(String::as_str).collect()
    };
    if let Some(dir) = &a.output_dir {
        std::fs::create_dir_all(dir).with_context(|| format!("--output-dir {}", dir.display()))?;
    }
    let bench = benchmark(a)?;
    let mut table = String::from(
        "| scenario | controller | during rms / max (um) | after rms / max (um) | max error (% stroke) | residual (um) | attenuation | peak patch (V) | saturated (ms) | held | step mean / max (us) |\n\
         |---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for id in scenarios {
        let mut runs: Vec<(String, BenchmarkRun)> = Vec::new();
        for e in &entrants {
            let mut controller: Box<dyn Controller> = match e {
                Entrant::Builtin(b) => bench.controller(*b)?,
                Entrant::Program(words) => Box::new(ProcessController::spawn(
                    &words[0],
                    &words[1..],
                    &[
                        ("MFCBEAM_SCENARIO", id.to_string()),
                        (
                            "MFCBEAM_SAMPLE_TIME",
                            format!("{:?}", bench.settings.sample_time),
                        ),
                    ],
                    Duration::from_secs_f64(a.timeout),
                )?),
                Entrant::Fmu(candidate, name) => Box::new(
                    HostedController::new(candidate, name)
                        .map_err(|e| anyhow::anyhow!("--fmu {name}: {e}"))?,
                ),
            };
            let run = bench
                .run(id, controller.as_mut())
                .with_context(|| format!("scenario {id}"))?;
            runs.push((e.id(), run));
        }
        let open_after = runs[0].1.scores.after_rms;
        for (_, run) in &runs {
            let s = &run.scores;
            // only where the open loop leaves an error after the transition
            let attenuation = if open_after.is_nan() || open_after <= 1e-9 {
                "-".to_string()
            } else {
                format!("{:.1}x", open_after / s.after_rms)
            };
            table.push_str(&format!(
                "| {id} | {} | {:.2} / {:.2} | {:.2} / {:.2} | {:.3} | {:.2} | {attenuation} | {:.0} | {:.1} | {} | {:.2} / {:.1} |\n",
                run.controller,
                s.during_rms * 1e6,
                s.during_max * 1e6,
                s.after_rms * 1e6,
                s.after_max * 1e6,
                100.0 * s.max_error / bench.settings.y_final,
                s.residual * 1e6,
                s.peak_voltage,
                s.saturated_time * 1e3,
                s.held,
                s.compute_mean * 1e6,
                s.compute_max * 1e6,
            ));
        }
        if let Some(dir) = &a.output_dir {
            write_outputs(dir, id, &runs)?;
        }
    }
    if let Some(dir) = &a.output_dir {
        write_atomic(&dir.join("scores.md"), table.as_bytes())?;
    }
    print!("{table}");
    Ok(())
}

/// The benchmark on the nominal models or the files given.
fn benchmark(a: &BenchmarkControlArgs) -> Result<Benchmark> {
    let model = match &a.model {
        Some(p) => read_model(p)?,
        None => mfcbeam::operators::nominal::nominal_model(),
    };
    let beam = match &a.beam {
        Some(p) => read_beam(p)?,
        None => BeamParameters::nominal(),
    };
    let kind = super::args::BeamModelArgs::kind_of(a.beam_model, a.elements);
    let modal = modal_model(&beam, kind).context("--beam")?;
    let bench = Benchmark::new(model, modal).context("the benchmark's feedforward")?;
    Ok(match &a.plant_model {
        Some(p) => {
            let plant = read_model(p)?;
            let (tp, tm) = (plant.sample_time(), bench.model.sample_time());
            if (tp - tm).abs() > 1e-12 * tm {
                bail!(
                    "--plant-model {}: sample time {tp} s, the model's is {tm} s",
                    p.display()
                );
            }
            bench.with_plant(plant)
        }
        None => bench,
    })
}

fn write_outputs(dir: &Path, id: &str, runs: &[(String, BenchmarkRun)]) -> Result<()> {
    for (name, run) in runs {
        let tr = &run.trace;
        let flag = |v: &[bool]| {
            v.iter()
                .map(|b| f64::from(u8::from(*b)))
                .collect::<Vec<f64>>()
        };
        let (held, saturated) = (flag(&tr.held), flag(&tr.saturated));
        let path = dir.join(format!("{id}-{name}.csv"));
        Trace::from_columns(
            &path,
            &[
                ("t", &tr.t),
                ("reference", &tr.reference),
                ("feedforward", &tr.feedforward),
                ("force", &tr.force),
                ("noise", &tr.noise),
                ("measurement", &tr.measurement),
                ("correction", &tr.correction),
                ("held", &held),
                ("u", &tr.u),
                ("saturated", &saturated),
                ("u_fs", &tr.u_fs),
                ("u_bs", &tr.u_bs),
                ("w", &tr.w),
                ("tip", &tr.tip),
            ],
        )
        .write(&path)?;
    }
    let t = &runs[0].1.trace.t;
    let from = t.iter().position(|&x| x >= 2.85).unwrap_or(0);
    let cut = |v: &[f64]| v[from..].to_vec();
    let mut tips = vec![series(
        "desired y_d",
        &cut(t),
        &scaled(&cut(&runs[0].1.trace.reference), 1e3),
        GREY,
    )];
    let mut corrections = Vec::new();
    for (i, (_, run)) in runs.iter().enumerate() {
        let color = COLORS[i % COLORS.len()];
        tips.push(series(
            &run.controller,
            &cut(t),
            &scaled(&cut(&run.trace.tip), 1e3),
            color,
        ));
        corrections.push(series(
            &run.controller,
            &cut(t),
            &cut(&run.trace.correction),
            color,
        ));
    }
    let figure = Figure {
        title: format!("closed-loop benchmark: {id}"),
        panels: vec![
            panel("tip deflection", "t (s)", "w(L) (mm)", tips),
            panel("feedback correction", "t (s)", "V", corrections),
        ],
    };
    write_figure(&figure, &dir.join(id)).map_err(|e| anyhow::anyhow!("{}: {e}", dir.display()))?;
    Ok(())
}
