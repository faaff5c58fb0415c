//! The Functional Mock-up Interface (FMI 2.0 and 3.0, Co-Simulation): the
//! compensator `W⁻¹`, the actuator model `W`, the plant (`W` and the
//! beam) and a feedback controller of the closed loop as FMUs that Simulink, OpenModelica, Dymola and FMPy import, and
//! an importer that runs any FMU of a compensator or a model through the
//! conformance checks.
//!
//! * [`variables`] — the kinds and their variables (one table for both
//!   FMI versions: names, value references, causality);
//! * [`component`] — one instance: parameters, inputs, the step and the
//!   outputs, save and restore; the C functions of the `mfcbeam-fmu`
//!   library are a thin layer over it;
//! * [`description`] — `modelDescription.xml` for FMI 2.0 and 3.0;
//! * [`platform`] — the platforms of the binaries and their folders;
//! * [`package`] (feature `fmi-tools`) — the `.fmu` archive;
//! * [`import`] (feature `fmi-tools`) — load an FMU and adapt it to the
//!   conformance traits;
//! * [`controller`] (feature `fmi-tools`) — an FMU as the controller of the
//!   closed loop ([`crate::control`]).
//!
//! ## Timing
//!
//! An FMU is sampled: every `doStep` advances a whole number `m ≥ 1` of
//! sample times `Ts` (a step of any other length is an error), with the
//! input held over the step (zero-order hold). After the step from `t_k`
//! the zero-order-hold outputs (`u`, `y`, `v`, the flags) hold the last
//! sample computed in it — the answer to the input set before the step —
//! so an importer that records outputs after each step (Co-Simulation)
//! sees sample `k` at time `t_{k+1}`: one communication step later than
//! the command line's trace. The flags are raised if any sample of the
//! step raised them. The beam's tip deflection and modal state are those
//! at the end of the step, as for a continuous plant. No output depends on
//! an input at the same communication point (no direct feedthrough), so an
//! FMU in a loop makes no algebraic loop.
//!
//! A dead time `d` has no causal inverse: the compensator FMU inverts the
//! memory part and reports `d` as the calculated parameter `delay`; the
//! importer previews the target, `y_d(t + d Ts)`, as the command line's
//! `compensate` does from a whole file.

pub mod component;
#[cfg(feature = "fmi-tools")]
pub mod controller;
pub mod description;
#[cfg(feature = "fmi-tools")]
pub mod import;
#[cfg(feature = "fmi-tools")]
pub mod package;
pub mod platform;
pub mod variables;

pub use component::{Component, FmuError};
pub use platform::Platform;
pub use variables::{FmiVersion, FmuConfig, FmuKind, Variable};
