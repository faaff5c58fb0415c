//! Flatness-based feedforward (28): the Gevrey trajectory of the flat output
//! with all its derivatives ([`trajectory`]) and the stable input
//! parametrization `u = D(d/dt) z`, `y = N(d/dt) z` ([`flatness`]).

pub mod flatness;
pub mod trajectory;

pub use flatness::*;
