//! Typed errors of the library.
//!
//! Every error names the field (for example `hysteresis.weights`) and the index
//! it is about, so that a command-line front end can turn it into one clear line.

use thiserror::Error;

use crate::realtime::ParameterError;

/// What is wrong with the parameters, the state or the file of an operator,
/// model or compensator.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum ModelError {
    /// A parameter or state breaks a condition the real-time core checks.
    /// `field`, when set, names the place in a file or a heap operator
    /// (`creep.state[3]`) instead of the static field the check knows.
    #[error("{}", .error.display_as(.field.as_deref().unwrap_or(.error.field())))]
    Parameter {
        field: Option<String>,
        error: ParameterError,
    },
    /// Parts that must agree do not (a state and its model, two sample
    /// times).
    #[error("{field}: {reason}")]
    Inconsistent { field: String, reason: String },
    /// The implementation does not implement this part of the model (an
    /// implementation of `H` alone given a model with creep, say): a
    /// conformance check counts such cases as skipped, not failed.
    #[error("{part}: not implemented here")]
    Unsupported { part: String },
}

impl ModelError {
    /// The parameter error behind this one, if it is one.
    pub fn parameter(&self) -> Option<&ParameterError> {
        match self {
            ModelError::Parameter { error, .. } => Some(error),
            ModelError::Inconsistent { .. } | ModelError::Unsupported { .. } => None,
        }
    }
}

impl From<ParameterError> for ModelError {
    fn from(error: ParameterError) -> Self {
        ModelError::Parameter { field: None, error }
    }
}

impl ParameterError {
    /// The message without its field, for an error type of another layer
    /// that names the field itself (a setting, an option).
    pub fn reason(&self) -> String {
        let text = self.display_as("").to_string();
        text.strip_prefix(": ").unwrap_or(&text).to_string()
    }

    /// The same error about `field` (a name built at run time).
    pub fn named(self, field: &str) -> ModelError {
        ModelError::Parameter {
            field: Some(field.to_string()),
            error: self,
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
