//! With `std`: the fixed-capacity operators behind the object-safe traits of
//! `crate::operators::traits` (`f64` in and out, rounded to `T` at the
//! boundary), built from model files, so the conformance suite checks the
//! `f32` core like any other implementation.

use crate::error::ModelError;
use crate::operators::model::ModelFile;
use crate::operators::traits::{
    ActuatorCompensator, ActuatorModel, Compensated, InverseHysteresis, Operator,
};
use crate::realtime::{
    CreepParameters, FixedCompensator, FixedHysteresis, FixedModel, HysteresisParameters,
    ModelParameters, Real,
};

impl ModelFile {
    /// The parameters of the model (its states not included), borrowed, as
    /// the real-time core and the bank take them.
    pub fn parameters(&self) -> ModelParameters<'_> {
        let file = self;
        ModelParameters {
            sample_time: file.sample_time,
            hysteresis: HysteresisParameters {
                thresholds: &file.hysteresis.thresholds,
                weights: &file.hysteresis.weights,
            },
            creep: file.creep.as_ref().map(|c| CreepParameters {
                thresholds: &c.thresholds,
                weights: &c.weights,
                eigenvalues: &c.eigenvalues,
            }),
            offset: file.offset.unwrap_or(0.0),
        }
    }
}

/// The creep state of a model file flattened as the fixed operators take it
/// (`state[i * m + j]`), after checking every row's length.
fn creep_state(file: &ModelFile) -> Result<Option<Vec<f64>>, ModelError> {
    let Some(c) = &file.creep else {
        return Ok(None);
    };
    let Some(rows) = &c.state else {
        return Ok(None);
    };
    let m = c.eigenvalues.len();
    crate::operators::hysteresis::check_length("creep.state", c.thresholds.len(), rows.len())?;
    for (i, row) in rows.iter().enumerate() {
        crate::operators::hysteresis::check_length(&format!("creep.state[{i}]"), m, row.len())?;
    }
    Ok(Some(rows.iter().flatten().copied().collect()))
}

impl<T: Real, const N: usize, const K: usize> FixedModel<T, N, K> {
    /// `W` of a model file, in the file's state.
    pub fn from_file(file: &ModelFile) -> Result<Self, ModelError> {
        let mut model = Self::new(&file.parameters())?;
        if let Some(x) = &file.hysteresis.state {
            model.hysteresis_mut().set_state(x)?;
        }
        if let (Some(state), Some(c)) = (creep_state(file)?, model.creep_mut()) {
            c.set_state(&state)?;
        }
        Ok(model)
    }
}

impl<T: Real, const N: usize, const K: usize> FixedCompensator<T, N, K> {
    /// `W⁻¹` of a model file, matched to the file's state.
    pub fn from_file(file: &ModelFile, lower: f64, upper: f64) -> Result<Self, ModelError> {
        let mut comp = Self::new(&file.parameters(), lower, upper)?;
        let creep = creep_state(file)?;
        if file.hysteresis.state.is_some() || creep.is_some() {
            let n = file.hysteresis.thresholds.len();
            let zeros = vec![0.0; n];
            let x = file.hysteresis.state.as_deref().unwrap_or(&zeros);
            comp.set_model_state(x, creep.as_deref())?;
        }
        Ok(comp)
    }
}

impl<T: Real, const N: usize> FixedHysteresis<T, N> {
    /// `H⁻¹` of a model file's hysteresis, matched to its state.
    pub fn inverse_from_file(file: &ModelFile) -> Result<Self, ModelError> {
        Ok(Self::inverse_of(
            &file.parameters().hysteresis,
            file.hysteresis.state.as_deref(),
        )?)
    }
}

impl<T: Real, const N: usize, const K: usize> Operator for FixedModel<T, N, K> {
    #[inline]
    fn step(&mut self, v: f64) -> f64 {
        FixedModel::step(self, T::from_f64(v)).to_f64()
    }

    fn reset(&mut self) {
        FixedModel::reset(self);
    }
}

impl<T: Real, const N: usize, const K: usize> ActuatorModel for FixedModel<T, N, K> {}

impl<T: Real, const N: usize> Operator for FixedHysteresis<T, N> {
    #[inline]
    fn step(&mut self, v: f64) -> f64 {
        FixedHysteresis::step(self, T::from_f64(v)).to_f64()
    }

    fn reset(&mut self) {
        FixedHysteresis::reset(self);
    }
}

impl<T: Real, const N: usize> InverseHysteresis for FixedHysteresis<T, N> {}

impl<T: Real, const N: usize, const K: usize> ActuatorCompensator for FixedCompensator<T, N, K> {
    #[inline]
    fn compensate(&mut self, target: f64) -> Compensated {
        let c = FixedCompensator::compensate(self, T::from_f64(target));
        Compensated {
            u: c.u.to_f64(),
            saturated: c.saturated,
            fault: c.fault,
        }
    }

    fn reset(&mut self) {
        FixedCompensator::reset(self);
    }
}
