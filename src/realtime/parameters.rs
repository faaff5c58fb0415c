//! The parameters of `W = S[H + C] + offset` (4), (6), borrowed from the
//! caller, and the admissibility conditions (11), (12), (17), (18) and those
//! of the superposition operator `S` every constructor checks (the `std`
//! operators use the same checks).

use crate::limits;
use crate::realtime::dynamics::DynamicsParameters;
use crate::realtime::error::ParameterError;

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

impl ModelParameters<'_> {
    /// Every condition on the parameters, the first one broken named.
    pub fn validate(&self) -> Result<(), ParameterError> {
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
        check_finite("offset", core::slice::from_ref(&self.offset))
    }
}

pub(crate) fn check_finite(field: &'static str, values: &[f64]) -> Result<(), ParameterError> {
    match values.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(ParameterError::NonFinite {
            field,
            index,
            value: values[index],
        }),
        None => Ok(()),
    }
}

pub(crate) fn check_length(
    field: &'static str,
    expected: usize,
    found: usize,
) -> Result<(), ParameterError> {
    if expected == found {
        Ok(())
    } else {
        Err(ParameterError::LengthMismatch {
            field,
            expected,
            found,
        })
    }
}

pub(crate) fn check_capacity(
    field: &'static str,
    capacity: usize,
    found: usize,
) -> Result<(), ParameterError> {
    if found <= capacity {
        Ok(())
    } else {
        Err(ParameterError::ExceedsCapacity {
            field,
            capacity,
            found,
        })
    }
}

/// (12)/(18): not empty, finite, `r_0 = 0`, strictly increasing.
pub(crate) fn check_thresholds(field: &'static str, r: &[f64]) -> Result<(), ParameterError> {
    if r.is_empty() {
        return Err(ParameterError::Empty { field });
    }
    check_finite(field, r)?;
    if r[0] != 0.0 {
        return Err(ParameterError::FirstThresholdNotZero { field, value: r[0] });
    }
    check_increasing(field, r)
}

/// Strictly increasing.
fn check_increasing(field: &'static str, r: &[f64]) -> Result<(), ParameterError> {
    for i in 1..r.len() {
        if r[i] <= r[i - 1] {
            return Err(ParameterError::ThresholdsNotIncreasing {
                field,
                index: i,
                previous: r[i - 1],
                value: r[i],
            });
        }
    }
    Ok(())
}

/// One threshold (a single play or creep operator): finite and `>= 0`.
#[cfg_attr(not(feature = "std"), allow(dead_code))] // used by the single-threshold std operators
pub(crate) fn check_threshold(field: &'static str, value: f64) -> Result<(), ParameterError> {
    if value.is_finite() && value >= 0.0 {
        Ok(())
    } else {
        Err(ParameterError::InvalidThreshold { field, value })
    }
}

/// (11) when `strict` (every partial sum `> 0`), else (17) (`≥ 0`).
pub(crate) fn check_partial_sums(
    field: &'static str,
    w: &[f64],
    strict: bool,
) -> Result<(), ParameterError> {
    let mut sum = 0.0;
    for (index, &wi) in w.iter().enumerate() {
        sum += wi;
        if strict && sum <= 0.0 {
            return Err(ParameterError::PartialSumNotPositive { field, index, sum });
        }
        if !strict && sum < 0.0 {
            return Err(ParameterError::PartialSumNegative { field, index, sum });
        }
    }
    Ok(())
}

/// Creep eigenvalues: at least one, each finite and `> 0`.
pub(crate) fn check_eigenvalues(field: &'static str, a: &[f64]) -> Result<(), ParameterError> {
    if a.is_empty() {
        return Err(ParameterError::Empty { field });
    }
    for (index, &value) in a.iter().enumerate() {
        if !(value.is_finite() && value > 0.0) {
            return Err(ParameterError::NonPositiveEigenvalue {
                field,
                index,
                value,
            });
        }
    }
    Ok(())
}

pub(crate) fn check_sample_time(sample_time: f64) -> Result<(), ParameterError> {
    if sample_time.is_finite() && sample_time > 0.0 {
        Ok(())
    } else {
        Err(ParameterError::NonPositiveSampleTime { value: sample_time })
    }
}

/// Saturation limits `lower < upper` (either may be infinite, neither NaN).
pub(crate) fn check_limits(lower: f64, upper: f64) -> Result<(), ParameterError> {
    if lower < upper {
        Ok(())
    } else {
        Err(ParameterError::InvalidLimits { lower, upper })
    }
}

/// A play state `x` reachable from the virgin state:
/// `|x_i − x_{i−1}| ≤ r_i − r_{i−1}`, allowing the rounding the clamps and
/// (22) make, `8 (n+1) ε (max|x| + r_n)` with the `ε` of the precision `r`
/// was stored in (thresholds rounded to `f32` move by `ε₃₂/2` relative).
/// Lengths must already agree.
pub(crate) fn check_admissible(
    field: &'static str,
    r: &[f64],
    x: &[f64],
    eps: f64,
) -> Result<(), ParameterError> {
    let n = r.len();
    let scale = x.iter().fold(0.0f64, |m, v| m.max(v.abs())) + r[n - 1];
    let tol = 8.0 * n as f64 * eps * scale;
    for i in 1..n {
        let gap = (x[i] - x[i - 1]).abs();
        let allowed = r[i] - r[i - 1];
        if gap > allowed + tol {
            return Err(ParameterError::InadmissibleState {
                field,
                index: i,
                gap,
                allowed,
            });
        }
    }
    Ok(())
}
