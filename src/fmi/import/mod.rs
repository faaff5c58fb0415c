//! Load an FMU (FMI 2.0 or 3.0 Co-Simulation, Linux x86-64) and run it:
//! the archive is unpacked into a temporary folder (removed with the
//! [`Fmu`]), the description read, the shared library opened and its
//! functions looked up. [`FmuModel`], [`FmuCompensator`] and
//! [`FmuInverseHysteresis`] adapt an instance to the conformance traits,
//! one sample per `doStep` of one sample time, with save and restore
//! through the FMU's state functions where it has them.
//!
//! This is a small loader of its own rather than the `fmi` crate: that
//! crate's sys layer is generated with bindgen (a libclang at build time)
//! and brings a schema layer besides, for the dozen functions per version
//! that a sampled Co-Simulation run needs.
//!
//! An FMU is native code in the process that loads it: one that crashes
//! takes that process with it. The checker therefore loads FMUs only in a
//! host process ([`crate::isolation`]), which runs these adapters. Calls
//! into one FMU are serialised (a third-party FMU may keep global state);
//! its instances are otherwise independent.
//!
//! * `fmu` — the archive unpacked (bounded) and the library opened;
//! * `abi` — the FMI 2.0 and 3.0 functions called and the callbacks given;
//! * `description` — what the adapters read of `modelDescription.xml`;
//! * `instance` — one instance: initialize, set, get, `doStep`, save and
//!   restore;
//! * `adapters` — an instance as [`FmuModel`], [`FmuCompensator`] or
//!   [`FmuInverseHysteresis`].

use thiserror::Error;

use super::variables::{FmiVersion, VariableType};

mod abi;
mod adapters;
mod description;
mod fmu;
mod instance;

pub use adapters::{
    bind, Bindings, FmuCandidate, FmuCompensator, FmuInverseHysteresis, FmuModel, ImportKind,
};
pub use description::{ImportedDescription, ImportedVariable};
pub(crate) use fmu::loader_error;
pub use fmu::{Fmu, MAX_DESCRIPTION, MAX_UNPACKED};
pub use instance::FmuInstance;

/// Why an FMU could not be loaded or run.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum ImportError {
    #[error("{path}: {reason}")]
    Archive { path: String, reason: String },
    #[error("modelDescription.xml: {0}")]
    Description(String),
    #[error("{path}: {reason}")]
    Library { path: String, reason: String },
    #[error("the FMU has no variable '{name}' ({what}); map another name with --fmu-variable {name}=NAME")]
    NoVariable { name: String, what: String },
    #[error("{call} failed with status {status}{log}")]
    Call {
        call: &'static str,
        status: i32,
        log: String,
    },
}
