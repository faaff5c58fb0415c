//! An identification end to end, in the three stages of (25): what to fit
//! ([`FitPlan`]: the fitted samples, the thresholds (23), eigenvalues (24)
//! and the operators the input excites), the regressor's factor and rank
//! (`regressor`), the constrained solve (`solve`) and the
//! report ([`super::report`]). A new model class adds its columns to the
//! regressor and its bounds to the solve; the plan and the report stay.

use faer::Mat;

use super::regressor::regressor_factor;
use super::report::{check_finite, first_at_max, range};
use super::settings::{thresholds_23, IdentificationError, IdentificationSettings};
use super::solve::{nnls, null_space_members, singular_values, weights_from_sums, RANK_TOLERANCE};
use super::{ActiveConstraint, FitErrors, FitReport, UnexcitedOperator};
use crate::error::ModelError;
use crate::operators::creep::{log_spaced_eigenvalues, CreepOperator};
use crate::operators::hysteresis::HysteresisOperator;
use crate::operators::model::HysteresisCreepModel;
use crate::operators::traits::Operator;

/// The identified model (virgin state, fitted offset) and its fit report.
#[derive(Debug, Clone)]
pub struct Identification {
    pub model: HysteresisCreepModel,
    pub report: FitReport,
}

/// Identify a model from input `u` (V) and measured output `y`, sampled at
/// `sample_time`. The operators start from the virgin state at the first
/// sample; the fit uses the samples from `settings.fit_from` (default: where
/// `|u|` first reaches `max|u|`) to the end less `settings.holdout`.
pub fn identify(
    u: &[f64],
    y: &[f64],
    sample_time: f64,
    settings: &IdentificationSettings,
) -> Result<Identification, IdentificationError> {
    let plan = FitPlan::new(u, y, sample_time, settings)?;
    let regression = Regression::of(u, y, &plan)?;
    let solution = regression.solve(&plan)?;
    let model = plan.model(&solution)?;
    // the fit of the model as it will be used, from the virgin state
    let fit = model.clone().run(u);
    let n = u.len();
    let (first, end) = (plan.fitted.start, plan.fitted.end);
    let unknowns = plan.excited();
    let report = FitReport {
        samples: n,
        fitted: plan.fitted.clone(),
        skip_reason: plan.skip_reason,
        fit: FitErrors::of(&fit, y, first..end),
        holdout: (end < n).then(|| FitErrors::of(&fit, y, end..n)),
        offset: solution.offset,
        condition_number: regression.condition_number,
        rank: regression.rank,
        unknowns,
        undetermined: regression.undetermined,
        epsilon_h: plan.epsilon_h,
        active_constraints: solution.active_constraints,
        unexcited: plan.unexcited,
        kkt_residual: solution.kkt_residual,
        iterations: solution.iterations,
    };
    Ok(Identification { model, report })
}

/// What an identification fits: samples, operators and the margin of (11).
struct FitPlan {
    sample_time: f64,
    fitted: std::ops::Range<usize>,
    skip_reason: String,
    fit_offset: bool,
    /// Hysteresis and creep thresholds, all of them; the first `nh` and `nc`
    /// are excited (`r < max|u|`), the rest keep weight 0.
    r_h: Vec<f64>,
    r_c: Vec<f64>,
    nh: usize,
    nc: usize,
    eigenvalues: Vec<f64>,
    epsilon_h: f64,
    unexcited: Vec<UnexcitedOperator>,
}

impl FitPlan {
    /// Check the data and settings and fix every choice the fit makes.
    fn new(
        u: &[f64],
        y: &[f64],
        sample_time: f64,
        settings: &IdentificationSettings,
    ) -> Result<Self, IdentificationError> {
        settings.validate()?;
        if u.len() != y.len() {
            return Err(IdentificationError::LengthMismatch {
                u: u.len(),
                y: y.len(),
            });
        }
        crate::realtime::parameters::check_sample_time(sample_time).map_err(ModelError::from)?;
        check_finite("u", u)?;
        check_finite("y", y)?;
        let n = u.len();
        let r_max = u.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        if n == 0 || u.iter().all(|&v| v == u[0]) {
            return Err(IdentificationError::ConstantInput {
                value: u.first().copied().unwrap_or(0.0),
            });
        }
        let (first, skip_reason) = match settings.fit_from {
            Some(k) => (k, "--fit-from".to_string()),
            None => (
                first_at_max(u),
                format!(
                    "before |u| first reaches max|u| = {r_max} the play states depend on the unknown history"
                ),
            ),
        };
        let end = n.saturating_sub(settings.holdout);
        if first >= end {
            return Err(IdentificationError::InvalidSetting {
                field: "fit_from",
                reason: format!("sample {first} leaves nothing to fit before sample {end}"),
            });
        }
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
        let unknowns = r_h.len() + r_c.len() + usize::from(settings.fit_offset);
        let needed = 2 * unknowns + 1;
        if end - first < needed {
            return Err(IdentificationError::TooFewSamples {
                found: end - first,
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
            .unwrap_or(1e-3 * range(&y[first..end]).max(f64::MIN_POSITIVE) / range(u));
        Ok(Self {
            sample_time,
            fitted: first..end,
            skip_reason,
            fit_offset: settings.fit_offset,
            r_h,
            r_c,
            nh,
            nc,
            eigenvalues,
            epsilon_h,
            unexcited,
        })
    }

    /// Number of excited operators: the unknown weights.
    fn excited(&self) -> usize {
        self.nh + self.nc
    }

    /// Column `j` of the regressor's weights as an operator of the model.
    fn operator(&self, j: usize) -> UnexcitedOperator {
        if j < self.nh {
            UnexcitedOperator {
                group: "hysteresis",
                index: j,
                threshold: self.r_h[j],
            }
        } else {
            UnexcitedOperator {
                group: "creep",
                index: j - self.nh,
                threshold: self.r_c[j - self.nh],
            }
        }
    }

    /// The lower bound of partial sum `j`: `ε_H` (11) or 0 (17).
    fn bound(&self, j: usize) -> f64 {
        if j < self.nh {
            self.epsilon_h
        } else {
            0.0
        }
    }

    /// The model with the solved weights (unexcited operators weigh 0).
    fn model(&self, solution: &Solution) -> Result<HysteresisCreepModel, ModelError> {
        let hysteresis = HysteresisOperator::new(self.r_h.clone(), solution.w_h.clone())?;
        let creep = if self.r_c.is_empty() {
            None
        } else {
            Some(CreepOperator::new(
                self.r_c.clone(),
                solution.w_c.clone(),
                self.eigenvalues.clone(),
                self.sample_time,
            )?)
        };
        Ok(
            HysteresisCreepModel::from_parts(self.sample_time, hysteresis, creep)?
                .with_offset(solution.offset),
        )
    }
}

/// Stage 1: the triangular factor of `[1 | Φ | ς]` and what it determines.
struct Regression {
    /// The factor, offset column first when the offset is fitted.
    factor: Mat<f64>,
    rank: usize,
    condition_number: f64,
    undetermined: Vec<UnexcitedOperator>,
}

impl Regression {
    fn of(u: &[f64], y: &[f64], plan: &FitPlan) -> Result<Self, IdentificationError> {
        let creep = if plan.nc > 0 {
            Some(CreepOperator::new(
                &plan.r_c[..plan.nc],
                vec![0.0; plan.nc],
                plan.eigenvalues.clone(),
                plan.sample_time,
            )?)
        } else {
            None
        };
        let factor = regressor_factor(
            u,
            y,
            plan.fitted.clone(),
            plan.fit_offset,
            &plan.r_h[..plan.nh],
            creep,
        );
        let p = plan.excited();
        let r = Self::weights_block(&factor, plan);
        let sv = singular_values(&r);
        let smax = sv.first().copied().unwrap_or(0.0);
        let rank = sv.iter().filter(|&&s| s > RANK_TOLERANCE * smax).count();
        let condition_number = if rank < p || smax == 0.0 {
            f64::INFINITY
        } else {
            smax / sv[p - 1]
        };
        let undetermined = null_space_members(&r, rank)
            .into_iter()
            .map(|j| plan.operator(j))
            .collect();
        Ok(Self {
            factor,
            rank,
            condition_number,
            undetermined,
        })
    }

    /// `R` of the weights: the factor with the offset eliminated (its first
    /// row and column dropped).
    fn weights_block(factor: &Mat<f64>, plan: &FitPlan) -> Mat<f64> {
        let (p, q) = (plan.excited(), usize::from(plan.fit_offset));
        Mat::from_fn(p, p, |i, j| factor[(q + i, q + j)])
    }

    /// Stage 2: non-negative least squares in the shifted partial sums
    /// `x = S − b`, then the weights and the offset.
    fn solve(&self, plan: &FitPlan) -> Result<Solution, IdentificationError> {
        let (p, q, nh) = (plan.excited(), usize::from(plan.fit_offset), plan.nh);
        let r = Self::weights_block(&self.factor, plan);
        let c: Vec<f64> = (0..p).map(|i| self.factor[(q + i, q + p)]).collect();
        // M = R D: column j of R D is R_j − R_{j+1} within each group
        let m = Mat::from_fn(p, p, |i, j| {
            let next = j + 1;
            let same_group = (j < nh && next < nh) || (j >= nh && next < p);
            r[(i, j)] - if same_group { r[(i, next)] } else { 0.0 }
        });
        let d: Vec<f64> = (0..p)
            .map(|i| c[i] - (0..p).map(|j| m[(i, j)] * plan.bound(j)).sum::<f64>())
            .collect();
        let solution = nnls(&m, &d)?;
        let sums: Vec<f64> = (0..p).map(|j| plan.bound(j) + solution.x[j]).collect();
        let active_constraints = (0..p)
            .filter(|&j| solution.x[j] == 0.0)
            .map(|j| {
                let op = plan.operator(j);
                ActiveConstraint {
                    group: op.group,
                    index: op.index,
                    bound: plan.bound(j),
                }
            })
            .collect();
        // weights from partial sums, such that the recomputed sums hold
        let mut w_h = weights_from_sums(&sums[..nh], plan.epsilon_h);
        w_h.resize(plan.r_h.len(), 0.0);
        let mut w_c = weights_from_sums(&sums[nh..], 0.0);
        w_c.resize(plan.r_c.len(), 0.0);
        // the offset from the first row of the factor: r_00 o + r_0j w_j = c_0
        let offset = if plan.fit_offset && self.factor[(0, 0)] != 0.0 {
            let w_all = w_h[..nh].iter().chain(&w_c[..plan.nc]);
            let dot: f64 = w_all
                .enumerate()
                .map(|(j, w)| self.factor[(0, 1 + j)] * w)
                .sum();
            (self.factor[(0, p + 1)] - dot) / self.factor[(0, 0)]
        } else {
            0.0
        };
        Ok(Solution {
            w_h,
            w_c,
            offset,
            active_constraints,
            kkt_residual: solution.kkt_residual,
            iterations: solution.iterations,
        })
    }
}

/// Stage 2's result: every weight (unexcited ones 0), the offset, and how
/// the solve ended.
struct Solution {
    w_h: Vec<f64>,
    w_c: Vec<f64>,
    offset: f64,
    active_constraints: Vec<ActiveConstraint>,
    kkt_residual: f64,
    iterations: usize,
}
