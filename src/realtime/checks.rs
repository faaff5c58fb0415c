//! The elementary conditions every parameter and state is checked
//! against, each returning the [`ParameterError`] that names the field: the
//! finite values, lengths and capacities, the thresholds (12), (18), the
//! partial sums (11), (17), the eigenvalues, the sample time, the output
//! limits and the admissible play states.

use crate::realtime::error::ParameterError;

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
pub(crate) fn check_increasing(field: &'static str, r: &[f64]) -> Result<(), ParameterError> {
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
