//! The explicit compensator (21), textbook form.

use super::{
    clip, lag_of, naive_parts, naive_superposition, NaiveCreep, NaiveDynamics, NaiveHysteresis,
    NaiveSuperposition,
};
use crate::error::ModelError;
use crate::operators::compensator::CompensatorSettings;
use crate::operators::model::ModelFile;
use crate::operators::traits::{ActuatorCompensator, Compensated, Operator};

/// The compensator (21), textbook form: `v_k = H⁻¹[ς_k − C_k]`, clipped; the
/// forward plays follow the emitted value, and after a clipped sample the
/// inverse is rebuilt from them by the direct sums of (22).
#[derive(Debug, Clone, PartialEq)]
pub struct NaiveCompensator {
    settings: CompensatorSettings,
    initial: (NaiveHysteresis, Option<NaiveCreep>),
    forward: NaiveHysteresis,
    inverse: NaiveHysteresis,
    creep: Option<NaiveCreep>,
    superposition: Option<NaiveSuperposition>,
    dynamics: Option<NaiveDynamics>,
    offset: f64,
    delay: usize,
    last_request: f64,
}

impl NaiveCompensator {
    /// The unclipped value `H⁻¹[ς_k − C_k]` of the last sample.
    pub fn last_request(&self) -> f64 {
        self.last_request
    }

    /// From a model file (validated), with matched states.
    pub fn from_file(file: &ModelFile, settings: CompensatorSettings) -> Result<Self, ModelError> {
        settings.validate()?;
        let (forward, creep) = naive_parts(file)?;
        Ok(Self {
            settings,
            inverse: forward.inverse(),
            initial: (forward.clone(), creep.clone()),
            forward,
            creep,
            superposition: naive_superposition(file),
            // what the target leads by, the compensator's G leads by
            dynamics: NaiveDynamics::of(file).map(|g| g.ahead()),
            offset: file.offset.unwrap_or(0.0),
            delay: file.delay.unwrap_or(0) + lag_of(file),
            last_request: 0.0,
        })
    }
}

impl ActuatorCompensator for NaiveCompensator {
    fn compensate(&mut self, target: f64) -> Compensated {
        if !target.is_finite() {
            // hold the previous output; the creep advances with it
            let u = self.forward.x[0];
            let c = self.creep.as_ref().map_or(0.0, NaiveCreep::output);
            self.advance_dynamics(self.forward.evaluate(u) + c);
            if let Some(cr) = &mut self.creep {
                cr.advance(u);
            }
            return Compensated {
                u,
                saturated: false,
                fault: true,
            };
        }
        let c = self.creep.as_ref().map_or(0.0, NaiveCreep::output);
        let (g_in, g_outputs) = match &self.dynamics {
            Some(g) => g.input_for(target - self.offset),
            None => (target - self.offset, Vec::new()),
        };
        let y = match &self.superposition {
            Some(s) => s.invert(g_in),
            None => g_in,
        };
        let v = self.inverse.step(y - c);
        self.last_request = v;
        let (u, saturated) = clip(v, &self.settings);
        let h = self.forward.step(u);
        if saturated {
            self.inverse = self.forward.inverse();
            self.advance_dynamics(h + c);
        } else if let Some(g) = &mut self.dynamics {
            g.push_exact(g_in, &g_outputs);
        }
        if let Some(cr) = &mut self.creep {
            cr.advance(u);
        }
        Compensated {
            u,
            saturated,
            fault: false,
        }
    }

    fn delay(&self) -> usize {
        self.delay
    }

    fn reset(&mut self) {
        let (mut h, mut c) = self.initial.clone();
        h.reset();
        if let Some(c) = &mut c {
            c.reset();
        }
        self.inverse = h.inverse();
        self.forward = h;
        self.creep = c;
        if let Some(g) = &mut self.dynamics {
            g.reset();
        }
    }
}

impl NaiveCompensator {
    /// `G` advanced with what the plant produces from `H + C = z`.
    fn advance_dynamics(&mut self, z: f64) {
        if let Some(g) = &mut self.dynamics {
            let w = match &self.superposition {
                Some(s) => s.evaluate(z),
                None => z,
            };
            g.push_input(w);
        }
    }
}
