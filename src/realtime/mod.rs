//! The `no_std` core: every operator and the compensator, in `f32` or `f64`,
//! in storage chosen by a type parameter.
//!
//! This module is all the crate is with `default-features = false`: it is
//! `#![no_std]`, needs no allocator and depends on `libm` only (for `expm1`
//! when building the creep gains). It imports nothing from the rest of the
//! crate; the `std` layer (`crate::operators`) adds heap storage, model
//! files and the object-safe traits on top of these same types.
//!
//! One type per concept, generic over the scalar `T` ([`Real`]: `f32`,
//! `f64`) and the storage `S` ([`Storage`]: [`Inline`] capacity fixed at
//! compile time, or `Heap` with `std`):
//!
//! * [`Hysteresis`] — `H` (10) over plays (20);
//! * [`Creep`] — `C` (16) of log(t)-creep operators (13)–(15);
//! * [`Superposition`] — the memory-free `S` of the modified PI model, which
//!   makes the loops asymmetric, and its inverse;
//! * [`Dynamics`] — linear dynamics `G` after `S[H + C]` (a low-pass, a
//!   resonance), all-pole with unit gain at DC, so that its inverse is exact;
//! * [`DelayLine`] — a dead time of `d` whole samples after `S[H + C]`;
//! * [`RateGain`] — thresholds of `H` widened by the input's rate;
//! * [`Model`] — `W = S[H + C] + offset` (4), (6), delayed by `d` samples;
//! * [`Compensator`] — `W⁻¹` (21) with saturation ([`CompensatorSettings`]),
//!   the inverse rules (22), the fault flag for a non-finite target and the
//!   model's offset.
//!
//! Orders are chosen at run time up to the capacity; [`nominal::Capacity`]
//! holds exactly the paper's (12 plays, 12 × 5 creep operators).
//! Parameters come in as `f64` slices ([`ModelParameters`]), are checked
//! once ([`ModelParameters::validate`], (11), (12), (17), (18)) and
//! transformed in `f64`; only the steps run in `T`.
//!
//! ```
//! use mfcbeam::realtime::{nominal, Compensator, CompensatorSettings, Model};
//!
//! type Size = nominal::Capacity;
//! let settings = CompensatorSettings::default();
//! let parameters = nominal::PARAMETERS.validate().unwrap(); // checked once
//! let mut comp = Compensator::<f32, Size>::new(&parameters, settings).unwrap();
//! let mut plant = Model::<f32, Size>::new(&parameters).unwrap();
//! let y = plant.step(comp.compensate(250.0).u);
//! assert!((y - 250.0).abs() < 1e-3);
//! ```

pub(crate) mod checks;
pub mod compensator;
pub mod creep;
pub(crate) mod creep_pass;
pub mod delay;
pub mod dynamics;
pub mod error;
pub mod hysteresis;
pub(crate) mod inverse;
pub mod limits;
pub mod model;
pub mod nominal;
pub mod parameters;
pub(crate) mod placement;
pub(crate) mod play;
pub mod rate;
pub mod real;
pub(crate) mod rounding;
pub(crate) mod simd;
pub mod storage;
pub mod superposition;

pub use compensator::{Compensated, Compensator, CompensatorSettings};
#[cfg(feature = "std")]
pub use simd::cpu_description;

/// The kernel set the `f64` step of an operator runs on this CPU
/// (`portable`, `avx2` or `avx512`): what a timing of it names.
#[cfg(feature = "std")]
pub fn kernel_set() -> &'static str {
    simd::Kernels::detect_single_step::<f64>().name()
}
pub use creep::Creep;
pub use delay::{preview, preview_into, DelayLine};
pub use dynamics::{Dynamics, DynamicsParameters, Resonance};
pub use error::ParameterError;
pub use hysteresis::Hysteresis;
pub use model::Model;
pub use parameters::{
    CreepParameters, HysteresisParameters, ModelParameters, SuperpositionParameters,
};
pub use rate::RateGain;
pub use real::Real;
pub use rounding::RoundingBounds;
pub use storage::{Buffer, Inline, InlineBuffer, PaddedBuffer, Storage};
pub use superposition::Superposition;
