//! The verification of mfcbeam, one module per concept (see
//! `verification/README.md`): the operators' properties, the inverse, the
//! identification, the beam, feedforward and loop, the golden traces and
//! the paper's figures, the conformance suite, the command line and the
//! FMUs. `cargo test --test verification MODULE::` runs one concept.

mod common;

mod bad_samples;
mod beam;
mod cli;
mod conformance;
mod control;
mod creep_properties;
mod delay;
mod dynamics;
mod explain;
mod feedforward;
mod fixed;
mod golden;
mod hysteresis_properties;
mod identification;
mod initial_state;
mod inverse_properties;
mod paper;
mod rate_dependence;
mod realtime;
mod superposition;

// the command line's own commands (conform, fmu, the lab records)
#[cfg(feature = "cli")]
mod conform;
#[cfg(feature = "cli")]
mod fmi;
#[cfg(feature = "cli")]
mod isolation;
#[cfg(feature = "cli")]
mod lab_data;
