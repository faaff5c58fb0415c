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
#[cfg(feature = "suite")]
pub mod external;
mod inverse_hysteresis;
mod model;
pub mod tolerance;

use std::fmt;

use crate::error::ModelError;
use crate::operators::compensator::CompensatorSettings;
use crate::operators::model::{HysteresisCreepModel, ModelFile};
use crate::operators::traits::{ActuatorCompensator, ActuatorModel, InverseHysteresis};
use crate::realtime::{FixedCompensator, FixedHysteresis, FixedModel, Real};

pub use cases::{
    nested_extrema, path, random_input, random_model, refine, segment, with_state_after,
    ModelShape, Rng,
};
pub use compensator::{check_compensator, recheck_compensator};
pub use inverse_hysteresis::{check_inverse_hysteresis, recheck_inverse_hysteresis};
pub use model::{check_model, recheck_model};

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
        if self.max_samples < 4 {
            return bad("max_samples", "must be at least 4".into());
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
}

/// Compare `found` with `expected` sample by sample within `tolerance`.
pub fn compare(
    signal: &[f64],
    expected: &[f64],
    found: &[f64],
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
    for (k, (e, f)) in expected.iter().zip(found).enumerate() {
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
pub fn fail(
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

/// The candidate refused a valid model.
pub fn refused(e: ModelError) -> Outcome {
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
    /// Cases outside tolerance.
    pub failures: usize,
    /// The largest `error / tolerance` over the cases run (0 when every
    /// error was 0); `error` and `tolerance` are those of that case.
    pub worst_ratio: f64,
    pub worst_error: f64,
    pub tolerance: f64,
    /// The first failure, shrunk.
    pub counterexample: Option<Counterexample>,
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

    /// A property by name.
    pub fn property(&self, name: &str) -> Option<&PropertyResult> {
        self.properties.iter().find(|p| p.name == name)
    }
}

impl fmt::Display for ConformanceReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{:<32} {:>6} {:>8} {:>12} {:>12}  result",
            format!("{} property", self.kind),
            "cases",
            "failed",
            "worst error",
            "tolerance"
        )?;
        for p in &self.properties {
            writeln!(
                f,
                "{:<32} {:>6} {:>8} {:>12.3e} {:>12.3e}  {}",
                p.name,
                p.cases,
                p.failures,
                p.worst_error,
                p.tolerance,
                match (p.holds(), p.cases) {
                    (true, 0) => "no case met the premise",
                    (true, _) => "holds",
                    (false, _) => "FAILS",
                }
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

/// One property of kind `F` (the factory type).
pub(crate) struct Property<F: ?Sized> {
    pub name: &'static str,
    pub description: &'static str,
    /// Cases at most (fixed inputs need only a few).
    pub max_cases: usize,
    pub generate: fn(&mut Rng, &ConformanceSettings, usize) -> Case,
    pub check: fn(&Case, &F, &ConformanceSettings) -> Outcome,
}

/// Run every property on `factory`, the properties spread over the
/// available cores (each has its own seeded generator, so the result does
/// not depend on the scheduling).
pub(crate) fn run_properties<F: ?Sized + Sync>(
    kind: &'static str,
    properties: &[Property<F>],
    factory: &F,
    settings: &ConformanceSettings,
) -> Result<ConformanceReport, ModelError> {
    settings.validate()?;
    let threads = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .min(properties.len())
        .max(1);
    let mut results: Vec<Option<PropertyResult>> = vec![None; properties.len()];
    std::thread::scope(|scope| {
        let handles: Vec<_> = (0..threads)
            .map(|t| {
                scope.spawn(move || {
                    (t..properties.len())
                        .step_by(threads)
                        .map(|pi| (pi, run_property(pi, &properties[pi], factory, settings)))
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        for h in handles {
            for (pi, r) in h.join().expect("a property check panicked") {
                results[pi] = Some(r);
            }
        }
    });
    Ok(ConformanceReport {
        kind,
        properties: results
            .into_iter()
            .map(|r| r.expect("every property ran"))
            .collect(),
    })
}

/// Rerun property `name` on one case (to reproduce a counterexample).
pub(crate) fn recheck<F: ?Sized>(
    properties: &[Property<F>],
    name: &str,
    case: &Case,
    factory: &F,
    settings: &ConformanceSettings,
) -> Option<Outcome> {
    properties
        .iter()
        .find(|p| p.name == name)
        .map(|p| (p.check)(case, factory, settings))
}

fn run_property<F: ?Sized>(
    pi: usize,
    p: &Property<F>,
    factory: &F,
    settings: &ConformanceSettings,
) -> PropertyResult {
    let mut rng = Rng::new(settings.seed ^ (0x9e37_79b9 * (pi as u64 + 1)));
    let mut result = PropertyResult {
        name: p.name,
        description: p.description,
        cases: 0,
        failures: 0,
        worst_ratio: 0.0,
        worst_error: 0.0,
        tolerance: 0.0,
        counterexample: None,
    };
    for i in 0..settings.cases.min(p.max_cases) {
        let case = (p.generate)(&mut rng, settings, i);
        let outcome = (p.check)(&case, factory, settings);
        let (error, tolerance) = match &outcome {
            Outcome::Skipped => continue,
            Outcome::Held { error, tolerance } => (*error, *tolerance),
            Outcome::Failed(f) => (f.error, f.tolerance),
        };
        result.cases += 1;
        let ratio = if error == 0.0 {
            0.0
        } else if tolerance > 0.0 {
            error / tolerance
        } else {
            f64::INFINITY
        };
        if ratio > result.worst_ratio || result.cases == 1 {
            result.worst_ratio = ratio;
            result.worst_error = error;
            result.tolerance = tolerance;
        }
        if let Outcome::Failed(failure) = outcome {
            result.failures += 1;
            if result.counterexample.is_none() {
                let (case, failure) = if settings.shrink {
                    shrink(case, *failure, settings.shrink_budget, |c| {
                        (p.check)(c, factory, settings)
                    })
                } else {
                    (case, *failure)
                };
                result.counterexample = Some(Counterexample {
                    case_index: i,
                    case,
                    failure,
                });
            }
        }
    }
    result
}

/// Make a failing case smaller while it still fails: a shorter input (cut
/// after the failing sample, then chunks and single samples removed), a
/// smaller model (state, creep, eigenvalues, thresholds dropped), rounder
/// numbers.
pub fn shrink(
    case: Case,
    failure: Failure,
    budget: usize,
    check: impl Fn(&Case) -> Outcome,
) -> (Case, Failure) {
    let mut best = (case, failure);
    let mut budget = budget;
    let attempt = |c: Case, best: &mut (Case, Failure), budget: &mut usize| -> bool {
        if *budget == 0 || HysteresisCreepModel::from_file(&c.model).is_err() {
            return false;
        }
        *budget -= 1;
        if let Outcome::Failed(f) = check(&c) {
            *best = (c, *f);
            true
        } else {
            false
        }
    };
    for _pass in 0..4 {
        let mut progress = false;
        // 1. cut the input after the failing sample
        let cut = best.1.sample + 1;
        if cut < best.0.input.len() {
            let mut c = best.0.clone();
            c.input.truncate(cut);
            progress |= attempt(c, &mut best, &mut budget);
        }
        // 2. remove chunks of the input, halving their size
        let mut size = best.0.input.len() / 2;
        while size >= 1 && budget > 0 {
            let mut start = 0;
            while start + size <= best.0.input.len() && best.0.input.len() > size {
                let mut c = best.0.clone();
                c.input.drain(start..start + size);
                if !attempt(c, &mut best, &mut budget) {
                    start += size;
                } else {
                    progress = true;
                }
            }
            size /= 2;
        }
        // 3. a smaller model
        for reduce in MODEL_REDUCTIONS {
            loop {
                let mut c = best.0.clone();
                if !reduce(&mut c.model) || !attempt(c, &mut best, &mut budget) {
                    break;
                }
                progress = true;
            }
        }
        // 4. rounder numbers
        for digits in [0i32, 1, 2, 3] {
            let mut c = best.0.clone();
            let before = c.clone();
            round_case(&mut c, digits);
            if c != before && attempt(c, &mut best, &mut budget) {
                progress = true;
                break;
            }
        }
        if !progress || budget == 0 {
            break;
        }
    }
    best
}

type Reduction = fn(&mut ModelFile) -> bool;

const MODEL_REDUCTIONS: [Reduction; 6] = [
    |m| {
        let had =
            m.hysteresis.state.is_some() || m.creep.as_ref().is_some_and(|c| c.state.is_some());
        m.hysteresis.state = None;
        if let Some(c) = &mut m.creep {
            c.state = None;
        }
        had
    },
    |m| m.creep.take().is_some(),
    |m| match &mut m.creep {
        Some(c) if c.eigenvalues.len() > 1 => {
            c.eigenvalues.pop();
            if let Some(s) = &mut c.state {
                s.iter_mut().for_each(|row| {
                    row.pop();
                });
            }
            true
        }
        _ => false,
    },
    |m| match &mut m.creep {
        Some(c) if c.thresholds.len() > 1 => {
            c.thresholds.pop();
            c.weights.pop();
            if let Some(s) = &mut c.state {
                s.pop();
            }
            true
        }
        _ => false,
    },
    |m| {
        let h = &mut m.hysteresis;
        if h.thresholds.len() > 1 {
            h.thresholds.pop();
            h.weights.pop();
            if let Some(s) = &mut h.state {
                s.pop();
            }
            true
        } else {
            false
        }
    },
    |m| {
        // drop the first play above r_0: the others move down one place
        let h = &mut m.hysteresis;
        if h.thresholds.len() > 2 && h.state.is_none() {
            h.thresholds.remove(1);
            h.weights.remove(1);
            true
        } else {
            false
        }
    },
];

/// Round to `digits` significant digits (0: to integers where that keeps the value non-zero).
fn round_to(x: f64, digits: i32) -> f64 {
    if x == 0.0 || !x.is_finite() {
        return x;
    }
    if digits == 0 {
        let r = x.round();
        return if r == 0.0 { x } else { r };
    }
    let e = x.abs().log10().floor() as i32;
    let f = 10f64.powi(digits - 1 - e);
    (x * f).round() / f
}

fn round_case(c: &mut Case, digits: i32) {
    for v in &mut c.input {
        *v = round_to(*v, digits.max(1) + 1);
    }
    if c.model.hysteresis.state.is_none() {
        for r in c.model.hysteresis.thresholds.iter_mut() {
            *r = round_to(*r, digits);
        }
    }
    for w in c.model.hysteresis.weights.iter_mut() {
        *w = round_to(*w, digits.max(1));
    }
    if let Some(cr) = &mut c.model.creep {
        if cr.state.is_none() {
            for r in cr.thresholds.iter_mut() {
                *r = round_to(*r, digits);
            }
        }
        for a in cr.eigenvalues.iter_mut() {
            *a = round_to(*a, digits.max(1));
        }
    }
}

/// `ε₃₂/ε₆₄ = 2²⁹`: the [`ConformanceSettings::tolerance_scale`] of an `f32`
/// implementation. Every tolerance is a sum of terms linear in `ε` (first-order
/// rounding analysis), so moving to binary32 scales each by this ratio; the
/// `f64` parameters rounded once to `f32` are relative perturbations of
/// `ε₃₂/2`, inside the same terms.
pub const F32_TOLERANCE_SCALE: f64 = (f32::EPSILON as f64) / f64::EPSILON;

/// Factory of the real-time core's `W` in `T` with capacity `N` plays and `K`
/// elementary creep operators.
pub fn fixed_model<T: Real, const N: usize, const K: usize>(
    file: &ModelFile,
) -> Result<Box<dyn ActuatorModel>, ModelError> {
    Ok(Box::new(FixedModel::<T, N, K>::from_file(file)?))
}

/// Factory of the real-time core's compensator in `T`.
pub fn fixed_compensator<T: Real, const N: usize, const K: usize>(
    file: &ModelFile,
    settings: CompensatorSettings,
) -> Result<Box<dyn ActuatorCompensator>, ModelError> {
    settings.validate()?;
    Ok(Box::new(FixedCompensator::<T, N, K>::from_file(
        file,
        settings.lower_limit,
        settings.upper_limit,
    )?))
}

/// Factory of the real-time core's `H⁻¹` in `T`.
pub fn fixed_inverse_hysteresis<T: Real, const N: usize>(
    file: &ModelFile,
) -> Result<Box<dyn InverseHysteresis>, ModelError> {
    HysteresisCreepModel::from_file(file)?;
    Ok(Box::new(FixedHysteresis::<T, N>::inverse_from_file(file)?))
}

/// Factory of the project's model `W` (for tests and examples).
pub fn fast_model(file: &ModelFile) -> Result<Box<dyn ActuatorModel>, ModelError> {
    Ok(Box::new(HysteresisCreepModel::from_file(file)?))
}

/// Factory of the project's compensator (21).
pub fn fast_compensator(
    file: &ModelFile,
    settings: CompensatorSettings,
) -> Result<Box<dyn ActuatorCompensator>, ModelError> {
    let model = HysteresisCreepModel::from_file(file)?;
    Ok(Box::new(crate::operators::compensator::Compensator::new(
        &model, settings,
    )?))
}

/// Factory of the project's inverse hysteresis operator (22).
pub fn fast_inverse_hysteresis(file: &ModelFile) -> Result<Box<dyn InverseHysteresis>, ModelError> {
    let model = HysteresisCreepModel::from_file(file)?;
    Ok(Box::new(model.hysteresis().inverse()))
}

/// Factory of the naive reference model.
pub fn reference_model(file: &ModelFile) -> Result<Box<dyn ActuatorModel>, ModelError> {
    Ok(Box::new(crate::suite::reference::NaiveModel::from_file(
        file,
    )?))
}

/// Factory of the naive reference compensator.
pub fn reference_compensator(
    file: &ModelFile,
    settings: CompensatorSettings,
) -> Result<Box<dyn ActuatorCompensator>, ModelError> {
    Ok(Box::new(
        crate::suite::reference::NaiveCompensator::from_file(file, settings)?,
    ))
}

/// Factory of the naive reference inverse hysteresis operator.
pub fn reference_inverse_hysteresis(
    file: &ModelFile,
) -> Result<Box<dyn InverseHysteresis>, ModelError> {
    Ok(Box::new(crate::suite::reference::naive_inverse_hysteresis(
        file,
    )?))
}

/// Factory of the numerical (bisection) compensator.
pub fn bisection_compensator(
    file: &ModelFile,
    settings: CompensatorSettings,
) -> Result<Box<dyn ActuatorCompensator>, ModelError> {
    Ok(Box::new(
        crate::suite::reference::BisectionCompensator::from_file(file, settings)?,
    ))
}
