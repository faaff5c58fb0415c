//! The compensator `W⁻¹` (21) with the `std` conveniences: built from a
//! model file or a model, the object-safe [`ActuatorCompensator`],
//! [`Operator`] and [`Snapshot`] traits. The compensator itself is
//! [`crate::realtime::Compensator`]: `v_k = H⁻¹[ς_k − offset − C_k]`,
//! explicit because the time-discrete creep operator (20) has a one-sample
//! delay; clipped to [`CompensatorSettings`] with every clipped sample
//! flagged; a non-finite target holds the last output and is flagged as a
//! fault.

use crate::error::ModelError;
use crate::operators::model::ModelFile;
use crate::operators::traits::{ActuatorCompensator, Operator, Snapshot};
use crate::realtime::{Model, ParameterError, Real, Storage};

pub use crate::realtime::{Compensated, Compensator, CompensatorSettings};

impl<S: Storage> Model<f64, S> {
    /// The compensator of this model in the same storage, matched to the
    /// model's current state.
    pub fn compensator(
        &self,
        settings: CompensatorSettings,
    ) -> Result<Compensator<f64, S>, ParameterError> {
        Compensator::of(self, settings)
    }
}

impl<T: Real, S: Storage> Compensator<T, S> {
    /// `W⁻¹` of a model file, matched to the file's state.
    pub fn from_file(file: &ModelFile, settings: CompensatorSettings) -> Result<Self, ModelError> {
        let mut comp = Self::new(&file.parameters().validate()?, settings)?;
        let creep = file.creep_state_flat()?;
        if file.hysteresis.state.is_some() || creep.is_some() {
            let zeros = vec![0.0; file.hysteresis.thresholds.len()];
            let x = file.hysteresis.state.as_deref().unwrap_or(&zeros);
            comp.set_model_state(x, creep.as_deref())?;
        }
        if let Some(g) = &file.dynamics {
            comp.set_dynamics_state(g.state.as_deref())?;
        }
        comp.set_last_input(file.hysteresis.last_input)?;
        Ok(comp)
    }
}

fn to_f64<T: Real>(x: &[T]) -> Vec<f64> {
    x.iter().map(|v| v.to_f64()).collect()
}

/// Everything the compensator's next output depends on.
#[derive(Debug, Clone, PartialEq)]
pub struct CompensatorState {
    /// Forward play states (those of the plant model).
    pub forward: Vec<f64>,
    /// Play states of `H⁻¹`.
    pub inverse: Vec<f64>,
    /// Creep state, one row of `m` values per threshold.
    pub creep: Option<Vec<Vec<f64>>>,
    /// `G` as the compensator tracks it (the plant's, advanced by its lag;
    /// outputs then inputs, newest first); `None` before the first sample
    /// or without dynamics.
    pub dynamics: Option<Vec<f64>>,
    /// The plant's last input, which rate-dependent thresholds need;
    /// `None` before the first sample or without them.
    pub last_input: Option<f64>,
}

impl<T: Real, S: Storage> Operator for Compensator<T, S> {
    /// The compensated voltage; use [`Compensator::compensate`] for the flags.
    #[inline]
    fn step(&mut self, target: f64) -> f64 {
        Compensator::compensate(self, T::from_f64(target))
            .u
            .to_f64()
    }

    fn reset(&mut self) {
        Compensator::reset(self);
    }
}

impl<T: Real, S: Storage> ActuatorCompensator for Compensator<T, S> {
    #[inline]
    fn compensate(&mut self, target: f64) -> Compensated {
        let c = Compensator::compensate(self, T::from_f64(target));
        Compensated {
            u: c.u.to_f64(),
            saturated: c.saturated,
            fault: c.fault,
        }
    }

    fn reset(&mut self) {
        Compensator::reset(self);
    }

    fn delay(&self) -> usize {
        Compensator::delay(self)
    }
}

impl<T: Real, S: Storage> Snapshot for Compensator<T, S> {
    type State = CompensatorState;

    fn state(&self) -> CompensatorState {
        let mut forward = self.inverse.play_states().to_vec();
        self.forward_state_into(&mut forward)
            .expect("one value per play");
        // with rate-dependent thresholds the plays of H⁻¹ are not stepped:
        // those (22) gives for the plant's
        let inverse = match self.rate_gain() {
            None => to_f64(self.inverse.play_states()),
            Some(_) => {
                let mut matched = self.clone();
                matched
                    .set_model_state(&to_f64(&forward), None)
                    .expect("the plant's plays are admissible");
                to_f64(matched.inverse.play_states())
            }
        };
        CompensatorState {
            forward: to_f64(&forward),
            inverse,
            creep: self.creep.as_ref().map(Snapshot::state),
            dynamics: self.dynamics().and_then(|g| {
                let mut y = vec![T::ZERO; g.state_len()];
                g.state_into(&mut y)?;
                Some(to_f64(&y))
            }),
            last_input: self
                .rate_gain()
                .and_then(|r| r.last_input())
                .map(|v| v.to_f64()),
        }
    }

    fn set_state(&mut self, state: &CompensatorState) -> Result<(), ModelError> {
        let n = self.inverse.len();
        let named = |field: &'static str| move |e: ParameterError| e.named(field);
        crate::realtime::checks::check_length("", n, state.forward.len())
            .map_err(named("compensator.forward"))?;
        // the plays of H⁻¹ are implied by those of H (22): both must agree
        // to rounding, amplified at most by the ratio of the slopes
        let mut trial = self.clone();
        trial
            .set_model_state(&state.forward, None)
            .map_err(|e| match e {
                ParameterError::NonFinite { .. } | ParameterError::InadmissibleState { .. } => {
                    e.named("compensator.forward")
                }
                e => e.into(),
            })?;
        match (&mut trial.creep, &state.creep) {
            (Some(c), Some(s)) => Snapshot::set_state(c, s)?,
            (None, None) => {}
            _ => {
                return Err(ModelError::Inconsistent {
                    field: "compensator.creep".into(),
                    reason: "a creep state must be given exactly when the model has creep".into(),
                })
            }
        }
        crate::realtime::checks::check_length("", n, state.inverse.len())
            .map_err(named("compensator.inverse"))?;
        crate::realtime::checks::check_finite("", &state.inverse)
            .map_err(named("compensator.inverse"))?;
        let expected = to_f64(trial.inverse.play_states());
        let sums = to_f64(&self.sums);
        let (s_min, s_max) = sums
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(a, b), &s| (a.min(s), b.max(s)));
        let scale = state.inverse.iter().fold(1.0f64, |m, x| m.max(x.abs()));
        let tolerance =
            8.0 * (n as f64 + 1.0) * T::EPSILON.to_f64() * scale * (1.0 + s_max / s_min);
        if let Some(j) = (0..n).find(|&j| (expected[j] - state.inverse[j]).abs() > tolerance) {
            return Err(ModelError::Inconsistent {
                field: format!("compensator.inverse[{j}]"),
                reason: format!(
                    "{} is not the state (22) gives for compensator.forward ({})",
                    state.inverse[j], expected[j]
                ),
            });
        }
        // the inverse plays as given (they agree with (22) to rounding)
        for (x, &v) in trial.inverse.state_mut().iter_mut().zip(&state.inverse) {
            *x = T::from_f64(v);
        }
        // the compensator's own state of G (advanced by its lag), as saved
        match (&mut trial.dynamics, &state.dynamics) {
            (Some(g), values) => g
                .set_state(values.as_deref())
                .map_err(|e| e.named("compensator.dynamics"))?,
            (None, None) => {}
            (None, Some(_)) => {
                return Err(ModelError::Inconsistent {
                    field: "compensator.dynamics".into(),
                    reason: "the model has no dynamics".into(),
                })
            }
        }
        trial.set_last_input(state.last_input)?;
        *self = trial;
        Ok(())
    }
}
