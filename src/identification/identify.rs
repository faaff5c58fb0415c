//! An identification end to end, in the three stages of (25): what to fit
//! ([`FitPlan`], in `plan`: the fitted samples, the thresholds (23),
//! eigenvalues (24) and the operators the input excites), the regressor's
//! factor and rank (`regressor`), the constrained solve (`solve`) and the
//! report ([`super::report`]). A new model class adds its columns to the
//! regressor and its bounds to the solve; the plan and the report stay.

use faer::Mat;

use super::plan::{in_record, FitPlan, Solution, EPSILON_S};
use super::regressor::{regressor_factor, OperatorColumns, OperatorState};
use super::report::check_record_signals;
use super::report::StartCheck;
use super::settings::CreepRegularisation;
use super::settings::{IdentificationError, IdentificationSettings};
use super::solve::{
    nnls, null_space_members, singular_values, weights_from_sums, NnlsSolution, RANK_TOLERANCE,
};
use super::{ActiveConstraint, FitErrors, FitReport, RecordFit, UnexcitedOperator};
use crate::operators::creep::CreepOperator;
use crate::operators::model::HysteresisCreepModel;
use crate::operators::traits::Operator;

/// The identified model (virgin state, fitted offset) and its fit report.
#[derive(Debug, Clone)]
pub struct Identification {
    pub model: HysteresisCreepModel,
    pub report: FitReport,
    /// Each fitted record's own model (virgin state): the weights, with its
    /// own offset. With `S` an offset shifts `S`'s input, so a record's
    /// model is not `model` with another offset. The first is `model`.
    pub record_models: Vec<HysteresisCreepModel>,
}

/// Identify a model from input `u` (V) and measured output `y`, sampled at
/// `sample_time`. The operators start from the virgin state at the first
/// sample; the fit uses the samples from `settings.fit_from` (default: where
/// `|u|` first reaches `max|u|`) to the end less `settings.holdout`.
///
/// With a dead time `d = settings.delay` the output `y_k` is fitted by the
/// memory part's output at `k − d`: the weights are those of the record
/// `u_0 … u_{n−1−d}` against `y_d … y_{n−1}` (`fit_from` still counts
/// samples of `y`), and the model carries `d`.
pub fn identify(
    u: &[f64],
    y: &[f64],
    sample_time: f64,
    settings: &IdentificationSettings,
) -> Result<Identification, IdentificationError> {
    let record = FitRecord {
        u,
        y,
        fit_from: settings.fit_from,
    };
    identify_records(&[record], sample_time, settings)
}

/// A record of a multi-record identification: input, output and the first
/// sample of `y` fitted (`None`: where `|u|` first reaches `max|u|`).
#[derive(Debug, Clone, Copy)]
pub struct FitRecord<'a> {
    pub u: &'a [f64],
    pub y: &'a [f64],
    pub fit_from: Option<usize>,
}

/// One model fitted to several records at once ([`identify`] for each
/// alone): each record starts from the virgin state and skips its own
/// start; with `settings.offset_per_record` each has its own output offset
/// (the model keeps the first record's; the report lists all), else they
/// share one. `settings.fit_from` is ignored (each record has its own);
/// `settings.holdout` must be 0 with several records (validate on another
/// record instead).
pub fn identify_records(
    records: &[FitRecord<'_>],
    sample_time: f64,
    settings: &IdentificationSettings,
) -> Result<Identification, IdentificationError> {
    identify_records_with(records, sample_time, settings, None, None).map(|(id, _)| id)
}

/// The operators' columns a search over `G` shares between its trials at
/// one alignment: filled by the first trial, read by the others.
pub(super) type SharedColumns = std::sync::OnceLock<OperatorColumns>;

/// [`identify_records`], and each record's model output as its report
/// scores it; `columns`: the operators' columns shared with the other
/// trials of a search over `G`; `states`: each record's operators start
/// there, not virgin (in the regression and the report).
pub(super) fn identify_records_with(
    records: &[FitRecord<'_>],
    sample_time: f64,
    settings: &IdentificationSettings,
    columns: Option<&SharedColumns>,
    states: Option<&[OperatorState]>,
) -> Result<(Identification, Vec<Vec<f64>>), IdentificationError> {
    settings.validate()?;
    if records.is_empty() {
        return Err(IdentificationError::InvalidSetting {
            field: "input",
            reason: "no record to fit".into(),
        });
    }
    if records.len() > 1 && settings.holdout > 0 {
        return Err(IdentificationError::InvalidSetting {
            field: "holdout",
            reason: "with several records, validate on another record instead".into(),
        });
    }
    let d = settings.delay;
    // the lag of the dynamics is aligned as dead time is; G then runs
    // without it
    let lag = settings.dynamics.as_ref().map_or(0, |g| g.lag());
    let aligned = d + lag;
    let (mut u_cat, mut y_cat, mut parts) = (Vec::new(), Vec::new(), Vec::new());
    let mut y_raw = Vec::new();
    for (index, r) in records.iter().enumerate() {
        check_record_signals(r.u, r.y).map_err(|e| in_record(e, index, records.len()))?;
        let n = r.u.len();
        if aligned >= n {
            return Err(in_record(
                IdentificationError::InvalidSetting {
                    field: "delay",
                    reason: format!("{aligned} samples of dead time leave nothing of {n} samples"),
                },
                index,
                records.len(),
            ));
        }
        let start = u_cat.len();
        u_cat.extend_from_slice(&r.u[..n - aligned]);
        let y_d = &r.y[aligned..];
        y_raw.extend_from_slice(y_d);
        match &settings.dynamics {
            // the regressor's columns pass through G; its measurement is G⁻¹[y]
            Some(g) => {
                let mut inverse =
                    crate::realtime::Dynamics::<f64>::new(g, sample_time)?.without_lag();
                y_cat.extend(y_d.iter().map(|&v| {
                    let w = inverse.input_for(v);
                    inverse.push_exact(v, w);
                    w
                }));
            }
            None => y_cat.extend_from_slice(y_d),
        }
        parts.push((
            start..u_cat.len(),
            r.fit_from.map(|k| k.saturating_sub(aligned)),
        ));
    }
    // the plan (thresholds, kinks, margins) from the measurement itself:
    // G⁻¹[y] carries its noise amplified
    let plan = FitPlan::new(&u_cat, &y_raw, sample_time, settings, &parts, records.len())?;
    // With G, the dead zones of S⁻¹ take S's output, which only G⁻¹[y]
    // measures, with the noise amplified; as an instrument, the output of
    // the model without G takes its place: first y itself (G ≈ 1 at the
    // rates fitted), then the output (noise-free, from u) of the model that
    // fitted, once.
    let instrument = settings.dynamics.is_some() && !plan.r_s.is_empty();
    let mut zone = instrument.then(|| y_raw.clone());
    let mut from_model = false;
    let (regression, solution) = loop {
        let regression = Regression::of(&u_cat, &y_cat, &plan, zone.as_deref(), columns, states)?;
        let solution = regression.solve(&plan)?;
        let Some(zone) = zone.as_mut().filter(|_| !from_model) else {
            break (regression, solution);
        };
        for (index, segment) in plan.segments.iter().enumerate() {
            let own = solution
                .offsets
                .get(index)
                .copied()
                .unwrap_or(solution.offset);
            let model = plan.model_with(&solution, own)?;
            let w = started_in(model, states.and_then(|s| s.get(index)))?
                .run(&u_cat[segment.whole.clone()]);
            zone[segment.whole.clone()].copy_from_slice(&w);
        }
        from_model = true;
    };
    let model = plan
        .model(&solution)?
        .with_dynamics(settings.dynamics.as_ref())?
        .with_delay(d)?;
    let standard_errors = regression.standard_errors(&plan);
    // the fit of the model as it will be used, from the virgin state, on
    // each record (the first one's in the main fields)
    let mut record_reports = Vec::with_capacity(records.len());
    let mut fits = Vec::with_capacity(records.len());
    let mut record_models = Vec::with_capacity(records.len());
    for (index, (r, segment)) in records.iter().zip(&plan.segments).enumerate() {
        let fitted = segment.fitted.start - segment.whole.start + aligned
            ..segment.fitted.end - segment.whole.start + aligned;
        let own = solution
            .offsets
            .get(index)
            .copied()
            .unwrap_or(solution.offset);
        let own = plan
            .model_with(&solution, own)?
            .with_dynamics(settings.dynamics.as_ref())?
            .with_delay(d)?;
        let fit = started_in(own.clone(), states.and_then(|s| s.get(index)))?.run(r.u);
        record_reports.push(RecordFit {
            samples: r.u.len(),
            fit: FitErrors::of(&fit, r.y, fitted.clone()),
            fitted,
            offset: own.offset(),
        });
        record_models.push(own);
        fits.push(fit);
    }
    let first = &record_reports[0];
    let (y, n) = (records[0].y, records[0].u.len());
    // the first record's own model is the model (the same weights and
    // offset)
    let fit = &fits[0];
    let (start, end) = (first.fitted.start, first.fitted.end);
    let unknowns = plan.excited();
    let report = FitReport {
        samples: n,
        fitted: start..end,
        delay: d,
        skip_reason: plan.skip_reason.clone(),
        fit: first.fit,
        holdout: (end < n).then(|| FitErrors::of(fit, y, end..n)),
        offset: model.offset(),
        condition_number: regression.condition_number,
        rank: regression.rank,
        unknowns,
        undetermined: regression.undetermined,
        epsilon_h: plan.epsilon_h,
        active_constraints: solution.active_constraints,
        unexcited: plan.unexcited,
        kkt_residual: solution.kkt_residual,
        iterations: solution.iterations,
        weights: solution.w_h[..plan.nh]
            .iter()
            .chain(&solution.w_c[..plan.nc])
            .chain(&solution.w_s)
            .copied()
            .collect(),
        standard_errors,
        start: StartCheck::of(fit, y, start..end),
        superposition: model
            .superposition()
            .map(|s| (s.thresholds().to_vec(), s.weights().to_vec())),
        records: if records.len() > 1 {
            record_reports
        } else {
            Vec::new()
        },
        dynamics: None,
        creep_regularisation: solution.creep_penalty,
    };
    Ok((
        Identification {
            model,
            report,
            record_models,
        },
        fits,
    ))
}

/// `model` with its operators in `state` (unchanged without one).
pub(super) fn started_in(
    model: HysteresisCreepModel,
    state: Option<&OperatorState>,
) -> Result<HysteresisCreepModel, IdentificationError> {
    let Some(state) = state else {
        return Ok(model);
    };
    let mut file = model.to_file();
    file.hysteresis.state = Some(state.plays.clone());
    if let Some(c) = &mut file.creep {
        let m = c.eigenvalues.len().max(1);
        c.state = Some(state.creep.chunks(m).map(<[f64]>::to_vec).collect());
    }
    Ok(HysteresisCreepModel::from_file(&file)?)
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
    /// `zone`: the argument of `S⁻¹`'s dead zones where it is not `y`
    /// (an instrument, with dynamics).
    fn of(
        u: &[f64],
        y: &[f64],
        plan: &FitPlan,
        zone: Option<&[f64]>,
        columns: Option<&SharedColumns>,
        states: Option<&[OperatorState]>,
    ) -> Result<Self, IdentificationError> {
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
        let width = plan.nh + creep.as_ref().map_or(0, |c| c.thresholds().len());
        let affordable = OperatorColumns::affordable(u.len(), width);
        // the shared columns start virgin
        let columns = columns.filter(|_| affordable && states.is_none()).map(|c| {
            c.get_or_init(|| {
                OperatorColumns::new(
                    u,
                    &plan.segments,
                    &plan.r_h[..plan.nh],
                    plan.gain(),
                    creep.as_ref(),
                )
            })
        });
        let factor = regressor_factor(
            u,
            y,
            &plan.segments,
            plan.offsets,
            &plan.r_h[..plan.nh],
            plan.gain(),
            creep,
            (!plan.r_s.is_empty()).then_some((plan.r_s.as_slice(), plan.centre)),
            plan.dynamics.as_ref().map(|g| (g, plan.sample_time)),
            zone,
            columns,
            states,
        )?;
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

    /// Standard errors of the weights in column order, as least squares
    /// without the bounds gives them: `σ̂ √((RᵀR)⁻¹)_jj` with `σ̂` the residual
    /// (the factor's last diagonal entry) over `√(N − p − q)`; infinite when
    /// the rank is deficient.
    fn standard_errors(&self, plan: &FitPlan) -> Vec<f64> {
        let (p, q) = (plan.excited(), plan.offsets);
        if self.rank < p {
            return vec![f64::INFINITY; p];
        }
        let r = Self::weights_block(&self.factor, plan);
        let dof = plan.rows.saturating_sub(p + q).max(1) as f64;
        let sigma = self.factor[(q + p, q + p)].abs() / dof.sqrt();
        // R⁻¹ column by column (back substitution), then its row norms
        let mut inv = Mat::<f64>::zeros(p, p);
        for k in 0..p {
            for i in (0..=k).rev() {
                let rhs = if i == k { 1.0 } else { 0.0 };
                let sum: f64 = (i + 1..=k).map(|j| r[(i, j)] * inv[(j, k)]).sum();
                inv[(i, k)] = (rhs - sum) / r[(i, i)];
            }
        }
        (0..p)
            .map(|j| {
                sigma
                    * (0..p)
                        .map(|k| inv[(j, k)] * inv[(j, k)])
                        .sum::<f64>()
                        .sqrt()
            })
            .collect()
    }

    /// `R` of the weights: the factor with the offset eliminated (its first
    /// row and column dropped).
    fn weights_block(factor: &Mat<f64>, plan: &FitPlan) -> Mat<f64> {
        let (p, q) = (plan.excited(), plan.offsets);
        Mat::from_fn(p, p, |i, j| factor[(q + i, q + j)])
    }

    /// Stage 2: non-negative least squares in the shifted partial sums
    /// `x = S − b`, then the weights and the offset.
    fn solve(&self, plan: &FitPlan) -> Result<Solution, IdentificationError> {
        let (p, q, nh) = (plan.excited(), plan.offsets, plan.nh);
        let r = Self::weights_block(&self.factor, plan);
        let c: Vec<f64> = (0..p).map(|i| self.factor[(q + i, q + p)]).collect();
        // M = R D: column j of R D is R_j − R_{j+1} within each group
        let groups = plan.group_ranges();
        // (except in a group whose weights are bounded themselves)
        let m = Mat::from_fn(p, p, |i, j| {
            let same_group = groups.iter().enumerate().any(|(index, g)| {
                !plan.bounds_weights(index) && g.contains(&j) && g.contains(&(j + 1))
            });
            r[(i, j)] - if same_group { r[(i, j + 1)] } else { 0.0 }
        });
        let d: Vec<f64> = (0..p)
            .map(|i| c[i] - (0..p).map(|j| m[(i, j)] * plan.bound(j)).sum::<f64>())
            .collect();
        let (solution, creep_penalty) = self.penalised(plan, &m, &d)?;
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
        let mut w_h = if plan.bounds_weights(0) {
            (0..nh).map(|j| sums[j].max(plan.bound(j))).collect()
        } else {
            weights_from_sums(&sums[..nh], plan.epsilon_h)
        };
        w_h.resize(plan.r_h.len(), 0.0);
        let mut w_c = weights_from_sums(&sums[groups[1].clone()], 0.0);
        w_c.resize(plan.r_c.len(), 0.0);
        let s_bound = EPSILON_S - 1.0;
        let mut w_s = weights_from_sums(&sums[groups[2].clone()], s_bound);
        w_s.extend(weights_from_sums(&sums[groups[3].clone()], s_bound));
        // the offsets from the first q rows of the factor (upper triangular):
        // R_oo o + R_ow w = c_o, by back substitution
        let w_all: Vec<f64> = w_h[..nh]
            .iter()
            .chain(&w_c[..plan.nc])
            .chain(&w_s)
            .copied()
            .collect();
        let mut offsets = vec![0.0; q];
        for i in (0..q).rev() {
            let dot: f64 = w_all
                .iter()
                .enumerate()
                .map(|(j, w)| self.factor[(i, q + j)] * w)
                .sum::<f64>()
                + (i + 1..q)
                    .map(|k| self.factor[(i, k)] * offsets[k])
                    .sum::<f64>();
            offsets[i] = if self.factor[(i, i)] != 0.0 {
                (self.factor[(i, q + p)] - dot) / self.factor[(i, i)]
            } else {
                0.0
            };
        }
        let offset = offsets.first().copied().unwrap_or(0.0);
        Ok(Solution {
            w_h,
            w_c,
            w_s,
            offset,
            offsets,
            active_constraints,
            kkt_residual: solution.kkt_residual,
            iterations: solution.iterations,
            creep_penalty,
        })
    }

    /// The non-negative least squares `min ‖M x − d‖` with the creep
    /// penalty of the plan's [`CreepRegularisation`] (its `λ` and the
    /// weights' effective parameters, where there is one). The creep
    /// weights are the differences of their partial sums, `w_C = D x_C`
    /// (their bound is 0), so the penalty is `√(λ s²) D` in the creep
    /// columns under `M`, with zeros under `d`: the problem stays a
    /// non-negative least squares.
    fn penalised(
        &self,
        plan: &FitPlan,
        m: &Mat<f64>,
        d: &[f64],
    ) -> Result<(NnlsSolution, Option<(f64, f64)>), IdentificationError> {
        let creep = plan.group_ranges()[1].clone();
        let lambdas: Vec<f64> = match plan.creep_regularisation {
            CreepRegularisation::None => Vec::new(),
            _ if creep.is_empty() => Vec::new(),
            CreepRegularisation::Fixed(l) => vec![l],
            CreepRegularisation::Gcv => std::iter::once(0.0)
                .chain((0..=20).map(|k| 10f64.powf(-10.0 + 0.5 * k as f64)))
                .collect(),
        };
        if lambdas.is_empty() {
            return Ok((nnls(m, d)?, None));
        }
        let (p, q) = (plan.excited(), plan.offsets);
        let r = Self::weights_block(&self.factor, plan);
        // the mean squared creep column of the regressor (RᵀR = ΦᵀΦ)
        let energy = creep
            .clone()
            .map(|j| (0..p).map(|i| r[(i, j)] * r[(i, j)]).sum::<f64>())
            .sum::<f64>()
            / creep.len() as f64;
        let residual = self.factor[(q + p, q + p)].powi(2);
        let samples = plan.rows as f64;
        let mut best: Option<(f64, NnlsSolution, f64, f64)> = None;
        for lambda in lambdas {
            let s = (lambda * energy).sqrt();
            let rows = p + creep.len();
            let a = Mat::from_fn(rows, p, |i, j| {
                if i < p {
                    m[(i, j)]
                } else {
                    // row k of D on the creep columns: x_k − x_{k−1}
                    let k = creep.start + (i - p);
                    if j == k {
                        s
                    } else if j + 1 == k && j >= creep.start {
                        -s
                    } else {
                        0.0
                    }
                }
            });
            let b: Vec<f64> = (0..rows).map(|i| if i < p { d[i] } else { 0.0 }).collect();
            let solution = nnls(&a, &b)?;
            let rss = (0..p)
                .map(|i| {
                    let e = (0..p).map(|j| m[(i, j)] * solution.x[j]).sum::<f64>() - d[i];
                    e * e
                })
                .sum::<f64>()
                + residual;
            let df = if lambda == 0.0 {
                self.rank as f64
            } else {
                effective_parameters(m, &a, p)
            } + q as f64;
            let score = if samples > df {
                samples * rss / (samples - df).powi(2)
            } else {
                f64::INFINITY
            };
            if best.as_ref().is_none_or(|(s, ..)| score < *s) {
                best = Some((score, solution, lambda, df));
            }
        }
        match best {
            // the weights' share of the effective parameters
            Some((_, solution, lambda, df)) => Ok((solution, Some((lambda, df - q as f64)))),
            None => Ok((nnls(m, d)?, None)),
        }
    }
}

/// `tr((MᵀM + PᵀP)⁻¹ MᵀM)`: the effective parameters of the unconstrained
/// penalised fit, `a = [M; P]` (`M` its first `p` rows).
fn effective_parameters(m: &Mat<f64>, a: &Mat<f64>, p: usize) -> f64 {
    let gram = |x: &Mat<f64>| {
        Mat::from_fn(p, p, |i, j| {
            (0..x.nrows()).map(|k| x[(k, i)] * x[(k, j)]).sum::<f64>()
        })
    };
    use faer::linalg::solvers::Solve;
    let (mtm, ata) = (gram(m), gram(a));
    let x = ata.partial_piv_lu().solve(&mtm);
    (0..p).map(|i| x[(i, i)]).sum()
}
