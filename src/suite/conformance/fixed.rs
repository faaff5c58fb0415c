//! Fixed implementations: a candidate that implements one given model —
//! its parameters compiled in, code generated from a block diagram, an FMU
//! — and reads no model file. It is checked against the model it claims
//! to be ([`ConformanceSettings::fixed_model`](super::ConformanceSettings::fixed_model)): every property whose cases
//! vary only the input (and the limits) runs on that model; the properties
//! that need other models (`S` alone, say) are reported as not runnable on
//! a fixed model; state split and resume goes through the candidate's own
//! save and restore ([`Operator::save_state`]) instead of the model file's
//! state, and is skipped for a candidate that cannot save.
//!
//! A factory of a fixed implementation builds it for the fixed model only
//! and declines every other model file ([`fixed_model_factory`] and its
//! siblings wrap a builder so).

use super::{compare, refused, Outcome};
use crate::error::ModelError;
use crate::operators::compensator::CompensatorSettings;
use crate::operators::model::ModelFile;
use crate::operators::traits::{
    ActuatorCompensator, ActuatorModel, Compensated, InverseHysteresis, Operator, SavedState,
};

/// Why a fixed implementation declines a model file.
pub const OTHER_MODEL: &str = "a model other than the one the fixed implementation implements";

/// A fixed implementation of `fixed` accepts `file` only if it is that
/// model; every other is declined ([`ModelError::Unsupported`]).
pub fn accepts(fixed: &ModelFile, file: &ModelFile) -> Result<(), ModelError> {
    if file == fixed {
        Ok(())
    } else {
        Err(ModelError::Unsupported {
            part: OTHER_MODEL.into(),
        })
    }
}

/// A model factory for a fixed implementation of `W` = `fixed`: `build`
/// makes a fresh instance; every other model file is declined.
pub fn fixed_model_factory<'a>(
    fixed: ModelFile,
    build: impl Fn() -> Result<Box<dyn ActuatorModel>, ModelError> + Sync + 'a,
) -> impl Fn(&ModelFile) -> Result<Box<dyn ActuatorModel>, ModelError> + Sync + 'a {
    move |file| {
        accepts(&fixed, file)?;
        build()
    }
}

/// A compensator factory for a fixed implementation of `W⁻¹` of `fixed`;
/// the limits are passed on (an FMU sets them as parameters).
pub fn fixed_compensator_factory<'a>(
    fixed: ModelFile,
    build: impl Fn(CompensatorSettings) -> Result<Box<dyn ActuatorCompensator>, ModelError> + Sync + 'a,
) -> impl Fn(&ModelFile, CompensatorSettings) -> Result<Box<dyn ActuatorCompensator>, ModelError>
       + Sync
       + 'a {
    move |file, settings| {
        accepts(&fixed, file)?;
        build(settings)
    }
}

/// An `H⁻¹` factory for a fixed implementation of the inverse of `fixed`'s
/// hysteresis part.
pub fn fixed_inverse_hysteresis_factory<'a>(
    fixed: ModelFile,
    build: impl Fn() -> Result<Box<dyn InverseHysteresis>, ModelError> + Sync + 'a,
) -> impl Fn(&ModelFile) -> Result<Box<dyn InverseHysteresis>, ModelError> + Sync + 'a {
    move |file| {
        accepts(&fixed, file)?;
        build()
    }
}

/// An implementation that saves its state by cloning itself: the
/// project's own operators as fixed implementations that can save and
/// restore (the tests of the fixed mode run them so).
#[derive(Debug, Clone)]
pub struct Restorable<T>(pub T);

impl<T: Clone + Send + 'static> Restorable<T> {
    fn save(&self) -> Option<SavedState> {
        Some(SavedState(Box::new(self.0.clone())))
    }

    /// False for a state this type did not save.
    fn restore(&mut self, state: &SavedState) -> bool {
        match state.0.downcast_ref::<T>() {
            Some(s) => {
                self.0 = s.clone();
                true
            }
            None => false,
        }
    }
}

impl<T: Operator + Clone + Send + 'static> Operator for Restorable<T> {
    fn step(&mut self, v: f64) -> f64 {
        self.0.step(v)
    }

    fn reset(&mut self) {
        self.0.reset();
    }

    fn save_state(&mut self) -> Option<SavedState> {
        self.save()
    }

    fn restore_state(&mut self, state: &SavedState) -> bool {
        self.restore(state)
    }
}

impl<T: ActuatorModel + Clone + Send + 'static> ActuatorModel for Restorable<T> {}
impl<T: InverseHysteresis + Clone + Send + 'static> InverseHysteresis for Restorable<T> {}

impl<T: ActuatorCompensator + Clone + Send + 'static> ActuatorCompensator for Restorable<T> {
    fn compensate(&mut self, target: f64) -> Compensated {
        self.0.compensate(target)
    }

    fn reset(&mut self) {
        self.0.reset();
    }

    fn delay(&self) -> usize {
        self.0.delay()
    }

    fn save_state(&mut self) -> Option<SavedState> {
        self.save()
    }

    fn restore_state(&mut self, state: &SavedState) -> bool {
        self.restore(state)
    }
}

/// One sample at a time through an operator or a compensator, with its
/// save and restore: what [`resume_from_saved`] needs of either.
pub(crate) trait Resumable {
    fn step_one(&mut self, x: f64) -> f64;
    fn save(&mut self) -> Option<SavedState>;
    fn restore(&mut self, s: &SavedState) -> bool;
}

impl<T: Operator + ?Sized> Resumable for Box<T> {
    fn step_one(&mut self, x: f64) -> f64 {
        self.step(x)
    }
    fn save(&mut self) -> Option<SavedState> {
        self.save_state()
    }
    fn restore(&mut self, s: &SavedState) -> bool {
        self.restore_state(s)
    }
}

/// A compensator as [`Resumable`] (its output `u`).
pub(crate) struct CompensatorSteps(pub Box<dyn ActuatorCompensator>);

impl Resumable for CompensatorSteps {
    fn step_one(&mut self, x: f64) -> f64 {
        self.0.compensate(x).u
    }
    fn save(&mut self) -> Option<SavedState> {
        self.0.save_state()
    }
    fn restore(&mut self, s: &SavedState) -> bool {
        self.0.restore_state(s)
    }
}

/// Split and resume of a fixed implementation: its whole run on `signal`
/// against a second instance that runs the first half, saves, runs a
/// disturbance (the second half reversed and negated), restores and runs
/// the second half. The state semantics of the candidate alone: the two
/// runs must agree within `tolerance` (0 for a deterministic candidate,
/// which restores bit for bit).
pub(crate) fn resume_from_saved<R: Resumable>(
    signal: &[f64],
    build: impl Fn() -> Result<R, ModelError>,
    tolerance: f64,
) -> Outcome {
    if signal.len() < 2 {
        return Outcome::Skipped;
    }
    let k = signal.len() / 2;
    let (mut whole, mut split) = match (build(), build()) {
        (Ok(a), Ok(b)) => (a, b),
        (Err(e), _) | (_, Err(e)) => return refused(e),
    };
    let expected: Vec<f64> = signal.iter().map(|&x| whole.step_one(x)).collect();
    for &x in &signal[..k] {
        split.step_one(x);
    }
    let Some(saved) = split.save() else {
        return Outcome::Unsupported("the candidate cannot save and restore its state".into());
    };
    for &x in signal[k..].iter().rev() {
        split.step_one(-x);
    }
    if !split.restore(&saved) {
        return Outcome::Unsupported("the candidate could not restore a state it saved".into());
    }
    let found: Vec<f64> = signal[k..].iter().map(|&x| split.step_one(x)).collect();
    compare(
        signal,
        &expected[k..],
        &found,
        tolerance,
        "second half after save, a disturbance and restore, against the whole run",
    )
}
