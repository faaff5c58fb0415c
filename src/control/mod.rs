//! Two degrees of freedom: feedback around the compensated flatness-based
//! feedforward, and a closed-loop benchmark that scores any controller
//! (`docs/MATHEMATICS.md` §11; the paper's Section 5 outlook).
//!
//! The loop ([`closed_loop`]), sampled at `T_s`: at step `k` the controller
//! sees the reference `y_d,k` and the measurement `m_k = y_k + n_k` (the tip
//! deflection *before* `u_k` acts, plus sensor noise) and returns a
//! correction `Δ_k` of the effective voltage. The compensator of the
//! controller's model turns `ς_k = u_d,k + Δ_k` into the balanced voltage
//! `u_k = W⁻¹[ς_k]`, clipped to the supply limits (1); the true actuator
//! produces `w_k = W[u_k]`; the beam advances with `w_k` and the disturbance
//! force `F_k` (zero-order hold), so `u_k` first shows in `y_{k+1}`. A
//! controller that returns zero is the open loop exactly.
//!
//! * [`controller`]: the [`Controller`] trait and the do-nothing controller;
//! * [`pid`]: a filtered PID on the tip, gains by pole placement on the first
//!   mode;
//! * [`state_feedback`]: LQ state feedback with a Kalman observer of the
//!   modal state and of an input disturbance, on the modes below a tenth of
//!   the sample rate; its Riccati equations by [`riccati`];
//! * [`file`](mod@file): a built-in design with its gains as a file (the controller
//!   FMU's);
//! * [`process`]: any program as a controller, one line per sample over
//!   stdin/stdout;
//! * [`scores`]: what a run is scored by;
//! * [`benchmark`]: the scenarios (disturbances, model error, noise) every
//!   controller runs.

// Without the `control` feature (the FMU library's build) only the
// controllers' steps and their file remain: their designs are computed
// beforehand.
#[cfg(feature = "control")]
pub mod benchmark;
#[cfg(feature = "control")]
pub mod closed_loop;
pub mod controller;
pub mod file;
pub mod pid;
#[cfg(feature = "control")]
pub mod process;
#[cfg(feature = "control")]
pub mod riccati;
#[cfg(feature = "control")]
pub mod scores;
pub mod state_feedback;

#[cfg(feature = "control")]
pub use benchmark::*;
#[cfg(feature = "control")]
pub use closed_loop::*;
pub use controller::*;
#[cfg(feature = "control")]
pub use scores::*;

/// What can go wrong designing or running a loop.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ControlError {
    /// A setting out of its range.
    #[error("{field}: {reason}")]
    Invalid { field: &'static str, reason: String },
    /// A design that cannot be computed.
    #[error("design: {0}")]
    Design(String),
    /// The controller failed (a program that died, hung or wrote garbage).
    #[error("controller {name}: {reason}")]
    Controller { name: String, reason: String },
    #[error(transparent)]
    Beam(#[from] crate::beam::BeamError),
    #[cfg(feature = "control")]
    #[error(transparent)]
    Feedforward(#[from] crate::feedforward::FeedforwardError),
    #[error(transparent)]
    Model(#[from] crate::error::ModelError),
}

impl From<crate::realtime::ParameterError> for ControlError {
    fn from(e: crate::realtime::ParameterError) -> Self {
        Self::Model(e.into())
    }
}
