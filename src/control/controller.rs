//! The controller interface of the loop: what it sees at step `k` and what
//! it returns (`docs/MATHEMATICS.md` §11.1).

use super::ControlError;

/// What a controller sees at step `k`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoopSample {
    /// Step `k`.
    pub k: usize,
    /// `t_k = k T_s` (s).
    pub t: f64,
    /// Reference tip deflection `y_d,k` (m).
    pub reference: f64,
    /// Measured tip deflection `m_k = y_k + n_k` (m), `y_k` before `u_k` acts.
    pub measurement: f64,
}

/// A feedback law in the two-degrees-of-freedom loop: from the reference and
/// the measurement to a correction `Δ_k` (V) of the effective voltage, added
/// to the feedforward `u_d,k` before the compensator.
///
/// `Ok(None)` (nothing) or a non-finite value is held: the loop applies the
/// last valid correction (0 before the first) and flags the sample. `Err`
/// ends the run with that error (a program that died, hung or wrote
/// garbage).
pub trait Controller {
    /// A name for reports.
    fn name(&self) -> String;
    /// `Δ_k` for the sample.
    fn step(&mut self, sample: &LoopSample) -> Result<Option<f64>, ControlError>;
}

/// The open loop: `Δ_k = 0`.
#[derive(Debug, Clone, Copy, Default)]
pub struct ZeroController;

impl Controller for ZeroController {
    fn name(&self) -> String {
        "open loop".into()
    }
    fn step(&mut self, _: &LoopSample) -> Result<Option<f64>, ControlError> {
        Ok(Some(0.0))
    }
}

impl<C: Controller + ?Sized> Controller for Box<C> {
    fn name(&self) -> String {
        (**self).name()
    }
    fn step(&mut self, sample: &LoopSample) -> Result<Option<f64>, ControlError> {
        (**self).step(sample)
    }
}
