//! The verification suite as a library: naive reference implementations
//! ([`reference`](mod@reference)), the property checks any implementation can be run
//! through ([`conformance`]), test signals ([`signal`]) and — with the
//! `suite` feature — the paper's scenarios ([`scenarios`]), their golden
//! traces ([`golden`]), figures ([`plots`]) and claims ([`reproduce`]).

pub mod conformance;
pub mod reference;
pub mod signal;

#[cfg(feature = "suite")]
pub mod golden;
#[cfg(feature = "suite")]
pub mod plots;
#[cfg(feature = "suite")]
pub mod records;
#[cfg(feature = "suite")]
pub mod reproduce;
#[cfg(feature = "suite")]
pub mod scenarios;
