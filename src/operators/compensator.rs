//! The real-time hysteresis and creep compensator `W⁻¹`, equation (21).
//!
//! `v_k = H⁻¹[ς_k − C_k]`, where `C_k` is the creep output at step `k`. Because
//! the time-discrete creep operator (20) has a one-sample delay, `C_k` depends
//! only on `v_{k−1}` and the creep state, so (21) is explicit: no iteration.
//! The compensator keeps its own copy of the creep state and of the inverse
//! hysteresis state (from the transformation rules (22)), so that from matched
//! states `W[W⁻¹[ς]] = ς` and `W⁻¹[W[v]] = v` hold to rounding.
//!
//! With a model offset (`y = W[v] + offset`) the target is `ς_k − offset`.
//!
//! A non-finite target never enters the state: the previous output is held
//! and the sample flagged as a fault ([`Compensated::fault`]).
//!
//! Saturation: the output is clipped to the configured limits (default: the
//! balanced supply range `[−1000, 1000]` V of (1)) and every clipped sample is
//! flagged. After a clipped sample the compensator recovers the plant's plays
//! from its inverse ones (the state rule of (22) solved backwards), advances
//! them with the clipped value and rebuilds the inverse state from them by
//! (22), so its state is the one the plant has after receiving the clipped
//! value and the identity resumes as soon as the target is reachable.

use crate::error::ModelError;
use crate::operators::creep::CreepOperator;
use crate::operators::hysteresis::{
    check_admissible, check_finite, check_length, HysteresisOperator,
};
use crate::operators::model::HysteresisCreepModel;
use crate::operators::traits::{ActuatorCompensator, Operator, Snapshot};
use crate::realtime::compensator::{invert_saturating, HysteresisPair};

/// Saturation limits of the compensator output (balanced voltage, V).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CompensatorSettings {
    /// Lowest output; `-inf` for none.
    pub lower_limit: f64,
    /// Highest output; `+inf` for none.
    pub upper_limit: f64,
}

impl Default for CompensatorSettings {
    /// The balanced supply range: `[−1000, 1000]` V.
    fn default() -> Self {
        Self {
            lower_limit: -1000.0,
            upper_limit: 1000.0,
        }
    }
}

impl CompensatorSettings {
    /// No saturation at all.
    pub fn unlimited() -> Self {
        Self {
            lower_limit: f64::NEG_INFINITY,
            upper_limit: f64::INFINITY,
        }
    }

    /// Limits `[lower, upper]`.
    pub fn with_limits(lower_limit: f64, upper_limit: f64) -> Self {
        Self {
            lower_limit,
            upper_limit,
        }
    }

    /// `lower < upper`, neither NaN.
    pub fn validate(&self) -> Result<(), ModelError> {
        Ok(crate::realtime::parameters::check_limits(
            self.lower_limit,
            self.upper_limit,
        )?)
    }
}

pub use crate::operators::traits::Compensated;

/// Everything the compensator's next output depends on.
#[derive(Debug, Clone, PartialEq)]
pub struct CompensatorState {
    /// Forward play states (those of the plant model).
    pub forward: Vec<f64>,
    /// Play states of `H⁻¹`.
    pub inverse: Vec<f64>,
    /// Creep state, one row of `m` values per threshold.
    pub creep: Option<Vec<Vec<f64>>>,
}

/// The compensator `W⁻¹` (21) of a [`HysteresisCreepModel`].
#[derive(Debug, Clone)]
pub struct Compensator {
    settings: CompensatorSettings,
    inverse: HysteresisOperator,
    forward_thresholds: Vec<f64>,
    forward_weights: Vec<f64>,
    forward_sums: Vec<f64>,
    /// Room for the plant's play states, used after a clipped sample.
    scratch: Vec<f64>,
    /// The last emitted value, held for a non-finite target.
    last_u: f64,
    creep: Option<CreepOperator>,
    /// The model's output offset, subtracted from every target.
    offset: f64,
}

impl Compensator {
    /// The compensator of `model`, starting from the model's current state
    /// (matched states).
    pub fn new(
        model: &HysteresisCreepModel,
        settings: CompensatorSettings,
    ) -> Result<Self, ModelError> {
        settings.validate()?;
        let h = model.hysteresis();
        Ok(Self {
            settings,
            inverse: h.inverse(),
            forward_thresholds: h.thresholds().to_vec(),
            forward_weights: h.weights().to_vec(),
            forward_sums: h.partial_sums(),
            scratch: vec![0.0; h.play_states().len()],
            last_u: h.play_states()[0],
            creep: model.creep().cloned(),
            offset: model.offset(),
        })
    }

    /// The limits in force.
    pub fn settings(&self) -> &CompensatorSettings {
        &self.settings
    }

    /// The plays of the plant's `H` that match the inverse plays (22).
    fn forward_state(&self) -> Vec<f64> {
        let mut x = self.inverse.play_states().to_vec();
        crate::realtime::inverse::forward_state_in_place(&self.forward_sums, &mut x);
        x
    }

    /// The inverse hysteresis operator `H⁻¹` with its current state.
    pub fn inverse_hysteresis(&self) -> &HysteresisOperator {
        &self.inverse
    }

    /// One sample of (21): the voltage that makes `W` produce `target`, clipped
    /// to the limits. Allocation-free, no I/O.
    #[inline]
    pub fn compensate(&mut self, target: f64) -> Compensated {
        crate::realtime::simd::dispatch(|| self.compensate_with::<true>(target))
    }

    /// [`Compensator::compensate`] compiled for the caller's instruction set,
    /// without run-time dispatch (the same bits).
    #[doc(hidden)]
    #[inline(always)]
    pub fn compensate_portable(&mut self, target: f64) -> Compensated {
        self.compensate_with::<false>(target)
    }

    #[inline(always)]
    fn compensate_with<const SIMD: bool>(&mut self, target: f64) -> Compensated {
        if !target.is_finite() {
            return self.hold();
        }
        let c = match &self.creep {
            Some(op) => op.output(),
            None => 0.0,
        };
        let (inv_thresholds, inv_weights, inv_state) = self.inverse.parts_mut();
        let (u, saturated) = invert_saturating::<f64, SIMD>(
            HysteresisPair {
                inv_thresholds,
                inv_weights,
                inv_state,
                thresholds: &self.forward_thresholds,
                weights: &self.forward_weights,
                sums: &self.forward_sums,
                scratch: &mut self.scratch,
            },
            target - self.offset - c,
            self.settings.lower_limit,
            self.settings.upper_limit,
        );
        self.last_u = u;
        if let Some(op) = &mut self.creep {
            op.advance_with::<SIMD>(u);
        }
        Compensated {
            u,
            saturated,
            fault: false,
        }
    }

    /// A non-finite target: emit the previous output again. The plays see
    /// the same input (no change); the creep advances with it, as the
    /// plant's does.
    #[cold]
    fn hold(&mut self) -> Compensated {
        let u = self.last_u;
        if let Some(op) = &mut self.creep {
            op.advance(u);
        }
        Compensated {
            u,
            saturated: false,
            fault: true,
        }
    }

    /// Return to the virgin state (forward plays, inverse plays and creep).
    pub fn reset(&mut self) {
        self.last_u = 0.0;
        self.inverse.reset();
        if let Some(c) = &mut self.creep {
            c.reset();
        }
    }

    /// Compensate a whole signal into caller buffers; returns the number of
    /// saturated samples.
    pub fn compensate_into(
        &mut self,
        targets: &[f64],
        u: &mut [f64],
        saturated: &mut [bool],
    ) -> Result<usize, crate::error::DimensionError> {
        for (what, len) in [
            ("output buffer", u.len()),
            ("saturation buffer", saturated.len()),
        ] {
            if len != targets.len() {
                return Err(crate::error::DimensionError {
                    what,
                    expected: targets.len(),
                    found: len,
                });
            }
        }
        // one instruction-set dispatch for the whole signal
        Ok(crate::realtime::simd::dispatch(|| {
            let mut count = 0;
            for ((&t, u), s) in targets.iter().zip(u.iter_mut()).zip(saturated.iter_mut()) {
                let out = self.compensate_with::<true>(t);
                *u = out.u;
                *s = out.saturated;
                count += usize::from(out.saturated);
            }
            count
        }))
    }
}

impl Operator for Compensator {
    /// The compensated voltage; use [`Compensator::compensate`] for the flag.
    #[inline]
    fn step(&mut self, target: f64) -> f64 {
        self.compensate(target).u
    }

    fn reset(&mut self) {
        Compensator::reset(self);
    }
}

impl ActuatorCompensator for Compensator {
    #[inline]
    fn compensate(&mut self, target: f64) -> Compensated {
        Compensator::compensate(self, target)
    }

    fn reset(&mut self) {
        Compensator::reset(self);
    }
}

impl Snapshot for Compensator {
    type State = CompensatorState;

    fn state(&self) -> CompensatorState {
        CompensatorState {
            forward: self.forward_state(),
            inverse: self.inverse.state(),
            creep: self.creep.as_ref().map(|c| c.state()),
        }
    }

    fn set_state(&mut self, state: &CompensatorState) -> Result<(), ModelError> {
        let n = self.forward_thresholds.len();
        check_length("compensator.forward", n, state.forward.len())?;
        check_finite("compensator.forward", &state.forward)?;
        check_admissible(
            "compensator.forward",
            &self.forward_thresholds,
            &state.forward,
        )?;
        let mut creep = self.creep.clone();
        match (&mut creep, &state.creep) {
            (Some(c), Some(s)) => c.set_state(s)?,
            (None, None) => {}
            _ => {
                return Err(ModelError::Inconsistent {
                    field: "compensator.creep".into(),
                    reason: "a creep state must be given exactly when the model has creep".into(),
                })
            }
        }
        let mut inverse = self.inverse.clone();
        inverse.set_state(&state.inverse)?;
        // The plays of H are implied by those of H⁻¹ (22): both must agree
        // to rounding, amplified at most by the ratio of the slopes.
        let mut expected = vec![0.0; n];
        crate::realtime::inverse::inverse_state_into(
            &self.forward_weights,
            &self.forward_sums,
            &state.forward,
            &mut expected,
        );
        let (s_min, s_max) = self
            .forward_sums
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(a, b), &s| (a.min(s), b.max(s)));
        let scale = state.inverse.iter().fold(1.0f64, |m, x| m.max(x.abs()));
        let tolerance = 8.0 * (n as f64 + 1.0) * f64::EPSILON * scale * (1.0 + s_max / s_min);
        if let Some(j) = (0..n).find(|&j| (expected[j] - state.inverse[j]).abs() > tolerance) {
            return Err(ModelError::Inconsistent {
                field: format!("compensator.inverse[{j}]"),
                reason: format!(
                    "{} is not the state (22) gives for compensator.forward ({})",
                    state.inverse[j], expected[j]
                ),
            });
        }
        self.last_u = state.forward[0];
        self.inverse = inverse;
        self.creep = creep;
        Ok(())
    }
}
