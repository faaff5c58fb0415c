//! The paper's scenarios, each a deterministic function of the nominal
//! models that produces one trace: the inputs and every intermediate signal.
//!
//! | id | paper | what it shows |
//! |---|---|---|
//! | `rectangle` | Fig. 2 | creep after a 500 V step held 40 s, remanent offset |
//! | `staircase` | Fig. 3 | hysteresis loop over the full range, creep at each step |
//! | `minor-loops` | Fig. 8a | nested reversals: Madelung rules, Masing congruence |
//! | `intersection` | Fig. 8b | three histories reaching one point, different slopes |
//! | `log-creep` | Fig. 9 | long plateaus: creep linear in log t |
//! | `identification` | Sec. 4.1 | shrinking periodic staircase and the identified fit |
//! | `compensated` | Fig. 10 | the staircase through `W⁻¹` then `W`: linear |
//! | `step` | Figs. 12–13 | a step through the beam with and without compensation |
//! | `feedforward` | Fig. 14 | rest-to-rest move through compensator, `W` and beam |
//! | `loop-nominal`, `loop-impulse`, `loop-step-load`, `loop-model-error`, `loop-noise` | Sec. 5 | the move open loop and 2-DOF, with disturbances, an error in `W` and noise |
//!
//! A scenario is one file with a [`Scenario`] static: its id and paper
//! figure, its columns with units and golden tolerances ([`Column`]), how it
//! runs, its figure and the paper's claims it measures. [`SCENARIOS`] lists
//! them; adding a scenario is a new file and one line there. A trace whose
//! columns differ from the declared ones is an error, so no column can go
//! without a tolerance.
//!
//! Every scenario runs at the full 5 kHz; long ones keep every `k`-th row
//! (`decimation`) in the golden files and are compared at those rows. The
//! plant's `W` and the compensator are pluggable ([`ScenarioContext`]), so
//! that an alternative or deliberately faulty implementation runs through the
//! same scenarios and is compared against the golden traces.

use std::collections::HashMap;

use thiserror::Error;

use crate::beam::modal::ModalModel;
use crate::beam::simulation::DiscreteBeam;
use crate::beam::step_response_fit::{modal_model, BeamModelKind};
use crate::beam::BeamParameters;
use crate::operators::compensator::CompensatorSettings;
use crate::operators::model::HysteresisCreepModel;
use crate::operators::nominal::{nominal_model, SAMPLE_TIME};
use crate::operators::traits::{ActuatorCompensator, ActuatorModel};
use crate::suite::conformance::{heap_compensator, heap_model, CompensatorFactory, ModelFactory};
use crate::suite::plots::{panel, scaled, series, Figure, Panel};
use crate::suite::signal::Staircase;

// what every scenario file uses, brought in by its `use super::*`
#[allow(unused_imports)]
use crate::operators::supply::Supply;
#[allow(unused_imports)]
use crate::operators::traits::Operator;
#[allow(unused_imports)]
use crate::suite::plots::{window, Series, COLORS, GREY};
#[allow(unused_imports)]
use plotters::style::RGBColor;

mod closed_loop;
mod compensated;
mod feedforward;
mod identification;
mod intersection;
mod log_creep;
mod minor_loops;
mod rectangle;
mod staircase;
mod step;

/// Every scenario, in the order of the paper.
pub static SCENARIOS: &[&Scenario] = &[
    &rectangle::SCENARIO,
    &staircase::SCENARIO,
    &minor_loops::SCENARIO,
    &intersection::SCENARIO,
    &log_creep::SCENARIO,
    &identification::SCENARIO,
    &compensated::SCENARIO,
    &step::SCENARIO,
    &feedforward::SCENARIO,
    &closed_loop::NOMINAL,
    &closed_loop::IMPULSE_SCENARIO,
    &closed_loop::STEP_LOAD_SCENARIO,
    &closed_loop::MODEL_ERROR_SCENARIO,
    &closed_loop::NOISE_SCENARIO,
];

/// Look a scenario up by id.
pub fn scenario(id: &str) -> Option<&'static Scenario> {
    SCENARIOS.iter().copied().find(|s| s.id == id)
}

/// One of the paper's experiments, reproduced: its id (also the golden
/// file's stem, `golden/<id>.csv`), the paper's figure or section, what it
/// shows, the decimation of its golden file, its columns with units and
/// tolerances, how it runs, its figure and the paper's claims it measures.
pub struct Scenario {
    pub id: &'static str,
    pub paper: &'static str,
    pub description: &'static str,
    /// Keep every `decimation`-th row in the golden file.
    pub decimation: usize,
    /// The columns of its trace, in order.
    pub columns: &'static [Column],
    /// Compute the trace at the full sample rate.
    pub compute: fn(&ScenarioContext) -> Result<ScenarioTrace, ScenarioError>,
    /// Its figure (the second argument holds every scenario's full-rate
    /// trace, for overlays).
    pub figure: fn(&ScenarioTrace, &Traces) -> Option<Figure>,
    /// The paper's claims this scenario measures.
    pub claims: fn(&ScenarioTrace, &Traces) -> Vec<Claim>,
}

/// For a scenario without a figure.
pub fn no_figure(_: &ScenarioTrace, _: &Traces) -> Option<Figure> {
    None
}

/// For a scenario that measures no claim.
pub fn no_claims(_: &ScenarioTrace, _: &Traces) -> Vec<Claim> {
    Vec::new()
}

impl Scenario {
    /// Compute the trace at the full sample rate.
    pub fn compute(&self, ctx: &ScenarioContext) -> Result<ScenarioTrace, ScenarioError> {
        (self.compute)(ctx)
    }

    /// Its figure, if it has one.
    pub fn figure(&self, trace: &ScenarioTrace, all: &Traces) -> Option<Figure> {
        (self.figure)(trace, all)
    }

    /// The claims it measures.
    pub fn claims(&self, trace: &ScenarioTrace, all: &Traces) -> Vec<Claim> {
        (self.claims)(trace, all)
    }
}

/// Full-rate traces by scenario id.
pub type Traces = HashMap<&'static str, ScenarioTrace>;

/// A column of a scenario's trace: unit, golden tolerance (a row passes when
/// `|candidate − golden| ≤ abs_tol + rel_tol · |golden|`) and why.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Column {
    pub name: &'static str,
    pub unit: &'static str,
    pub abs_tol: f64,
    pub rel_tol: f64,
    pub justification: &'static str,
}

/// The time column `t = k T_s`.
pub const fn time() -> Column {
    Column {
        name: "t",
        unit: "s",
        abs_tol: 1e-9,
        rel_tol: 0.0,
        justification: "k Ts in double precision",
    }
}

/// A generated input in volts (closed-form samples).
pub const fn input(name: &'static str) -> Column {
    Column {
        name,
        unit: "V",
        abs_tol: 1e-9,
        rel_tol: 0.0,
        justification: "generated input: closed-form samples, equal to rounding (1e-12 of 1000 V)",
    }
}

/// An output of `W`, `H` or `C` (V).
pub const fn model_output(name: &'static str) -> Column {
    Column {
        name,
        unit: "V",
        abs_tol: 1e-9,
        rel_tol: 1e-12,
        justification: "W: sums of at most 72 terms of at most 1000 V round to < 2e-11 V; 50x margin for another summation order",
    }
}

/// An output of the compensator `W⁻¹` or a patch voltage derived from it (V).
pub const fn compensator_output(name: &'static str) -> Column {
    Column {
        name,
        unit: "V",
        abs_tol: 1e-8,
        rel_tol: 1e-11,
        justification: "W^-1: the W rounding amplified by the steepest inverse slope 1/s_min (2.2) and the creep term; 1e-8 V",
    }
}

/// The flat output's tip deflection `y_d = N(d/dt) z_d` (m).
pub const fn flat_reference(name: &'static str) -> Column {
    Column {
        name,
        unit: "m",
        abs_tol: 1e-15,
        rel_tol: 1e-10,
        justification: "N(d/dt) z_d from order-30 derivatives accurate to 1e-10 of their scale",
    }
}

/// A tip deflection from the exact zero-order-hold beam (m).
pub const fn tip(name: &'static str) -> Column {
    Column {
        name,
        unit: "m",
        abs_tol: 1e-12,
        rel_tol: 1e-9,
        justification:
            "beam: exact ZOH by diagonalization, rounding ~1e-11 of the 1 mm scale; 1e-12 m",
    }
}

/// A 0/1 flag: must match exactly.
pub const fn flag(name: &'static str) -> Column {
    Column {
        name,
        unit: "0/1",
        abs_tol: 0.0,
        rel_tol: 0.0,
        justification: "a flag: must match exactly",
    }
}

/// A claim of the paper, measured.
#[derive(Debug, Clone, PartialEq)]
pub struct Claim {
    pub figure: &'static str,
    pub claim: &'static str,
    pub measured: String,
    pub holds: bool,
}

/// A scenario that could not run, or whose trace breaks its declaration.
#[derive(Debug, Clone, PartialEq, Error)]
#[error("scenario {scenario}: {reason}")]
pub struct ScenarioError {
    pub scenario: &'static str,
    pub reason: String,
}

impl ScenarioError {
    pub(crate) fn new(scenario: &'static str, reason: impl std::fmt::Display) -> Self {
        Self {
            scenario,
            reason: reason.to_string(),
        }
    }
}

/// The models a scenario runs on, and how its `W` and `W⁻¹` are built.
pub struct ScenarioContext {
    /// The hysteresis and creep model (compensator and plant).
    pub model: HysteresisCreepModel,
    /// The beam.
    pub beam: BeamParameters,
    /// Its `modal` model (240 elements → 15 modes).
    pub modal: ModalModel,
    /// How the plant's `W` is built from the model file (default: the
    /// project's [`HysteresisCreepModel`]).
    pub plant: Box<ModelFactory<'static>>,
    /// How the compensator is built (default: the project's
    /// [`crate::operators::compensator::Compensator`]).
    pub compensator: Box<CompensatorFactory<'static>>,
}

impl ScenarioContext {
    /// The nominal models.
    pub fn nominal() -> Self {
        let beam = BeamParameters::nominal();
        let modal = modal_model(&beam, BeamModelKind::default()).expect("nominal beam is valid");
        Self {
            model: nominal_model(),
            beam,
            modal,
            plant: Box::new(heap_model),
            compensator: Box::new(heap_compensator),
        }
    }

    /// A fresh plant `W` from the model's current state.
    pub fn plant(&self, scenario: &'static str) -> Result<Box<dyn ActuatorModel>, ScenarioError> {
        (self.plant)(&self.model.to_file()).map_err(|e| ScenarioError::new(scenario, e))
    }

    /// A fresh compensator with the given limits.
    pub fn compensator(
        &self,
        scenario: &'static str,
        settings: CompensatorSettings,
    ) -> Result<Box<dyn ActuatorCompensator>, ScenarioError> {
        (self.compensator)(&self.model.to_file(), settings)
            .map_err(|e| ScenarioError::new(scenario, e))
    }

    /// The beam discretized at the sample time, at rest.
    pub fn beam(&self) -> DiscreteBeam {
        DiscreteBeam::new(&self.modal, SAMPLE_TIME).expect("nominal beam discretizes")
    }
}

/// A computed scenario: named columns at the full sample rate.
#[derive(Debug, Clone, PartialEq)]
pub struct ScenarioTrace {
    pub columns: Vec<(&'static str, Vec<f64>)>,
}

impl ScenarioTrace {
    /// The trace of `info`'s columns, one vector of values per column in
    /// their order ([`run`] checks that every declared column came).
    pub fn of(info: &Scenario, values: Vec<Vec<f64>>) -> Self {
        ScenarioTrace {
            columns: info.columns.iter().map(|c| c.name).zip(values).collect(),
        }
    }

    /// A column by name.
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        self.columns
            .iter()
            .find(|c| c.0 == name)
            .map(|c| c.1.as_slice())
    }

    /// A column by name, empty if absent (for figures and claims).
    pub fn col(&self, name: &str) -> &[f64] {
        self.column(name).unwrap_or(&[])
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.columns.first().map_or(0, |c| c.1.len())
    }

    /// Whether there are no rows.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// A panel of columns over `t`: `(column, label, colour)` each, times
    /// `scale` (1e3 shows a deflection in metres as millimetres).
    pub(crate) fn time_panel(
        &self,
        title: &str,
        y_label: &str,
        scale: f64,
        curves: &[(&str, &str, RGBColor)],
    ) -> Panel {
        let t = self.col("t");
        let curves = curves.iter();
        let series =
            curves.map(|&(c, label, color)| series(label, t, &scaled(self.col(c), scale), color));
        panel(title, "t (s)", y_label, series.collect())
    }

    /// A panel of input–output loops: `(x column, y column, label, colour)`
    /// each.
    pub(crate) fn loop_panel(
        &self,
        title: &str,
        x_label: &str,
        y_label: &str,
        curves: &[(&str, &str, &str, RGBColor)],
    ) -> Panel {
        let curves = curves.iter();
        let series =
            curves.map(|&(x, y, label, color)| series(label, self.col(x), self.col(y), color));
        panel(title, x_label, y_label, series.collect())
    }

    /// The tip deflection over `t`, in millimetres.
    pub(crate) fn tip_panel(&self, color: RGBColor) -> Panel {
        self.time_panel("tip deflection", "w(L) (mm)", 1e3, &[("tip", "tip", color)])
    }

    /// The rows with `lo ≤ t ≤ hi` (for a detail of a figure).
    pub(crate) fn window(&self, lo: f64, hi: f64) -> ScenarioTrace {
        let t = self.col("t");
        let rows: Vec<usize> = (0..t.len()).filter(|&k| t[k] >= lo && t[k] <= hi).collect();
        let columns = self.columns.iter();
        ScenarioTrace {
            columns: columns
                .map(|(n, v)| (*n, rows.iter().map(|&k| v[k]).collect()))
                .collect(),
        }
    }

    /// Every `k`-th row, starting with the first.
    pub fn decimated(&self, k: usize) -> ScenarioTrace {
        ScenarioTrace {
            columns: self
                .columns
                .iter()
                .map(|(n, v)| (*n, v.iter().step_by(k.max(1)).copied().collect()))
                .collect(),
        }
    }
}

/// Run a scenario and check its trace against its declared columns.
pub fn run(scenario: &Scenario, ctx: &ScenarioContext) -> Result<ScenarioTrace, ScenarioError> {
    let trace = scenario.compute(ctx)?;
    let declared: Vec<&str> = scenario.columns.iter().map(|c| c.name).collect();
    let found: Vec<&str> = trace.columns.iter().map(|c| c.0).collect();
    if declared != found {
        return Err(ScenarioError::new(
            scenario.id,
            format!("computed columns {found:?} differ from the declared {declared:?}"),
        ));
    }
    if let Some((name, _)) = trace.columns.iter().find(|c| c.1.len() != trace.len()) {
        return Err(ScenarioError::new(
            scenario.id,
            format!("column {name} has a different length"),
        ));
    }
    Ok(trace)
}

/// Run every scenario at the full rate.
pub fn run_all(ctx: &ScenarioContext) -> Result<Traces, ScenarioError> {
    SCENARIOS.iter().map(|s| Ok((s.id, run(s, ctx)?))).collect()
}

/// A compensator's run over `targets`: its voltage, its saturation flags
/// (0/1) and the patch voltages the supply makes of that voltage.
pub(crate) struct SuppliedRun {
    pub u: Vec<f64>,
    pub saturated: Vec<f64>,
    pub front: Vec<f64>,
    pub back: Vec<f64>,
}

impl SuppliedRun {
    pub(crate) fn new(
        comp: &mut dyn ActuatorCompensator,
        targets: &[f64],
        supply: &Supply,
    ) -> Self {
        let mut run = SuppliedRun {
            u: Vec::with_capacity(targets.len()),
            saturated: Vec::with_capacity(targets.len()),
            front: Vec::with_capacity(targets.len()),
            back: Vec::with_capacity(targets.len()),
        };
        for &y in targets {
            let c = comp.compensate(y);
            let (p, _) = supply.patch_voltages_saturating(c.u);
            run.u.push(c.u);
            run.saturated.push(if c.saturated { 1.0 } else { 0.0 });
            run.front.push(p.front);
            run.back.push(p.back);
        }
        run
    }
}

/// `t_k = k T_s`.
pub fn time_axis(len: usize) -> Vec<f64> {
    (0..len).map(|k| k as f64 * SAMPLE_TIME).collect()
}

/// Samples in `[0, duration]`.
pub(crate) fn samples(duration: f64) -> usize {
    (duration / SAMPLE_TIME).round() as usize + 1
}

/// Piecewise-linear path through `points` from 0 at `rate` V/s.
pub(crate) fn ramps(points: &[f64], rate: f64) -> Vec<f64> {
    let mut out = vec![0.0];
    let mut last = 0.0;
    for &p in points {
        let n = (((p - last).abs() / rate) / SAMPLE_TIME).ceil().max(1.0) as usize;
        for j in 1..=n {
            out.push(if j == n {
                p
            } else {
                last + (p - last) * j as f64 / n as f64
            });
        }
        last = p;
    }
    out
}

/// The staircase input of Fig. 3 (and, as a target, of Fig. 10).
pub fn fig3_staircase(amplitude: f64) -> Vec<f64> {
    Staircase::full_loop(amplitude, 4, 0.2, 1.8).sample(SAMPLE_TIME)
}

/// The first index with `t ≥ x` (the last if none).
pub(crate) fn at_time(t: &[f64], x: f64) -> usize {
    t.iter()
        .position(|&v| v >= x)
        .unwrap_or(t.len().saturating_sub(1))
}

/// `max − min`.
pub(crate) fn range(x: &[f64]) -> f64 {
    x.iter().fold(f64::NEG_INFINITY, |m, v| m.max(*v))
        - x.iter().fold(f64::INFINITY, |m, v| m.min(*v))
}
