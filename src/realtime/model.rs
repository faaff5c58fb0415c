//! The actuator model `W[v] = S[H[v] + C[v]] + offset` (4), (6): `W` maps
//! the balanced patch voltage `u` (V) to the effective voltage that drives
//! the linear beam; the offset is a measurement's sensor offset. `C` may be
//! absent (pure hysteresis), and so may the superposition operator `S` (the
//! identity: the paper's symmetric model `H + C + offset`). The output may
//! pass linear dynamics `G` ([`Dynamics`]: a low-pass, a resonance) and be
//! delayed by a dead time of `d` whole samples ([`DelayLine`]):
//! `y_k = G[S[H + C]]_{max(k−d, 0)} + offset`. `H`'s thresholds may grow
//! with the input's rate ([`RateGain`]).

use crate::realtime::checks::check_finite;
use crate::realtime::creep::Creep;
use crate::realtime::delay::DelayLine;
use crate::realtime::dynamics::Dynamics;
use crate::realtime::error::ParameterError;
use crate::realtime::hysteresis::Hysteresis;
use crate::realtime::parameters::{
    Checked, CreepParameters, HysteresisParameters, ModelParameters,
};
use crate::realtime::rate::RateGain;
use crate::realtime::real::Real;
use crate::realtime::storage::Storage;
use crate::realtime::superposition::Superposition;

/// `W = S[H + C] + offset` (6) in `T`, kept in storage `S`.
#[derive(Debug, Clone, PartialEq)]
pub struct Model<T: Real, S: Storage> {
    sample_time: f64,
    offset: T,
    hysteresis: Hysteresis<T, S>,
    /// `None`: `β = 0`, the paper's `H`.
    rate: Option<RateGain<T>>,
    creep: Option<Creep<T, S>>,
    superposition: Option<Superposition<T, S>>,
    dynamics: Option<Dynamics<T>>,
    delay: DelayLine<T, S>,
}

impl<T: Real, S: Storage> Model<T, S> {
    /// `W` of checked parameters ([`ModelParameters::validate`]), in the
    /// virgin state.
    pub fn new(parameters: &Checked<ModelParameters<'_>>) -> Result<Self, ParameterError> {
        let p = parameters.get();
        let ts = p.sample_time;
        Ok(Self {
            sample_time: ts,
            offset: T::from_f64(p.offset),
            hysteresis: Hysteresis::from_trusted(
                p.hysteresis.thresholds,
                p.hysteresis.weights,
                None,
            )?,
            rate: (p.rate_gain != 0.0).then(|| RateGain::new(p.rate_gain, ts)),
            creep: p.creep.as_ref().map(|c| Creep::build(c, ts)).transpose()?,
            superposition: p
                .superposition
                .as_ref()
                .map(Superposition::build)
                .transpose()?,
            dynamics: p.dynamics.as_ref().map(|g| Dynamics::build(g, ts)),
            delay: DelayLine::new(p.delay)?,
        })
    }

    /// The same model with the superposition operator `S` after `H + C`.
    pub fn with_superposition(mut self, superposition: Option<Superposition<T, S>>) -> Self {
        self.superposition = superposition;
        self
    }

    /// The same model with linear dynamics `G` after `S` (not started;
    /// `None`: none).
    pub fn with_dynamics(
        mut self,
        dynamics: Option<&crate::realtime::DynamicsParameters>,
    ) -> Result<Self, ParameterError> {
        self.dynamics = dynamics
            .map(|g| Dynamics::new(g, self.sample_time))
            .transpose()?;
        Ok(self)
    }

    /// The same model with its output delayed by `d` samples (not started).
    pub fn with_delay(mut self, d: usize) -> Result<Self, ParameterError> {
        self.delay = DelayLine::new(d)?;
        Ok(self)
    }

    /// The same model with output offset `offset` (finite): `y = W[u] +
    /// offset`.
    pub fn with_offset(mut self, offset: f64) -> Result<Self, ParameterError> {
        check_finite("offset", core::slice::from_ref(&offset))?;
        self.offset = T::from_f64(offset);
        Ok(self)
    }

    /// Sample time `T_s` (s).
    pub fn sample_time(&self) -> f64 {
        self.sample_time
    }

    /// The output offset.
    pub fn offset(&self) -> T {
        self.offset
    }

    /// The hysteresis operator `H`.
    pub fn hysteresis(&self) -> &Hysteresis<T, S> {
        &self.hysteresis
    }

    pub fn hysteresis_mut(&mut self) -> &mut Hysteresis<T, S> {
        &mut self.hysteresis
    }

    /// The rate dependence of `H`'s thresholds, if any (`β ≠ 0`).
    pub fn rate_gain(&self) -> Option<&RateGain<T>> {
        self.rate.as_ref()
    }

    /// Set the input of the last sample, which the rate-dependent
    /// thresholds need (`None`: not started); without them only `None` is
    /// taken.
    pub fn set_last_input(&mut self, last: Option<f64>) -> Result<(), ParameterError> {
        self.check_last_input(last)?;
        if let Some(rate) = &mut self.rate {
            rate.set_last_input(last.map(T::from_f64));
        }
        Ok(())
    }

    /// Whether [`Self::set_last_input`] takes `last`.
    pub fn check_last_input(&self, last: Option<f64>) -> Result<(), ParameterError> {
        let field = "hysteresis.last_input";
        match last {
            None => Ok(()),
            Some(_) if self.rate.is_none() => Err(ParameterError::Unsupported {
                field,
                reason: "only a model with a rate gain keeps its last input",
            }),
            Some(v) => check_finite(field, core::slice::from_ref(&v)),
        }
    }

    /// The creep operator `C`, if any.
    pub fn creep(&self) -> Option<&Creep<T, S>> {
        self.creep.as_ref()
    }

    pub fn creep_mut(&mut self) -> Option<&mut Creep<T, S>> {
        self.creep.as_mut()
    }

    /// The superposition operator `S`, if any (none: the identity).
    pub fn superposition(&self) -> Option<&Superposition<T, S>> {
        self.superposition.as_ref()
    }

    /// The linear dynamics `G` after `S`, if any.
    pub fn dynamics(&self) -> Option<&Dynamics<T>> {
        self.dynamics.as_ref()
    }

    pub fn dynamics_mut(&mut self) -> Option<&mut Dynamics<T>> {
        self.dynamics.as_mut()
    }

    /// The dead time `d` (samples).
    pub fn delay(&self) -> usize {
        self.delay.len()
    }

    /// The samples a compensator's target must lead the output by: the
    /// dead time and the lag of the dynamics (`d + ρ`).
    pub fn preview(&self) -> usize {
        self.delay.len() + self.dynamics.as_ref().map_or(0, |g| g.lag())
    }

    /// The dead time's line: the last `d` values of `S[H + C]`.
    pub fn delay_line(&self) -> &DelayLine<T, S> {
        &self.delay
    }

    pub fn delay_line_mut(&mut self) -> &mut DelayLine<T, S> {
        &mut self.delay
    }

    /// Set the play states of `H` and (flattened, `state[i * m + j]`) the
    /// creep states; both are checked before either changes. `creep: None`
    /// leaves `C` in its zero state. (With `std`, `Snapshot::set_state`
    /// takes the model file's rows instead.)
    pub fn set_state_flat(
        &mut self,
        hysteresis: &[f64],
        creep: Option<&[f64]>,
    ) -> Result<(), ParameterError> {
        let mut h = self.hysteresis.clone();
        h.set_state(hysteresis)?;
        let mut c = self.creep.clone();
        match (&mut c, creep) {
            (Some(c), Some(state)) => c.set_state_flat(state)?,
            (Some(c), None) => c.reset(),
            (None, None) => {}
            (None, Some(state)) => {
                return Err(ParameterError::LengthMismatch {
                    field: "creep.state",
                    expected: 0,
                    found: state.len(),
                })
            }
        }
        self.hysteresis = h;
        self.creep = c;
        Ok(())
    }

    /// One sample of `W`. A non-finite input is taken as the previous input
    /// held: the plays do not move, the creep advances with the held value.
    #[inline]
    pub fn step(&mut self, v: T) -> T {
        let v = if v.is_finite() {
            v
        } else {
            self.rate
                .and_then(|r| r.last_input())
                .unwrap_or(self.hysteresis.play_states()[0])
        };
        let h = match &mut self.rate {
            None => self.hysteresis.step(v),
            Some(rate) => {
                let widening = rate.widen(v);
                self.hysteresis.step_widened(v, widening)
            }
        };
        let w = match &mut self.creep {
            Some(c) => h + c.step(v),
            None => h,
        };
        let w = match &self.superposition {
            Some(s) => s.apply(w),
            None => w,
        };
        let w = match &mut self.dynamics {
            Some(g) => g.step(w),
            None => w,
        };
        self.delay.step(w) + self.offset
    }

    /// Back to the virgin state.
    pub fn reset(&mut self) {
        self.delay.reset();
        if let Some(g) = &mut self.dynamics {
            g.reset();
        }
        self.hysteresis.reset();
        if let Some(r) = &mut self.rate {
            r.reset();
        }
        if let Some(c) = &mut self.creep {
            c.reset();
        }
    }
}

impl<S: Storage> Model<f64, S> {
    /// The parameters of the model (its state not included), borrowed: what
    /// a compensator, a bank or another storage is built from. A model is
    /// valid by construction, so they are [`Checked`].
    pub fn parameters(&self) -> Checked<ModelParameters<'_>> {
        Checked::trusted(ModelParameters {
            sample_time: self.sample_time,
            hysteresis: HysteresisParameters {
                thresholds: self.hysteresis.thresholds(),
                weights: self.hysteresis.weights(),
            },
            creep: self.creep.as_ref().map(|c| CreepParameters {
                thresholds: c.thresholds(),
                weights: c.weights(),
                eigenvalues: c.eigenvalues(),
            }),
            superposition: self.superposition.as_ref().map(|s| s.parameters()),
            dynamics: self.dynamics.as_ref().map(|g| *g.parameters()),
            delay: self.delay.len(),
            offset: self.offset,
            rate_gain: self.rate.map_or(0.0, |r| r.rate_gain()),
        })
    }
}
