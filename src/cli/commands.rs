//! The commands of the `mfcbeam` binary: read files, call the library,
//! write files. Argument definitions are in [`super::args`].

use std::path::{Path, PathBuf};

use anyhow::{anyhow, bail, Context, Result};
use serde::Serialize;

use mfcbeam::beam::step_response_fit::{modal_model, simulate_response, FitParameter};
use mfcbeam::beam::BeamParameters;
use mfcbeam::io::{read_beam, read_model, write_atomic, write_json, Trace};
use mfcbeam::operators::compensator::CompensatorSettings;
use mfcbeam::operators::heap::Heap;
use mfcbeam::operators::nominal::SAMPLE_TIME;
use mfcbeam::operators::traits::Operator;
use mfcbeam::suite::signal::{time_axis, Staircase};

use super::args::*;
use super::trace_sample_time;

/// Run the command `cli` names.
pub fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Simulate(a) => simulate(&a),
        Command::Compensate(a) => compensate(&a),
        Command::Invert(a) => invert(&a),
        Command::Identify(a) => super::identify::identify(&a),
        Command::EstimateState(a) => super::identify::estimate_state(&a),
        Command::Beam(BeamCommand::Modes(a)) => beam_modes(&a),
        Command::Beam(BeamCommand::Simulate(a)) => beam_simulate(&a),
        Command::Beam(BeamCommand::Identify(a)) => beam_identify(&a),
        Command::Feedforward(a) => feedforward(&a),
        Command::Reproduce(a) => reproduce(&a),
        Command::Scenario(a) => scenario(&a),
        Command::Golden(a) => golden(&a),
        Command::Conform(a) => {
            let settings = super::conform::settings(&a)?;
            if a.fmu.is_some() || a.library.library.is_some() {
                super::hosted::conform_hosted(&a, settings)
            } else {
                super::conform::conform_program(&a, settings)
            }
        }
        Command::Verify(a) => verify(&a),
        Command::Fmu(a) => super::fmu::fmu(&a),
        Command::Nominal(a) => nominal(&a),
        Command::Signal(a) => signal(&a),
        Command::Records(a) => records(&a),
        Command::BenchmarkControl(a) => super::control::benchmark_control(&a),
        Command::Bench(a) => super::bench::bench(&a),
        Command::Host(a) => mfcbeam::isolation::serve(a.progress.as_deref(), a.memory_limit)
            .map_err(|e| anyhow::anyhow!("host: {e}")),
    }
}

fn simulate(a: &SimulateArgs) -> Result<()> {
    let a = &a.files;
    let mut model = read_model(&a.model)?;
    let trace = Trace::read(&a.input)?;
    trace.check_time_column(model.sample_time())?;
    let y = model.run(&trace.column("u")?);
    write_with_y(trace, &y, &a.output)
}

fn compensate(a: &CompensateArgs) -> Result<()> {
    let model = read_model(&a.files.model)?;
    let settings = match (a.limits, a.no_limits) {
        (_, true) => CompensatorSettings::unlimited(),
        (Some((lo, hi)), false) => CompensatorSettings::with_limits(lo, hi),
        (None, false) => CompensatorSettings::default(),
    };
    let mut comp = model.compensator(settings).context("--limits")?;
    let mut trace = Trace::read(&a.files.input)?;
    trace.check_time_column(model.sample_time())?;
    let y_d = trace.column("y_d")?;
    // a planned target is known ahead: previewed by the dead time
    let mut targets = vec![0.0; y_d.len()];
    mfcbeam::realtime::preview_into(&y_d, comp.delay(), &mut targets)?;
    let mut u = vec![0.0; y_d.len()];
    let mut sat = vec![false; y_d.len()];
    let mut fault = vec![false; y_d.len()];
    let (count, _) = comp.compensate_into(&targets, &mut u, &mut sat, &mut fault)?;
    trace.push_column("u", &u)?;
    trace.push_text_column(
        "saturated",
        sat.iter().map(|&s| if s { "1" } else { "0" }.to_string()),
    )?;
    trace.write(&a.files.output)?;
    eprintln!(
        "mfcbeam: compensated {} samples, {} saturated, wrote {}",
        u.len(),
        count,
        a.files.output.display()
    );
    Ok(())
}

#[derive(Serialize)]
struct InverseJson<'a> {
    thresholds: &'a [f64],
    weights: &'a [f64],
    state: &'a [f64],
    /// The model's output offset: the compensator applies `H⁻¹` to
    /// `S⁻¹[target − offset] − C`.
    #[serde(skip_serializing_if = "Option::is_none")]
    offset: Option<f64>,
    /// `S⁻¹` by its inverse rules, when the model has `S`.
    #[serde(skip_serializing_if = "Option::is_none")]
    inverse_superposition: Option<InverseSuperpositionJson>,
}

#[derive(Serialize)]
struct InverseSuperpositionJson {
    thresholds: Vec<f64>,
    weights: Vec<f64>,
}

fn invert(a: &InvertArgs) -> Result<()> {
    let model = read_model(&a.model)?;
    if model.rate_gain().is_some() {
        bail!(
            "{}: hysteresis.rate_gain: the inverse of rate-dependent thresholds is no PI operator; it is computed sample by sample",
            a.model.display()
        );
    }
    let inv = model.hysteresis().inverse();
    let inverse_superposition = match model.superposition() {
        None => None,
        Some(s) => {
            let s_inv = mfcbeam::realtime::Superposition::<f64, Heap>::inverse_of(&s.parameters())?;
            Some(InverseSuperpositionJson {
                thresholds: s_inv.thresholds().to_vec(),
                weights: s_inv.weights().to_vec(),
            })
        }
    };
    let json = serde_json::to_string_pretty(&InverseJson {
        thresholds: inv.thresholds(),
        weights: inv.weights(),
        state: inv.play_states(),
        offset: (model.offset() != 0.0).then_some(model.offset()),
        inverse_superposition,
    })?;
    print_stdout(&json)
}

fn feedforward(a: &FeedforwardArgs) -> Result<()> {
    use mfcbeam::feedforward::{
        compensate as compensate_ff, design, FeedforwardSettings, FlatParametrization,
    };
    let beam = read_beam(&a.beam.beam)?;
    let model = a.model.as_deref().map(read_model).transpose()?;
    let ts = a
        .sample_time
        .or(model.as_ref().map(|m| m.sample_time()))
        .unwrap_or(SAMPLE_TIME);
    if let (Some(m), Some(t)) = (&model, a.sample_time) {
        if (m.sample_time() - t).abs() > 1e-12 * t {
            bail!(
                "--sample-time: {t} s differs from the model's sample time {} s",
                m.sample_time()
            );
        }
    }
    let modal =
        modal_model(&beam, a.beam.kind()).with_context(|| a.beam.beam.display().to_string())?;
    let flat =
        FlatParametrization::new(&modal).with_context(|| a.beam.beam.display().to_string())?;
    let settings = FeedforwardSettings {
        start: a.start,
        duration: a.duration,
        y_final: a.y_final,
        sigma: a.sigma,
        end: a.end,
        sample_time: ts,
    };
    let ff = design(&flat, &settings)?;
    eprintln!(
        "mfcbeam: feedforward of {} m in {} s (σ = {}), peak |u_d| = {:.4} V effective, static gain {:.6e} m/V",
        a.y_final, a.duration, a.sigma, ff.peak, flat.static_gain()
    );
    let compensated = model
        .as_ref()
        .map(|m| {
            let supply = mfcbeam::operators::supply::Supply::default();
            compensate_ff(&ff.u_d, m, &supply).map(|c| (c, supply))
        })
        .transpose()?;
    // the columns taken over, not copied: a long trace is held once
    let mut trace = Trace::from_owned_columns(
        &a.output,
        vec![("t", ff.t), ("y_d", ff.y_d), ("u_d", ff.u_d)],
    );
    if let Some((c, supply)) = compensated {
        trace.push_owned_column("u", c.u)?;
        trace.push_owned_column("u_fs", c.u_fs)?;
        trace.push_owned_column("u_bs", c.u_bs)?;
        trace.push_text_column(
            "saturated",
            c.saturated
                .iter()
                .map(|&s| if s { "1" } else { "0" }.to_string()),
        )?;
        let count = c.saturated.iter().filter(|&&s| s).count();
        let (lo, hi) = supply.balanced_limits();
        if count > 0 {
            eprintln!(
                "mfcbeam: warning: {count} samples saturated: the compensated voltage leaves the supply range [{lo}, {hi}] V; shorten the move less (longer --duration) or lower --y-final"
            );
        } else {
            eprintln!(
                "mfcbeam: compensated peak |u| = {:.4} V, inside the supply range [{lo}, {hi}] V",
                c.peak
            );
        }
    }
    trace.write(&a.output)?;
    eprintln!(
        "mfcbeam: wrote {} samples to {}",
        trace.len(),
        a.output.display()
    );
    Ok(())
}

fn reproduce(a: &ReproduceArgs) -> Result<()> {
    let claims = mfcbeam::suite::reproduce::reproduce(&a.out)?;
    let mut text = String::from("| figure | claim | measured | holds |\n|---|---|---|---|\n");
    for c in &claims {
        text.push_str(&format!(
            "| {} | {} | {} | {} |\n",
            c.figure,
            c.claim,
            c.measured,
            if c.holds { "yes" } else { "NO" }
        ));
    }
    write_atomic(&a.out.join("summary.md"), text.as_bytes())?;
    print_stdout(text.trim_end())?;
    eprintln!(
        "mfcbeam: wrote traces to {}, figures to {}, summary to {}",
        a.out.join("traces").display(),
        a.out.join("plots").display(),
        a.out.join("summary.md").display()
    );
    if claims.iter().all(|c| c.holds) {
        Ok(())
    } else {
        bail!("a claim does not hold (see the table)")
    }
}

fn scenario(a: &ScenarioArgs) -> Result<()> {
    use mfcbeam::suite::scenarios::{run, scenario, ScenarioContext, SCENARIOS};
    let Some(sc) = scenario(&a.name) else {
        let ids: Vec<&str> = SCENARIOS.iter().map(|s| s.id).collect();
        bail!(
            "scenario '{}': unknown (one of: {})",
            a.name,
            ids.join(", ")
        );
    };
    let tr = run(sc, &ScenarioContext::nominal())?;
    let tr = if a.full {
        tr
    } else {
        tr.decimated(sc.decimation)
    };
    let cols: Vec<(&str, &[f64])> = tr.columns.iter().map(|(n, v)| (*n, v.as_slice())).collect();
    Trace::from_columns(&a.output, &cols).write(&a.output)?;
    eprintln!(
        "mfcbeam: {} ({}): wrote {} rows to {}",
        sc.id,
        sc.paper,
        tr.len(),
        a.output.display()
    );
    Ok(())
}

fn golden(a: &GoldenArgs) -> Result<()> {
    use mfcbeam::suite::golden::{check_golden, write_golden};
    if a.write {
        let m = write_golden(&a.dir)?;
        eprintln!(
            "mfcbeam: wrote {} golden traces and {}",
            m.traces.len(),
            a.dir.join("manifest.json").display()
        );
        return Ok(());
    }
    if !a.check {
        bail!("golden: say --write (regenerate) or --check (compare)");
    }
    let ctx = mfcbeam::suite::scenarios::ScenarioContext::nominal();
    let differences = check_golden(&a.dir, &ctx)?;
    for d in &differences {
        eprintln!("{}: {}", d.file, d.what);
    }
    if !differences.is_empty() {
        eprintln!("mfcbeam: {} golden differences", differences.len());
        return Err(super::Exit(1).into());
    }
    eprintln!(
        "mfcbeam: all {} golden traces reproduce within tolerance",
        mfcbeam::suite::scenarios::SCENARIOS.len()
    );
    Ok(())
}

fn verify(a: &VerifyArgs) -> Result<()> {
    let report = mfcbeam::suite::golden::verify(&a.golden, &a.candidate)?;
    print_stdout(&report.to_string())?;
    if report.failed() > 0 {
        return Err(super::Exit(1).into());
    }
    Ok(())
}

fn nominal(a: &NominalArgs) -> Result<()> {
    fn emit<T: Serialize>(output: &Option<PathBuf>, value: &T) -> Result<()> {
        match output {
            Some(path) => Ok(write_json(path, value)?),
            None => print_stdout(&serde_json::to_string_pretty(value)?),
        }
    }
    if a.beam {
        emit(&a.output, &BeamParameters::nominal())
    } else {
        emit(
            &a.output,
            &mfcbeam::operators::nominal::nominal_model_file(),
        )
    }
}

/// Print a line on stdout; a closed pipe (`| head`) ends quietly instead of
/// panicking.
fn print_stdout(text: &str) -> Result<()> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    match writeln!(out, "{text}").and_then(|_| out.flush()) {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        other => Ok(other?),
    }
}

/// Append the computed column `y` to the input trace and write it.
fn write_with_y(mut trace: Trace, y: &[f64], output: &Path) -> Result<()> {
    trace.push_column("y", y)?;
    trace.write(output)?;
    eprintln!(
        "mfcbeam: simulated {} samples, wrote {}",
        y.len(),
        output.display()
    );
    Ok(())
}

#[derive(Serialize)]
struct ModesJson {
    frequencies_hz: Vec<f64>,
    static_gain: f64,
    damping_ratios: Vec<f64>,
    model: &'static str,
    modes: usize,
    /// The modal model itself, `η̈ + D η̇ + Ω² η = b w + c F`, `y = cᵀ η`
    /// (w the effective voltage, F a tip force), for a simulation elsewhere.
    omega: Vec<f64>,
    /// `D`, row-major `n × n`.
    modal_damping: Vec<f64>,
    modal_input: Vec<f64>,
    modal_output: Vec<f64>,
}

fn beam_modes(a: &BeamModesArgs) -> Result<()> {
    let beam = read_beam(&a.model.beam)?;
    let modal =
        modal_model(&beam, a.model.kind()).with_context(|| a.model.beam.display().to_string())?;
    let json = ModesJson {
        frequencies_hz: modal.frequencies_hz(),
        static_gain: modal.static_gain(),
        damping_ratios: modal.damping_ratios(),
        model: match a.model.beam_model {
            ModelKindArg::Ritz => "ritz",
            ModelKindArg::Modal => "modal",
        },
        modes: modal.len(),
        omega: modal.omega.clone(),
        modal_damping: modal.damping.clone(),
        modal_input: modal.input.clone(),
        modal_output: modal.output.clone(),
    };
    print_stdout(&serde_json::to_string_pretty(&json)?)
}

fn beam_simulate(a: &BeamSimulateArgs) -> Result<()> {
    let beam = read_beam(&a.model.beam)?;
    let trace = Trace::read(&a.input)?;
    let ts = trace_sample_time(&trace, a.sample_time, Some(SAMPLE_TIME))?;
    let y = simulate_response(&beam, a.model.kind(), ts, &trace.column("u")?)
        .with_context(|| a.model.beam.display().to_string())?;
    write_with_y(trace, &y, &a.output)
}

fn beam_identify(a: &BeamIdentifyArgs) -> Result<()> {
    let beam = read_beam(&a.model.beam)?;
    let trace = Trace::read(&a.input)?;
    let ts = trace_sample_time(&trace, a.sample_time, Some(SAMPLE_TIME))?;
    let u = trace.column("u")?;
    let y = trace.column("y")?;
    let params = a
        .fit
        .iter()
        .map(|n| FitParameter::around(&beam, n.trim()))
        .collect::<std::result::Result<Vec<_>, _>>()
        .context("--fit")?;
    use mfcbeam::beam::step_response_fit::{fit_step_response, StepFitOptions, StepInput};
    let step = StepInput::detect(&u).ok();
    let options = StepFitOptions {
        offset: !a.no_offset,
        step_time: !a.no_step_time && step.is_some(),
    };
    let fit = fit_step_response(&beam, &params, a.model.kind(), ts, &u, &y, options)
        .with_context(|| a.input.display().to_string())?;
    write_json(&a.output, &fit.beam)?;
    eprintln!("parameter                       start            fitted           std. error");
    for (i, p) in params.iter().enumerate() {
        eprintln!(
            "{:<30} {:<16.9e} {:<16.9e} {:.3e}",
            p.name,
            mfcbeam::beam::step_response_fit::parameter(&beam, &p.name).unwrap_or(f64::NAN),
            fit.values[i],
            fit.standard_errors[i]
        );
    }
    if let Some((o, se)) = fit.offset {
        eprintln!("{:<30} {:<16} {:<16.9e} {:.3e}", "offset (m)", "-", o, se);
    }
    if let Some((t, se)) = fit.step_time {
        eprintln!(
            "{:<30} {:<16} {:<16.9e} {:.3e}",
            "step time (s)", "-", t, se
        );
    } else if !a.no_step_time {
        eprintln!("(column u is not a single step: the step time is not fitted)");
    }
    eprintln!(
        "rms residual {:.4e} m (start {:.4e} m), {} evaluations (Levenberg-Marquardt)",
        fit.rms_residual, fit.initial_rms_residual, fit.iterations
    );
    eprintln!("mfcbeam: wrote {}", a.output.display());
    Ok(())
}

fn signal(a: &SignalArgs) -> Result<()> {
    let s = Staircase::try_shrinking_loops(a.amplitude, a.periods, a.steps, a.rise, a.plateau)
        .map_err(option_error)?;
    let x = s.try_sample(a.sample_time).map_err(option_error)?;
    let t = time_axis(x.len(), a.sample_time);
    let samples = x.len();
    let trace = Trace::from_owned_columns(Path::new(&a.output), vec![("t", t), (&a.column, x)]);
    trace.write(&a.output)?;
    eprintln!(
        "mfcbeam: wrote {} samples ({} s) to {}",
        samples,
        s.duration(),
        a.output.display()
    );
    Ok(())
}

fn records(a: &RecordsArgs) -> Result<()> {
    use mfcbeam::suite::records::{generate, Drive, RecordSettings};
    let settings = RecordSettings {
        drive: match a.drive {
            DriveArg::Cycles => Drive::Cycles,
            DriveArg::Tracking => Drive::Tracking,
        },
        rates: a.rates.clone(),
        rate_gain: a.rate_gain,
        noise: a.noise,
        seed: a.seed,
        hold_level: a.hold_at,
        tracking_range: a.tracking_range,
        ..RecordSettings::default()
    };
    let ts = settings.sample_time;
    if a.rates.is_empty()
        || a.rates
            .iter()
            .any(|r| !(r.is_finite() && *r > 0.0 && *r < 0.1 / ts))
    {
        bail!(
            "--rates: each rate must be > 0 and below a tenth of the sample rate {} Hz",
            1.0 / ts
        );
    }
    if !(a.rate_gain.is_finite() && a.rate_gain >= 0.0 && a.rate_gain < ts) {
        bail!("--rate-gain: must be >= 0 and below the sample time {ts} s (else a play is not monotone)");
    }
    if !(a.noise.is_finite() && a.noise >= 0.0) {
        bail!("--noise: must be a finite number >= 0");
    }
    if let Some(h) = a.hold_at {
        if !(h.is_finite() && h.abs() <= settings.amplitude) {
            bail!(
                "--hold-at: must lie within ±{} V, found {h}",
                settings.amplitude
            );
        }
    }
    if !(a.tracking_range.is_finite() && a.tracking_range > 0.0 && a.tracking_range <= 1.0) {
        bail!("--tracking-range: must lie in (0, 1]");
    }
    if let Some(p) = &a.plot {
        if !matches!(p.extension().and_then(|e| e.to_str()), Some("png" | "svg")) {
            bail!("--plot: {}: name a .png or .svg file", p.display());
        }
    }
    std::fs::create_dir_all(&a.output_dir)
        .with_context(|| format!("--output-dir {}", a.output_dir.display()))?;
    let records = generate(&settings);
    let mut names = Vec::new();
    for r in &records {
        let path = a.output_dir.join(format!("{}hz.csv", r.rate));
        let trace = Trace::from_owned_columns(
            &path,
            vec![
                ("t", time_axis(r.u.len(), ts)),
                ("u", r.u.clone()),
                ("y", r.y.clone()),
            ],
        );
        trace.write(&path)?;
        eprintln!(
            "mfcbeam: wrote {} ({} samples, {} Hz, sensor offset {:.4})",
            path.display(),
            r.u.len(),
            r.rate,
            r.offset
        );
        names.push(format!("{} Hz", r.rate));
    }
    if a.write_model {
        let path = a.output_dir.join("actuator.json");
        write_json(&path, &settings.actuator_model())?;
        eprintln!(
            "mfcbeam: wrote {} (the records' actuator, virgin, its rate gain included)",
            path.display()
        );
    }
    if let Some(p) = &a.plot {
        let loops: Vec<(String, &[f64], &[f64])> = records
            .iter()
            .zip(&names)
            .map(|(r, n)| (n.clone(), r.u.as_slice(), r.y.as_slice()))
            .collect();
        let hold = (settings.hold / ts).round() as usize;
        mfcbeam::suite::plots::write_loops_plot(
            p,
            "synthetic records: the loops at each rate",
            &loops,
            hold,
        )
        .map_err(anyhow::Error::msg)?;
        eprintln!("mfcbeam: wrote {}", p.display());
    }
    Ok(())
}

/// A parameter error about an option: a field that is an option's name is
/// written as the option (`sample_time` as `--sample-time`).
fn option_error(e: mfcbeam::realtime::ParameterError) -> anyhow::Error {
    let field = e.field();
    if !field.is_empty() && field.chars().all(|c| c.is_ascii_lowercase() || c == '_') {
        anyhow!("--{}", e.display_as(&field.replace('_', "-")))
    } else {
        anyhow!("{e}")
    }
}
