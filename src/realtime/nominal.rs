//! The nominal model as compile-time constants, so firmware can use it:
//! `T_s = 0.2 ms`, 12 plays at `r_i = 1000 i / 12` V ((23) with
//! `r_max = 1000` V), log(t)-creep with five eigenvalues spread over decades
//! (24). The weights are reconstructed (`docs/MATHEMATICS.md` §8): the paper
//! does not print its identified ones.

use crate::realtime::parameters::{CreepParameters, HysteresisParameters, ModelParameters};
use crate::realtime::storage::Inline;

/// Inline storage for exactly the paper's orders: 12 plays, 12 × 5
/// elementary creep operators, no superposition operator (the paper's
/// actuator is symmetric) and no dead time (`Compensator<f32, nominal::Capacity>`).
pub type Capacity = Inline<PLAYS, CREEP, 0, 0>;

/// Plays of the paper's model (`n = 11`).
pub const PLAYS: usize = 12;
/// Elementary creep operators of the paper's model (12 thresholds × 5
/// eigenvalues).
pub const CREEP: usize = 60;

pub const SAMPLE_TIME: f64 = 2e-4;

/// `r_i = 1000 i / 12` V, `i = 0..12`, for hysteresis and creep alike.
pub const THRESHOLDS: [f64; 12] = {
    let mut r = [0.0; 12];
    let mut i = 0;
    while i < 12 {
        r[i] = (i as f64 * 1000.0) / 12.0;
        i += 1;
    }
    r
};

pub const HYSTERESIS_WEIGHTS: [f64; 12] = [
    0.45, 0.0963, 0.0773, 0.062, 0.0498, 0.0399, 0.0321, 0.0257, 0.0206, 0.0166, 0.0133, -0.01,
];

pub const CREEP_WEIGHTS: [f64; 12] = [
    0.08, 0.006, 0.005, 0.004, 0.003, 0.002, 0.002, 0.001, 0.001, 0.001, 0.001, 0.001,
];

/// (24) at `T_s = 0.2 ms`: `a_j = 1 / (10^j T_s)`, s⁻¹.
pub const CREEP_EIGENVALUES: [f64; 5] = [500.0, 50.0, 5.0, 0.5, 0.05];

/// The nominal model's parameters (no offset).
pub const PARAMETERS: ModelParameters<'static> = ModelParameters {
    sample_time: SAMPLE_TIME,
    hysteresis: HysteresisParameters {
        thresholds: &THRESHOLDS,
        weights: &HYSTERESIS_WEIGHTS,
    },
    creep: Some(CreepParameters {
        thresholds: &THRESHOLDS,
        weights: &CREEP_WEIGHTS,
        eigenvalues: &CREEP_EIGENVALUES,
    }),
    superposition: None,
    dynamics: None,
    delay: 0,
    offset: 0.0,
    rate_gain: 0.0,
};
