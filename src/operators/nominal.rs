//! The nominal hysteresis and creep model (`docs/MATHEMATICS.md` §8; reconstructed: the
//! paper does not print its identified weights).

use crate::operators::creep::CreepOperator;
use crate::operators::hysteresis::HysteresisOperator;
use crate::operators::model::{HysteresisCreepModel, ModelFile};

/// Sample time of the paper's real-time board: 0.2 ms.
pub const SAMPLE_TIME: f64 = 2e-4;

/// Hysteresis weights (reconstructed).
pub const HYSTERESIS_WEIGHTS: [f64; 12] = [
    0.45, 0.0963, 0.0773, 0.062, 0.0498, 0.0399, 0.0321, 0.0257, 0.0206, 0.0166, 0.0133, -0.01,
];

/// Creep weights (reconstructed).
pub const CREEP_WEIGHTS: [f64; 12] = [
    0.08, 0.006, 0.005, 0.004, 0.003, 0.002, 0.002, 0.001, 0.001, 0.001, 0.001, 0.001,
];

/// Creep eigenvalues (s⁻¹), (24) with `m = 5`.
pub const CREEP_EIGENVALUES: [f64; 5] = [500.0, 50.0, 5.0, 0.5, 0.05];

/// `r_i = (i · 1000) / 12`, `i = 0..11`: (23) with `r_max = 1000` V.
pub fn nominal_thresholds() -> Vec<f64> {
    (0..12).map(|i| (i as f64 * 1000.0) / 12.0).collect()
}

/// The nominal model `W = H + C` in the virgin state.
pub fn nominal_model() -> HysteresisCreepModel {
    let h = HysteresisOperator::new(nominal_thresholds(), HYSTERESIS_WEIGHTS.to_vec())
        .expect("nominal hysteresis satisfies (11), (12)");
    let c = CreepOperator::new(
        nominal_thresholds(),
        CREEP_WEIGHTS.to_vec(),
        CREEP_EIGENVALUES.to_vec(),
        SAMPLE_TIME,
    )
    .expect("nominal creep satisfies (17), (18)");
    HysteresisCreepModel::new(SAMPLE_TIME, h, Some(c)).expect("consistent sample time")
}

/// The nominal model as a model file, virgin (no `state` entries).
pub fn nominal_model_file() -> ModelFile {
    nominal_model().to_file().without_state()
}
