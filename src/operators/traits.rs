//! The traits every implementation of an operator of the paper implements.
//!
//! They are object safe, so that property checks ([`crate::suite::conformance`]),
//! scenarios and benchmarks take `&mut dyn …` and run the project's fast
//! implementations, the naive references ([`crate::suite::reference`]) and
//! anybody else's through the same code:
//!
//! * [`Operator`] — a causal single-input single-output operator, one sample
//!   at a time: the play (7)–(9), PI hysteresis (10), the creep operators
//!   (13)–(16), the model `W` (6);
//! * [`ActuatorModel`] — the model `W = H + C` of the actuator (4), (6);
//! * [`InverseHysteresis`] — the inverse PI operator `H⁻¹` of (22);
//! * [`ActuatorCompensator`] — the compensator `W⁻¹` (21): the output and
//!   whether it was clipped.
//!
//! Typed snapshots of the state are a separate trait, [`Snapshot`], because a
//! state type differs per implementation. Implementations are configured from
//! the model file ([`crate::operators::model::ModelFile`]): its `state` is the
//! common way to start one from a given state.

use crate::error::{DimensionError, ModelError};

/// A state saved by an implementation that can save and restore itself as
/// a whole (an FMU through its state functions), opaque to everybody else:
/// only the object that saved it can restore it.
pub struct SavedState(pub Box<dyn std::any::Any + Send>);

impl std::fmt::Debug for SavedState {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("SavedState(..)")
    }
}

/// A causal time-discrete operator `v ↦ y`, one sample at a time.
pub trait Operator {
    /// Process one sample. Allocates nothing and does no I/O.
    fn step(&mut self, v: f64) -> f64;

    /// Return to the virgin (all-zero) state.
    fn reset(&mut self);

    /// Process a whole signal into a caller-provided buffer (no allocation).
    fn run_into(&mut self, input: &[f64], output: &mut [f64]) -> Result<(), DimensionError> {
        if input.len() != output.len() {
            return Err(DimensionError {
                what: "output buffer",
                expected: input.len(),
                found: output.len(),
            });
        }
        for (y, &v) in output.iter_mut().zip(input) {
            *y = self.step(v);
        }
        Ok(())
    }

    /// Process a whole signal and return the output.
    fn run(&mut self, input: &[f64]) -> Vec<f64> {
        input.iter().map(|&v| self.step(v)).collect()
    }

    /// Save the whole state, for an implementation that cannot be started
    /// from a model file's state (a fixed implementation, an FMU); `None`
    /// when it cannot save. The conformance checks of a fixed
    /// implementation split and resume through this.
    fn save_state(&mut self) -> Option<SavedState> {
        None
    }

    /// Restore a state [`save_state`](Operator::save_state) returned;
    /// false if it cannot.
    fn restore_state(&mut self, _state: &SavedState) -> bool {
        false
    }
}

/// A state that can be read, set and restored, so that a run can be split
/// and resumed bit-identically (the semigroup property).
pub trait Snapshot {
    /// Everything the next output depends on.
    type State: Clone + PartialEq + std::fmt::Debug;

    /// A copy of the current state.
    fn state(&self) -> Self::State;

    /// Replace the state; refuses states of the wrong shape or, for
    /// hysteresis, states that no input can reach.
    fn set_state(&mut self, state: &Self::State) -> Result<(), ModelError>;
}

/// The actuator model `W = H + C` (6): balanced voltage in, effective voltage
/// out. `step` returns `W[v]_k` for the input `v_k`; the creep part uses
/// `v_{k−1}` (the one-sample delay of (20)). A non-finite input is taken as
/// the previous input held (what a zero-order hold does with a lost sample):
/// it never enters the state.
pub trait ActuatorModel: Operator {}

/// The inverse Prandtl–Ishlinskii operator `H⁻¹` (22): `step(y)` returns the
/// `v` for which the forward operator, from the matched state, outputs `y`.
pub trait InverseHysteresis: Operator {}

pub use crate::realtime::Compensated;

/// The compensator `W⁻¹` (21): for a target effective voltage, the balanced
/// voltage that makes `W` produce it, clipped to the limits, and whether it
/// was clipped. After a clipped sample its state is the one the plant has
/// after receiving the clipped value.
///
/// A model with dead time `d` ([`delay`](ActuatorCompensator::delay)) is
/// inverted in its memory part only: `compensate` takes the target wanted
/// `d` samples later, and `compensate_all`, which sees the whole signal,
/// previews it so (`u_k = W⁻¹[y]_{k+d}`, the last `d` samples holding the
/// last target): `W[W⁻¹[y]] = y` from sample `d` on.
pub trait ActuatorCompensator {
    /// One sample of the memory part's inverse. Allocates nothing and does
    /// no I/O.
    fn compensate(&mut self, target: f64) -> Compensated;

    /// Return to the virgin state.
    fn reset(&mut self);

    /// The model's dead time `d` (samples) that `compensate_all` previews.
    fn delay(&self) -> usize {
        0
    }

    /// As [`Operator::save_state`].
    fn save_state(&mut self) -> Option<SavedState> {
        None
    }

    /// As [`Operator::restore_state`].
    fn restore_state(&mut self, _state: &SavedState) -> bool {
        false
    }

    /// Compensate a whole signal, previewed by the dead time.
    fn compensate_all(&mut self, targets: &[f64]) -> Vec<Compensated> {
        let d = self.delay();
        (0..targets.len())
            .map(|k| self.compensate(crate::realtime::preview(targets, d, k)))
            .collect()
    }
}

/// [`Operator`] for a core operator in every precision and storage: `f64`
/// in and out, rounded to `T` at the boundary (exact for `f64`). A
/// non-finite input is held out by the operator's own step.
macro_rules! operator_in_any_precision {
    ($operator:ident) => {
        impl<T: $crate::realtime::Real, S: $crate::realtime::Storage>
            $crate::operators::traits::Operator for $operator<T, S>
        {
            #[inline]
            fn step(&mut self, v: f64) -> f64 {
                $operator::step(self, T::from_f64(v)).to_f64()
            }

            fn reset(&mut self) {
                $operator::reset(self);
            }
        }
    };
}
pub(crate) use operator_in_any_precision;
