//! The parameters of `W = S[H + C] + offset` (4), (6), borrowed from the
//! caller, and the admissibility conditions (11), (12), (17), (18) and those
//! of the superposition operator `S` every constructor checks (the `std`
//! operators use the same checks).

use crate::realtime::checks::{
    check_eigenvalues, check_finite, check_increasing, check_length, check_partial_sums,
    check_sample_time, check_thresholds,
};
use crate::realtime::dynamics::DynamicsParameters;
use crate::realtime::error::ParameterError;
use crate::realtime::limits;

/// `H` (10): thresholds `0 = r_0 < … < r_n` (12), weights with positive
/// partial sums (11).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HysteresisParameters<'a> {
    pub thresholds: &'a [f64],
    pub weights: &'a [f64],
}

/// `C` (16): thresholds as (18), weights with non-negative partial sums (17),
/// eigenvalues `a_j > 0` (s⁻¹) of the log(t)-creep operators (15).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CreepParameters<'a> {
    pub thresholds: &'a [f64],
    pub weights: &'a [f64],
    pub eigenvalues: &'a [f64],
}

/// The superposition operator `S[z] = Σ_i w_i d_{r_i}(z)` (Kuhnen's modified
/// PI operator): thresholds strictly increasing with exactly one equal to 0,
/// and weights whose sums from the zero threshold outward, on each side,
/// are positive (the slopes of `S`, so that `S` is strictly increasing).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SuperpositionParameters<'a> {
    pub thresholds: &'a [f64],
    pub weights: &'a [f64],
}

/// The model `W[v] = S[H[v] + C[v]] + offset` at sample time `T_s`, in the
/// virgin state, its output delayed by `delay` whole samples; without `S`
/// (`None`, the identity) and delay it is the paper's `H + C + offset`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModelParameters<'a> {
    pub sample_time: f64,
    pub hysteresis: HysteresisParameters<'a>,
    pub creep: Option<CreepParameters<'a>>,
    pub superposition: Option<SuperpositionParameters<'a>>,
    /// Linear dynamics `G` after `S` (`None`: the identity):
    /// `y = G[S[H + C]]`, delayed, plus the offset.
    pub dynamics: Option<DynamicsParameters>,
    /// Dead time `d` (samples): `y_k = G[S[H + C]]_{max(k−d, 0)} + offset`.
    pub delay: usize,
    pub offset: f64,
    /// `β` (s) of `H`'s rate-dependent thresholds `r_i + β|v_k − v_{k−1}|/T_s`
    /// ([`crate::realtime::rate`]), `0 ≤ β < T_s`; 0: the paper's `H`.
    pub rate_gain: f64,
}

impl HysteresisParameters<'_> {
    pub fn validate(&self) -> Result<(), ParameterError> {
        let field = "hysteresis.thresholds";
        limits::check(field, limits::MAX_PLAYS, self.thresholds.len())?;
        check_thresholds(field, self.thresholds)?;
        check_finite("hysteresis.weights", self.weights)?;
        check_length(
            "hysteresis.weights",
            self.thresholds.len(),
            self.weights.len(),
        )?;
        check_partial_sums("hysteresis.weights", self.weights, true)
    }
}

impl CreepParameters<'_> {
    pub fn validate(&self, sample_time: f64) -> Result<(), ParameterError> {
        let (n, m) = (self.thresholds.len(), self.eigenvalues.len());
        limits::check("creep.thresholds", limits::MAX_CREEP_THRESHOLDS, n)?;
        limits::check("creep.eigenvalues", limits::MAX_CREEP_EIGENVALUES, m)?;
        limits::check(
            "creep (thresholds × eigenvalues)",
            limits::MAX_CREEP_ELEMENTS,
            n.saturating_mul(m),
        )?;
        check_thresholds("creep.thresholds", self.thresholds)?;
        check_finite("creep.weights", self.weights)?;
        check_length("creep.weights", self.thresholds.len(), self.weights.len())?;
        check_partial_sums("creep.weights", self.weights, false)?;
        check_eigenvalues("creep.eigenvalues", self.eigenvalues)?;
        check_sample_time(sample_time)
    }
}

impl SuperpositionParameters<'_> {
    pub fn validate(&self) -> Result<(), ParameterError> {
        let field = "superposition.thresholds";
        let r = self.thresholds;
        limits::check(field, limits::MAX_SUPERPOSITION_TERMS, r.len())?;
        if r.is_empty() {
            return Err(ParameterError::Empty { field });
        }
        check_finite(field, r)?;
        check_increasing(field, r)?;
        let zero = zero_index(r).ok_or(ParameterError::NoZeroThreshold { field })?;
        let field = "superposition.weights";
        check_finite(field, self.weights)?;
        check_length(field, r.len(), self.weights.len())?;
        // the slope on each segment: the weights summed outward from r = 0
        let slope = |indices: &mut dyn Iterator<Item = usize>| {
            let mut sum = 0.0;
            for index in indices {
                sum += self.weights[index];
                if sum <= 0.0 {
                    return Err(ParameterError::SlopeNotPositive { field, index, sum });
                }
            }
            Ok(())
        };
        slope(&mut (zero..r.len()))?;
        slope(&mut core::iter::once(zero).chain((0..zero).rev()))
    }
}

/// The index of the zero threshold of a superposition operator.
pub(crate) fn zero_index(thresholds: &[f64]) -> Option<usize> {
    thresholds.iter().position(|&r| r == 0.0)
}

/// A value that has passed its `validate()`: what the constructors take,
/// so that each input is checked once, at the boundary, and nothing built
/// from it checks it again.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Checked<P>(P);

impl<P> Checked<P> {
    /// A value checked already: the parameters of something built from
    /// checked ones.
    pub(crate) fn trusted(value: P) -> Self {
        Checked(value)
    }

    /// The checked value.
    pub fn get(&self) -> &P {
        &self.0
    }

    /// The value, no longer marked as checked.
    pub fn into_inner(self) -> P {
        self.0
    }
}

impl<P> core::ops::Deref for Checked<P> {
    type Target = P;
    fn deref(&self) -> &P {
        &self.0
    }
}

impl<'a> ModelParameters<'a> {
    /// Every condition on the parameters, the first one broken named; the
    /// parameters as [`Checked`] if none is, which is what `Model::new`
    /// and `Compensator::new` take.
    pub fn validate(&self) -> Result<Checked<ModelParameters<'a>>, ParameterError> {
        check_sample_time(self.sample_time)?;
        limits::check("delay", limits::MAX_DELAY, self.delay)?;
        self.hysteresis.validate()?;
        if let Some(c) = &self.creep {
            c.validate(self.sample_time)?;
        }
        if let Some(s) = &self.superposition {
            s.validate()?;
        }
        if let Some(g) = &self.dynamics {
            g.validate(self.sample_time)?;
        }
        check_finite("offset", core::slice::from_ref(&self.offset))?;
        if !(self.rate_gain >= 0.0 && self.rate_gain < self.sample_time) {
            return Err(ParameterError::OutOfHalfOpenRange {
                field: "hysteresis.rate_gain",
                value: self.rate_gain,
                lower: 0.0,
                upper: self.sample_time,
            });
        }
        Ok(Checked(*self))
    }
}
