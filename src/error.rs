//! Typed errors of the library.
//!
//! Every error names the field (for example `hysteresis.weights`) and the index
//! it is about, so that a command-line front end can turn it into one clear line.

use thiserror::Error;

use crate::realtime::ParameterError;

/// What is wrong with the parameters or the state of an operator, model or
/// compensator.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum ModelError {
    /// A list that must hold at least one value is empty.
    #[error("{field}: must not be empty")]
    Empty { field: String },
    /// A value is NaN or infinite.
    #[error("{field}[{index}]: {value} is not a finite number")]
    NonFinite {
        field: String,
        index: usize,
        value: f64,
    },
    /// The first threshold must be exactly 0, see (12) and (18).
    #[error("{field}[0]: the first threshold must be 0, found {value}")]
    FirstThresholdNotZero { field: String, value: f64 },
    /// Thresholds must increase strictly, see (12) and (18).
    #[error("{field}[{index}]: thresholds must increase strictly, but {value} follows {previous}")]
    ThresholdsNotIncreasing {
        field: String,
        index: usize,
        previous: f64,
        value: f64,
    },
    /// A single threshold (play operator) must be finite and non-negative.
    #[error("{field}: a threshold must be finite and >= 0, found {value}")]
    InvalidThreshold { field: String, value: f64 },
    /// Two lists that must have the same length do not.
    #[error("{field}: expected {expected} values, found {found}")]
    LengthMismatch {
        field: String,
        expected: usize,
        found: usize,
    },
    /// A hysteresis weight partial sum `s_j = w_0 + … + w_j` is not positive, which breaks (11).
    #[error("{field}: partial sum w[0] + ... + w[{index}] = {sum} must be > 0 (condition (11))")]
    PartialSumNotPositive {
        field: String,
        index: usize,
        sum: f64,
    },
    /// A creep weight partial sum is negative, which breaks (17).
    #[error("{field}: partial sum w[0] + ... + w[{index}] = {sum} must be >= 0 (condition (17))")]
    PartialSumNegative {
        field: String,
        index: usize,
        sum: f64,
    },
    /// A creep eigenvalue must be finite and positive.
    #[error("{field}[{index}]: a creep eigenvalue must be > 0, found {value}")]
    NonPositiveEigenvalue {
        field: String,
        index: usize,
        value: f64,
    },
    /// The sample time must be finite and positive.
    #[error("sample_time: must be a finite number > 0, found {value}")]
    NonPositiveSampleTime { value: f64 },
    /// A play state that no input can reach from the virgin state.
    #[error("{field}[{index}]: inadmissible state, |x[{index}] - x[{prev}]| = {gap} exceeds r[{index}] - r[{prev}] = {allowed}", prev = index - 1)]
    InadmissibleState {
        field: String,
        index: usize,
        gap: f64,
        allowed: f64,
    },
    /// Saturation limits must satisfy `lower < upper` and not be NaN.
    #[error("limits: the lower limit {lower} must be below the upper limit {upper}")]
    InvalidLimits { lower: f64, upper: f64 },
    /// Two operators that must share a sample time do not.
    #[error("{field}: {reason}")]
    Inconsistent { field: String, reason: String },
    /// More values than a fixed-capacity operator holds.
    #[error("{field}: {found} values exceed the capacity of {capacity} fixed at compile time")]
    ExceedsCapacity {
        field: String,
        capacity: usize,
        found: usize,
    },
}

impl From<ParameterError> for ModelError {
    fn from(e: ParameterError) -> Self {
        e.named("")
    }
}

impl ParameterError {
    /// The same error as a [`ModelError`], about `field` (or, if `field` is
    /// empty, the field it names itself).
    pub fn named(self, field: &str) -> ModelError {
        use ParameterError as P;
        let name = |own: &'static str| -> String {
            if field.is_empty() { own } else { field }.to_string()
        };
        match self {
            P::Empty { field } => ModelError::Empty { field: name(field) },
            P::NonFinite {
                field,
                index,
                value,
            } => ModelError::NonFinite {
                field: name(field),
                index,
                value,
            },
            P::FirstThresholdNotZero { field, value } => ModelError::FirstThresholdNotZero {
                field: name(field),
                value,
            },
            P::ThresholdsNotIncreasing {
                field,
                index,
                previous,
                value,
            } => ModelError::ThresholdsNotIncreasing {
                field: name(field),
                index,
                previous,
                value,
            },
            P::LengthMismatch {
                field,
                expected,
                found,
            } => ModelError::LengthMismatch {
                field: name(field),
                expected,
                found,
            },
            P::PartialSumNotPositive { field, index, sum } => ModelError::PartialSumNotPositive {
                field: name(field),
                index,
                sum,
            },
            P::PartialSumNegative { field, index, sum } => ModelError::PartialSumNegative {
                field: name(field),
                index,
                sum,
            },
            P::NonPositiveEigenvalue {
                field,
                index,
                value,
            } => ModelError::NonPositiveEigenvalue {
                field: name(field),
                index,
                value,
            },
            P::NonPositiveSampleTime { value } => ModelError::NonPositiveSampleTime { value },
            P::InadmissibleState {
                field,
                index,
                gap,
                allowed,
            } => ModelError::InadmissibleState {
                field: name(field),
                index,
                gap,
                allowed,
            },
            P::InvalidLimits { lower, upper } => ModelError::InvalidLimits { lower, upper },
            P::ChannelMismatch { .. } => ModelError::Inconsistent {
                field: name("bank"),
                reason: self.to_string(),
            },
            P::ExceedsCapacity {
                field,
                capacity,
                found,
            } => ModelError::ExceedsCapacity {
                field: name(field),
                capacity,
                found,
            },
        }
    }
}

/// A balanced voltage that the asymmetric supply (1) cannot produce.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum SupplyError {
    /// The supply range must satisfy `u_min < u_max`.
    #[error("supply: u_min = {u_min} must be below u_max = {u_max}")]
    InvalidRange { u_min: f64, u_max: f64 },
    /// `u` lies outside the balanced range `[-(u_max - u_min)/2, (u_max - u_min)/2]`.
    #[error(
        "balanced voltage {u} V lies outside [{lower}, {upper}] V that the supply can produce"
    )]
    OutOfRange { u: f64, lower: f64, upper: f64 },
}

/// Two signals that must have the same length do not.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("{what}: expected {expected} samples, found {found}")]
pub struct DimensionError {
    pub what: &'static str,
    pub expected: usize,
    pub found: usize,
}
