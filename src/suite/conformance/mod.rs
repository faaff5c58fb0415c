//! Conformance: every property of the operators, written once, run on any
//! implementation of a kind — the project's fast one, the naive references
//! of [`crate::suite::reference`], an `f32` port, a wrapper around a C
//! library — through the object-safe traits of [`crate::operators::traits`].
//!
//! One call per kind:
//!
//! * [`check_model`] — the actuator model `W` ([`ActuatorModel`]);
//! * [`check_compensator`] — the compensator `W⁻¹` ([`ActuatorCompensator`]);
//! * [`check_inverse_hysteresis`] — the inverse PI operator `H⁻¹` ([`InverseHysteresis`]).
//!
//! Each takes a *factory* (a model file → a boxed implementation; the model
//! file, with its `state`, is how every implementation is configured) and
//! [`ConformanceSettings`] (number of cases, seed, tolerance scale), runs every
//! property that applies on seeded random admissible models and inputs and on
//! the paper's inputs, and returns a [`ConformanceReport`]: per property
//! whether it holds, the worst error against its tolerance, and for a failure
//! a small counterexample (model file and input) found by shrinking the first
//! failing case.
//!
//! An implementation of part of the model declines the cases with a part
//! it lacks ([`ModelError::Unsupported`] from its factory, or
//! [`decline_case`] while it runs; a program through the file contract
//! exits with code 3): they are counted as skipped, with the coverage in
//! the report, and the properties hold or fail on the cases that ran. A
//! counterexample keeps the case before shrinking beside the shrunk one;
//! [`explain`] splits the reference into its parts at the failing sample
//! and names known mistakes (band width vs half-width, creep missing, the
//! first-sample convention (8), …).
//!
//! Tolerances come from rounding analysis of the reference formulas
//! ([`tolerance`]): `c · n · ε · Σ|w| · max|x|` for a sum of `n` products, amplified
//! by the steepest inverse slope `1/s_min` where an inverse is involved. A
//! lower-precision implementation multiplies them by
//! [`ConformanceSettings::tolerance_scale`] (for `f32`, `ε₃₂/ε₆₄ = 2²⁹`).
//! Properties that hold exactly in real arithmetic (odd symmetry, rate
//! independence, the Madelung rules, split and resume) are checked against
//! the same rounding tolerance; the project's own implementation meets them
//! with error 0.

mod cases;
mod compensator;
pub mod explain;
#[cfg(feature = "suite")]
pub mod external;
mod factories;
pub mod fixed;
mod inverse_hysteresis;
mod model;
mod runner;
pub mod tolerance;

use std::fmt;

use crate::error::ModelError;
use crate::operators::compensator::CompensatorSettings;
use crate::operators::model::{HysteresisCreepModel, ModelFile};
use crate::operators::traits::{ActuatorCompensator, ActuatorModel, InverseHysteresis};
use crate::realtime::limits;

pub use cases::{
    case_model, delay_of, input_length, nested_extrema, path, random_input, random_model,
    random_superposition, refine, segment, superposition_is_odd, superposition_model,
    with_every_part, with_state_after, ModelShape, Rng,
};
pub use compensator::{check_compensator, compensator_properties};
pub use factories::*;
pub use inverse_hysteresis::{check_inverse_hysteresis, inverse_hysteresis_properties};
pub use model::{check_model, model_properties};
pub use runner::current_case;
pub(crate) use runner::run_properties;

/// Builds an implementation of `W` from a model file (starting from its
/// `state`). `Sync`: properties run in parallel.
pub type ModelFactory<'a> =
    dyn Fn(&ModelFile) -> Result<Box<dyn ActuatorModel>, ModelError> + Sync + 'a;

/// Builds a compensator `W⁻¹` from a model file (matched to its `state`) and limits.
pub type CompensatorFactory<'a> = dyn Fn(&ModelFile, CompensatorSettings) -> Result<Box<dyn ActuatorCompensator>, ModelError>
    + Sync
    + 'a;

/// Builds `H⁻¹` of a model file's hysteresis part, its state transformed by (22).
pub type InverseHysteresisFactory<'a> =
    dyn Fn(&ModelFile) -> Result<Box<dyn InverseHysteresis>, ModelError> + Sync + 'a;

/// How many cases, from which seed, at which precision.
#[derive(Debug, Clone, PartialEq)]
pub struct ConformanceSettings {
    /// Random cases per property (default 48). Properties on the paper's
    /// fixed inputs run at most a few cases.
    pub cases: usize,
    /// Seed of the case generator (default fixed: runs are reproducible).
    pub seed: u64,
    /// Factor on every tolerance (default 1 for `f64` implementations).
    pub tolerance_scale: f64,
    /// Largest number of plays (and creep thresholds) of a random model
    /// (default 12, the paper's order).
    pub max_plays: usize,
    /// Longest random input (default 300 samples).
    pub max_samples: usize,
    /// Try to shrink a failing case (default true).
    pub shrink: bool,
    /// Property evaluations one shrink may spend (default 1500).
    pub shrink_budget: usize,
    /// Check the properties that hold exactly in real arithmetic (odd
    /// symmetry, rate independence, Madelung (i)–(iii): the candidate against
    /// itself) bit for bit, with tolerance 0 (default false). The project's
    /// own operators meet them exactly: their clamps and sums are odd and
    /// each play output is one of `x`, `v − r`, `v + r`.
    pub exact: bool,
    /// Reduce every case's model to its hysteresis part `H` — no creep, no
    /// superposition operator, no dead time, no offset — for an
    /// implementation of `H` alone, as most published PI code is (default
    /// false). Properties that need a part then skip.
    pub hysteresis_only: bool,
    /// Draw models with linear dynamics `G` after `S` as well (a low-pass,
    /// a resonance; default false: the file contract's models before
    /// dynamics, which every earlier candidate reads). Properties that take
    /// the output sample by sample (rate independence, the branching rules)
    /// never get them: `G` has memory of its own.
    pub dynamics: bool,
    /// The fixed mode ([`fixed`]): the one model the candidate implements
    /// (default `None`: random models). Every case uses it; properties
    /// that need other models do not run, and split and resume goes
    /// through the candidate's own save and restore.
    pub fixed_model: Option<ModelFile>,
    /// In the fixed mode, the limits of a compensator that cannot change
    /// them (an FMU without limit parameters), default `None`: random
    /// voltages stay inside them and the saturating cases use them.
    pub fixed_limits: Option<(f64, f64)>,
}

impl Default for ConformanceSettings {
    fn default() -> Self {
        Self {
            cases: 48,
            seed: 0x6d66_6362_6561_6d00,
            tolerance_scale: 1.0,
            max_plays: 12,
            max_samples: 300,
            shrink: true,
            shrink_budget: 1500,
            exact: false,
            hysteresis_only: false,
            dynamics: false,
            fixed_model: None,
            fixed_limits: None,
        }
    }
}

impl ConformanceSettings {
    /// The tolerance of a property that holds exactly in real arithmetic:
    /// 0 when [`ConformanceSettings::exact`], else the scaled rounding bound.
    pub fn exact_or(&self, rounding: f64) -> f64 {
        if self.exact {
            0.0
        } else {
            self.tolerance_scale * rounding
        }
    }

    /// The same settings with `total` cases spread over `properties`
    /// properties (at least one case each).
    pub fn spread(mut self, total: usize, properties: usize) -> Self {
        self.cases = total.div_ceil(properties.max(1)).max(1);
        self
    }

    /// At least one case, a finite scale ≥ 1, at least one play and 4 samples.
    pub fn validate(&self) -> Result<(), ModelError> {
        let bad = |field: &str, reason: String| {
            Err(ModelError::Inconsistent {
                field: field.into(),
                reason,
            })
        };
        if self.cases == 0 {
            return bad("cases", "must be at least 1".into());
        }
        if let Err(e) = limits::check("cases", limits::MAX_CONFORMANCE_CASES, self.cases) {
            return Err(e.into());
        }
        if !(self.tolerance_scale.is_finite() && self.tolerance_scale >= 1.0) {
            return bad(
                "tolerance_scale",
                format!(
                    "must be a finite number >= 1, found {}",
                    self.tolerance_scale
                ),
            );
        }
        if self.max_plays == 0 {
            return bad("max_plays", "must be at least 1".into());
        }
        if let Err(e) = limits::check("max_plays", limits::MAX_PLAYS, self.max_plays) {
            return Err(e.into());
        }
        if self.max_samples < 4 {
            return bad("max_samples", "must be at least 4".into());
        }
        if let Err(e) = limits::check(
            "max_samples",
            limits::MAX_GENERATED_SAMPLES,
            self.max_samples,
        ) {
            return Err(e.into());
        }
        if let Some(m) = &self.fixed_model {
            HysteresisCreepModel::from_file(m)?;
        }
        Ok(())
    }
}

/// One case of a property: a model file, an input (a signal, or for the
/// branching rules the extrema a path is built from) and, for a compensator,
/// limits (`None`: unlimited).
#[derive(Debug, Clone, PartialEq)]
pub struct Case {
    pub model: ModelFile,
    pub input: Vec<f64>,
    pub limits: Option<(f64, f64)>,
}

impl Case {
    /// The case with its model reduced to the hysteresis part `H`
    /// ([`ModelFile::hysteresis_part`]).
    pub fn hysteresis_part(mut self) -> Self {
        self.model = self.model.hysteresis_part();
        self
    }
}

/// The compensator settings of a case's limits (`None`: unlimited).
pub(crate) fn limit_settings(limits: Option<(f64, f64)>) -> CompensatorSettings {
    match limits {
        Some((lo, hi)) => CompensatorSettings::with_limits(lo, hi),
        None => CompensatorSettings::unlimited(),
    }
}

/// Why a case failed.
#[derive(Debug, Clone, PartialEq)]
pub struct Failure {
    /// The signal the candidate received (for the branching rules, the path
    /// built from the case's extrema).
    pub signal: Vec<f64>,
    /// What the property requires at each compared sample.
    pub expected: Vec<f64>,
    /// What the candidate gave.
    pub found: Vec<f64>,
    /// First compared sample outside the tolerance.
    pub sample: usize,
    /// `|expected − found|` there (infinite for a non-finite output or a refusal).
    pub error: f64,
    /// The tolerance there.
    pub tolerance: f64,
    /// What went wrong, in words.
    pub message: String,
}

/// The outcome of one case.
#[derive(Debug, Clone, PartialEq)]
pub enum Outcome {
    /// Within tolerance: the worst error and its tolerance.
    Held { error: f64, tolerance: f64 },
    /// Outside tolerance.
    Failed(Box<Failure>),
    /// The case does not meet the property's premise (after shrinking, say).
    Skipped,
    /// The implementation declined the case: its model has a part the
    /// implementation does not implement (the reason, in words). Counted
    /// as skipped; the property holds or fails on the cases that ran.
    Unsupported(String),
}

thread_local! {
    /// A part an implementation declined during the current case (set by
    /// the adapters of [`external`], which cannot refuse in their factory).
    static DECLINED: std::cell::RefCell<Option<String>> = const { std::cell::RefCell::new(None) };
}

/// Record, from inside a running check, that the implementation declined
/// the case (a part it does not implement): the case's outcome becomes
/// [`Outcome::Unsupported`] whatever the property concluded from the
/// outputs it got. An implementation that can tell when it is built
/// returns [`ModelError::Unsupported`] from its factory instead.
pub fn decline_case(reason: &str) {
    DECLINED.with(|d| {
        d.borrow_mut().get_or_insert_with(|| reason.to_string());
    });
}

/// Run one check, turning a declined case into [`Outcome::Unsupported`].
pub(crate) fn evaluate(check: impl FnOnce() -> Outcome) -> Outcome {
    DECLINED.with(|d| d.borrow_mut().take());
    let outcome = check();
    match DECLINED.with(|d| d.borrow_mut().take()) {
        Some(reason) => Outcome::Unsupported(reason),
        None => outcome,
    }
}

/// Compare `found` with `expected` sample by sample within `tolerance`.
pub(crate) fn compare(
    signal: &[f64],
    expected: &[f64],
    found: &[f64],
    tolerance: f64,
    what: &str,
) -> Outcome {
    compare_from(signal, expected, found, 0, tolerance, what)
}

/// [`compare`] from sample `from` on (a model's dead time: the identity
/// holds from sample `d`).
pub(crate) fn compare_from(
    signal: &[f64],
    expected: &[f64],
    found: &[f64],
    from: usize,
    tolerance: f64,
    what: &str,
) -> Outcome {
    if expected.len() != found.len() {
        return fail(
            signal,
            expected,
            found,
            expected.len().min(found.len()),
            f64::INFINITY,
            tolerance,
            format!(
                "{what}: {} samples expected, {} found",
                expected.len(),
                found.len()
            ),
        );
    }
    let mut worst = 0.0f64;
    for (k, (e, f)) in expected.iter().zip(found).enumerate().skip(from) {
        let err = (e - f).abs();
        // NaN (a non-finite output) fails too
        let within = err <= tolerance;
        if !within {
            let err = if err.is_nan() { f64::INFINITY } else { err };
            return fail(
                signal,
                expected,
                found,
                k,
                err,
                tolerance,
                format!("{what}: sample {k}: expected {e:?}, found {f:?}"),
            );
        }
        worst = worst.max(err);
    }
    Outcome::Held {
        error: worst,
        tolerance,
    }
}

/// A failed outcome.
pub(crate) fn fail(
    signal: &[f64],
    expected: &[f64],
    found: &[f64],
    sample: usize,
    error: f64,
    tolerance: f64,
    message: String,
) -> Outcome {
    Outcome::Failed(Box::new(Failure {
        signal: signal.to_vec(),
        expected: expected.to_vec(),
        found: found.to_vec(),
        sample,
        error,
        tolerance,
        message,
    }))
}

/// The candidate a factory built, or — if it refused a valid model — that
/// refusal as the property's outcome.
macro_rules! candidate {
    ($build:expr) => {
        match $build {
            Ok(c) => c,
            Err(o) => return o,
        }
    };
}
pub(crate) use candidate;

/// Two fresh candidates (for properties that compare two runs).
pub(crate) fn two<T>(build: impl Fn() -> Result<T, Outcome>) -> Result<(T, T), Outcome> {
    Ok((build()?, build()?))
}

/// The candidate refused a valid model (or declined a part it does not
/// implement).
pub(crate) fn refused(e: ModelError) -> Outcome {
    if let ModelError::Unsupported { part } = &e {
        return Outcome::Unsupported(format!("{part}: not implemented"));
    }
    fail(
        &[],
        &[],
        &[],
        0,
        f64::INFINITY,
        0.0,
        format!("the factory refused a valid model: {e}"),
    )
}

/// A failing case, shrunk.
#[derive(Debug, Clone, PartialEq)]
pub struct Counterexample {
    /// Index of the random case that failed first.
    pub case_index: usize,
    /// The shrunk case: model file, input, limits.
    pub case: Case,
    /// How it fails.
    pub failure: Failure,
    /// The case as generated, before shrinking, and how it failed: shrinking
    /// keeps any failure of the property, which may be another one than the
    /// first (see [`Counterexample::shrinking_changed_failure`]).
    pub unshrunk_case: Case,
    pub unshrunk_failure: Failure,
}

impl Counterexample {
    /// Shrinking kept a failure of another size: the error before and after
    /// differ by more than a factor of 10 either way (or one is infinite
    /// and the other not). The failing sample moves as the input is cut, so
    /// its index alone says nothing.
    pub fn shrinking_changed_failure(&self) -> bool {
        let (a, b) = (self.unshrunk_failure.error, self.failure.error);
        if a.is_infinite() || b.is_infinite() {
            return a.is_infinite() != b.is_infinite();
        }
        let (lo, hi) = (a.min(b), a.max(b));
        hi > 10.0 * lo
    }
}

/// The result of one property.
#[derive(Debug, Clone, PartialEq)]
pub struct PropertyResult {
    /// Short name, e.g. `odd_symmetry`.
    pub name: &'static str,
    /// What it checks, with the equation.
    pub description: &'static str,
    /// Cases run (skipped ones not counted).
    pub cases: usize,
    /// Cases the implementation declined ([`Outcome::Unsupported`]).
    pub skipped: usize,
    /// Why the first declined case was declined.
    pub skip_reason: Option<String>,
    /// Cases outside tolerance.
    pub failures: usize,
    /// The largest `error / tolerance` over the cases run (0 when every
    /// error was 0); `error` and `tolerance` are those of that case.
    pub worst_ratio: f64,
    pub worst_error: f64,
    pub tolerance: f64,
    /// The first failure, shrunk.
    pub counterexample: Option<Counterexample>,
    /// In the fixed mode: why the property cannot run on a fixed model
    /// (it needs other models); it then ran no case.
    pub not_on_fixed_model: Option<&'static str>,
}

impl PropertyResult {
    /// No case failed. (A property whose premise no case met ran no case:
    /// see [`PropertyResult::cases`].)
    pub fn holds(&self) -> bool {
        self.failures == 0
    }
}

/// The result of a conformance run.
#[derive(Debug, Clone, PartialEq)]
pub struct ConformanceReport {
    /// `model`, `compensator` or `inverse hysteresis`.
    pub kind: &'static str,
    pub properties: Vec<PropertyResult>,
}

impl ConformanceReport {
    /// Every property holds.
    pub fn passed(&self) -> bool {
        self.properties.iter().all(PropertyResult::holds)
    }

    /// The properties that do not hold.
    pub fn failed(&self) -> Vec<&PropertyResult> {
        self.properties.iter().filter(|p| !p.holds()).collect()
    }

    /// Cases run and cases skipped (declined by the implementation), over
    /// every property.
    pub fn coverage(&self) -> (usize, usize) {
        self.properties
            .iter()
            .fold((0, 0), |(r, s), p| (r + p.cases, s + p.skipped))
    }

    /// A property by name.
    pub fn property(&self, name: &str) -> Option<&PropertyResult> {
        self.properties.iter().find(|p| p.name == name)
    }
}

impl fmt::Display for ConformanceReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{:<32} {:>6} {:>8} {:>8} {:>12} {:>12}  result",
            format!("{} property", self.kind),
            "cases",
            "skipped",
            "failed",
            "worst error",
            "tolerance"
        )?;
        for p in &self.properties {
            writeln!(
                f,
                "{:<32} {:>6} {:>8} {:>8} {:>12.3e} {:>12.3e}  {}",
                p.name,
                p.cases,
                p.skipped,
                p.failures,
                p.worst_error,
                p.tolerance,
                match (p.holds(), p.cases, p.skipped) {
                    _ if p.not_on_fixed_model.is_some() => "cannot run on a fixed model",
                    (true, 0, 0) => "no case met the premise",
                    (true, 0, _) => "not covered: every case skipped",
                    (true, _, _) => "holds",
                    (false, _, _) => "FAILS",
                }
            )?;
        }
        let fixed: Vec<String> = self
            .properties
            .iter()
            .filter_map(|p| {
                p.not_on_fixed_model
                    .map(|why| format!("{} ({why})", p.name))
            })
            .collect();
        if !fixed.is_empty() {
            writeln!(f, "not on a fixed model: {}", fixed.join(", "))?;
        }
        let (ran, skipped) = self.coverage();
        if skipped > 0 {
            // a few distinct reasons, as the implementation gave them
            let mut reasons: Vec<&str> = Vec::new();
            for r in self
                .properties
                .iter()
                .filter_map(|p| p.skip_reason.as_deref())
            {
                if !reasons.contains(&r) && reasons.len() < 3 {
                    reasons.push(r);
                }
            }
            let reason = reasons.join("; ");
            writeln!(
                f,
                "coverage: {ran} of {} cases ran; {skipped} skipped, the implementation declined them ({reason})",
                ran + skipped
            )?;
        }
        for p in self.failed() {
            if let Some(c) = &p.counterexample {
                writeln!(
                    f,
                    "{}: {} ({} plays, {} samples): {}",
                    p.name,
                    p.description,
                    c.case.model.hysteresis.thresholds.len(),
                    c.case.input.len(),
                    c.failure.message
                )?;
            }
        }
        Ok(())
    }
}

/// The properties of one kind (`F`, its factory type): run them all on an
/// implementation, count them, or rerun one by name on one case.
pub struct Properties<F: ?Sized> {
    kind: &'static str,
    properties: Vec<Property<F>>,
}

impl<F: ?Sized + Sync> Properties<F> {
    pub(crate) fn new(kind: &'static str, properties: Vec<Property<F>>) -> Self {
        Self { kind, properties }
    }

    /// Run every property on the implementations `factory` builds.
    pub fn check(
        &self,
        factory: &F,
        settings: &ConformanceSettings,
    ) -> Result<ConformanceReport, ModelError> {
        run_properties(self.kind, &self.properties, factory, settings)
    }

    /// How many properties there are.
    pub fn len(&self) -> usize {
        self.properties.len()
    }

    pub fn is_empty(&self) -> bool {
        self.properties.is_empty()
    }

    /// Rerun property `name` on one case, to reproduce a counterexample
    /// (`None`: no such property).
    pub fn recheck(
        &self,
        name: &str,
        case: &Case,
        factory: &F,
        settings: &ConformanceSettings,
    ) -> Option<Outcome> {
        self.properties
            .iter()
            .find(|p| p.name == name)
            .map(|p| evaluate(|| (p.check)(case, factory, settings)))
    }
}

/// One property of kind `F` (the factory type).
#[allow(clippy::type_complexity)]
pub(crate) struct Property<F: ?Sized> {
    pub name: &'static str,
    pub description: &'static str,
    /// Cases at most (fixed inputs need only a few).
    pub max_cases: usize,
    pub generate: fn(&mut Rng, &ConformanceSettings, usize) -> Case,
    pub check: fn(&Case, &F, &ConformanceSettings) -> Outcome,
    /// Why the property cannot run on a fixed model (`None`: it can).
    pub not_on_fixed_model: Option<&'static str>,
    /// The property's premise is a model of `H` alone (no creep).
    pub hysteresis_alone: bool,
}

impl<F: ?Sized> Property<F> {
    pub(crate) fn new(
        name: &'static str,
        description: &'static str,
        max_cases: usize,
        generate: fn(&mut Rng, &ConformanceSettings, usize) -> Case,
        check: fn(&Case, &F, &ConformanceSettings) -> Outcome,
    ) -> Self {
        Self {
            name,
            description,
            max_cases,
            generate,
            check,
            not_on_fixed_model: None,
            hysteresis_alone: false,
        }
    }

    /// The property holds for `H` alone: on a fixed model with creep it
    /// cannot run.
    pub(crate) fn needs_hysteresis_alone(mut self) -> Self {
        self.hysteresis_alone = true;
        self
    }

    /// The property needs models other than a fixed one, for `why`.
    pub(crate) fn needs_other_models(mut self, why: &'static str) -> Self {
        self.not_on_fixed_model = Some(why);
        self
    }
}
