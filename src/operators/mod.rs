//! The operators of the actuator model and its inverse: the play (7)–(9),
//! Prandtl–Ishlinskii hysteresis (10)–(12), creep (13)–(18), the analytic
//! inverse (22), the model `W = H + C` (4), (6) with its file form, the
//! real-time compensator (21), the asymmetric supply (1) and the nominal
//! model.
//!
//! This is the core of the crate: it builds without any of the numerical,
//! plotting or command-line dependencies (`default-features = false`).
//! [`traits`] holds the object-safe traits every implementation — the fast
//! ones here, the naive references in [`crate::suite::reference`] and your
//! own — implements, so that one property suite checks them all.

pub mod bank;
pub mod compensator;
pub mod creep;
pub mod heap;
pub mod hysteresis;
pub mod inverse;
pub mod model;
pub mod nominal;
pub mod play;
pub mod rate_dependent;
pub mod supply;
pub mod traits;
