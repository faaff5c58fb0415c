//! The actuator model `W[v] = H[v] + C[v] + offset` (4), (6) in fixed-capacity
//! storage: what a test bench on the target runs the compensator against.

use crate::realtime::creep::FixedCreep;
use crate::realtime::error::ParameterError;
use crate::realtime::hysteresis::FixedHysteresis;
use crate::realtime::parameters::ModelParameters;
use crate::realtime::real::Real;

/// `W` with at most `N` plays and `K` elementary creep operators.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FixedModel<T: Real, const N: usize, const K: usize> {
    hysteresis: FixedHysteresis<T, N>,
    creep: Option<FixedCreep<T, K>>,
    offset: T,
}

impl<T: Real, const N: usize, const K: usize> FixedModel<T, N, K> {
    /// `W` with checked parameters, in the virgin state.
    pub fn new(parameters: &ModelParameters<'_>) -> Result<Self, ParameterError> {
        parameters.validate()?;
        Ok(Self {
            hysteresis: FixedHysteresis::new(&parameters.hysteresis)?,
            creep: match &parameters.creep {
                Some(c) => Some(FixedCreep::new(c, parameters.sample_time)?),
                None => None,
            },
            offset: T::from_f64(parameters.offset),
        })
    }

    pub fn hysteresis(&self) -> &FixedHysteresis<T, N> {
        &self.hysteresis
    }

    pub fn hysteresis_mut(&mut self) -> &mut FixedHysteresis<T, N> {
        &mut self.hysteresis
    }

    pub fn creep(&self) -> Option<&FixedCreep<T, K>> {
        self.creep.as_ref()
    }

    pub fn creep_mut(&mut self) -> Option<&mut FixedCreep<T, K>> {
        self.creep.as_mut()
    }

    pub fn offset(&self) -> T {
        self.offset
    }

    /// One sample of `W`; a non-finite input holds the last one.
    #[inline]
    pub fn step(&mut self, v: T) -> T {
        let v = if v.is_finite() {
            v
        } else {
            self.hysteresis.state()[0]
        };
        let h = self.hysteresis.step(v);
        let w = match &mut self.creep {
            Some(c) => h + c.step(v),
            None => h,
        };
        w + self.offset
    }

    pub fn reset(&mut self) {
        self.hysteresis.reset();
        if let Some(c) = &mut self.creep {
            c.reset();
        }
    }
}
