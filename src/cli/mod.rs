//! Subcommands of the `mfcbeam` binary.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use clap::{Args, Parser, Subcommand};
use serde::Serialize;

use mfcbeam::beam::step_response_fit::{
    fit_step_response, modal_model, simulate_response, BeamModelKind, FitParameter,
};
use mfcbeam::beam::BeamParameters;
use mfcbeam::identification::{identify as identify_model, IdentificationSettings};
use mfcbeam::io::{read_beam, read_model, write_atomic, write_json, Trace};
use mfcbeam::operators::compensator::{Compensator, CompensatorSettings};
use mfcbeam::operators::traits::Operator;
use mfcbeam::suite::signal::{time_axis, Staircase};

#[derive(Debug, Parser)]
#[command(
    name = "mfcbeam",
    version,
    about = "Hysteresis and creep compensation of an MFC-actuated beam (Schröck, Meurer, Kugi 2011)"
)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Run the model W = H + C on column `u`; writes IN's columns plus `y = W[u]`.
    Simulate(SimulateArgs),
    /// Run the compensator W⁻¹ on column `y_d`; writes IN's columns plus `u` and `saturated`.
    Compensate(CompensateArgs),
    /// Print H⁻¹ (thresholds, weights, state) of a model as JSON, by the rules (22).
    Invert(InvertArgs),
    /// Identify a model (weights by constrained least squares, (23)–(25)) from
    /// columns `t`, `u`, `y`; prints the fit report on stderr.
    Identify(IdentifyArgs),
    /// The beam: modal analysis, simulation, step-response identification.
    #[command(subcommand)]
    Beam(BeamCommand),
    /// Flatness-based feedforward: y_d and u_d for a rest-to-rest move of the
    /// tip, and with --model the compensated patch voltages.
    Feedforward(FeedforwardArgs),
    /// Run every scenario on the nominal models: traces, figures (SVG, PNG) and
    /// the paper's claims as numbers.
    Reproduce(ReproduceArgs),
    /// Run one scenario of SPEC section 9 and write its trace.
    Scenario(ScenarioArgs),
    /// Regenerate (--write) or check (--check) the golden traces and manifest.
    Golden(GoldenArgs),
    /// Compare a candidate trace from any implementation with a golden trace.
    Verify(VerifyArgs),
    /// Write the nominal model of SPEC section 8 (virgin state) as a model file.
    Nominal(NominalArgs),
    /// Write a test signal (a smooth staircase) as a trace with columns `t` and the chosen name.
    Signal(SignalArgs),
}

/// A model applied to one trace, written to another.
#[derive(Debug, Args)]
struct ModelTraceArgs {
    /// Model file (JSON).
    #[arg(long)]
    model: PathBuf,
    /// Input trace (CSV): column `u` (V) for simulate, `y_d` (V) for compensate.
    #[arg(long)]
    input: PathBuf,
    /// Output trace (CSV).
    #[arg(long)]
    output: PathBuf,
}

#[derive(Debug, Args)]
struct SimulateArgs {
    #[command(flatten)]
    files: ModelTraceArgs,
}

#[derive(Debug, Args)]
struct CompensateArgs {
    #[command(flatten)]
    files: ModelTraceArgs,
    /// Saturation limits `LO,HI` of the balanced voltage (default: -1000,1000).
    #[arg(long, value_name = "LO,HI", allow_hyphen_values = true, value_parser = parse_limits, conflicts_with = "no_limits")]
    limits: Option<(f64, f64)>,
    /// Do not saturate the output.
    #[arg(long)]
    no_limits: bool,
}

#[derive(Debug, Args)]
struct InvertArgs {
    /// Model file (JSON).
    #[arg(long)]
    model: PathBuf,
}

#[derive(Debug, Args)]
struct IdentifyArgs {
    /// Measurement (CSV) with columns `u` (V), `y` and, unless --sample-time is given, `t` (s).
    #[arg(long)]
    input: PathBuf,
    /// Output model file (JSON, virgin state).
    #[arg(long)]
    output: PathBuf,
    /// Number of plays n_H + 1.
    #[arg(long, default_value_t = 12)]
    hysteresis_operators: usize,
    /// Number of log(t)-creep operators n_C + 1 (0: no creep).
    #[arg(long, default_value_t = 12)]
    creep_operators: usize,
    /// Number of creep eigenvalues m, spread by (24).
    #[arg(long, default_value_t = 5)]
    creep_eigenvalues: usize,
    /// Sample time (s); default: from the `t` column.
    #[arg(long, allow_hyphen_values = true)]
    sample_time: Option<f64>,
    /// Margin ε_H > 0 of the hysteresis partial sums (default 1e-3 · range(y) / range(u)).
    #[arg(long, allow_hyphen_values = true)]
    epsilon_h: Option<f64>,
    /// Explicit hysteresis thresholds `0,r1,r2,...` instead of (23).
    #[arg(long, value_delimiter = ',', num_args = 1..)]
    hysteresis_thresholds: Option<Vec<f64>>,
    /// Explicit creep thresholds `0,r1,r2,...` instead of (23).
    #[arg(long, value_delimiter = ',', num_args = 1..)]
    creep_thresholds: Option<Vec<f64>>,
    /// Explicit creep eigenvalues (1/s) instead of (24).
    #[arg(long, value_delimiter = ',', num_args = 1..)]
    eigenvalues: Option<Vec<f64>>,
}

#[derive(Debug, Args)]
struct FeedforwardArgs {
    /// Beam file (JSON).
    #[arg(long)]
    beam: PathBuf,
    /// Hysteresis and creep model (JSON): adds `u = W⁻¹[u_d]`, `u_fs`, `u_bs`, `saturated`.
    #[arg(long)]
    model: Option<PathBuf>,
    /// Beam discretization the design uses.
    #[arg(long, value_enum, default_value_t = ModelKindArg::Modal)]
    beam_model: ModelKindArg,
    /// Finite elements of the modal beam model.
    #[arg(long, default_value_t = mfcbeam::beam::fe::DEFAULT_ELEMENTS)]
    elements: usize,
    /// Start of the transition (s).
    #[arg(long, default_value_t = 2.9, allow_hyphen_values = true)]
    start: f64,
    /// Duration T of the transition (s).
    #[arg(long, default_value_t = 0.075, allow_hyphen_values = true)]
    duration: f64,
    /// Final tip deflection y_T (m), from rest at 0.
    #[arg(long, default_value_t = 0.001, allow_hyphen_values = true)]
    y_final: f64,
    /// Gevrey parameter σ of the trajectory (28).
    #[arg(long, default_value_t = 1.1, allow_hyphen_values = true)]
    sigma: f64,
    /// End of the trace (s).
    #[arg(long, default_value_t = 4.0, allow_hyphen_values = true)]
    end: f64,
    /// Sample time (s); default: the model's, else 2e-4.
    #[arg(long, allow_hyphen_values = true)]
    sample_time: Option<f64>,
    /// Output trace (CSV).
    #[arg(long)]
    output: PathBuf,
}

#[derive(Debug, Args)]
struct ReproduceArgs {
    /// Output directory (traces/ and plots/ are created in it).
    #[arg(long, default_value = "reproduce")]
    out: PathBuf,
}

#[derive(Debug, Args)]
struct ScenarioArgs {
    /// Scenario id: rectangle, staircase, minor-loops, intersection, log-creep,
    /// identification, compensated, step, feedforward.
    name: String,
    /// Output trace (CSV).
    #[arg(long)]
    output: PathBuf,
    /// Every sample at 5 kHz instead of the golden file's decimation.
    #[arg(long)]
    full: bool,
}

#[derive(Debug, Args)]
struct GoldenArgs {
    /// Directory of the golden files.
    #[arg(long, default_value = "golden")]
    dir: PathBuf,
    /// Regenerate every golden trace and the manifest (an explicit action).
    #[arg(long, conflicts_with = "check")]
    write: bool,
    /// Recompute every trace and compare with the stored ones (exit 1 on a difference).
    #[arg(long)]
    check: bool,
}

#[derive(Debug, Args)]
struct VerifyArgs {
    /// Golden trace, e.g. golden/compensated.csv (its manifest is read from the same directory).
    #[arg(long)]
    golden: PathBuf,
    /// Candidate trace (CSV) with the same column names: as stored, or every sample at 5 kHz.
    #[arg(long)]
    candidate: PathBuf,
}

#[derive(Debug, Args)]
struct NominalArgs {
    /// Output file (JSON); stdout if absent.
    #[arg(long)]
    output: Option<PathBuf>,
    /// Write the nominal beam (SPEC section 8) instead of the hysteresis and creep model.
    #[arg(long)]
    beam: bool,
}

#[derive(Debug, Subcommand)]
enum BeamCommand {
    /// Undamped natural frequencies and static gain of the model's n modes, as JSON on stdout.
    Modes(BeamModesArgs),
    /// Tip deflection `y` (m) for column `u` (effective V), exact ZOH, from rest in equilibrium with u_0.
    Simulate(BeamSimulateArgs),
    /// Fit beam parameters to a step response (columns `u`, `y`) by Levenberg–Marquardt.
    Identify(BeamIdentifyArgs),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum ModelKindArg {
    /// The paper's Ritz model (uniform-beam eigenfunctions).
    Ritz,
    /// Converged finite elements reduced to n modes (default).
    Modal,
}

#[derive(Debug, Args)]
struct BeamModelArgs {
    /// Beam file (JSON).
    #[arg(long)]
    beam: PathBuf,
    /// Discretization.
    #[arg(long, value_enum, default_value_t = ModelKindArg::Modal)]
    model: ModelKindArg,
    /// Finite elements of the modal model.
    #[arg(long, default_value_t = mfcbeam::beam::fe::DEFAULT_ELEMENTS)]
    elements: usize,
}

impl BeamModelArgs {
    fn kind(&self) -> BeamModelKind {
        match self.model {
            ModelKindArg::Ritz => BeamModelKind::Ritz,
            ModelKindArg::Modal => BeamModelKind::Modal {
                elements: self.elements,
            },
        }
    }
}

#[derive(Debug, Args)]
struct BeamModesArgs {
    #[command(flatten)]
    model: BeamModelArgs,
}

#[derive(Debug, Args)]
struct BeamSimulateArgs {
    #[command(flatten)]
    model: BeamModelArgs,
    /// Input trace (CSV) with column `u` (effective V).
    #[arg(long)]
    input: PathBuf,
    /// Output trace (CSV).
    #[arg(long)]
    output: PathBuf,
    /// Sample time (s); default: from the `t` column, else 2e-4. Given together
    /// with a `t` column, the two must agree.
    #[arg(long, allow_hyphen_values = true)]
    sample_time: Option<f64>,
}

#[derive(Debug, Args)]
struct BeamIdentifyArgs {
    #[command(flatten)]
    model: BeamModelArgs,
    /// Measured step response (CSV) with columns `u` (effective V) and `y` (m).
    #[arg(long)]
    input: PathBuf,
    /// Parameters to fit, e.g. `youngs_modulus,patch.input_gain`.
    #[arg(long, value_delimiter = ',', required = true)]
    fit: Vec<String>,
    /// Fitted beam file (JSON).
    #[arg(long)]
    output: PathBuf,
    /// Sample time (s); default: from the `t` column, else 2e-4. Given together
    /// with a `t` column, the two must agree.
    #[arg(long, allow_hyphen_values = true)]
    sample_time: Option<f64>,
}

#[derive(Debug, Args)]
struct SignalArgs {
    /// Output trace (CSV).
    #[arg(long)]
    output: PathBuf,
    /// Name of the signal column.
    #[arg(long, default_value = "u")]
    column: String,
    /// Peak value of the staircase 0 → +A → −A → 0.
    #[arg(long, default_value_t = 900.0, allow_hyphen_values = true)]
    amplitude: f64,
    /// Number of loops; with more than one the amplitude shrinks each period
    /// (the identification input of section 4.1).
    #[arg(long, default_value_t = 1)]
    periods: usize,
    /// Steps per quarter of the loop.
    #[arg(long, default_value_t = 3)]
    steps: usize,
    /// Duration of each smooth transition (s).
    #[arg(long, default_value_t = 0.1, allow_hyphen_values = true)]
    rise: f64,
    /// Duration of each plateau (s).
    #[arg(long, default_value_t = 1.5, allow_hyphen_values = true)]
    plateau: f64,
    /// Sample time (s).
    #[arg(long, default_value_t = 2e-4, allow_hyphen_values = true)]
    sample_time: f64,
}

fn parse_limits(s: &str) -> std::result::Result<(f64, f64), String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    if parts.len() != 2 {
        return Err(format!("expected LO,HI, found '{s}'"));
    }
    let parse = |p: &str| {
        p.parse::<f64>()
            .ok()
            .filter(|v| !v.is_nan())
            .ok_or_else(|| format!("'{p}' is not a number"))
    };
    let (lo, hi) = (parse(parts[0])?, parse(parts[1])?);
    if lo >= hi {
        return Err(format!("LO = {lo} must be below HI = {hi}"));
    }
    Ok((lo, hi))
}

pub fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Simulate(a) => simulate(&a),
        Command::Compensate(a) => compensate(&a),
        Command::Invert(a) => invert(&a),
        Command::Identify(a) => identify(&a),
        Command::Beam(BeamCommand::Modes(a)) => beam_modes(&a),
        Command::Beam(BeamCommand::Simulate(a)) => beam_simulate(&a),
        Command::Beam(BeamCommand::Identify(a)) => beam_identify(&a),
        Command::Feedforward(a) => feedforward(&a),
        Command::Reproduce(a) => reproduce(&a),
        Command::Scenario(a) => scenario(&a),
        Command::Golden(a) => golden(&a),
        Command::Verify(a) => verify(&a),
        Command::Nominal(a) => nominal(&a),
        Command::Signal(a) => signal(&a),
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
    let settings = if a.no_limits {
        CompensatorSettings::unlimited()
    } else if let Some((lo, hi)) = a.limits {
        CompensatorSettings::with_limits(lo, hi)
    } else {
        CompensatorSettings::default()
    };
    let mut comp = Compensator::new(&model, settings).context("--limits")?;
    let mut trace = Trace::read(&a.files.input)?;
    trace.check_time_column(model.sample_time())?;
    let y_d = trace.column("y_d")?;
    let mut u = vec![0.0; y_d.len()];
    let mut sat = vec![false; y_d.len()];
    let count = comp.compensate_into(&y_d, &mut u, &mut sat)?;
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
}

fn invert(a: &InvertArgs) -> Result<()> {
    let model = read_model(&a.model)?;
    let inv = model.hysteresis().inverse();
    let json = serde_json::to_string_pretty(&InverseJson {
        thresholds: inv.thresholds(),
        weights: inv.weights(),
        state: inv.play_states(),
    })?;
    print_stdout(&json)
}

fn identify(a: &IdentifyArgs) -> Result<()> {
    let trace = Trace::read(&a.input)?;
    let ts = trace_sample_time(&trace, a.sample_time, None)?;
    let u = trace.column("u")?;
    let y = trace.column("y")?;
    let settings = IdentificationSettings {
        hysteresis_operators: a.hysteresis_operators,
        creep_operators: a.creep_operators,
        creep_eigenvalues: a.creep_eigenvalues,
        hysteresis_thresholds: a.hysteresis_thresholds.clone(),
        creep_thresholds: a.creep_thresholds.clone(),
        eigenvalues: a.eigenvalues.clone(),
        epsilon_h: a.epsilon_h,
    };
    let id =
        identify_model(&u, &y, ts, &settings).with_context(|| a.input.display().to_string())?;
    write_json(&a.output, &id.model.to_file().without_state())?;
    eprint!("{}", id.report);
    eprintln!("mfcbeam: wrote {}", a.output.display());
    Ok(())
}

fn feedforward(a: &FeedforwardArgs) -> Result<()> {
    use mfcbeam::feedforward::{
        compensate as compensate_ff, design, FeedforwardSettings, FlatParametrization,
    };
    let beam = read_beam(&a.beam)?;
    let model = a.model.as_deref().map(read_model).transpose()?;
    let ts = a
        .sample_time
        .or(model.as_ref().map(|m| m.sample_time()))
        .unwrap_or(2e-4);
    if let (Some(m), Some(t)) = (&model, a.sample_time) {
        if (m.sample_time() - t).abs() > 1e-12 * t {
            bail!(
                "--sample-time: {t} s differs from the model's sample time {} s",
                m.sample_time()
            );
        }
    }
    let kind = match a.beam_model {
        ModelKindArg::Ritz => BeamModelKind::Ritz,
        ModelKindArg::Modal => BeamModelKind::Modal {
            elements: a.elements,
        },
    };
    let modal = modal_model(&beam, kind).with_context(|| a.beam.display().to_string())?;
    let flat = FlatParametrization::new(&modal).with_context(|| a.beam.display().to_string())?;
    let settings = FeedforwardSettings {
        start: a.start,
        duration: a.duration,
        y_final: a.y_final,
        sigma: a.sigma,
        end: a.end,
        sample_time: ts,
    };
    let ff = design(&flat, &settings)?;
    let mut trace = Trace::from_columns(
        &a.output,
        &[("t", &ff.t), ("y_d", &ff.y_d), ("u_d", &ff.u_d)],
    );
    eprintln!(
        "mfcbeam: feedforward of {} m in {} s (σ = {}), peak |u_d| = {:.4} V effective, static gain {:.6e} m/V",
        a.y_final, a.duration, a.sigma, ff.peak, flat.static_gain()
    );
    if let Some(m) = &model {
        let supply = mfcbeam::operators::supply::Supply::default();
        let c = compensate_ff(&ff.u_d, m, &supply)?;
        trace.push_column("u", &c.u)?;
        trace.push_column("u_fs", &c.u_fs)?;
        trace.push_column("u_bs", &c.u_bs)?;
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
        ff.t.len(),
        a.output.display()
    );
    Ok(())
}

fn reproduce(a: &ReproduceArgs) -> Result<()> {
    let claims = mfcbeam::suite::reproduce::reproduce(&a.out).map_err(anyhow::Error::msg)?;
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
    let tr = run(sc.id, &ScenarioContext::nominal()).context("scenario failed")?;
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
    use mfcbeam::suite::golden::{
        compare_columns, compute_all, read_manifest, sha256_hex, write_golden,
    };
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
    let manifest = read_manifest(&a.dir.join("manifest.json"))?;
    let ctx = mfcbeam::suite::scenarios::ScenarioContext::nominal();
    let mut failures = 0;
    for (file, trace, _) in compute_all(&ctx) {
        let Some(entry) = manifest.entry_for_file(&file) else {
            bail!(
                "{}: no entry for {file}",
                a.dir.join("manifest.json").display()
            );
        };
        let path = a.dir.join(&file);
        let bytes = std::fs::read(&path).with_context(|| path.display().to_string())?;
        if sha256_hex(&bytes) != entry.sha256 {
            eprintln!("{file}: SHA-256 differs from the manifest");
            failures += 1;
        }
        let stored = mfcbeam::suite::golden::numeric_columns(&Trace::read(&path)?)?;
        let fresh: Vec<(String, Vec<f64>)> = trace
            .columns
            .iter()
            .map(|(n, v)| (n.to_string(), v.clone()))
            .collect();
        if fresh.first().map(|c| c.1.len()) != stored.first().map(|c| c.1.len()) {
            eprintln!("{file}: row count differs");
            failures += 1;
            continue;
        }
        for r in compare_columns(&stored, &fresh, entry) {
            if !r.compared || !r.pass() {
                eprintln!(
                    "{file}: column {} differs (max abs {:.3e}, tolerance {:.1e})",
                    r.name, r.max_abs, r.abs_tol
                );
                failures += 1;
            }
        }
    }
    if failures > 0 {
        eprintln!("mfcbeam: {failures} golden differences");
        std::process::exit(1);
    }
    eprintln!(
        "mfcbeam: all {} golden traces reproduce within tolerance",
        manifest.traces.len()
    );
    Ok(())
}

fn verify(a: &VerifyArgs) -> Result<()> {
    use mfcbeam::suite::golden::{
        align, compare_columns, manifest_path_for, numeric_columns, read_manifest,
    };
    let manifest_path = manifest_path_for(&a.golden);
    let manifest = read_manifest(&manifest_path)?;
    let file = a
        .golden
        .file_name()
        .map(|f| f.to_string_lossy().into_owned())
        .unwrap_or_default();
    let Some(entry) = manifest.entry_for_file(&file) else {
        bail!("{}: no entry for {file}", manifest_path.display());
    };
    let golden = numeric_columns(&Trace::read(&a.golden)?)?;
    let candidate = numeric_columns(&Trace::read(&a.candidate)?)?;
    let rows = golden.first().map_or(0, |c| c.1.len());
    let candidate = align(candidate, rows, entry.decimation, &a.candidate)?;
    let reports = compare_columns(&golden, &candidate, entry);
    let mut text = format!(
        "golden {} ({} {}), candidate {}\n{:<12} {:>12} {:>12} {:>12} {:>10} {:>10}  result\n",
        a.golden.display(),
        entry.id,
        entry.paper,
        a.candidate.display(),
        "column",
        "max abs",
        "rms",
        "max rel",
        "abs tol",
        "rel tol"
    );
    let mut compared = 0;
    let mut failed = 0;
    for r in &reports {
        if !r.compared {
            text.push_str(&format!(
                "{:<12} {:>12} {:>12} {:>12} {:>10.1e} {:>10.1e}  not in candidate\n",
                r.name, "-", "-", "-", r.abs_tol, r.rel_tol
            ));
            continue;
        }
        compared += 1;
        let verdict = match r.first_failure {
            None => "pass".to_string(),
            Some(row) => {
                failed += 1;
                format!("FAIL (first at row {row})")
            }
        };
        text.push_str(&format!(
            "{:<12} {:>12.3e} {:>12.3e} {:>12.3e} {:>10.1e} {:>10.1e}  {verdict}\n",
            r.name, r.max_abs, r.rms, r.max_rel, r.abs_tol, r.rel_tol
        ));
    }
    if compared == 0 {
        bail!(
            "{}: shares no column with {}",
            a.candidate.display(),
            a.golden.display()
        );
    }
    text.push_str(&format!(
        "{} of {} columns compared, {}\n",
        compared,
        reports.len(),
        if failed == 0 {
            "all within tolerance".to_string()
        } else {
            format!("{failed} outside tolerance")
        }
    ));
    print_stdout(text.trim_end())?;
    if failed > 0 {
        std::process::exit(1);
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

/// Sample time: the `t` column if present (uniform), else the flag.
/// The sample time of a trace: `--sample-time` if given (checked against the
/// `t` column, if any), else from the `t` column, else `fallback` (an error
/// when there is none).
fn trace_sample_time(trace: &Trace, flag: Option<f64>, fallback: Option<f64>) -> Result<f64> {
    match flag {
        Some(ts) => {
            if !(ts.is_finite() && ts > 0.0) {
                bail!("--sample-time: must be a finite number > 0, found {ts}");
            }
            trace.check_time_column(ts)?;
            Ok(ts)
        }
        None if trace.has_column("t") => Ok(trace.sample_time_from_t()?),
        None => match fallback {
            Some(ts) => Ok(ts),
            // names the missing column
            None => Ok(trace.sample_time_from_t()?),
        },
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
}

fn beam_modes(a: &BeamModesArgs) -> Result<()> {
    let beam = read_beam(&a.model.beam)?;
    let modal =
        modal_model(&beam, a.model.kind()).with_context(|| a.model.beam.display().to_string())?;
    let json = ModesJson {
        frequencies_hz: modal.frequencies_hz(),
        static_gain: modal.static_gain(),
        damping_ratios: modal.damping_ratios(),
        model: match a.model.model {
            ModelKindArg::Ritz => "ritz",
            ModelKindArg::Modal => "modal",
        },
        modes: modal.len(),
    };
    print_stdout(&serde_json::to_string_pretty(&json)?)
}

fn beam_simulate(a: &BeamSimulateArgs) -> Result<()> {
    let beam = read_beam(&a.model.beam)?;
    let trace = Trace::read(&a.input)?;
    let ts = trace_sample_time(&trace, a.sample_time, Some(2e-4))?;
    let y = simulate_response(&beam, a.model.kind(), ts, &trace.column("u")?)
        .with_context(|| a.model.beam.display().to_string())?;
    write_with_y(trace, &y, &a.output)
}

fn beam_identify(a: &BeamIdentifyArgs) -> Result<()> {
    let beam = read_beam(&a.model.beam)?;
    let trace = Trace::read(&a.input)?;
    let ts = trace_sample_time(&trace, a.sample_time, Some(2e-4))?;
    let u = trace.column("u")?;
    let y = trace.column("y")?;
    let params = a
        .fit
        .iter()
        .map(|n| FitParameter::around(&beam, n.trim()))
        .collect::<std::result::Result<Vec<_>, _>>()
        .context("--fit")?;
    let fit = fit_step_response(&beam, &params, a.model.kind(), ts, &u, &y)
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
    eprintln!(
        "rms residual {:.4e} m (start {:.4e} m), {} iterations",
        fit.rms_residual, fit.initial_rms_residual, fit.iterations
    );
    eprintln!("mfcbeam: wrote {}", a.output.display());
    Ok(())
}

fn signal(a: &SignalArgs) -> Result<()> {
    for (name, v) in [
        ("--rise", a.rise),
        ("--plateau", a.plateau),
        ("--sample-time", a.sample_time),
    ] {
        if !(v.is_finite() && v > 0.0) {
            bail!("{name}: must be a finite number > 0, found {v}");
        }
    }
    if !a.amplitude.is_finite() {
        bail!("--amplitude: must be finite, found {}", a.amplitude);
    }
    let s = Staircase::shrinking_loops(a.amplitude, a.periods, a.steps, a.rise, a.plateau);
    let x = s.sample(a.sample_time);
    let t = time_axis(x.len(), a.sample_time);
    let trace = Trace::from_columns(Path::new(&a.output), &[("t", &t), (&a.column, &x)]);
    trace.write(&a.output)?;
    eprintln!(
        "mfcbeam: wrote {} samples ({} s) to {}",
        x.len(),
        s.duration(),
        a.output.display()
    );
    Ok(())
}
