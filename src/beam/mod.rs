//! The MFC-patch-driven cantilever (26)–(27): parameters and the beam file
//! ([`parameters`]), the paper's Ritz discretization ([`ritz`]), the converged
//! finite-element model ([`fe`]), the modal form both end in ([`modal`]),
//! exact zero-order-hold simulation and the Hammerstein plant
//! ([`simulation`]), the state-space matrices in nalgebra ([`state_space`]),
//! and the step-response fit of section 4.2
//! ([`step_response_fit`]).

//! Without the `beam` feature (the FMU library's build) only the parameters
//! and the discretized beam's step remain: the beam is then discretized
//! beforehand and read from its coefficients.

#[cfg(feature = "beam")]
pub mod fe;
#[cfg(feature = "beam")]
pub mod modal;
pub mod parameters;
#[cfg(feature = "beam")]
pub mod ritz;
pub mod simulation;
#[cfg(feature = "beam")]
pub mod state_space;
#[cfg(feature = "beam")]
pub mod step_response_fit;

pub use parameters::*;
