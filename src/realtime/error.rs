//! Errors of the real-time core: `Copy`, no allocation, field names static.
//! With `std`, each converts into the corresponding [`crate::error::ModelError`]
//! with the same message.

use thiserror::Error;

/// What is wrong with parameters or a state handed to the real-time core.
#[derive(Debug, Clone, Copy, PartialEq, Error)]
#[non_exhaustive]
pub enum ParameterError {
    #[error("{field}: must not be empty")]
    Empty { field: &'static str },
    #[error("{field}[{index}]: {value} is not a finite number")]
    NonFinite {
        field: &'static str,
        index: usize,
        value: f64,
    },
    #[error("{field}[0]: the first threshold must be 0, found {value}")]
    FirstThresholdNotZero { field: &'static str, value: f64 },
    #[error("{field}[{index}]: thresholds must increase strictly, but {value} follows {previous}")]
    ThresholdsNotIncreasing {
        field: &'static str,
        index: usize,
        previous: f64,
        value: f64,
    },
    #[error("{field}: expected {expected} values, found {found}")]
    LengthMismatch {
        field: &'static str,
        expected: usize,
        found: usize,
    },
    /// (11) broken.
    #[error("{field}: partial sum w[0] + ... + w[{index}] = {sum} must be > 0 (condition (11))")]
    PartialSumNotPositive {
        field: &'static str,
        index: usize,
        sum: f64,
    },
    /// (17) broken.
    #[error("{field}: partial sum w[0] + ... + w[{index}] = {sum} must be >= 0 (condition (17))")]
    PartialSumNegative {
        field: &'static str,
        index: usize,
        sum: f64,
    },
    #[error("{field}[{index}]: a creep eigenvalue must be > 0, found {value}")]
    NonPositiveEigenvalue {
        field: &'static str,
        index: usize,
        value: f64,
    },
    #[error("sample_time: must be a finite number > 0, found {value}")]
    NonPositiveSampleTime { value: f64 },
    /// A play state that no input reaches from the virgin state.
    #[error("{field}[{index}]: inadmissible state, |x[{index}] - x[{prev}]| = {gap} exceeds r[{index}] - r[{prev}] = {allowed}", prev = index - 1)]
    InadmissibleState {
        field: &'static str,
        index: usize,
        gap: f64,
        allowed: f64,
    },
    #[error("limits: the lower limit {lower} must be below the upper limit {upper}")]
    InvalidLimits { lower: f64, upper: f64 },
    /// A channel of a compensator bank whose model differs in shape from the
    /// first channel's.
    #[error("models[{channel}].{field}: differs from models[0] (every channel of a bank needs the same orders and sample time)")]
    ChannelMismatch { field: &'static str, channel: usize },
    /// More values than the compile-time capacity holds.
    #[error("{field}: {found} values exceed the capacity of {capacity} fixed at compile time")]
    ExceedsCapacity {
        field: &'static str,
        capacity: usize,
        found: usize,
    },
}
