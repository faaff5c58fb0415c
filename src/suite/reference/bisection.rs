//! `W⁻¹` by bisection on the forward model: how a model without an
//! analytic inverse is compensated, and the peer the analytic inverse is
//! measured against.

use super::{NaiveCreep, NaiveDynamics, NaiveHysteresis, NaiveModel, NaiveSuperposition};
use crate::error::ModelError;
use crate::operators::compensator::CompensatorSettings;
use crate::operators::model::ModelFile;
use crate::operators::traits::{ActuatorCompensator, Compensated, Operator};

/// The forward map a bisection searches: `v ↦ S[H_state(v) + C_k]`, or
/// `H_state(v)` without `S`.
struct Forward<'a> {
    h: &'a NaiveHysteresis,
    c: f64,
    s: Option<&'a NaiveSuperposition>,
}

impl Forward<'_> {
    fn evaluate(&self, v: f64) -> f64 {
        match self.s {
            Some(s) => s.evaluate(self.h.evaluate(v) + self.c),
            None => self.h.evaluate(v),
        }
    }
}

/// A numerical inverse of `W`: each sample, bisection on the forward
/// operator for the `v` with `H_state[v] + C_k = ς_k` (`H` is strictly
/// increasing by (11)), then the forward state advances with it. This is how
/// a hysteresis model without an analytic inverse is compensated; here it is
/// the peer the analytic inverse (22) is measured against. Allocation-free.
#[derive(Debug, Clone, PartialEq)]
pub struct BisectionCompensator {
    settings: CompensatorSettings,
    model: NaiveModel,
    initial: NaiveModel,
    /// The model's `G` advanced by its lag (the target leads by it).
    ahead: Option<NaiveDynamics>,
    /// Bisection steps per sample (64 reach the last bit of a double).
    pub iterations: u32,
}

impl BisectionCompensator {
    /// From a model file (validated), with matched states.
    pub fn from_file(file: &ModelFile, settings: CompensatorSettings) -> Result<Self, ModelError> {
        settings.validate()?;
        let model = NaiveModel::from_file(file)?;
        Ok(Self {
            settings,
            initial: model.clone(),
            ahead: model.dynamics.as_ref().map(NaiveDynamics::ahead),
            model,
            iterations: 64,
        })
    }
}

impl ActuatorCompensator for BisectionCompensator {
    fn compensate(&mut self, target: f64) -> Compensated {
        if !target.is_finite() {
            let u = self.model.hysteresis.x[0];
            self.advance_ahead(u);
            self.model.step(u);
            return Compensated {
                u,
                saturated: false,
                fault: true,
            };
        }
        let c = self.model.creep.as_ref().map_or(0.0, NaiveCreep::output);
        let h = &self.model.hysteresis;
        // S[H(v) + C_k] = ς_k − offset; without S, H(v) = ς_k − offset − C_k
        let s = self.model.superposition.as_ref();
        // G's input that gives the target (ρ samples later)
        let t = match &self.ahead {
            Some(g) => g.input_for(target - self.model.offset).0,
            None => target - self.model.offset,
        };
        let goal = match s {
            Some(_) => t,
            None => t - c,
        };
        let h = Forward { h, c, s };
        // A bracket: the limits, or where they are infinite, doubling steps
        // away from the last input (the state of the play with r = 0).
        let centre = h.h.x.first().copied().unwrap_or(0.0);
        let mut lo = self.settings.lower_limit;
        if !lo.is_finite() {
            let mut width = 1.0f64;
            lo = centre - width;
            while h.evaluate(lo) > goal && width < 1e300 {
                width *= 2.0;
                lo = centre - width;
            }
        }
        let mut hi = self.settings.upper_limit;
        if !hi.is_finite() {
            let mut width = 1.0f64;
            hi = centre + width;
            while h.evaluate(hi) < goal && width < 1e300 {
                width *= 2.0;
                hi = centre + width;
            }
        }
        let (u, saturated) = if h.evaluate(lo) > goal {
            (lo, true)
        } else if h.evaluate(hi) < goal {
            (hi, true)
        } else {
            for _ in 0..self.iterations {
                let mid = 0.5 * (lo + hi);
                if mid <= lo || mid >= hi {
                    break;
                }
                if h.evaluate(mid) < goal {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            // the end of the final bracket whose output is nearer the goal
            if (h.evaluate(lo) - goal).abs() <= (h.evaluate(hi) - goal).abs() {
                (lo, false)
            } else {
                (hi, false)
            }
        };
        self.advance_ahead(u);
        self.model.step(u);
        Compensated {
            u,
            saturated,
            fault: false,
        }
    }

    fn delay(&self) -> usize {
        let lag = self
            .model
            .dynamics
            .as_ref()
            .map_or(0, |g| usize::from(g.lag.is_some()));
        self.model.delay + lag
    }

    fn reset(&mut self) {
        self.model = self.initial.clone();
        self.model.reset();
        if let Some(g) = &mut self.ahead {
            g.reset();
        }
    }
}

impl BisectionCompensator {
    /// The lag-ahead `G` advanced with what the plant makes of `u` (before
    /// the model steps: its creep output is this sample's).
    fn advance_ahead(&mut self, u: f64) {
        let Some(g) = &mut self.ahead else { return };
        let c = self.model.creep.as_ref().map_or(0.0, NaiveCreep::output);
        let z = self.model.hysteresis.evaluate(u) + c;
        let w = match &self.model.superposition {
            Some(s) => s.evaluate(z),
            None => z,
        };
        g.push_input(w);
    }
}
