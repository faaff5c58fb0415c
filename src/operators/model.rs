//! The hysteresis and creep model `W = H + C`, equations (4) and (6), and its
//! file form (`docs/FILES.md`).
//!
//! `W[v]_k = H[v]_k + C[v]_k` (plus an optional constant output offset, a
//! measurement's sensor offset): `W` maps the balanced patch voltage `u` (V) to
//! the effective voltage (V) that drives the linear beam. `creep` may be absent
//! (pure hysteresis).

use serde::{Deserialize, Serialize};

use crate::error::ModelError;
use crate::operators::creep::CreepOperator;
use crate::operators::hysteresis::HysteresisOperator;
use crate::operators::traits::{ActuatorModel, Operator, Snapshot};

/// The hysteresis part of a model file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HysteresisData {
    pub thresholds: Vec<f64>,
    pub weights: Vec<f64>,
    /// `x_init` of (8) per play; absent means virgin.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub state: Option<Vec<f64>>,
}

/// The creep part of a model file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CreepData {
    pub thresholds: Vec<f64>,
    pub weights: Vec<f64>,
    pub eigenvalues: Vec<f64>,
    /// `χ` at the first sample, one row of `m` values per threshold; absent means zero.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub state: Option<Vec<Vec<f64>>>,
}

/// A model file as it is stored (JSON).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelFile {
    pub sample_time: f64,
    pub hysteresis: HysteresisData,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub creep: Option<CreepData>,
    /// Constant output offset (unit of the output): `y = W[u] + offset`.
    /// Absent means 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub offset: Option<f64>,
}

impl ModelFile {
    /// The same model without `state` entries (virgin).
    pub fn without_state(mut self) -> Self {
        self.hysteresis.state = None;
        if let Some(c) = &mut self.creep {
            c.state = None;
        }
        self
    }
}

/// The complete state of a [`HysteresisCreepModel`].
#[derive(Debug, Clone, PartialEq)]
pub struct ModelState {
    pub hysteresis: Vec<f64>,
    pub creep: Option<Vec<Vec<f64>>>,
}

/// The operator `W = H + C` (6).
#[derive(Debug, Clone, PartialEq)]
pub struct HysteresisCreepModel {
    sample_time: f64,
    offset: f64,
    hysteresis: HysteresisOperator,
    creep: Option<CreepOperator>,
}

impl HysteresisCreepModel {
    /// Combine a hysteresis operator and an optional creep operator. The creep
    /// operator's sample time must equal `sample_time`.
    pub fn new(
        sample_time: f64,
        hysteresis: HysteresisOperator,
        creep: Option<CreepOperator>,
    ) -> Result<Self, ModelError> {
        crate::realtime::parameters::check_sample_time(sample_time)?;
        if let Some(c) = &creep {
            if c.sample_time() != sample_time {
                return Err(ModelError::Inconsistent {
                    field: "creep".into(),
                    reason: format!(
                        "creep sample time {} differs from the model's {}",
                        c.sample_time(),
                        sample_time
                    ),
                });
            }
        }
        Ok(Self {
            sample_time,
            offset: 0.0,
            hysteresis,
            creep,
        })
    }

    /// Validate a model file and build the model with its state.
    pub fn from_file(file: &ModelFile) -> Result<Self, ModelError> {
        crate::realtime::parameters::check_sample_time(file.sample_time)?;
        let h = &file.hysteresis;
        let mut hysteresis = HysteresisOperator::new(h.thresholds.clone(), h.weights.clone())?;
        if let Some(s) = &h.state {
            hysteresis.set_state(s)?;
        }
        let creep = match &file.creep {
            None => None,
            Some(c) => {
                let mut op = CreepOperator::new(
                    c.thresholds.clone(),
                    c.weights.clone(),
                    c.eigenvalues.clone(),
                    file.sample_time,
                )?;
                if let Some(s) = &c.state {
                    op.set_state(s)?;
                }
                Some(op)
            }
        };
        let offset = file.offset.unwrap_or(0.0);
        crate::realtime::parameters::check_finite("offset", core::slice::from_ref(&offset))?;
        Ok(Self::new(file.sample_time, hysteresis, creep)?.with_offset(offset))
    }

    /// The same model with output offset `offset`: `y = W[u] + offset`.
    pub fn with_offset(mut self, offset: f64) -> Self {
        self.offset = offset;
        self
    }

    /// The output offset.
    pub fn offset(&self) -> f64 {
        self.offset
    }

    /// The model file of this model, with its current state.
    pub fn to_file(&self) -> ModelFile {
        ModelFile {
            sample_time: self.sample_time,
            hysteresis: HysteresisData {
                thresholds: self.hysteresis.thresholds().to_vec(),
                weights: self.hysteresis.weights().to_vec(),
                state: Some(self.hysteresis.state()),
            },
            creep: self.creep.as_ref().map(|c| CreepData {
                thresholds: c.thresholds().to_vec(),
                weights: c.weights().to_vec(),
                eigenvalues: c.eigenvalues().to_vec(),
                state: Some(c.state()),
            }),
            offset: (self.offset != 0.0).then_some(self.offset),
        }
    }

    /// Sample time `T_s` (s).
    pub fn sample_time(&self) -> f64 {
        self.sample_time
    }

    /// The hysteresis operator `H`.
    pub fn hysteresis(&self) -> &HysteresisOperator {
        &self.hysteresis
    }

    /// The creep operator `C`, if any.
    pub fn creep(&self) -> Option<&CreepOperator> {
        self.creep.as_ref()
    }
}

impl Operator for HysteresisCreepModel {
    /// A non-finite input is taken as the previous input held: the plays do
    /// not move, the creep advances with the held value.
    #[inline]
    fn step(&mut self, v: f64) -> f64 {
        let v = if v.is_finite() {
            v
        } else {
            self.hysteresis.play_states()[0]
        };
        let h = self.hysteresis.step(v);
        let w = match &mut self.creep {
            Some(c) => h + c.step(v),
            None => h,
        };
        w + self.offset
    }

    fn reset(&mut self) {
        self.hysteresis.reset();
        if let Some(c) = &mut self.creep {
            c.reset();
        }
    }
}

impl Snapshot for HysteresisCreepModel {
    type State = ModelState;

    fn state(&self) -> ModelState {
        ModelState {
            hysteresis: self.hysteresis.state(),
            creep: self.creep.as_ref().map(|c| c.state()),
        }
    }

    fn set_state(&mut self, state: &ModelState) -> Result<(), ModelError> {
        match (&mut self.creep, &state.creep) {
            (Some(c), Some(s)) => {
                // Validate both before changing either.
                let mut trial = c.clone();
                trial.set_state(s)?;
                self.hysteresis.set_state(&state.hysteresis)?;
                *c = trial;
                Ok(())
            }
            (None, None) => self.hysteresis.set_state(&state.hysteresis),
            _ => Err(ModelError::Inconsistent {
                field: "creep.state".into(),
                reason: "a creep state must be given exactly when the model has creep".into(),
            }),
        }
    }
}

impl ActuatorModel for HysteresisCreepModel {}
