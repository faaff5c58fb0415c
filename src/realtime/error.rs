//! Errors of the real-time core: `Copy`, no allocation, field names static.
//!
//! This is the one error type for a bad parameter or state, whichever layer
//! finds it. The `std` layer's [`crate::error::ModelError`] wraps it with a
//! field name built at run time (`creep.state[3]`) instead of restating it,
//! so every message is written once, here.

use core::fmt;

/// What is wrong with parameters or a state handed to an operator.
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum ParameterError {
    /// A list that must hold at least one value is empty.
    Empty { field: &'static str },
    /// A value is NaN or infinite.
    NonFinite {
        field: &'static str,
        index: usize,
        value: f64,
    },
    /// The first threshold must be exactly 0, see (12) and (18).
    FirstThresholdNotZero { field: &'static str, value: f64 },
    /// Thresholds must increase strictly, see (12) and (18).
    ThresholdsNotIncreasing {
        field: &'static str,
        index: usize,
        previous: f64,
        value: f64,
    },
    /// A single threshold (one play or creep operator) must be finite and
    /// non-negative.
    InvalidThreshold { field: &'static str, value: f64 },
    /// Two lists that must have the same length do not.
    LengthMismatch {
        field: &'static str,
        expected: usize,
        found: usize,
    },
    /// A hysteresis partial sum is not positive: (11) broken.
    PartialSumNotPositive {
        field: &'static str,
        index: usize,
        sum: f64,
    },
    /// A creep partial sum is negative: (17) broken.
    PartialSumNegative {
        field: &'static str,
        index: usize,
        sum: f64,
    },
    /// The thresholds of a superposition operator must include 0.
    NoZeroThreshold { field: &'static str },
    /// A slope of a superposition operator is not positive: the sum of its
    /// weights from the zero threshold out to `index` (on that side).
    SlopeNotPositive {
        field: &'static str,
        index: usize,
        sum: f64,
    },
    /// A creep eigenvalue must be finite and positive.
    NonPositiveEigenvalue {
        field: &'static str,
        index: usize,
        value: f64,
    },
    /// The sample time must be finite and positive.
    NonPositiveSampleTime { value: f64 },
    /// A play state that no input reaches from the virgin state.
    InadmissibleState {
        field: &'static str,
        index: usize,
        gap: f64,
        allowed: f64,
    },
    /// Saturation limits must satisfy `lower < upper` and not be NaN.
    InvalidLimits { lower: f64, upper: f64 },
    /// A channel of a compensator bank whose model differs in shape from the
    /// first channel's.
    ChannelMismatch { field: &'static str, channel: usize },
    /// More values than the compile-time capacity holds.
    ExceedsCapacity {
        field: &'static str,
        capacity: usize,
        found: usize,
    },
    /// A single value that must be finite.
    NonFiniteValue { field: &'static str, value: f64 },
    /// A duration (s) that must be finite and positive.
    InvalidDuration { field: &'static str, value: f64 },
    /// A count above its documented limit ([`crate::realtime::limits`]): refused
    /// before anything is allocated from it.
    ExceedsLimit {
        field: &'static str,
        limit: usize,
        found: usize,
    },
    /// A weight that must not be negative.
    NegativeWeight {
        field: &'static str,
        index: usize,
        value: f64,
    },
    /// A value outside the half-open interval `[lower, upper)`.
    OutOfHalfOpenRange {
        field: &'static str,
        value: f64,
        lower: f64,
        upper: f64,
    },
    /// A parameter or state that this operator does not take (the reason
    /// says why).
    Unsupported {
        field: &'static str,
        reason: &'static str,
    },
    /// A value outside the open interval `(lower, upper)`.
    OutOfRange {
        field: &'static str,
        value: f64,
        lower: f64,
        upper: f64,
    },
}

impl ParameterError {
    /// The field the check named (empty for errors about no field).
    pub fn field(&self) -> &'static str {
        use ParameterError as P;
        match *self {
            P::Empty { field }
            | P::NonFinite { field, .. }
            | P::FirstThresholdNotZero { field, .. }
            | P::ThresholdsNotIncreasing { field, .. }
            | P::InvalidThreshold { field, .. }
            | P::LengthMismatch { field, .. }
            | P::PartialSumNotPositive { field, .. }
            | P::PartialSumNegative { field, .. }
            | P::NoZeroThreshold { field }
            | P::SlopeNotPositive { field, .. }
            | P::NonPositiveEigenvalue { field, .. }
            | P::InadmissibleState { field, .. }
            | P::ChannelMismatch { field, .. }
            | P::ExceedsCapacity { field, .. }
            | P::ExceedsLimit { field, .. }
            | P::InvalidDuration { field, .. }
            | P::NonFiniteValue { field, .. }
            | P::NegativeWeight { field, .. }
            | P::OutOfHalfOpenRange { field, .. }
            | P::OutOfRange { field, .. }
            | P::Unsupported { field, .. } => field,
            P::NonPositiveSampleTime { .. } => "sample_time",
            P::InvalidLimits { .. } => "limits",
        }
    }

    /// The message, about `field` instead of the field the check named
    /// (errors that name a fixed field, like `sample_time`, keep it).
    pub fn display_as<'a>(&'a self, field: &'a str) -> impl fmt::Display + 'a {
        Message { error: self, field }
    }
}

struct Message<'a> {
    error: &'a ParameterError,
    field: &'a str,
}

impl fmt::Display for Message<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use ParameterError as P;
        let field = self.field;
        match *self.error {
            P::Empty { .. } => write!(f, "{field}: must not be empty"),
            P::NonFinite { index, value, .. } => {
                write!(f, "{field}[{index}]: {value} is not a finite number")
            }
            P::FirstThresholdNotZero { value, .. } => {
                write!(f, "{field}[0]: the first threshold must be 0, found {value}")
            }
            P::ThresholdsNotIncreasing {
                index,
                previous,
                value,
                ..
            } => write!(
                f,
                "{field}[{index}]: thresholds must increase strictly, but {value} follows {previous}"
            ),
            P::InvalidThreshold { value, .. } => write!(
                f,
                "{field}: a threshold must be finite and >= 0, found {value}"
            ),
            P::LengthMismatch {
                expected, found, ..
            } => write!(f, "{field}: expected {expected} values, found {found}"),
            P::PartialSumNotPositive { index, sum, .. } => write!(
                f,
                "{field}: partial sum w[0] + ... + w[{index}] = {sum} must be > 0 (condition (11))"
            ),
            P::PartialSumNegative { index, sum, .. } => write!(
                f,
                "{field}: partial sum w[0] + ... + w[{index}] = {sum} must be >= 0 (condition (17))"
            ),
            P::NoZeroThreshold { .. } => {
                write!(f, "{field}: one threshold must be exactly 0")
            }
            P::SlopeNotPositive { index, sum, .. } => write!(
                f,
                "{field}: the weights summed from the zero threshold out to [{index}] give the slope {sum}, which must be > 0 (S must increase)"
            ),
            P::NonPositiveEigenvalue { index, value, .. } => write!(
                f,
                "{field}[{index}]: a creep eigenvalue must be > 0, found {value}"
            ),
            P::NonPositiveSampleTime { value } => {
                write!(f, "{field}: must be a finite number > 0, found {value}")
            }
            P::NonFiniteValue { value, .. } => {
                write!(f, "{field}: {value} is not a finite number")
            }
            P::InadmissibleState {
                index, gap, allowed, ..
            } => {
                let prev = index.saturating_sub(1);
                write!(
                    f,
                    "{field}[{index}]: inadmissible state, |x[{index}] - x[{prev}]| = {gap} exceeds r[{index}] - r[{prev}] = {allowed}"
                )
            }
            P::InvalidLimits { lower, upper } => write!(
                f,
                "limits: the lower limit {lower} must be below the upper limit {upper}"
            ),
            P::ChannelMismatch { channel, .. } => write!(
                f,
                "models[{channel}].{field}: differs from models[0] (every channel of a bank needs the same orders and sample time)"
            ),
            P::ExceedsCapacity {
                capacity, found, ..
            } => write!(
                f,
                "{field}: {found} values exceed the capacity of {capacity} fixed at compile time"
            ),
            P::InvalidDuration { value, .. } => {
                write!(f, "{field}: must be a finite number > 0 (s), found {value}")
            }
            P::ExceedsLimit { limit, found, .. } => write!(
                f,
                "{field}: {found} exceeds the limit of {limit} (docs/FILES.md, \"Limits\")"
            ),
            P::NegativeWeight { index, value, .. } => {
                write!(f, "{field}[{index}] = {value}: must not be negative")
            }
            P::OutOfHalfOpenRange {
                value,
                lower,
                upper,
                ..
            } => write!(
                f,
                "{field}: {value} must be at least {lower} and below {upper}"
            ),
            P::Unsupported { reason, .. } => write!(f, "{field}: {reason}"),
            P::OutOfRange {
                value,
                lower,
                upper,
                ..
            } => write!(
                f,
                "{field}: {value} must lie strictly between {lower} and {upper}"
            ),
        }
    }
}

impl fmt::Display for ParameterError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.display_as(self.field()).fmt(f)
    }
}

impl core::error::Error for ParameterError {}
