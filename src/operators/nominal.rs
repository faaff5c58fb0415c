//! The nominal hysteresis and creep model (`docs/MATHEMATICS.md` §8; reconstructed: the
//! paper does not print its identified weights).

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
    let parameters = crate::realtime::nominal::PARAMETERS
        .validate()
        .expect("the nominal model satisfies (11), (12), (17), (18)");
    HysteresisCreepModel::new(&parameters).expect("heap storage holds any size")
}

/// The nominal model as a model file, virgin (no `state` entries).
pub fn nominal_model_file() -> ModelFile {
    nominal_model().to_file().without_state()
}
