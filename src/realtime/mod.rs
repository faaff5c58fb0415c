//! The real-time core: every operator a compensator needs on the target, in
//! `f32` or `f64`, in storage fixed at compile time.
//!
//! This module is all the crate is with `default-features = false`: it is
//! `#![no_std]`, needs no allocator and depends on `libm` only (for
//! `expm1` when building the creep gains). The `std` operators in
//! `crate::operators` run the same per-sample kernels ([`hysteresis::step`],
//! [`creep::advance`], the compensator's inversion), so there is one
//! implementation of the mathematics, instantiated for `f32`, `f64` and for
//! heap or fixed storage.
//!
//! * [`FixedHysteresis`] — `H` (10) with at most `N` plays (20);
//! * [`FixedCreep`] — `C` (16) with at most `K = (n+1)·m` elementary
//!   operators (13)–(15);
//! * [`FixedModel`] — `W = H + C + offset` (4), (6);
//! * [`FixedCompensator`] — `W⁻¹` (21) with saturation and the inverse rules
//!   (22), the fault flag for a non-finite target and the model's offset.
//!
//! Orders are chosen at run time up to the capacity; [`PaperCompensator`] and
//! [`PaperModel`] have exactly the paper's (12 plays, 12 × 5 creep
//! operators). Parameters come in as `f64` slices ([`ModelParameters`]), are
//! checked like the model file's (11), (12), (17), (18) and transformed in
//! `f64`; only the steps run in `T`.
//!
//! ```
//! use mfcbeam::realtime::{nominal, PaperCompensator, PaperModel};
//!
//! let mut comp = PaperCompensator::<f32>::new(&nominal::PARAMETERS, -1000.0, 1000.0).unwrap();
//! let mut plant = PaperModel::<f32>::new(&nominal::PARAMETERS).unwrap();
//! let y = plant.step(comp.compensate(250.0).u);
//! assert!((y - 250.0).abs() < 1e-3);
//! ```

pub mod compensator;
pub mod creep;
pub mod error;
pub mod hysteresis;
pub mod inverse;
pub mod model;
pub mod nominal;
pub mod parameters;
pub mod play;
pub mod real;
pub mod rounding;
pub mod simd;

pub use compensator::{Compensated, FixedCompensator};
pub use creep::FixedCreep;
pub use error::ParameterError;
pub use hysteresis::FixedHysteresis;
pub use model::FixedModel;
pub use parameters::{CreepParameters, HysteresisParameters, ModelParameters};
pub use real::Real;
pub use rounding::RoundingBounds;

/// Plays of the paper's model (`n = 11`).
pub const PAPER_PLAYS: usize = 12;
/// Elementary creep operators of the paper's model (12 thresholds × 5
/// eigenvalues).
pub const PAPER_CREEP: usize = 60;

/// A compensator sized for the paper's model.
pub type PaperCompensator<T> = FixedCompensator<T, PAPER_PLAYS, PAPER_CREEP>;
/// A model `W` sized for the paper's model.
pub type PaperModel<T> = FixedModel<T, PAPER_PLAYS, PAPER_CREEP>;
