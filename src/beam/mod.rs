//! The MFC-patch-driven cantilever (26)–(27): parameters and the beam file
//! ([`parameters`]), the paper's Ritz discretization ([`ritz`]), the converged
//! finite-element model ([`fe`]), the modal form both end in ([`modal`]),
//! exact zero-order-hold simulation and the Hammerstein plant
//! ([`simulation`]), the state-space matrices in nalgebra ([`state_space`]),
//! and the step-response fit of section 4.2
//! ([`step_response_fit`]).

pub mod fe;
pub mod modal;
pub mod parameters;
pub mod ritz;
pub mod simulation;
pub mod state_space;
pub mod step_response_fit;

pub use parameters::*;
