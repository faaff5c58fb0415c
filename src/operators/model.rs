//! The hysteresis and creep model `W = S[H + C]`, equations (4) and (6), and
//! its file form (`docs/FILES.md`).
//!
//! `W[v]_k = S[H[v]_k + C[v]_k]` (plus an optional constant output offset, a
//! measurement's sensor offset): `W` maps the balanced patch voltage `u` (V) to
//! the effective voltage (V) that drives the linear beam. `creep` may be absent
//! (pure hysteresis), and so may `superposition` (`S` the identity: the
//! paper's symmetric model). A dead time of `delay` whole samples shifts the
//! output: `y_k = S[H + C]_{max(k−d, 0)} + offset`.

use serde::{Deserialize, Serialize};

use crate::error::ModelError;
use crate::operators::heap::Heap;
use crate::operators::traits::{ActuatorModel, Snapshot};
use crate::realtime::{
    CreepParameters, DynamicsParameters, HysteresisParameters, Model, ModelParameters, Real,
    Resonance, Storage, SuperpositionParameters,
};

/// `W = H + C + offset` in `f64` on the heap: what most programs use.
pub type HysteresisCreepModel = Model<f64, Heap>;

/// The hysteresis part of a model file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HysteresisData {
    pub thresholds: Vec<f64>,
    pub weights: Vec<f64>,
    /// `x_init` of (8) per play; absent means virgin.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub state: Option<Vec<f64>>,
    /// `β` (s): thresholds `r_i + β|u_k − u_{k−1}|/T_s`, `0 ≤ β < T_s`;
    /// absent means 0 (the paper's `H`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rate_gain: Option<f64>,
    /// The input of the sample before the first, which the first
    /// rate-dependent thresholds need; absent means not started (the first
    /// sample has no rate). Only with a `rate_gain`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub last_input: Option<f64>,
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

/// The superposition operator `S` of a model file (memory-free: no state).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SuperpositionData {
    pub thresholds: Vec<f64>,
    pub weights: Vec<f64>,
}

/// A first-order low-pass of a model file's dynamics.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LowPassData {
    /// Cut-off frequency (Hz).
    pub frequency: f64,
}

/// A resonance of a model file's dynamics.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ResonanceData {
    /// Natural frequency (Hz), below the Nyquist frequency.
    pub frequency: f64,
    /// Damping ratio, `0 < ζ < 1`.
    pub damping: f64,
}

/// The linear dynamics `G` after `S` of a model file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DynamicsData {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub low_pass: Option<LowPassData>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub resonance: Option<ResonanceData>,
    /// A delay of a fraction of a sample, `−0.5 < τ < 0.5`; absent means 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub delay_fraction: Option<f64>,
    /// The state of `G`: its last outputs (before the dead time and the
    /// offset), one per order of its denominator, then its last two inputs,
    /// each newest first; absent means not started (at rest on the first
    /// sample's value).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub state: Option<Vec<f64>>,
}

impl DynamicsData {
    pub fn parameters(&self) -> DynamicsParameters {
        DynamicsParameters {
            low_pass: self.low_pass.map(|l| l.frequency),
            resonance: self.resonance.map(|r| Resonance {
                frequency: r.frequency,
                damping: r.damping,
            }),
            delay_fraction: self.delay_fraction.unwrap_or(0.0),
        }
    }

    /// The file form of `parameters` (no state).
    pub fn of(parameters: &DynamicsParameters) -> Self {
        Self {
            low_pass: parameters
                .low_pass
                .map(|frequency| LowPassData { frequency }),
            resonance: parameters.resonance.map(|r| ResonanceData {
                frequency: r.frequency,
                damping: r.damping,
            }),
            delay_fraction: (parameters.delay_fraction != 0.0).then_some(parameters.delay_fraction),
            state: None,
        }
    }
}

/// A model file as it is stored (JSON).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelFile {
    pub sample_time: f64,
    pub hysteresis: HysteresisData,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub creep: Option<CreepData>,
    /// `S` after `H + C`; absent means the identity.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub superposition: Option<SuperpositionData>,
    /// Linear dynamics `G` after `S`; absent means none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dynamics: Option<DynamicsData>,
    /// Dead time `d` in whole samples: `y_k = G[S[H + C]]_{max(k−d, 0)} +
    /// offset`. Absent means 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub delay: Option<usize>,
    /// The `d` values of `S[H + C]` waiting in the dead time, oldest (the
    /// next output) first; absent means not started (the line fills with
    /// the first sample's value).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub delay_state: Option<Vec<f64>>,
    /// Constant output offset (unit of the output): `y = W[u] + offset`.
    /// Absent means 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub offset: Option<f64>,
}

impl ModelFile {
    /// The hysteresis part `H` alone, with its state: no creep, no
    /// superposition operator, no dead time, no offset.
    pub fn hysteresis_part(mut self) -> Self {
        (
            self.creep,
            self.superposition,
            self.dynamics,
            self.delay,
            self.delay_state,
            self.offset,
        ) = (None, None, None, None, None, None);
        self
    }

    /// The same model without `state` entries (virgin).
    pub fn without_state(mut self) -> Self {
        self.hysteresis.state = None;
        self.hysteresis.last_input = None;
        if let Some(c) = &mut self.creep {
            c.state = None;
        }
        if let Some(g) = &mut self.dynamics {
            g.state = None;
        }
        self.delay_state = None;
        self
    }
}

/// The complete state of a [`HysteresisCreepModel`].
#[derive(Debug, Clone, PartialEq)]
pub struct ModelState {
    pub hysteresis: Vec<f64>,
    pub creep: Option<Vec<Vec<f64>>>,
    /// The last outputs of the dynamics `G` (newest first); `None` before
    /// the first sample or without dynamics.
    pub dynamics: Option<Vec<f64>>,
    /// The values waiting in the dead time (oldest first); `None` before
    /// the first sample or without dead time.
    pub delay: Option<Vec<f64>>,
    /// The last input, which rate-dependent thresholds need; `None` before
    /// the first sample or without them.
    pub last_input: Option<f64>,
}

impl ModelFile {
    /// The parameters of the model (its states not included), borrowed, as
    /// the core's constructors and the bank take them.
    pub fn parameters(&self) -> ModelParameters<'_> {
        ModelParameters {
            sample_time: self.sample_time,
            hysteresis: HysteresisParameters {
                thresholds: &self.hysteresis.thresholds,
                weights: &self.hysteresis.weights,
            },
            creep: self.creep.as_ref().map(|c| CreepParameters {
                thresholds: &c.thresholds,
                weights: &c.weights,
                eigenvalues: &c.eigenvalues,
            }),
            superposition: self
                .superposition
                .as_ref()
                .map(|s| SuperpositionParameters {
                    thresholds: &s.thresholds,
                    weights: &s.weights,
                }),
            dynamics: self.dynamics.as_ref().map(DynamicsData::parameters),
            delay: self.delay.unwrap_or(0),
            offset: self.offset.unwrap_or(0.0),
            rate_gain: self.hysteresis.rate_gain.unwrap_or(0.0),
        }
    }

    /// The creep state flattened as the core takes it (`state[i * m + j]`),
    /// every row's length checked.
    pub(crate) fn creep_state_flat(&self) -> Result<Option<Vec<f64>>, ModelError> {
        let Some(c) = &self.creep else {
            return Ok(None);
        };
        let Some(rows) = &c.state else {
            return Ok(None);
        };
        let m = c.eigenvalues.len();
        crate::realtime::checks::check_length("creep.state", c.thresholds.len(), rows.len())?;
        for (i, row) in rows.iter().enumerate() {
            crate::realtime::checks::check_length("", m, row.len())
                .map_err(|e| e.named(&format!("creep.state[{i}]")))?;
        }
        Ok(Some(rows.iter().flatten().copied().collect()))
    }
}

impl<T: Real, S: Storage> Model<T, S> {
    /// Validate a model file and build the model in the file's state.
    pub fn from_file(file: &ModelFile) -> Result<Self, ModelError> {
        let mut model = Self::new(&file.parameters().validate()?)?;
        if let Some(x) = &file.hysteresis.state {
            model.hysteresis_mut().set_state(x)?;
        }
        model.set_last_input(file.hysteresis.last_input)?;
        if let (Some(state), Some(c)) = (file.creep_state_flat()?, model.creep_mut()) {
            c.set_state_flat(&state)?;
        }
        if let (Some(g), Some(data)) = (model.dynamics_mut(), &file.dynamics) {
            g.set_state(data.state.as_deref())?;
        }
        model
            .delay_line_mut()
            .set_state(file.delay_state.as_deref())?;
        Ok(model)
    }

    /// The model file of this model and its current state.
    pub fn to_file(&self) -> ModelFile {
        let f64s = |x: &[T]| x.iter().map(|v| v.to_f64()).collect::<Vec<f64>>();
        let h = self.hysteresis();
        let offset = self.offset().to_f64();
        ModelFile {
            sample_time: self.sample_time(),
            hysteresis: HysteresisData {
                thresholds: f64s(h.thresholds()),
                weights: f64s(h.weights()),
                state: Some(Snapshot::state(h)),
                rate_gain: self.rate_gain().map(|r| r.rate_gain()),
                last_input: self
                    .rate_gain()
                    .and_then(|r| r.last_input())
                    .map(|v| v.to_f64()),
            },
            creep: self.creep().map(|c| CreepData {
                thresholds: f64s(c.thresholds()),
                weights: f64s(c.weights()),
                eigenvalues: f64s(c.eigenvalues()),
                state: Some(Snapshot::state(c)),
            }),
            superposition: self.superposition().map(|s| SuperpositionData {
                thresholds: f64s(s.thresholds()),
                weights: f64s(s.weights()),
            }),
            dynamics: self.dynamics().map(|g| DynamicsData {
                state: self.dynamics_state(),
                ..DynamicsData::of(g.parameters())
            }),
            delay: (self.delay() != 0).then_some(self.delay()),
            delay_state: self.delay_state(),
            offset: (offset != 0.0).then_some(offset),
        }
    }

    /// The state of `G`: outputs, then inputs, newest first (`None`: not
    /// started, or no dynamics).
    pub fn dynamics_state(&self) -> Option<Vec<f64>> {
        let g = self.dynamics()?;
        let mut values = vec![T::ZERO; g.state_len()];
        g.state_into(&mut values)?;
        Some(values.iter().map(|v| v.to_f64()).collect())
    }

    /// The values waiting in the dead time, oldest first (`None`: not
    /// started, or no dead time).
    pub fn delay_state(&self) -> Option<Vec<f64>> {
        let line = self.delay_line();
        let mut values = vec![T::ZERO; line.len()];
        line.state_into(&mut values)?;
        (!values.is_empty()).then(|| values.iter().map(|v| v.to_f64()).collect())
    }
}

crate::operators::traits::operator_in_any_precision!(Model);

impl<T: Real, S: Storage> Snapshot for Model<T, S> {
    type State = ModelState;

    fn state(&self) -> ModelState {
        ModelState {
            hysteresis: Snapshot::state(self.hysteresis()),
            creep: self.creep().map(Snapshot::state),
            dynamics: self.dynamics_state(),
            delay: self.delay_state(),
            last_input: self
                .rate_gain()
                .and_then(|r| r.last_input())
                .map(|v| v.to_f64()),
        }
    }

    fn set_state(&mut self, state: &ModelState) -> Result<(), ModelError> {
        // the delay line and G checked first, on copies, so a refusal
        // changes nothing
        let mut line = self.delay_line().clone();
        line.set_state(state.delay.as_deref())?;
        let mut g = self.dynamics().copied();
        match &mut g {
            Some(g) => g.set_state(state.dynamics.as_deref())?,
            None if state.dynamics.is_none() => {}
            None => {
                return Err(ModelError::Inconsistent {
                    field: "dynamics.state".into(),
                    reason: "the model has no dynamics".into(),
                })
            }
        }
        self.check_last_input(state.last_input)?;
        self.set_memory_state(state)?;
        self.set_last_input(state.last_input)?;
        *self.delay_line_mut() = line;
        if let (Some(mine), Some(g)) = (self.dynamics_mut(), g) {
            *mine = g;
        }
        Ok(())
    }
}

impl<T: Real, S: Storage> Model<T, S> {
    fn set_memory_state(&mut self, state: &ModelState) -> Result<(), ModelError> {
        match (self.creep().cloned(), &state.creep) {
            (Some(mut trial), Some(s)) => {
                // validate both before changing either
                Snapshot::set_state(&mut trial, s)?;
                self.hysteresis_mut().set_state(&state.hysteresis)?;
                if let Some(c) = self.creep_mut() {
                    *c = trial;
                }
                Ok(())
            }
            (None, None) => Ok(self.hysteresis_mut().set_state(&state.hysteresis)?),
            _ => Err(ModelError::Inconsistent {
                field: "creep.state".into(),
                reason: "a creep state must be given exactly when the model has creep".into(),
            }),
        }
    }
}

impl<T: Real, S: Storage> ActuatorModel for Model<T, S> {}
