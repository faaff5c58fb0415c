//! # mfcbeam
//!
//! A reference implementation of the hysteresis and creep compensation of a
//! flexible beam driven by a pair of piezoelectric macro-fiber composite (MFC)
//! patches, after Schröck, Meurer and Kugi, *Control of a flexible beam actuated
//! by macro-fiber composite patches: II. Hysteresis and creep compensation,
//! experimental results*, Smart Mater. Struct. 20 (2011) 015016. Equation
//! numbers `(n)` refer to that paper; `docs/MATHEMATICS.md` in the repository
//! restates them with every number resolved.
//!
//! ## The mathematics
//!
//! The patch pair is fed through the asymmetric supply (1): `u_fs = ū + u`,
//! `u_bs = ū − u`. The balanced voltage `u` passes through the operator
//! `W = H + C` (4), (6) to an effective voltage that drives the linear beam.
//!
//! * **Play** (7)–(9), time-discrete (20): `x_k = max(v_k − r, min(v_k + r, x_{k−1}))`
//!   ([`operators::play`]).
//! * **Prandtl–Ishlinskii hysteresis** (10)–(12): `H[v] = Σ_i w_i P_{r_i}[v]` with
//!   `0 = r_0 < … < r_n` and partial sums `s_j = Σ_{i≤j} w_i > 0`
//!   ([`operators::hysteresis`]). Its branches have the slopes `s_j`; it
//!   obeys the Madelung rules, the Masing rule and the intersection property.
//! * **Creep** (13)–(18): elementary operators `dχ/dt = a d_r(v − χ)` solved
//!   exactly under zero-order hold, averaged over eigenvalues spread over
//!   decades (24) into log(t)-creep operators (15), and weighted into a PI creep
//!   operator (16) ([`operators::creep`]).
//! * **Inverse** (22): the Krejčí–Kuhnen transformation rules give `H⁻¹` as
//!   another PI operator, with transformed thresholds, weights and states
//!   ([`operators::inverse`]).
//! * **Compensator** (21): `v_k = H⁻¹[ς_k − C_k]`, explicit because the
//!   discrete creep operator has a one-sample delay
//!   ([`operators::compensator`]), with saturation to the supply limits.
//! * **Identification** (23)–(25): weights by constrained least squares,
//!   a streamed faer QR and an exact active-set solve, with an offset and an
//!   unknown initial state (`identification`, feature `identification`);
//!   the memory a record starts in, for a fixed model
//!   (`identification::initial_state`, feature `std`).
//! * **Beam** (26)–(27): the paper's Ritz model and a converged finite-element
//!   model, both in modal form, exact zero-order-hold simulation, the
//!   Hammerstein plant and step-response fits (`beam`, feature `beam`).
//! * **Feedforward** (28): the Gevrey trajectory and the flatness-based input
//!   (`feedforward`, feature `feedforward`).
//! * **The suite** ([`suite`]): naive reference implementations, conformance
//!   checks for any implementation, and — feature `suite` — the paper's
//!   scenarios, golden traces, figures and claims.
//!
//! `docs/MATHEMATICS.md` states all of it equation by equation;
//! `docs/FILES.md` is the file and command-line contract.
//!
//! ## Features
//!
//! Without default features the crate is [`realtime`]: `#![no_std]`, no
//! allocator, every operator and the compensator as one generic type each,
//! in `f32` or `f64`, in storage fixed at compile time (dependency: `libm`).
//! The feature `std` adds heap storage and the traits ([`operators`]), model files
//! ([`io`]), the naive references and the conformance checks ([`suite`];
//! `serde`, `serde_json`). `identification` (faer), `beam` (faer, nalgebra,
//! levenberg-marquardt), `feedforward`, `rayon` (the bank's parallel step,
//! `operators::bank::Par`), `suite` (scenarios, golden traces, plots, CSV
//! traces) and `cli` (the binary; the default) add the rest. `internals`,
//! which no default enables, opens the kernel sets to the project's own
//! benches and tests. The C library is the workspace member `mfcbeam-capi`.
//!
//! ## Two tiers
//!
//! Most users call [`io::read_model`], `model.compensator(settings)` and
//! [`operators::traits::Operator::run`]. The real-time path is
//! [`realtime::Compensator::compensate`] (and every operator's
//! [`operators::traits::Operator::step`]): one sample, no allocation, no I/O;
//! state can be snapshotted and restored ([`operators::traits::Snapshot`]) so
//! that runs split and resume bit-identically.
//!
//! ## Example
//!
//! ```
//! use mfcbeam::prelude::*;
//!
//! let model = nominal_model();
//! let mut plant = model.clone();
//! let mut comp = model.compensator(CompensatorSettings::default()).unwrap();
//! for k in 0..1000 {
//!     let target = 300.0 * (k as f64 * 1e-3).sin();
//!     let u = comp.compensate(target);
//!     let y = plant.step(u.u);
//!     assert!((y - target).abs() < 1e-9);
//! }
//! ```

#![cfg_attr(not(feature = "std"), no_std)]
#![deny(unsafe_op_in_unsafe_fn)]

pub mod realtime;

#[cfg(feature = "std")]
pub mod error;
#[cfg(feature = "std")]
pub mod io;
#[cfg(feature = "std")]
pub mod operators;
#[cfg(feature = "std")]
pub mod suite;

#[cfg(any(feature = "beam", feature = "fmi"))]
pub mod beam;
#[cfg(any(feature = "control", feature = "fmi"))]
pub mod control;
#[cfg(feature = "feedforward")]
pub mod feedforward;
#[cfg(feature = "fmi")]
pub mod fmi;
#[cfg(feature = "std")]
pub mod identification;
#[cfg(feature = "fmi-tools")]
pub mod isolation;

/// The types most programs need, one name for each concept: the `f64`
/// operators on the heap (`HysteresisOperator` is `Hysteresis<f64, Heap>`,
/// and so on); the generic types, for other precisions and fixed storage,
/// are [`realtime`]'s.
#[cfg(feature = "std")]
pub mod prelude {
    pub use crate::error::{ModelError, SupplyError};
    pub use crate::io::read_model;
    pub use crate::operators::creep::CreepOperator;
    pub use crate::operators::heap::Heap;
    pub use crate::operators::hysteresis::HysteresisOperator;
    pub use crate::operators::model::{HysteresisCreepModel, ModelFile};
    pub use crate::operators::nominal::nominal_model;
    pub use crate::operators::play::PlayOperator;
    pub use crate::operators::supply::Supply;
    pub use crate::operators::traits::{
        ActuatorCompensator, ActuatorModel, Compensated, InverseHysteresis, Operator, Snapshot,
    };
    pub use crate::realtime::{Compensator, CompensatorSettings, ParameterError};
}

/// The project's own benches and tests (feature `internals`, which no
/// default enables): the kernel sets and the hooks that run an operation on
/// a chosen one. Not a stable interface.
#[cfg(feature = "internals")]
pub mod internals {
    pub use crate::operators::bank::frames::FrameTiling;
    pub use crate::realtime::simd::{cpu_description, simd_kernel_calls, Kernels};
}

/// The Rust examples of the README and the guide (`docs/guide/`), compiled
/// and run as doctests; `docs/check_guide.py` checks that every page with
/// one is here.
#[cfg(doctest)]
pub mod guide_doctests {
    #[doc = include_str!("../README.md")]
    pub struct Readme;
    #[doc = include_str!("../docs/guide/checking.md")]
    pub struct Checking;
    #[doc = include_str!("../docs/guide/closed-loop.md")]
    pub struct ClosedLoop;
    #[doc = include_str!("../docs/guide/deploy.md")]
    pub struct Deploy;
    #[doc = include_str!("../docs/guide/library.md")]
    pub struct Library;
}
