//! Command-line arguments (clap); the commands themselves are in
//! [`super::commands`]. Defaults come from the library's `Default`s. One
//! option name means one thing in every command: `--model` is always a
//! hysteresis and creep model file, `--beam` a beam file, `--beam-model`
//! the beam discretization.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand};

use mfcbeam::beam::step_response_fit::BeamModelKind;
use mfcbeam::feedforward::FeedforwardSettings;
use mfcbeam::identification::{
    DelaySetting, DynamicsParts, FitStart, IdentificationSettings, RateGainSetting, ZeroSegment,
    DEFAULT_MAX_DELAY,
};
use mfcbeam::operators::nominal::SAMPLE_TIME;
use mfcbeam::suite::conformance::ConformanceSettings;
use mfcbeam::suite::records::RecordSettings;

#[derive(Debug, Parser)]
#[command(
    name = "mfcbeam",
    version,
    about = "Hysteresis and creep compensation of an MFC-actuated beam (Schröck, Meurer, Kugi 2011)"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Run the model W = S[H + C] + offset on column `u`; writes IN's columns plus `y = W[u]`.
    Simulate(SimulateArgs),
    /// Run the compensator W⁻¹ on column `y_d` (previewed by the model's dead time); writes IN's columns plus `u` and `saturated`.
    Compensate(CompensateArgs),
    /// Print H⁻¹ (thresholds, weights, state) of a model as JSON, by the rules (22), and S⁻¹ if the model has a superposition operator.
    Invert(InvertArgs),
    /// Identify a model (weights by constrained least squares, (23)–(25)) from
    /// columns `t`, `u`, `y`; prints the fit report on stderr.
    Identify(IdentifyArgs),
    /// Estimate the memory a record starts in (play and creep states, the
    /// state of G, the offset) for a fixed model from the record's first
    /// samples; writes the model with that state.
    EstimateState(EstimateStateArgs),
    /// The beam: modal analysis, simulation, step-response identification.
    #[command(subcommand)]
    Beam(BeamCommand),
    /// Flatness-based feedforward: y_d and u_d for a rest-to-rest move of the
    /// tip, and with --model the compensated patch voltages.
    Feedforward(FeedforwardArgs),
    /// Run every scenario on the nominal models: traces, figures (SVG, PNG) and
    /// the paper's claims as numbers.
    Reproduce(ReproduceArgs),
    /// Run one scenario of the paper and write its trace.
    Scenario(ScenarioArgs),
    /// Regenerate (--write) or check (--check) the golden traces and manifest.
    Golden(GoldenArgs),
    /// Run the conformance properties on a program in any language that
    /// follows the file contract; writes shrunk counterexamples.
    Conform(ConformArgs),
    /// Compare a candidate trace from any implementation with a golden trace.
    Verify(VerifyArgs),
    /// Build an FMU (FMI 2.0 or 3.0 Co-Simulation, Linux x86-64) of the
    /// compensator, the actuator model or the plant (actuator and beam)
    /// from a model file (and a beam file), for Simulink, OpenModelica,
    /// Dymola and FMPy.
    Fmu(FmuArgs),
    /// Write the nominal model of the paper (reconstructed) (virgin state) as a model file.
    Nominal(NominalArgs),
    /// Write a test signal (a smooth staircase) as a trace with columns `t` and the chosen name.
    Signal(SignalArgs),
    /// Write synthetic lab records at several rates (`t`, `u`, `y`): a hold,
    /// then raised-cosine cycles of rising amplitude, from an actuator with
    /// rate-dependent thresholds, asymmetric loops, creep, a resonance, a
    /// sensor low-pass, a history before each record, offsets and noise.
    Records(RecordsArgs),
    /// Run a controller in the closed loop around the compensated Fig. 14
    /// feedforward (two degrees of freedom) in every scenario (nominal, tip
    /// impulse, step load, model error, sensor noise) and print the score
    /// table, the open loop alongside; with --output-dir also traces and
    /// plots.
    BenchmarkControl(BenchmarkControlArgs),
    /// The real-time budget: the latency of each step (median, p99, p99.9,
    /// p99.99, max) of the reference and of C libraries and FMUs, in
    /// interleaved rounds on the same targets, against the sample time.
    Bench(BenchArgs),
    /// Serve a candidate to the checker on stdin and stdout (what `conform`,
    /// `bench` and `benchmark-control` run FMUs and libraries in).
    #[command(hide = true)]
    Host(HostServeArgs),
}

/// `benchmark-control`.
#[derive(Debug, Args)]
pub struct BenchmarkControlArgs {
    /// A built-in controller: `pid` (filtered PID), `lq` (LQ with a Kalman
    /// observer), `open` (zero); repeatable. Default: both designs unless
    /// --exec or --fmu names another.
    #[arg(long, value_name = "pid|lq|open")]
    pub controller: Vec<String>,
    /// A program as the controller, its command line, e.g. 'python3
    /// my_controller.py': one line `k,t,reference,measurement` in per
    /// sample, one line `correction` out (docs/FILES.md, "The controller
    /// protocol"); started afresh for every scenario.
    #[arg(
        long,
        value_name = "CMD ARGS…",
        allow_hyphen_values = true,
        conflicts_with = "fmu"
    )]
    pub exec: Option<String>,
    /// An FMU (FMI 2.0 or 3.0 Co-Simulation) as the controller: Float64
    /// inputs `reference` and `measurement`, output `correction`; one
    /// communication step of Ts per sample, the output read after it is the
    /// sample's correction. A fresh instance for every scenario.
    #[arg(long, value_name = "X.fmu")]
    pub fmu: Option<PathBuf>,
    /// With --fmu: the FMU's name for one of ours, `OURS=THEIRS` (ours:
    /// reference, measurement, correction); repeatable.
    #[arg(long, value_name = "OURS=THEIRS", requires = "fmu")]
    pub fmu_variable: Vec<String>,
    /// Run only these scenarios (repeatable; default: all).
    #[arg(long, value_name = "ID")]
    pub scenario: Vec<String>,
    /// The model file of the compensator W⁻¹ in the loop (default: the
    /// nominal model).
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// The model file of the true actuator W (default: the same as
    /// --model); `model-error` scales its weights.
    #[arg(long, value_name = "M.json")]
    pub plant_model: Option<PathBuf>,
    /// Beam file (JSON) of the loop, its feedforward and the built-in
    /// designs (default: the nominal beam).
    #[arg(long)]
    pub beam: Option<PathBuf>,
    /// Beam discretization: `modal` (finite elements reduced to
    /// `basis_functions` modes) or `ritz` (the paper's).
    #[arg(long, value_enum, default_value_t = ModelKindArg::Modal)]
    pub beam_model: ModelKindArg,
    /// Finite elements of the modal model.
    #[arg(long, default_value_t = mfcbeam::beam::fe::DEFAULT_ELEMENTS, value_parser = parse_elements)]
    pub elements: usize,
    /// Longest the controller may take to answer one sample (s).
    #[arg(long, default_value_t = 10.0, allow_hyphen_values = true)]
    pub timeout: f64,
    #[command(flatten)]
    pub host: HostArgs,
    /// Directory for the traces (`<scenario>-<controller>.csv`), the plots
    /// (`<scenario>.png`) and the table (`scores.md`).
    #[arg(long)]
    pub output_dir: Option<PathBuf>,
}

/// A model applied to one trace, written to another.
#[derive(Debug, Args)]
pub struct ModelTraceArgs {
    /// Model file (JSON).
    #[arg(long)]
    pub model: PathBuf,
    /// Input trace (CSV): column `u` (V) for simulate, `y_d` (V) for compensate.
    #[arg(long)]
    pub input: PathBuf,
    /// Output trace (CSV).
    #[arg(long)]
    pub output: PathBuf,
}

#[derive(Debug, Args)]
pub struct SimulateArgs {
    #[command(flatten)]
    pub files: ModelTraceArgs,
}

#[derive(Debug, Args)]
pub struct CompensateArgs {
    #[command(flatten)]
    pub files: ModelTraceArgs,
    /// Saturation limits `LO,HI` of the balanced voltage (default: -1000,1000).
    #[arg(long, value_name = "LO,HI", allow_hyphen_values = true, value_parser = parse_limits, conflicts_with = "no_limits")]
    pub limits: Option<(f64, f64)>,
    /// Do not saturate the output.
    #[arg(long)]
    pub no_limits: bool,
}

#[derive(Debug, Args)]
pub struct InvertArgs {
    /// Model file (JSON).
    #[arg(long)]
    pub model: PathBuf,
}

#[derive(Debug, Args)]
pub struct IdentifyArgs {
    /// Measurement (CSV) with columns `u` (V), `y` and, unless --sample-time is given, `t` (s).
    /// Give it several times to fit one model to several records (each from
    /// the virgin state, each skipping its own --fit-from; same sample time).
    #[arg(long, required = true)]
    pub input: Vec<PathBuf>,
    /// With several --input records: `shared` (one output offset for all)
    /// or `per-record` (each its own; the model file keeps the first
    /// record's, the report lists every one).
    #[arg(long, value_name = "shared|per-record", default_value = "shared")]
    pub offset: OffsetSetting,
    /// Linear dynamics after the hysteresis to fit with the weights: `none`
    /// or any of `low-pass`, `resonance`, `delay-fraction`, comma-separated
    /// (a sensor's or amplifier's lag, a stage's lightly damped resonance, a
    /// delay of a fraction of a sample on top of --delay). The model carries
    /// them and its compensator inverts them exactly (a resonance adds one
    /// sample to the preview).
    #[arg(long, value_name = "PARTS", default_value = "none")]
    pub dynamics: DynamicsParts,
    /// Threads of the --dynamics search and --fit-initial-state (the
    /// trials, and the records' state estimates, run side by side; the
    /// model does not depend on the count): 0 for one per core, 1 for this
    /// thread alone.
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub threads: usize,
    /// Fit each record's initial memory (its play and creep states)
    /// together with the weights, in rounds that each lower the squared
    /// error over every sample: a record with an unknown past fitted from
    /// its first sample. After the --delay and --dynamics searches, with
    /// what they found. The model file stays in the virgin state.
    #[arg(long)]
    pub fit_initial_state: bool,
    /// A penalty λ s² ‖w_C‖² on the creep weights (s² the mean squared
    /// creep column): `none`, a λ, or `gcv` (λ by generalized
    /// cross-validation on the fitted samples alone).
    #[arg(
        long,
        value_name = "none|gcv|LAMBDA",
        default_value = "none",
        allow_hyphen_values = true
    )]
    pub creep_regularisation: mfcbeam::identification::CreepRegularisation,
    /// Where the play thresholds go: `uniform` (23) or `reversals` (half by
    /// (23), half at the quantiles of the half-amplitudes of the input's
    /// reversals: records of small loops get plays that move in them).
    #[arg(long, value_name = "uniform|reversals", default_value = "uniform")]
    pub thresholds: ThresholdRule,
    /// Before scoring each --validate record, estimate its constant offset
    /// on this stretch (`1.0s..1.5s` or samples `10000..15000`, the end
    /// of a hold: the practice of zeroing a sensor before a run) and report
    /// its errors with and without it removed.
    #[arg(long, value_name = "A..B")]
    pub validate_zero: Option<ZeroSegment>,
    /// Output model file (JSON, virgin state).
    #[arg(long)]
    pub output: PathBuf,
    /// Number of plays n_H + 1.
    #[arg(long, default_value_t = IdentificationSettings::default().hysteresis_operators)]
    pub hysteresis_operators: usize,
    /// Number of log(t)-creep operators n_C + 1 (0: no creep).
    #[arg(long, default_value_t = IdentificationSettings::default().creep_operators)]
    pub creep_operators: usize,
    /// Number of creep eigenvalues m, spread by (24).
    #[arg(long, default_value_t = IdentificationSettings::default().creep_eigenvalues)]
    pub creep_eigenvalues: usize,
    /// Sample time (s); default: from the `t` column.
    #[arg(long, allow_hyphen_values = true)]
    pub sample_time: Option<f64>,
    /// Margin ε_H > 0 of the hysteresis partial sums (default 1e-3 · range(y) / range(u)).
    #[arg(long, allow_hyphen_values = true)]
    pub epsilon_h: Option<f64>,
    /// Explicit hysteresis thresholds `0,r1,r2,...` instead of (23).
    #[arg(long, value_delimiter = ',', num_args = 1..)]
    pub hysteresis_thresholds: Option<Vec<f64>>,
    /// Explicit creep thresholds `0,r1,r2,...` instead of (23).
    #[arg(long, value_delimiter = ',', num_args = 1..)]
    pub creep_thresholds: Option<Vec<f64>>,
    /// Explicit creep eigenvalues (1/s) instead of (24).
    #[arg(long, value_delimiter = ',', num_args = 1..)]
    pub eigenvalues: Option<Vec<f64>>,
    /// Dead zones per side of a superposition operator S after H + C (the
    /// modified PI model for asymmetric loops, fitted by Kuhnen's error
    /// model); 0 fits the paper's symmetric model.
    #[arg(long, value_name = "M", default_value_t = IdentificationSettings::default().superposition)]
    pub superposition: usize,
    /// Explicit kinks of S⁻¹ on the output axis `y1,y2,...` instead of the
    /// rule (M per side evenly over the output's half-range around its
    /// mid-point).
    #[arg(long, value_delimiter = ',', num_args = 1.., allow_hyphen_values = true)]
    pub superposition_kinks: Option<Vec<f64>>,
    /// Fix the output offset at 0 instead of fitting it.
    #[arg(long)]
    pub no_offset: bool,
    /// First sample to fit, as a sample (`1000`; 0: assume the virgin state
    /// at the first sample) or a time after the first sample (`0.1s`: leave
    /// a start transient out); default: where |u| first reaches max|u|, from
    /// where every play's state is fixed by the input.
    #[arg(long, value_name = "SAMPLE|SECONDSs")]
    pub fit_from: Option<FitStart>,
    /// Leave this fraction of the data at the end out of the fit and report
    /// the errors on it.
    #[arg(long, value_name = "FRACTION", allow_hyphen_values = true)]
    pub holdout: Option<f64>,
    /// Another measurement (columns `u`, `y`, and `t` or the fit's sample
    /// time) to report the identified model's errors on; may be given
    /// several times (a table, one row per record, with its input's rate).
    #[arg(long, value_name = "OTHER.csv")]
    pub validate: Vec<PathBuf>,
    /// Estimate each validation record's initial memory (as
    /// `estimate-state` does) from its samples before this sample or time
    /// (like `1.2s`), and score it from there on: a record with an
    /// unknown past scored fairly.
    #[arg(long, value_name = "SAMPLE|SECONDSs")]
    pub validate_state_until: Option<FitStart>,
    /// Where the validation records' errors start (a sample or a time like
    /// `0.1s`); default: as --fit-from (or where |u| first reaches max|u|).
    #[arg(long, value_name = "SAMPLE|SECONDSs")]
    pub validate_from: Option<FitStart>,
    /// Dead time between input and output in whole samples, or `auto`: fit
    /// every one in 0..=--max-delay and keep the best on the --validate
    /// records (else the --holdout, else the fit), with a table of the
    /// errors of each.
    #[arg(long, value_name = "N|auto", default_value = "0")]
    pub delay: DelaySetting,
    /// The largest dead time `--delay auto` tries (samples).
    #[arg(long, value_name = "N", default_value_t = DEFAULT_MAX_DELAY)]
    pub max_delay: usize,
    /// Rate-dependent play thresholds `r_i + β|Δu|/T_s`: `β` in seconds
    /// (below the sample time; the hysteresis weights are then fitted
    /// non-negative), or `auto`: search `β` and keep the best on the
    /// --validate records (else the --holdout, else the fit), with a table
    /// of the errors of each (after the --delay search).
    #[arg(long, value_name = "SECONDS|auto", default_value = "0")]
    pub rate_gain: RateGainSetting,
    /// Draw measured and model output over the input, and the residual over
    /// time (`.png` or `.svg`).
    #[arg(long, value_name = "FILE")]
    pub plot: Option<PathBuf>,
}

/// `identify --thresholds`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ThresholdRule {
    Uniform,
    Reversals,
}

/// How the output offset of several records is fitted.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OffsetSetting {
    Shared,
    PerRecord,
}

impl std::str::FromStr for OffsetSetting {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "shared" => Ok(Self::Shared),
            "per-record" => Ok(Self::PerRecord),
            _ => Err(format!("'{s}' is neither shared nor per-record")),
        }
    }
}

#[derive(Debug, Args)]
pub struct FeedforwardArgs {
    #[command(flatten)]
    pub beam: BeamModelArgs,
    /// Hysteresis and creep model file (JSON): adds `u = W⁻¹[u_d]`, `u_fs`, `u_bs`, `saturated`.
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Start of the transition (s).
    #[arg(long, default_value_t = FeedforwardSettings::default().start, allow_hyphen_values = true)]
    pub start: f64,
    /// Duration T of the transition (s).
    #[arg(long, default_value_t = FeedforwardSettings::default().duration, allow_hyphen_values = true)]
    pub duration: f64,
    /// Final tip deflection y_T (m), from rest at 0.
    #[arg(long, default_value_t = FeedforwardSettings::default().y_final, allow_hyphen_values = true)]
    pub y_final: f64,
    /// Gevrey parameter σ of the trajectory (28).
    #[arg(long, default_value_t = FeedforwardSettings::default().sigma, allow_hyphen_values = true)]
    pub sigma: f64,
    /// End of the trace (s).
    #[arg(long, default_value_t = FeedforwardSettings::default().end, allow_hyphen_values = true)]
    pub end: f64,
    /// Sample time (s); default: the model's, else 2e-4.
    #[arg(long, allow_hyphen_values = true)]
    pub sample_time: Option<f64>,
    /// Output trace (CSV).
    #[arg(long)]
    pub output: PathBuf,
}

#[derive(Debug, Args)]
pub struct ReproduceArgs {
    /// Output directory (traces/ and plots/ are created in it).
    #[arg(long, default_value = "reproduce")]
    pub out: PathBuf,
}

#[derive(Debug, Args)]
pub struct ScenarioArgs {
    /// Scenario id: rectangle, staircase, minor-loops, intersection, log-creep,
    /// identification, compensated, step, feedforward.
    pub name: String,
    /// Output trace (CSV).
    #[arg(long)]
    pub output: PathBuf,
    /// Every sample at 5 kHz instead of the golden file's decimation.
    #[arg(long)]
    pub full: bool,
}

#[derive(Debug, Args)]
pub struct GoldenArgs {
    /// Directory of the golden files.
    #[arg(long, default_value = "golden")]
    pub dir: PathBuf,
    /// Regenerate every golden trace and the manifest (an explicit action).
    #[arg(long, conflicts_with = "check")]
    pub write: bool,
    /// Recompute every trace and compare with the stored ones (exit 1 on a difference).
    #[arg(long)]
    pub check: bool,
}

/// What a `conform` candidate implements.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ConformKind {
    /// `W`: reads column `u`, writes `y` (as `mfcbeam simulate`).
    Model,
    /// `W⁻¹`: reads column `y_d`, writes `u` and `saturated` (as `mfcbeam compensate`).
    Compensator,
    /// `H` alone (the PI operator, as most published code is): reads `u`,
    /// writes `y`; its model files hold the hysteresis part only.
    Hysteresis,
    /// `H⁻¹` alone (the inverse PI operator (22)): reads `y`, writes `u`; its
    /// model files hold `H`, whose inverse the candidate computes.
    InverseHysteresis,
}

#[derive(Debug, Args)]
pub struct ConformArgs {
    /// What the candidate implements.
    #[arg(long, value_enum)]
    pub kind: ConformKind,
    /// The candidate's command line, e.g. 'mfcbeam simulate' or
    /// 'python3 my_model.py'; it is run as `CMD ARGS… --model M.json --input
    /// IN.csv --output OUT.csv`, a compensator also with `--limits=LO,HI`
    /// (with --model: without `--model M.json`).
    #[arg(
        long,
        value_name = "CMD ARGS…",
        allow_hyphen_values = true,
        required_unless_present_any = ["fmu", "library"],
        conflicts_with_all = ["fmu", "library"]
    )]
    pub exec: Option<String>,
    /// An FMU (FMI 2.0 or 3.0 Co-Simulation) to check instead of a
    /// command; it implements the model given with --model. It runs in a
    /// host process of its own.
    #[arg(
        long,
        value_name = "X.fmu",
        requires = "model",
        conflicts_with = "library"
    )]
    pub fmu: Option<PathBuf>,
    #[command(flatten)]
    pub library: LibraryArgs,
    #[command(flatten)]
    pub host: HostArgs,
    /// The fixed mode: the candidate implements this one model (its
    /// parameters compiled in) and reads no model file. Only properties
    /// that vary the input run; the report lists the others.
    #[arg(long, value_name = "M.json")]
    pub model: Option<PathBuf>,
    /// With --fmu: the FMU's name for one of ours, `OURS=THEIRS` (ours:
    /// u, y, y_d, saturated, fault, u_min, u_max); repeatable.
    #[arg(long, value_name = "OURS=THEIRS", requires = "fmu")]
    pub fmu_variable: Vec<String>,
    /// With --fmu, a compensator without limit parameters (u_min, u_max):
    /// the saturation limits `LO,HI` it has built in (default: -1000,1000).
    #[arg(long, value_name = "LO,HI", allow_hyphen_values = true, value_parser = parse_limits, requires = "fmu")]
    pub limits: Option<(f64, f64)>,
    /// Random cases in all, spread evenly over the properties.
    #[arg(long, default_value_t = 200)]
    pub cases: usize,
    /// Seed of the case generator.
    #[arg(long, default_value_t = ConformanceSettings::default().seed)]
    pub seed: u64,
    /// Factor on every tolerance, for lower-precision candidates (f32: 536870912 = 2^29).
    #[arg(long, default_value_t = ConformanceSettings::default().tolerance_scale, allow_hyphen_values = true)]
    pub tolerance_scale: f64,
    /// Directory for the counterexamples (one subdirectory per failing property).
    #[arg(long, default_value = "conform")]
    pub out: PathBuf,
    /// Longest a single run of the candidate may take (s) before it is killed.
    #[arg(long, default_value_t = 20.0, allow_hyphen_values = true)]
    pub timeout: f64,
    /// Draw models with linear dynamics after S too (a low-pass, a
    /// resonance, a delay fraction: the model file's `dynamics`); off, the
    /// cases are those a candidate written before them reads.
    #[arg(long)]
    pub with_dynamics: bool,
}

/// What `bench` times.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum BenchKind {
    /// The compensator W⁻¹: targets y_d in, u out.
    Compensator,
    /// The actuator model W: voltages u in, y out.
    Model,
    /// The closed loop's controller: reference and measurement in,
    /// correction out (FMUs only; the reference is the built-in design of
    /// --controller).
    Controller,
}

/// `bench`.
#[derive(Debug, Args)]
pub struct BenchArgs {
    /// What the candidates implement.
    #[arg(long, value_enum, default_value_t = BenchKind::Compensator)]
    pub kind: BenchKind,
    /// The model file the reference is built from and the libraries get
    /// (default: the nominal model); the FMUs implement it.
    #[arg(long, value_name = "M.json")]
    pub model: Option<PathBuf>,
    /// A shared library with the step ABI (PREFIX_create, PREFIX_step,
    /// PREFIX_free); repeatable.
    #[arg(long, value_name = "LIB.so")]
    pub library: Vec<PathBuf>,
    /// The prefix of the libraries' functions.
    #[arg(long, default_value = mfcbeam::isolation::DEFAULT_SYMBOL_PREFIX)]
    pub symbol_prefix: String,
    /// The floating-point type of the libraries' step.
    #[arg(long, value_enum, default_value_t = PrecisionArg::F64)]
    pub precision: PrecisionArg,
    /// An FMU (FMI 2.0 or 3.0 Co-Simulation), one doStep per sample;
    /// repeatable.
    #[arg(long, value_name = "X.fmu")]
    pub fmu: Vec<PathBuf>,
    /// The FMUs' name for one of ours, `OURS=THEIRS` (ours: u, y, y_d,
    /// saturated, fault, u_min, u_max); repeatable.
    #[arg(long, value_name = "OURS=THEIRS")]
    pub fmu_variable: Vec<String>,
    /// The targets: `adversarial` (reversals at every sample, saturation,
    /// the whole range, sub-normal steps off zero), a scenario of the paper
    /// with the kind's input column (`compensated`, `feedforward`, … for
    /// y_d; `rectangle`, `staircase`, … for u), or a trace file with that
    /// column. For a controller: a closed-loop benchmark scenario (`nominal`,
    /// …), whose reference and measurement, recorded with the built-in
    /// design, are the inputs. Default: adversarial; nominal for a
    /// controller.
    #[arg(long)]
    pub target: Option<String>,
    /// With --kind controller: the built-in design the FMUs are compared
    /// with and timed beside: `pid` or `lq`.
    #[arg(long, default_value = "lq", value_name = "pid|lq")]
    pub controller: String,
    /// Steps per round for each candidate.
    #[arg(long, default_value_t = 100_000)]
    pub steps: usize,
    /// Rounds; each times every candidate once, in turn.
    #[arg(long, default_value_t = 10)]
    pub rounds: usize,
    /// The budget of one step (µs); default: the model's sample time.
    #[arg(long, value_name = "US")]
    pub budget: Option<f64>,
    /// The saturation limits of the compensators.
    #[arg(long, value_name = "LO,HI", allow_hyphen_values = true, value_parser = parse_limits)]
    pub limits: Option<(f64, f64)>,
    /// Factor on the agreement tolerance, for lower-precision candidates
    /// (f32: 536870912 = 2^29).
    #[arg(long, default_value_t = 1.0)]
    pub tolerance_scale: f64,
    /// Pin the reference and every host to this CPU.
    #[arg(long, value_name = "N")]
    pub cpu: Option<usize>,
    /// Write the figures as JSON.
    #[arg(long, value_name = "FILE.json")]
    pub json: Option<PathBuf>,
    /// Write the latency histograms (SVG or PNG by the extension).
    #[arg(long, value_name = "FILE.svg")]
    pub histogram: Option<PathBuf>,
    /// Longest one round of one candidate may take (s).
    #[arg(long, default_value_t = 60.0, allow_hyphen_values = true)]
    pub timeout: f64,
    #[command(flatten)]
    pub host: HostArgs,
}

/// A shared library with the step ABI as the candidate.
#[derive(Debug, Args)]
pub struct LibraryArgs {
    /// A shared library with the step ABI (PREFIX_create, PREFIX_step,
    /// PREFIX_free; docs/FILES.md, "The step ABI") to check instead of a
    /// command; it runs in a host process of its own.
    #[arg(long, value_name = "LIB.so")]
    pub library: Option<PathBuf>,
    /// The prefix of the library's functions.
    #[arg(long, default_value = mfcbeam::isolation::DEFAULT_SYMBOL_PREFIX, requires = "library")]
    pub symbol_prefix: String,
    /// The floating-point type of the library's step.
    #[arg(long, value_enum, default_value_t = PrecisionArg::F64, requires = "library")]
    pub precision: PrecisionArg,
}

/// The floating-point type of a step library.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum PrecisionArg {
    /// `double PREFIX_step(void *, double)`.
    F64,
    /// `float PREFIX_step(void *, float)`.
    F32,
}

impl PrecisionArg {
    pub fn precision(self) -> mfcbeam::isolation::Precision {
        match self {
            Self::F64 => mfcbeam::isolation::Precision::F64,
            Self::F32 => mfcbeam::isolation::Precision::F32,
        }
    }
}

/// The host process of an FMU or library candidate.
#[derive(Debug, Args)]
pub struct HostArgs {
    /// The address space the candidate's host process may use (MB): an
    /// allocation beyond it fails inside the host.
    #[arg(long, value_name = "MB", default_value_t = mfcbeam::isolation::DEFAULT_MEMORY_LIMIT >> 20)]
    pub memory_limit: u64,
}

impl HostArgs {
    /// The host's settings with `timeout` (s, checked by the caller).
    pub fn settings(&self, timeout: f64) -> anyhow::Result<mfcbeam::isolation::HostSettings> {
        const MOST: u64 = 1 << 30;
        if !(16..=MOST).contains(&self.memory_limit) {
            anyhow::bail!(
                "--memory-limit: must be a number of MB in [16, {MOST}], found {}",
                self.memory_limit
            );
        }
        let mut s = mfcbeam::isolation::HostSettings::this_program(
            std::time::Duration::from_secs_f64(timeout),
        )
        .map_err(|e| anyhow::anyhow!("this program's path: {e}"))?;
        s.memory_limit = Some(self.memory_limit << 20);
        Ok(s)
    }
}

/// `host` (internal): serve a candidate to the checker.
#[derive(Debug, Args)]
pub struct HostServeArgs {
    /// The shared progress page.
    #[arg(long)]
    pub progress: Option<PathBuf>,
    /// The address space limit (bytes).
    #[arg(long)]
    pub memory_limit: Option<u64>,
}

/// What an FMU contains.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum FmuKindArg {
    /// The compensator W⁻¹: y_d in; u, saturated, fault out.
    Compensator,
    /// The actuator model W: u in, y out.
    Model,
    /// The actuator and the beam: u in; tip deflection y, effective voltage v, modal state out (needs --beam).
    Plant,
    /// A feedback design of the closed loop (needs --controller): reference and measurement in; correction, held out.
    Controller,
}

#[derive(Debug, Args)]
pub struct FmuArgs {
    /// What the FMU contains.
    #[arg(long, value_enum)]
    pub kind: FmuKindArg,
    /// Model file (JSON); it travels inside the FMU (not the controller's).
    #[arg(long, required_if_eq_any([("kind", "compensator"), ("kind", "model"), ("kind", "plant")]))]
    pub model: Option<PathBuf>,
    /// The controller's design (--kind controller): `pid` or `lq`, designed
    /// for the benchmark's nominal models (or the beam given with --beam).
    #[arg(long, value_name = "pid|lq", required_if_eq("kind", "controller"))]
    pub controller: Option<String>,
    /// Beam file (JSON) of the plant; it travels inside the FMU. For the
    /// controller: the beam its design is for (default: the nominal beam).
    #[arg(long, required_if_eq("kind", "plant"))]
    pub beam: Option<PathBuf>,
    /// Beam discretization (the plant): `modal` (finite elements reduced
    /// to `basis_functions` modes) or `ritz` (the paper's).
    #[arg(long, value_enum, default_value_t = ModelKindArg::Modal)]
    pub beam_model: ModelKindArg,
    /// Finite elements of the modal model (the plant).
    #[arg(long, default_value_t = mfcbeam::beam::fe::DEFAULT_ELEMENTS, value_parser = parse_elements)]
    pub elements: usize,
    /// FMI version: 2 (2.0) or 3 (3.0).
    #[arg(long, value_parser = clap::builder::PossibleValuesParser::new(["2", "3"]))]
    pub fmi: String,
    /// The FMU to write.
    #[arg(long)]
    pub output: PathBuf,
    /// The platforms to pack, comma-separated (x86_64-linux, x86_64-windows, aarch64-linux, x86_64-darwin, aarch64-darwin; FMI 2 folder names too), or `all`; each must have its library in the release folder, where one that is missing is built with cargo if the folder is a checkout's target folder. Default: every platform whose library is there, naming those that are not.
    #[arg(long, value_delimiter = ',', conflicts_with = "library")]
    pub platforms: Vec<String>,
    /// The cargo target folder holding the libraries: the host's in release/, the others in <rust target>/release/ (default: the one this program runs from).
    #[arg(long, value_name = "DIR", conflicts_with = "library")]
    pub release_folder: Option<PathBuf>,
    /// An mfcbeam-fmu shared library to pack instead, repeatable; its platform is read from its header.
    #[arg(long)]
    pub library: Vec<PathBuf>,
}

#[derive(Debug, Args)]
pub struct VerifyArgs {
    /// Golden trace, e.g. golden/compensated.csv (its manifest is read from the same directory).
    #[arg(long)]
    pub golden: PathBuf,
    /// Candidate trace (CSV) with the same column names: as stored, or every sample at 5 kHz.
    #[arg(long)]
    pub candidate: PathBuf,
}

#[derive(Debug, Args)]
pub struct NominalArgs {
    /// Output file (JSON); stdout if absent.
    #[arg(long)]
    pub output: Option<PathBuf>,
    /// Write the nominal beam (the paper (reconstructed)) instead of the hysteresis and creep model.
    #[arg(long)]
    pub beam: bool,
}

#[derive(Debug, Subcommand)]
pub enum BeamCommand {
    /// Undamped natural frequencies, damping ratios and static gain of the model's n modes, and the modal model itself (omega, modal_damping, modal_input, modal_output), as JSON on stdout.
    Modes(BeamModesArgs),
    /// Tip deflection `y` (m) for column `u` (effective V), exact ZOH, from rest in equilibrium with u_0.
    Simulate(BeamSimulateArgs),
    /// Fit beam parameters to a step response (columns `u`, `y`) by Levenberg–Marquardt.
    Identify(BeamIdentifyArgs),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ModelKindArg {
    /// The paper's Ritz model (uniform-beam eigenfunctions).
    Ritz,
    /// Converged finite elements reduced to n modes (default).
    Modal,
}

#[derive(Debug, Args)]
pub struct BeamModelArgs {
    /// Beam file (JSON).
    #[arg(long)]
    pub beam: PathBuf,
    /// Beam discretization: `modal` (converged finite elements reduced to
    /// `basis_functions` modes) or `ritz` (the paper's).
    #[arg(long, value_enum, default_value_t = ModelKindArg::Modal)]
    pub beam_model: ModelKindArg,
    /// Finite elements of the modal model.
    #[arg(long, default_value_t = mfcbeam::beam::fe::DEFAULT_ELEMENTS, value_parser = parse_elements)]
    pub elements: usize,
}

impl BeamModelArgs {
    pub fn kind(&self) -> BeamModelKind {
        Self::kind_of(self.beam_model, self.elements)
    }

    /// The discretization named by `--beam-model` and `--elements`.
    pub fn kind_of(beam_model: ModelKindArg, elements: usize) -> BeamModelKind {
        match beam_model {
            ModelKindArg::Ritz => BeamModelKind::Ritz,
            ModelKindArg::Modal => BeamModelKind::Modal { elements },
        }
    }
}

#[derive(Debug, Args)]
pub struct BeamModesArgs {
    #[command(flatten)]
    pub model: BeamModelArgs,
}

#[derive(Debug, Args)]
pub struct BeamSimulateArgs {
    #[command(flatten)]
    pub model: BeamModelArgs,
    /// Input trace (CSV) with column `u` (effective V).
    #[arg(long)]
    pub input: PathBuf,
    /// Output trace (CSV).
    #[arg(long)]
    pub output: PathBuf,
    /// Sample time (s); default: from the `t` column, else 2e-4. Given together
    /// with a `t` column, the two must agree.
    #[arg(long, allow_hyphen_values = true)]
    pub sample_time: Option<f64>,
}

#[derive(Debug, Args)]
pub struct BeamIdentifyArgs {
    #[command(flatten)]
    pub model: BeamModelArgs,
    /// Measured step response (CSV) with columns `u` (effective V) and `y` (m).
    #[arg(long)]
    pub input: PathBuf,
    /// Parameters to fit, e.g. `youngs_modulus,patch.input_gain`.
    #[arg(long, value_delimiter = ',', required = true)]
    pub fit: Vec<String>,
    /// Fitted beam file (JSON).
    #[arg(long)]
    pub output: PathBuf,
    /// Sample time (s); default: from the `t` column, else 2e-4. Given together
    /// with a `t` column, the two must agree.
    #[arg(long, allow_hyphen_values = true)]
    pub sample_time: Option<f64>,
    /// Fix the output offset at 0 instead of fitting it.
    #[arg(long)]
    pub no_offset: bool,
    /// Do not fit the time of the step (it is fitted, continuously, when
    /// column `u` is a single step).
    #[arg(long)]
    pub no_step_time: bool,
}

#[derive(Debug, Args)]
pub struct EstimateStateArgs {
    /// Model file (JSON): its parameters are kept; its state, if any, is
    /// where the estimate starts from (virgin otherwise).
    #[arg(long)]
    pub model: PathBuf,
    /// The record (CSV): columns `u` (V), `y` and `t` (s) at the model's
    /// sample time.
    #[arg(long)]
    pub input: PathBuf,
    /// The end of the estimation window: a sample or a time like `1.2s`
    /// (default: the whole record).
    #[arg(long, value_name = "SAMPLE|SECONDSs")]
    pub until: Option<FitStart>,
    /// Model file written (JSON): the model in the estimated state.
    #[arg(long)]
    pub output: PathBuf,
    /// The state the file holds: at the record's `start`, or at the `end`
    /// of the window (where a compensator started up by the record goes
    /// on).
    #[arg(long, value_name = "start|end", default_value = "start")]
    pub state_at: StateAt,
    /// Keep the model's offset instead of estimating it.
    #[arg(long)]
    pub keep_offset: bool,
    /// Keep the model's creep states instead of estimating them.
    #[arg(long)]
    pub keep_creep: bool,
    /// Start G at rest on its first input instead of estimating its state.
    #[arg(long)]
    pub keep_dynamics: bool,
}

/// `estimate-state --state-at`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum StateAt {
    Start,
    End,
}

#[derive(Debug, Args)]
pub struct RecordsArgs {
    /// Directory for the records (`<rate>hz.csv`, one per rate).
    #[arg(long)]
    pub output_dir: PathBuf,
    /// Rates of the records (Hz).
    #[arg(long, value_delimiter = ',', default_values_t = RecordSettings::default().rates)]
    pub rates: Vec<f64>,
    /// β (s) of the thresholds r_i + β|du/dt| (0: rate-independent loops;
    /// below the sample time).
    #[arg(long, default_value_t = RecordSettings::default().rate_gain)]
    pub rate_gain: f64,
    /// Noise as a fraction of the output range.
    #[arg(long, default_value_t = RecordSettings::default().noise)]
    pub noise: f64,
    /// Seed of the history, offsets and noise.
    #[arg(long, default_value_t = RecordSettings::default().seed)]
    pub seed: u64,
    /// Draw the loops of every record in one figure (`.png` or `.svg`).
    #[arg(long, value_name = "FILE")]
    pub plot: Option<PathBuf>,
    /// After the hold: `cycles` (raised cosines of rising amplitude at each
    /// rate) or `tracking` (2 s of random levels at each rate through a
    /// lag, the voltage jagged with steps every 5 ms).
    #[arg(long, value_name = "cycles|tracking", default_value = "cycles")]
    pub drive: DriveArg,
    /// The hold's level (V); default -90 (saturation, which wipes the
    /// history out). Another level keeps the history's memory; a tracking
    /// run starts from it.
    #[arg(long, value_name = "V", allow_hyphen_values = true)]
    pub hold_at: Option<f64>,
    /// The tracking run's levels within this fraction of ±90 V.
    #[arg(long, value_name = "FRACTION", default_value_t = RecordSettings::default().tracking_range)]
    pub tracking_range: f64,
    /// Also write the actuator as a model file, `DIR/actuator.json`
    /// (virgin, its rate gain included).
    #[arg(long)]
    pub write_model: bool,
}

/// `records --drive`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum DriveArg {
    Cycles,
    Tracking,
}

#[derive(Debug, Args)]
pub struct SignalArgs {
    /// Output trace (CSV).
    #[arg(long)]
    pub output: PathBuf,
    /// Name of the signal column.
    #[arg(long, default_value = "u")]
    pub column: String,
    /// Peak value of the staircase 0 → +A → −A → 0.
    #[arg(long, default_value_t = 900.0, allow_hyphen_values = true)]
    pub amplitude: f64,
    /// Number of loops; with more than one the amplitude shrinks each period
    /// (the identification input of section 4.1).
    #[arg(long, default_value_t = 1)]
    pub periods: usize,
    /// Steps per quarter of the loop.
    #[arg(long, default_value_t = 3)]
    pub steps: usize,
    /// Duration of each smooth transition (s).
    #[arg(long, default_value_t = 0.1, allow_hyphen_values = true)]
    pub rise: f64,
    /// Duration of each plateau (s).
    #[arg(long, default_value_t = 1.5, allow_hyphen_values = true)]
    pub plateau: f64,
    /// Sample time (s).
    #[arg(long, default_value_t = SAMPLE_TIME, allow_hyphen_values = true)]
    pub sample_time: f64,
}

/// `--elements`: from 3 to [`mfcbeam::realtime::limits::MAX_ELEMENTS`].
fn parse_elements(s: &str) -> std::result::Result<usize, String> {
    let most = mfcbeam::realtime::limits::MAX_ELEMENTS;
    match s.parse::<usize>() {
        Ok(n) if (3..=most).contains(&n) => Ok(n),
        _ => Err(format!(
            "expected a whole number from 3 to {most} (docs/FILES.md, \"Limits\")"
        )),
    }
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
    if lo.is_infinite() && hi.is_infinite() {
        return Err("no limits at all is --no-limits".into());
    }
    if lo >= hi {
        return Err(format!("LO = {lo} must be below HI = {hi}"));
    }
    Ok((lo, hi))
}
