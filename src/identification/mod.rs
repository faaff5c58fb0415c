//! Identification of the hysteresis and creep weights from a measurement,
//! (23)–(25): thresholds and eigenvalues fixed, weights by linearly
//! constrained least squares ([`weights`]).

pub mod weights;

pub use weights::*;
