//! What an identification takes: its settings with their defaults and
//! checks, the thresholds of (23), and what can go wrong.

use thiserror::Error;

use crate::error::ModelError;

/// What can go wrong in an identification.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum IdentificationError {
    /// `u` and `y` differ in length.
    #[error("u and y differ in length: {u} and {y} samples")]
    LengthMismatch { u: usize, y: usize },
    /// Not enough samples for the number of unknowns.
    #[error("too few samples: {found}, at least {needed} are needed for {unknowns} weights")]
    TooFewSamples {
        found: usize,
        needed: usize,
        unknowns: usize,
    },
    /// A NaN or infinite sample.
    #[error("{signal}[{index}]: {value} is not a finite number")]
    NonFinite {
        signal: &'static str,
        index: usize,
        value: f64,
    },
    /// The input never changes: nothing can be identified.
    #[error("the input is constant ({value}): it excites no operator")]
    ConstantInput { value: f64 },
    /// A setting is out of range.
    #[error("{field}: {reason}")]
    InvalidSetting { field: &'static str, reason: String },
    /// The active-set method did not converge (should not happen).
    #[error("the constrained least-squares problem was not solved: {reason}")]
    NotSolved { reason: String },
    /// The identified parameters do not form a valid model (should not happen).
    #[error(transparent)]
    Model(#[from] ModelError),
}

impl From<crate::realtime::ParameterError> for IdentificationError {
    fn from(e: crate::realtime::ParameterError) -> Self {
        Self::Model(e.into())
    }
}

/// Orders, thresholds, eigenvalues and margin of an identification.
#[derive(Debug, Clone, PartialEq)]
pub struct IdentificationSettings {
    /// Number of plays `n_H + 1` (default 12). Ignored if thresholds are given.
    pub hysteresis_operators: usize,
    /// Number of log(t)-creep operators `n_C + 1` (default 12; 0 for no creep).
    /// Ignored if creep thresholds are given.
    pub creep_operators: usize,
    /// Number of creep eigenvalues `m` (default 5). Ignored if eigenvalues are given.
    pub creep_eigenvalues: usize,
    /// Explicit hysteresis thresholds instead of (23).
    pub hysteresis_thresholds: Option<Vec<f64>>,
    /// Explicit creep thresholds instead of (23).
    pub creep_thresholds: Option<Vec<f64>>,
    /// Explicit creep eigenvalues (s⁻¹) instead of (24).
    pub eigenvalues: Option<Vec<f64>>,
    /// Margin `ε_H > 0` of the hysteresis partial sums; default
    /// `1e-3 · range(ς) / range(v)`.
    pub epsilon_h: Option<f64>,
    /// Fit an output offset (default true).
    pub fit_offset: bool,
    /// First sample fitted; default: the first at which `|v|` reaches
    /// `max|v|` (from there every play's state is known). `Some(0)` assumes
    /// the virgin state at the first sample.
    pub fit_from: Option<usize>,
    /// Samples at the end left out of the fit, for validation (default 0).
    pub holdout: usize,
    /// Dead zones per side of a superposition operator `S` after `H + C`
    /// (the modified PI model, fitted by Kuhnen's error model); 0 (the
    /// default) fits the paper's symmetric model.
    pub superposition: usize,
    /// Explicit kinks of `S⁻¹` on the output axis (the unit of `y`) instead
    /// of the rule ([`superposition_kinks`]); they must lie strictly inside
    /// the fitted output's range and differ from its mid-point.
    pub superposition_kinks: Option<Vec<f64>>,
    /// Dead time `d` (whole samples) between the input and the output
    /// (default 0); [`search_delay`](super::search_delay) chooses it.
    pub delay: usize,
    /// With several records ([`identify_records`](super::identify_records)):
    /// one output offset per record (default false: one for all).
    pub offset_per_record: bool,
    /// Known linear dynamics `G` after `S` (default none); the weights are
    /// then fitted to `y = G[S[H + C]]`.
    /// [`fit_dynamics`](super::fit_dynamics) finds `G`.
    pub dynamics: Option<crate::realtime::DynamicsParameters>,
    /// A penalty on the creep weights (default none).
    pub creep_regularisation: CreepRegularisation,
    /// `β` (s) of rate-dependent play thresholds `r_i + β|Δu|/T_s`,
    /// `0 ≤ β < T_s` (default 0: the paper's `H`). With `β > 0` the
    /// hysteresis weights are fitted non-negative (`w_0 ≥ ε_H`), which
    /// keeps the model's exact inverse;
    /// [`search_rate_gain`](super::search_rate_gain) chooses `β`.
    pub rate_gain: f64,
}

/// A penalty `λ s² ‖w_C‖²` on the creep weights, added to the squared
/// error of (25): `s²` is the mean squared creep column of the regressor,
/// so `λ` weighs the creep weights against the data without units. The
/// creep columns are nearly collinear (their eigenvalues are decades
/// apart on a short record), so least squares alone can give large
/// weights of opposite signs that cancel on the record and not after it.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[non_exhaustive]
pub enum CreepRegularisation {
    /// Least squares alone (`λ = 0`).
    #[default]
    None,
    /// This `λ ≥ 0`.
    Fixed(f64),
    /// `λ` minimising the generalized cross-validation score of the fitted
    /// samples, `N · RSS(λ) / (N − df(λ))²`, over `0` and `10⁻¹⁰ … 1` in
    /// half decades (`df`: the trace of the unconstrained fit's hat matrix).
    /// Chosen from the fitted record alone.
    Gcv,
}

impl std::str::FromStr for CreepRegularisation {
    type Err = String;

    /// `none`, `gcv`, or `λ` (a number at least 0).
    fn from_str(s: &str) -> Result<Self, String> {
        match s.trim() {
            "none" => Ok(Self::None),
            "gcv" => Ok(Self::Gcv),
            t => match t.parse::<f64>() {
                Ok(l) if l.is_finite() && l >= 0.0 => Ok(Self::Fixed(l)),
                _ => Err(format!(
                    "'{t}' is none of \"none\", \"gcv\" or a number at least 0"
                )),
            },
        }
    }
}

impl Default for IdentificationSettings {
    /// The paper's orders: 12 plays, 12 log(t)-creep operators, 5 eigenvalues.
    fn default() -> Self {
        Self {
            hysteresis_operators: 12,
            creep_operators: 12,
            creep_eigenvalues: 5,
            hysteresis_thresholds: None,
            creep_thresholds: None,
            eigenvalues: None,
            epsilon_h: None,
            fit_offset: true,
            fit_from: None,
            holdout: 0,
            superposition: 0,
            superposition_kinks: None,
            delay: 0,
            offset_per_record: false,
            dynamics: None,
            creep_regularisation: CreepRegularisation::None,
            rate_gain: 0.0,
        }
    }
}

impl IdentificationSettings {
    /// Check the orders and explicit values.
    pub fn validate(&self) -> Result<(), IdentificationError> {
        let bad = |field, reason: &str| {
            Err(IdentificationError::InvalidSetting {
                field,
                reason: reason.into(),
            })
        };
        if self.hysteresis_thresholds.is_none() && self.hysteresis_operators == 0 {
            return bad("hysteresis_operators", "must be at least 1");
        }
        if let CreepRegularisation::Fixed(l) = self.creep_regularisation {
            if !(l.is_finite() && l >= 0.0) {
                return Err(IdentificationError::InvalidSetting {
                    field: "creep_regularisation",
                    reason: format!("λ must be finite and at least 0, not {l}"),
                });
            }
        }
        let creep = self
            .creep_thresholds
            .as_ref()
            .map_or(self.creep_operators, Vec::len);
        if creep > 0 && self.eigenvalues.is_none() && self.creep_eigenvalues == 0 {
            return bad(
                "creep_eigenvalues",
                "must be at least 1 when there is creep",
            );
        }
        if let Some(e) = self.epsilon_h {
            if !(e.is_finite() && e > 0.0) {
                return bad(
                    "epsilon_h",
                    &format!("must be a finite number > 0, found {e}"),
                );
            }
        }
        let check =
            |field: &'static str, r: &Option<Vec<f64>>| -> Result<(), IdentificationError> {
                if let Some(r) = r {
                    crate::realtime::checks::check_thresholds(field, r).map_err(|e| {
                        IdentificationError::InvalidSetting {
                            field,
                            reason: e.to_string(),
                        }
                    })?;
                }
                Ok(())
            };
        check("hysteresis_thresholds", &self.hysteresis_thresholds)?;
        check("creep_thresholds", &self.creep_thresholds)?;
        if let Some(k) = &self.superposition_kinks {
            if k.iter().any(|x| !x.is_finite()) {
                return bad("superposition_kinks", "must be finite numbers");
            }
        }
        if let Some(a) = &self.eigenvalues {
            if a.is_empty() || a.iter().any(|&x| !(x.is_finite() && x > 0.0)) {
                return bad("eigenvalues", "must be finite numbers > 0");
            }
        }
        self.check_counts()
    }

    /// The counts against [`crate::realtime::limits`], before anything is allocated
    /// from them.
    fn check_counts(&self) -> Result<(), IdentificationError> {
        use crate::realtime::limits::{self as l, check};
        let plays = self
            .hysteresis_thresholds
            .as_ref()
            .map_or(self.hysteresis_operators, Vec::len);
        let creep = self
            .creep_thresholds
            .as_ref()
            .map_or(self.creep_operators, Vec::len);
        let eigenvalues = match (creep, &self.eigenvalues) {
            (0, _) => 0,
            (_, Some(a)) => a.len(),
            (_, None) => self.creep_eigenvalues,
        };
        let kinks = self
            .superposition_kinks
            .as_ref()
            .map_or(self.superposition.saturating_mul(2), Vec::len);
        let counted = |field, limit, found| {
            check(field, limit, found).map_err(|e| IdentificationError::InvalidSetting {
                field,
                reason: e.reason(),
            })
        };
        counted("hysteresis_operators", l::MAX_PLAYS, plays)?;
        counted("creep_operators", l::MAX_CREEP_THRESHOLDS, creep)?;
        counted("creep_eigenvalues", l::MAX_CREEP_EIGENVALUES, eigenvalues)?;
        counted(
            "creep_operators × creep_eigenvalues",
            l::MAX_CREEP_ELEMENTS,
            creep.saturating_mul(eigenvalues),
        )?;
        counted(
            "superposition (terms of S)",
            l::MAX_SUPERPOSITION_TERMS,
            kinks.saturating_add(1),
        )?;
        counted(
            "weights to fit (plays + creep operators + kinks of S)",
            l::MAX_IDENTIFIED_WEIGHTS,
            plays.saturating_add(creep).saturating_add(kinks),
        )?;
        counted("delay", l::MAX_DELAY, self.delay)
    }
}

/// Samples at the end of a record of `samples` left out of the fit for a
/// hold-out `fraction` in `[0, 1)` (rounded down).
pub fn holdout_samples(fraction: f64, samples: usize) -> Result<usize, IdentificationError> {
    if (0.0..1.0).contains(&fraction) {
        Ok((fraction * samples as f64).floor() as usize)
    } else {
        Err(IdentificationError::InvalidSetting {
            field: "holdout",
            reason: format!("must be a fraction in [0, 1), found {fraction}"),
        })
    }
}

fn check_finite(signal: &'static str, x: &[f64]) -> Result<(), IdentificationError> {
    match x.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(IdentificationError::NonFinite {
            signal,
            index,
            value: x[index],
        }),
        None => Ok(()),
    }
}

/// A record's input and output: one length, every sample finite.
pub(super) fn check_record_signals(u: &[f64], y: &[f64]) -> Result<(), IdentificationError> {
    if u.len() != y.len() {
        return Err(IdentificationError::LengthMismatch {
            u: u.len(),
            y: y.len(),
        });
    }
    check_finite("u", u)?;
    check_finite("y", y)
}

/// Thresholds by (23): `r_i = (i · r_max) / (n + 1)`, `i = 0..n`, evaluated in
/// that order so every implementation gets the same bits.
pub fn thresholds_23(count: usize, r_max: f64) -> Vec<f64> {
    (0..count)
        .map(|i| (i as f64 * r_max) / count as f64)
        .collect()
}

/// The kinks of `S⁻¹` on the output axis, relative to the centre `c` (the
/// mid-point of the fitted output; 0 when no offset is fitted): `m` per
/// side, evenly between `c` and the output's extreme on that side,
/// `c + i·above/(m + 1)` and `c − i·below/(m + 1)`, `i = 1..m`, so the
/// outermost stay inside the range and every dead zone is excited. The
/// positive side outward, then the negative side outward.
pub fn superposition_kinks(m: usize, above: f64, below: f64) -> Vec<f64> {
    let step = |i: usize, h: f64| (i as f64 * h) / (m + 1) as f64;
    let up = (1..=m).map(|i| step(i, above));
    up.chain((1..=m).map(|i| -step(i, below))).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thresholds_of_23_are_exact_fractions_of_r_max() {
        let r = thresholds_23(12, 1000.0);
        assert_eq!(r[0], 0.0);
        assert_eq!(r[3], 250.0);
        assert_eq!(r, crate::operators::nominal::nominal_thresholds());
    }

    #[test]
    fn settings_are_validated() {
        assert!(IdentificationSettings::default().validate().is_ok());
        let s = IdentificationSettings {
            hysteresis_operators: 0,
            ..Default::default()
        };
        assert!(s.validate().is_err());
        let s = IdentificationSettings {
            epsilon_h: Some(-1.0),
            ..Default::default()
        };
        assert!(s.validate().is_err());
        let s = IdentificationSettings {
            hysteresis_thresholds: Some(vec![0.0, 2.0, 1.0]),
            ..Default::default()
        };
        assert!(s.validate().is_err());
    }
}
