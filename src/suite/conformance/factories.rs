//! Factories of the project's own implementations for the checks: the fast
//! operators, the real-time core in `f32`/`f64`, the naive references and
//! the numerical (bisection) compensator.

use crate::error::ModelError;
use crate::operators::heap::Heap;
use crate::operators::hysteresis::HysteresisOperator;
use crate::operators::model::{HysteresisCreepModel, ModelFile};
use crate::operators::traits::{ActuatorCompensator, ActuatorModel, InverseHysteresis};
use crate::realtime::{Compensator, CompensatorSettings, Hysteresis, Inline, Model, Real};
use crate::suite::reference::{
    naive_inverse_hysteresis, BisectionCompensator, NaiveCompensator, NaiveModel,
};

/// `ε₃₂/ε₆₄ = 2²⁹`: the [`ConformanceSettings::tolerance_scale`](super::ConformanceSettings::tolerance_scale) of an `f32`
/// implementation. Every tolerance is a sum of terms linear in `ε` (first-order
/// rounding analysis), so moving to binary32 scales each by this ratio; the
/// `f64` parameters rounded once to `f32` are relative perturbations of
/// `ε₃₂/2`, inside the same terms.
pub const F32_TOLERANCE_SCALE: f64 = (f32::EPSILON as f64) / f64::EPSILON;

/// Factory of the core's `W` in `T`, inline with capacity `N` plays and `K`
/// elementary creep operators.
pub fn inline_model<T: Real, const N: usize, const K: usize>(
    file: &ModelFile,
) -> Result<Box<dyn ActuatorModel>, ModelError> {
    Ok(Box::new(Model::<T, Inline<N, K>>::from_file(file)?))
}

/// Factory of the core's compensator in `T`, inline.
pub fn inline_compensator<T: Real, const N: usize, const K: usize>(
    file: &ModelFile,
    settings: CompensatorSettings,
) -> Result<Box<dyn ActuatorCompensator>, ModelError> {
    Ok(Box::new(Compensator::<T, Inline<N, K>>::from_file(
        file, settings,
    )?))
}

/// Factory of the core's `H⁻¹` in `T`, inline with capacity `N` plays.
pub fn inline_inverse_hysteresis<T: Real, const N: usize>(
    file: &ModelFile,
) -> Result<Box<dyn InverseHysteresis>, ModelError> {
    HysteresisCreepModel::from_file(file)?;
    Ok(Box::new(Hysteresis::<T, Inline<N, 0>>::inverse_from_file(
        file,
    )?))
}

/// Factory of the project's model `W` (`f64`, heap).
pub fn heap_model(file: &ModelFile) -> Result<Box<dyn ActuatorModel>, ModelError> {
    Ok(Box::new(HysteresisCreepModel::from_file(file)?))
}

/// Factory of the project's compensator (21) (`f64`, heap).
pub fn heap_compensator(
    file: &ModelFile,
    settings: CompensatorSettings,
) -> Result<Box<dyn ActuatorCompensator>, ModelError> {
    Ok(Box::new(Compensator::<f64, Heap>::from_file(
        file, settings,
    )?))
}

/// Factory of the project's inverse hysteresis operator (22) (`f64`, heap).
pub fn heap_inverse_hysteresis(file: &ModelFile) -> Result<Box<dyn InverseHysteresis>, ModelError> {
    HysteresisCreepModel::from_file(file)?;
    Ok(Box::new(HysteresisOperator::inverse_from_file(file)?))
}

/// Factory of the naive reference model.
pub fn reference_model(file: &ModelFile) -> Result<Box<dyn ActuatorModel>, ModelError> {
    Ok(Box::new(NaiveModel::from_file(file)?))
}

/// Factory of the naive reference compensator.
pub fn reference_compensator(
    file: &ModelFile,
    settings: CompensatorSettings,
) -> Result<Box<dyn ActuatorCompensator>, ModelError> {
    Ok(Box::new(NaiveCompensator::from_file(file, settings)?))
}

/// Factory of the naive reference inverse hysteresis operator.
pub fn reference_inverse_hysteresis(
    file: &ModelFile,
) -> Result<Box<dyn InverseHysteresis>, ModelError> {
    Ok(Box::new(naive_inverse_hysteresis(file)?))
}

/// Factory of the numerical (bisection) compensator.
pub fn bisection_compensator(
    file: &ModelFile,
    settings: CompensatorSettings,
) -> Result<Box<dyn ActuatorCompensator>, ModelError> {
    Ok(Box::new(BisectionCompensator::from_file(file, settings)?))
}
