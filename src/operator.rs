//! The [`Operator`] trait: a time-discrete single-input single-output operator
//! with explicit state.
//!
//! Every operator of the paper — the play (7)–(9), the Prandtl–Ishlinskii
//! hysteresis operator (10), the creep operators (13)–(16), the model
//! `W = H + C` (6) and the compensator (21) — implements it, so that an
//! alternative implementation can be run through the same checks.

use crate::error::{DimensionError, ModelError};

/// A time-discrete operator `v ↦ y` with a state that can be read, set, reset and
/// snapshotted, so that a run can be split and resumed bit-identically.
pub trait Operator {
    /// A snapshot of everything the next output depends on.
    type State: Clone + PartialEq + std::fmt::Debug;

    /// Process one sample. Allocates nothing and does no I/O.
    fn step(&mut self, v: f64) -> f64;

    /// Return to the virgin (all-zero) state.
    fn reset(&mut self);

    /// A copy of the current state.
    fn state(&self) -> Self::State;

    /// Replace the state; refuses states of the wrong shape or, for hysteresis,
    /// states that no input can reach.
    fn set_state(&mut self, state: &Self::State) -> Result<(), ModelError>;

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
}
