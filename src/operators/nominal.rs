//! The nominal hysteresis and creep model (`docs/MATHEMATICS.md` §8; reconstructed: the
//! paper does not print its identified weights).

use crate::operators::creep::CreepOperator;
use crate::operators::hysteresis::HysteresisOperator;
use crate::operators::model::{HysteresisCreepModel, ModelFile};

pub use crate::realtime::nominal::{
    CREEP_EIGENVALUES, CREEP_WEIGHTS, HYSTERESIS_WEIGHTS, SAMPLE_TIME,
};

/// `r_i = (i · 1000) / 12`, `i = 0..11`: (23) with `r_max = 1000` V.
pub fn nominal_thresholds() -> Vec<f64> {
    crate::realtime::nominal::THRESHOLDS.to_vec()
}

/// The nominal model `W = H + C` in the virgin state.
pub fn nominal_model() -> HysteresisCreepModel {
    let h = HysteresisOperator::new(nominal_thresholds(), HYSTERESIS_WEIGHTS)
        .expect("nominal hysteresis satisfies (11), (12)");
    let c = CreepOperator::new(
        nominal_thresholds(),
        CREEP_WEIGHTS,
        CREEP_EIGENVALUES,
        SAMPLE_TIME,
    )
    .expect("nominal creep satisfies (17), (18)");
    HysteresisCreepModel::from_parts(SAMPLE_TIME, h, Some(c)).expect("consistent sample time")
}

/// The nominal model as a model file, virgin (no `state` entries).
pub fn nominal_model_file() -> ModelFile {
    nominal_model().to_file().without_state()
}
