//! The sampled closed loop (`docs/MATHEMATICS.md` §11.1): the true actuator
//! `W` (its own model), the beam with a tip force and sensor noise, the
//! supply limits (1), and the controller's compensator `W⁻¹` of *its*
//! model. Per step `k`, in this order:
//!
//! 1. `y_k = cᵀx_k` (the state before `u_k` acts), `m_k = y_k + n_k`;
//! 2. the controller returns `Δ_k` from `(k, t_k, y_d,k, m_k)`; nothing or a
//!    non-finite value holds the last valid `Δ` (0 before the first) and is
//!    flagged;
//! 3. `ς_k = u_d,k + Δ_k`, `u_k = W⁻¹[ς_k]` clipped to the balanced supply
//!    range, patch voltages `ū ± u_k`;
//! 4. `w_k = W[u_k]`; `x_{k+1} = Φx_k + Γ_w w_k + Γ_F F_k` (exact
//!    zero-order hold of the modal model, the tip force entering through the
//!    tip's mode shapes: a point force at the tip has the modal input `Vᵀc`).
//!
//! The beam starts at rest, the actuator and compensator from their models'
//! states.

use std::time::Instant;

use super::{ControlError, Controller, LoopSample};
use crate::beam::modal::ModalModel;
use crate::beam::simulation::DiscreteBeam;
use crate::operators::compensator::CompensatorSettings;
use crate::operators::model::HysteresisCreepModel;
use crate::operators::supply::Supply;

/// Everything a loop runs on. Every signal has one value per sample.
#[derive(Debug, Clone)]
pub struct LoopSetup {
    /// The true actuator `W`.
    pub plant: HysteresisCreepModel,
    /// The model whose `W⁻¹` the controller uses.
    pub model: HysteresisCreepModel,
    /// The beam.
    pub beam: ModalModel,
    /// Sample time `T_s` (s).
    pub sample_time: f64,
    /// Reference `y_d,k` (m).
    pub reference: Vec<f64>,
    /// Feedforward `u_d,k` (effective V).
    pub feedforward: Vec<f64>,
    /// Tip force `F_k` (N), held over the sample.
    pub force: Vec<f64>,
    /// Sensor noise `n_k` (m).
    pub noise: Vec<f64>,
    /// The patch supply.
    pub supply: Supply,
}

/// One run of the loop, a value per sample.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LoopTrace {
    pub t: Vec<f64>,
    pub reference: Vec<f64>,
    pub feedforward: Vec<f64>,
    pub force: Vec<f64>,
    pub noise: Vec<f64>,
    /// `m_k` as the controller saw it.
    pub measurement: Vec<f64>,
    /// `Δ_k` applied (after holding).
    pub correction: Vec<f64>,
    /// Whether the controller's answer was held (nothing or not finite).
    pub held: Vec<bool>,
    /// Balanced voltage `u_k`.
    pub u: Vec<f64>,
    /// Whether `u_k` was clipped to the supply.
    pub saturated: Vec<bool>,
    pub u_fs: Vec<f64>,
    pub u_bs: Vec<f64>,
    /// Effective voltage `w_k = W[u_k]`.
    pub w: Vec<f64>,
    /// True tip deflection `y_k` (m).
    pub tip: Vec<f64>,
    /// Wall-clock time of each controller step (s).
    pub compute_time: Vec<f64>,
}

impl LoopSetup {
    /// Length and finiteness of the signals, agreeing sample times, and a
    /// compensator without preview.
    pub fn validate(&self) -> Result<(), ControlError> {
        let n = self.reference.len();
        for (field, v) in [
            ("reference", &self.reference),
            ("feedforward", &self.feedforward),
            ("force", &self.force),
            ("noise", &self.noise),
        ] {
            if v.len() != n {
                return Err(ControlError::Invalid {
                    field,
                    reason: format!("has {} samples, the reference {n}", v.len()),
                });
            }
            if let Some(k) = v.iter().position(|x| !x.is_finite()) {
                return Err(ControlError::Invalid {
                    field,
                    reason: format!("sample {k} is {}", v[k]),
                });
            }
        }
        let ts = self.sample_time;
        for (field, t) in [
            ("plant.sample_time", self.plant.sample_time()),
            ("model.sample_time", self.model.sample_time()),
        ] {
            if (t - ts).abs() > 1e-12 * ts {
                return Err(ControlError::Invalid {
                    field,
                    reason: format!("{t} s differs from the loop's {ts} s"),
                });
            }
        }
        let preview = self.model.preview();
        if preview != 0 {
            return Err(ControlError::Invalid {
                field: "model",
                reason: format!(
                    "its compensator needs a preview of {preview} samples (dead time or \
                     dynamics), which feedback cannot give"
                ),
            });
        }
        Ok(())
    }
}

/// Run the loop with `controller`.
pub fn run_loop(
    setup: &LoopSetup,
    controller: &mut dyn Controller,
) -> Result<LoopTrace, ControlError> {
    setup.validate()?;
    let ts = setup.sample_time;
    let (lower, upper) = setup.supply.balanced_limits();
    let mut comp = setup
        .model
        .compensator(CompensatorSettings::with_limits(lower, upper))?;
    let mut actuator = setup.plant.clone();
    let mut beam = DiscreteBeam::new(&setup.beam, ts)?;
    let tip_force = ModalModel {
        input: setup.beam.output.clone(),
        ..setup.beam.clone()
    };
    let mut load = DiscreteBeam::new(&tip_force, ts)?;
    let n = setup.reference.len();
    let mut tr = LoopTrace {
        t: (0..n).map(|k| k as f64 * ts).collect(),
        reference: setup.reference.clone(),
        feedforward: setup.feedforward.clone(),
        force: setup.force.clone(),
        noise: setup.noise.clone(),
        measurement: Vec::with_capacity(n),
        correction: Vec::with_capacity(n),
        held: Vec::with_capacity(n),
        u: Vec::with_capacity(n),
        saturated: Vec::with_capacity(n),
        u_fs: Vec::with_capacity(n),
        u_bs: Vec::with_capacity(n),
        w: Vec::with_capacity(n),
        tip: Vec::with_capacity(n),
        compute_time: Vec::with_capacity(n),
    };
    let mut last = 0.0;
    let name = controller.name();
    for k in 0..n {
        let y = beam.output() + load.output();
        let m = y + setup.noise[k];
        let sample = LoopSample {
            k,
            t: tr.t[k],
            reference: setup.reference[k],
            measurement: m,
        };
        let start = Instant::now();
        let answer = controller.step(&sample).map_err(|e| match e {
            ControlError::Controller { .. } => e,
            other => ControlError::Controller {
                name: name.clone(),
                reason: format!("at sample {k}: {other}"),
            },
        })?;
        tr.compute_time.push(start.elapsed().as_secs_f64());
        let (correction, held) = match answer {
            Some(v) if v.is_finite() => (v, false),
            _ => (last, true),
        };
        last = correction;
        let c = comp.compensate(setup.feedforward[k] + correction);
        let (p, _) = setup.supply.patch_voltages_saturating(c.u);
        let w = actuator.step(c.u);
        beam.step(w);
        load.step(setup.force[k]);
        tr.measurement.push(m);
        tr.correction.push(correction);
        tr.held.push(held);
        tr.u.push(c.u);
        tr.saturated.push(c.saturated);
        tr.u_fs.push(p.front);
        tr.u_bs.push(p.back);
        tr.w.push(w);
        tr.tip.push(y);
    }
    Ok(tr)
}
