//! The plan of an identification (25), made before the regression: what
//! it fits ([`FitPlan`]) — the records' fitted samples, the thresholds
//! (23) and eigenvalues (24), the operators the input excites, the margin
//! of (11), and `S⁻¹`'s kinks about the output's mid-point.

use super::regressor::Segment;
use super::report::{check_record_signals, first_at_max, range};
use super::settings::{
    superposition_kinks, thresholds_23, IdentificationError, IdentificationSettings,
};
use super::ActiveConstraint;
use super::UnexcitedOperator;
use crate::error::ModelError;
use crate::operators::creep::log_spaced_eigenvalues;
use crate::operators::model::HysteresisCreepModel;
use crate::realtime::{
    CreepParameters, HysteresisParameters, ModelParameters, Superposition, SuperpositionParameters,
};

/// What an identification fits: samples, operators and the margin of (11).
pub(super) struct FitPlan {
    pub(super) sample_time: f64,
    /// Every record's samples in the concatenated signals and its fitted
    /// rows.
    pub(super) segments: Vec<Segment>,
    /// Fitted rows in all.
    pub(super) rows: usize,
    pub(super) skip_reason: String,
    /// Offset columns: 0, 1, or one per record.
    pub(super) offsets: usize,
    /// Hysteresis and creep thresholds, all of them; the first `nh` and `nc`
    /// are excited (`r < max|u|`), the rest keep weight 0.
    pub(super) r_h: Vec<f64>,
    pub(super) r_c: Vec<f64>,
    pub(super) nh: usize,
    pub(super) nc: usize,
    pub(super) eigenvalues: Vec<f64>,
    pub(super) epsilon_h: f64,
    pub(super) unexcited: Vec<UnexcitedOperator>,
    /// `S⁻¹`'s kinks relative to `centre` (the positive side outward, then
    /// the negative side outward; empty without `S`), how many are positive,
    /// and the output's mid-point `c`.
    pub(super) r_s: Vec<f64>,
    pub(super) ns_pos: usize,
    pub(super) centre: f64,
    /// The fixed dynamics `G` the columns pass through.
    pub(super) dynamics: Option<crate::realtime::DynamicsParameters>,
    pub(super) creep_regularisation: super::settings::CreepRegularisation,
    /// `β` (s) of rate-dependent thresholds; with `β > 0` the hysteresis
    /// weights themselves are bounded (non-negative), not their partial
    /// sums.
    pub(super) rate_gain: f64,
}

/// The four groups of columns with partial-sum bounds: the plays, the creep
/// operators, and the dead zones of `S⁻¹` above and below the mid-point.
const GROUPS: [&str; 4] = [
    "hysteresis",
    "creep",
    "superposition above",
    "superposition below",
];

impl FitPlan {
    /// Check the data and settings and fix every choice the fit makes.
    /// `parts`: each record's samples in `u` and `y` (concatenated) and
    /// its first fitted sample, relative to its start.
    pub(super) fn new(
        u: &[f64],
        y: &[f64],
        sample_time: f64,
        settings: &IdentificationSettings,
        parts: &[(std::ops::Range<usize>, Option<usize>)],
        records: usize,
    ) -> Result<Self, IdentificationError> {
        settings.validate()?;
        check_record_signals(u, y)?;
        crate::realtime::checks::check_sample_time(sample_time).map_err(ModelError::from)?;
        if !(settings.rate_gain >= 0.0 && settings.rate_gain < sample_time) {
            return Err(IdentificationError::InvalidSetting {
                field: "rate_gain",
                reason: format!(
                    "{} s must be at least 0 and below the sample time {sample_time} s",
                    settings.rate_gain
                ),
            });
        }
        let r_max = u.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        if u.is_empty() || u.iter().all(|&v| v == u[0]) {
            return Err(IdentificationError::ConstantInput {
                value: u.first().copied().unwrap_or(0.0),
            });
        }
        let offsets = match (settings.fit_offset, settings.offset_per_record) {
            (false, _) => 0,
            (true, false) => 1,
            (true, true) => records,
        };
        let mut segments = Vec::with_capacity(parts.len());
        let mut skip_reason = String::new();
        for (index, (whole, fit_from)) in parts.iter().enumerate() {
            let (first, reason) = match fit_from {
                Some(k) => (*k, "--fit-from".to_string()),
                None => {
                    let own = &u[whole.clone()];
                    let m = own.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                    (
                        first_at_max(own),
                        format!(
                            "before |u| first reaches max|u| = {m} the play states depend on the unknown history"
                        ),
                    )
                }
            };
            if index == 0 {
                skip_reason = reason;
            }
            let end = whole.len().saturating_sub(settings.holdout);
            if first >= end {
                return Err(in_record(
                    IdentificationError::InvalidSetting {
                        field: "fit_from",
                        reason: format!("sample {first} leaves nothing to fit before sample {end}"),
                    },
                    index,
                    records,
                ));
            }
            segments.push(Segment {
                whole: whole.clone(),
                fitted: whole.start + first..whole.start + end,
                offset_column: if offsets > 1 { index } else { 0 },
            });
        }
        let rows: usize = segments.iter().map(|s| s.fitted.len()).sum();
        let fitted_y = || {
            segments
                .iter()
                .flat_map(|s| y[s.fitted.clone()].iter().copied())
        };
        let r_h = settings
            .hysteresis_thresholds
            .clone()
            .unwrap_or_else(|| thresholds_23(settings.hysteresis_operators, r_max));
        let r_c = settings
            .creep_thresholds
            .clone()
            .unwrap_or_else(|| thresholds_23(settings.creep_operators, r_max));
        let eigenvalues = settings
            .eigenvalues
            .clone()
            .unwrap_or_else(|| log_spaced_eigenvalues(settings.creep_eigenvalues, sample_time));
        let (lo, hi) = fitted_y().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
        // with the offset fixed at 0 the zero of S⁻¹ stays at y = 0
        let centre = if settings.fit_offset {
            0.5 * (lo + hi)
        } else {
            0.0
        };
        let mut r_s = match &settings.superposition_kinks {
            Some(k) => k.iter().map(|x| x - centre).collect(),
            None => superposition_kinks(settings.superposition, hi - centre, centre - lo),
        };
        if let Some(&bad) = r_s
            .iter()
            .find(|&&r| !(r > lo - centre && r < hi - centre && r != 0.0))
        {
            return Err(IdentificationError::InvalidSetting {
                field: "superposition_kinks",
                reason: format!(
                    "{} is not strictly inside the fitted output's range ({lo}, {hi}) or is its mid-point",
                    bad + centre
                ),
            });
        }
        // positive side outward, then negative side outward
        r_s.sort_by(|a, b| {
            (*a < 0.0)
                .cmp(&(*b < 0.0))
                .then(a.abs().total_cmp(&b.abs()))
        });
        r_s.dedup();
        let ns_pos = r_s.iter().filter(|&&r| r > 0.0).count();
        let unknowns = r_h.len() + r_c.len() + r_s.len() + offsets;
        let needed = 2 * unknowns + 1;
        if rows < needed {
            return Err(IdentificationError::TooFewSamples {
                found: rows,
                needed,
                unknowns,
            });
        }
        // operators never excited: thresholds at or above max|u| (a suffix)
        let nh = r_h.iter().take_while(|&&r| r < r_max).count();
        let nc = r_c.iter().take_while(|&&r| r < r_max).count();
        let mut unexcited = Vec::new();
        for (group, r, k) in [("hysteresis", &r_h, nh), ("creep", &r_c, nc)] {
            for (index, &threshold) in r.iter().enumerate().skip(k) {
                unexcited.push(UnexcitedOperator {
                    group,
                    index,
                    threshold,
                });
            }
        }
        let epsilon_h = settings
            .epsilon_h
            .unwrap_or(1e-3 * (hi - lo).max(f64::MIN_POSITIVE) / range(u));
        Ok(Self {
            sample_time,
            segments,
            rows,
            skip_reason,
            offsets,
            r_h,
            r_c,
            nh,
            nc,
            eigenvalues,
            epsilon_h,
            unexcited,
            r_s,
            ns_pos,
            centre,
            dynamics: settings.dynamics,
            creep_regularisation: settings.creep_regularisation,
            rate_gain: settings.rate_gain,
        })
    }

    /// `g = β/T_s`: the thresholds' widening per unit of input change.
    pub(super) fn gain(&self) -> f64 {
        self.rate_gain / self.sample_time
    }

    /// Whether the columns of group `group` are bounded one by one (the
    /// hysteresis weights under rate-dependent thresholds) rather than
    /// through their partial sums.
    pub(super) fn bounds_weights(&self, group: usize) -> bool {
        group == 0 && self.rate_gain > 0.0
    }

    /// Number of unknown weights: the excited operators and `S⁻¹`'s dead
    /// zones.
    pub(super) fn excited(&self) -> usize {
        self.nh + self.nc + self.r_s.len()
    }

    /// The columns of each group (`GROUPS`), in order.
    pub(super) fn group_ranges(&self) -> [std::ops::Range<usize>; 4] {
        let (a, b) = (self.nh, self.nh + self.nc);
        let c = b + self.ns_pos;
        [0..a, a..b, b..c, c..self.excited()]
    }

    /// The group of column `j` and `j`'s index in it.
    pub(super) fn group_of(&self, j: usize) -> (usize, usize) {
        let groups = self.group_ranges();
        let g = groups.iter().position(|r| r.contains(&j)).unwrap_or(3);
        (g, j - groups[g].start)
    }

    /// Column `j` of the regressor's weights as an operator of the model
    /// (a dead zone of `S⁻¹` by its kink on the output axis, counted
    /// outward from 1).
    pub(super) fn operator(&self, j: usize) -> UnexcitedOperator {
        let (g, index) = self.group_of(j);
        let (index, threshold) = match g {
            0 => (index, self.r_h[index]),
            1 => (index, self.r_c[index]),
            _ => (index + 1, self.centre + self.r_s[j - self.nh - self.nc]),
        };
        UnexcitedOperator {
            group: GROUPS[g],
            index,
            threshold,
        }
    }

    /// The lower bound of partial sum `j`: `ε_H` (11), 0 (17), or for
    /// `S⁻¹` (whose linear weight is 1) `ε_S − 1`, so that every slope
    /// `1 + Σ w'` is at least `ε_S`. Where [`Self::bounds_weights`], that
    /// of weight `j` itself: `ε_H` for the first, 0 for the others.
    pub(super) fn bound(&self, j: usize) -> f64 {
        match self.group_of(j) {
            (0, index) if self.bounds_weights(0) && index > 0 => 0.0,
            (0, _) => self.epsilon_h,
            (1, _) => 0.0,
            _ => EPSILON_S - 1.0,
        }
    }

    /// `S⁻¹`'s parameters on `ς − c` (kinks increasing, the zero one
    /// included, its weight 1) from the fitted weights of its columns.
    pub(super) fn inverse_superposition(&self, w_s: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let (pos, neg) = (self.ns_pos, self.r_s.len() - self.ns_pos);
        let mut r: Vec<f64> = self.r_s[pos..].iter().rev().copied().collect();
        let mut w: Vec<f64> = w_s[pos..].iter().rev().copied().collect();
        r.push(0.0);
        w.push(1.0);
        r.extend_from_slice(&self.r_s[..pos]);
        w.extend_from_slice(&w_s[..pos]);
        debug_assert_eq!(r.len(), pos + neg + 1);
        (r, w)
    }

    /// The model with the solved weights (unexcited operators weigh 0).
    pub(super) fn model(
        &self,
        solution: &Solution,
    ) -> Result<HysteresisCreepModel, IdentificationError> {
        self.model_with(solution, solution.offset)
    }

    /// The model with the solved weights and offset `offset` (with `S`, in
    /// the domain of `H + C`: `S⁻¹[ς − c] = H + C + offset`).
    pub(super) fn model_with(
        &self,
        solution: &Solution,
        offset: f64,
    ) -> Result<HysteresisCreepModel, IdentificationError> {
        let parameters = ModelParameters {
            sample_time: self.sample_time,
            hysteresis: HysteresisParameters {
                thresholds: &self.r_h,
                weights: &solution.w_h,
            },
            creep: (!self.r_c.is_empty()).then_some(CreepParameters {
                thresholds: &self.r_c,
                weights: &solution.w_c,
                eigenvalues: &self.eigenvalues,
            }),
            superposition: None,
            dynamics: None,
            delay: 0,
            offset: 0.0,
            rate_gain: self.rate_gain,
        };
        let model = HysteresisCreepModel::new(&parameters.validate()?)?;
        if self.r_s.is_empty() {
            return Ok(model.with_offset(offset)?);
        }
        // H + C + d = S⁻¹[ς − c], so ς = S[H + C + d] + c: S shifted along its
        // input by d, and the constant S(d) + c as the output offset
        let (r_inv, w_inv) = self.inverse_superposition(&solution.w_s);
        let s = Superposition::<f64, crate::operators::heap::Heap>::inverse_of(
            &SuperpositionParameters {
                thresholds: &r_inv,
                weights: &w_inv,
            },
        )?;
        let d = offset;
        let (r, w) = shifted_superposition(s.thresholds(), s.weights(), d)?;
        let shifted = Superposition::new(&r, &w)?;
        Ok(model
            .with_superposition(Some(shifted))
            .with_offset(self.centre + s.apply(d))?)
    }
}

/// `S_d(z) = S(z + d) − S(d)` as a superposition operator: the kinks move to
/// `r_i − d`; a kink that changes side changes the sign of its weight (a
/// weight is the change of slope going outward); the new zero threshold
/// carries the slope of `S` at `d`.
pub(super) fn shifted_superposition(
    r: &[f64],
    w: &[f64],
    d: f64,
) -> Result<(Vec<f64>, Vec<f64>), IdentificationError> {
    let zero = r.iter().position(|&x| x == 0.0).unwrap_or(0);
    let mut slope = w[zero];
    let mut kinks: Vec<(f64, f64)> = Vec::with_capacity(r.len());
    for (i, (&ri, &wi)) in r.iter().zip(w).enumerate() {
        if i == zero {
            continue;
        }
        let t = ri - d;
        if t == 0.0 {
            return Err(IdentificationError::NotSolved {
                reason: format!("the fitted shift {d} of S lies on its kink {ri}"),
            });
        }
        // kinks between 0 and d: the slope at d has passed them
        if (ri > 0.0 && ri < d) || (ri < 0.0 && ri > d) {
            slope += wi;
        }
        let same_side = (ri > 0.0) == (t > 0.0);
        kinks.push((t, if same_side { wi } else { -wi }));
    }
    kinks.push((0.0, slope));
    kinks.sort_by(|a, b| a.0.total_cmp(&b.0));
    Ok(kinks.into_iter().unzip())
}

/// The smallest slope of the fitted `S⁻¹` relative to its slope 1 at the
/// output's mid-point: `S` is then at most 1000 times steeper there.
pub const EPSILON_S: f64 = 1e-3;

/// An error about record `index` of `count`, named when there are several.
pub(super) fn in_record(e: IdentificationError, index: usize, count: usize) -> IdentificationError {
    if count < 2 {
        return e;
    }
    IdentificationError::InvalidSetting {
        field: "input",
        reason: format!("record {}: {e}", index + 1),
    }
}

/// Stage 2's result: every weight (unexcited ones 0), the offset, and how
/// the solve ended.
pub(super) struct Solution {
    pub(super) w_h: Vec<f64>,
    pub(super) w_c: Vec<f64>,
    /// The weights of `S⁻¹`'s dead zones, in column order.
    pub(super) w_s: Vec<f64>,
    /// The first record's offset (in the domain of `H + C` with `S`).
    pub(super) offset: f64,
    /// Every record's (one, or one per record).
    pub(super) offsets: Vec<f64>,
    pub(super) active_constraints: Vec<ActiveConstraint>,
    pub(super) kkt_residual: f64,
    pub(super) iterations: usize,
    /// The creep penalty's `λ` and the fit's effective parameters there,
    /// where one was asked for.
    pub(super) creep_penalty: Option<(f64, f64)>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_shifted_superposition_is_s_moved_along_its_input() {
        let (r, w) = (vec![-2.0, 0.0, 1.0, 3.0], vec![0.5, 1.0, -0.25, 0.5]);
        let s = Superposition::<f64, crate::operators::heap::Heap>::new(&r, &w).unwrap();
        for d in [-3.0, -1.0, 0.4, 2.0, 5.0] {
            let (rs, ws) = shifted_superposition(&r, &w, d).unwrap();
            let t = Superposition::<f64, crate::operators::heap::Heap>::new(&rs, &ws).unwrap();
            for k in 0..=80 {
                let z = -8.0 + 0.2 * k as f64;
                let (a, b) = (t.apply(z), s.apply(z + d) - s.apply(d));
                assert!(
                    (a - b).abs() <= 1e-14 * (1.0 + b.abs()),
                    "d {d}, z {z}: {a} vs {b}"
                );
            }
        }
    }
}
