//! Identification of the hysteresis and creep weights from a measurement,
//! equations (23)–(25).
//!
//! Thresholds (23): `r_i = (i · r_max)/(n + 1)`, `r_max = max_k |v_k|`;
//! creep eigenvalues (24): `a_j = 1/(10^j T_s)`. With those fixed, `W` is linear
//! in the weights, `W[v] = Φ w`, where `Φ` has one column per play output and
//! one per log(t)-creep output (15), sampled on the measured input from the
//! virgin state. (25) becomes the convex QP
//!
//! ```text
//! min_w ½ ‖Φ w − ς‖²   s.t.  Σ_{i≤j} w_H,i ≥ ε_H  (j = 0..n_H),   Σ_{i≤j} w_C,i ≥ 0  (j = 0..n_C)
//! ```
//!
//! **Unknown initial state and offset.** A measurement starts from a history
//! the model does not know, and a sensor adds an offset. Once `|v|` has
//! reached `max|v|`, every play has been pushed to one side of its band, so
//! its state is fixed by the input alone (wiping out, Madelung (iii)): by
//! default only the samples from there on are fitted (the operators still run
//! from the first sample). The creep states are not wiped out that way; their
//! unknown initial part decays like `e^{−a t}`. An output offset is fitted as
//! one more, unconstrained, unknown.
//!
//! Solved as follows:
//!
//! 1. `Φ` is built in one pass over the input (the plays and creep operators
//!    are stepped once per sample); the fitted rows of `[1 | Φ | ς]` (offset
//!    column first) get one thin Householder QR (faer). Eliminating the
//!    offset leaves `‖Φ w − ς‖² = ‖R w − c‖² + ρ²` with a small triangular
//!    `R`: the rest no longer depends on the number of samples.
//! 2. The unknowns become the partial sums shifted by their bounds,
//!    `x_j = S_j − b_j ≥ 0` (`w = D S`, `D` the difference operator per
//!    group), a non-negative least-squares problem `min ‖M x − d‖`,
//!    `M = R D`, solved exactly by the Lawson–Hanson active-set method: it
//!    ends in finitely many steps at a point that meets the KKT conditions
//!    (`g = Mᵀ(M x − d)`: `g_j = 0` where `x_j > 0`, `g_j ≥ 0` where
//!    `x_j = 0`), which the report states as a relative residual.
//! 3. The numerical rank of `R` comes from its singular values: those below
//!    [`RANK_TOLERANCE`] times the largest span directions the input does not
//!    determine; the operators with weight in them are named. Every
//!    least-squares step takes the minimum-norm solution (in `x`), so the
//!    returned optimum is the minimum-norm one of its active set.
//! 4. The weights are rebuilt from the partial sums so that the recomputed
//!    partial sums satisfy the bounds in floating point: the identified model
//!    always satisfies (11) and (17), so its inverse (22) exists.
//!
//! Operators whose threshold the input never exceeds (`r_i ≥ max|v|`) are
//! never excited: their columns are zero. They keep weight 0 (which leaves the
//! partial sums, and so (11), intact) and are named in the report.

use faer::reborrow::ReborrowMut;
use faer::Mat;
use thiserror::Error;

use crate::error::ModelError;
use crate::operators::creep::{log_spaced_eigenvalues, CreepOperator};
use crate::operators::hysteresis::HysteresisOperator;
use crate::operators::model::HysteresisCreepModel;
use crate::operators::play::play;
use crate::operators::traits::Operator;

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
                    crate::operators::hysteresis::check_thresholds(field, r).map_err(|e| {
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
        if let Some(a) = &self.eigenvalues {
            if a.is_empty() || a.iter().any(|&x| !(x.is_finite() && x > 0.0)) {
                return bad("eigenvalues", "must be finite numbers > 0");
            }
        }
        Ok(())
    }
}

/// Thresholds by (23): `r_i = (i · r_max) / (n + 1)`, `i = 0..n`, evaluated in
/// that order so every implementation gets the same bits.
pub fn thresholds_23(count: usize, r_max: f64) -> Vec<f64> {
    (0..count)
        .map(|i| (i as f64 * r_max) / count as f64)
        .collect()
}

/// Singular values of `R` below this fraction of the largest span directions
/// of the weights that the input does not determine: a column whose part
/// independent of the others is below 1e-10 of the largest could be seen
/// only at a noise level of 1e-10 of the signal.
pub const RANK_TOLERANCE: f64 = 1e-10;

/// A constraint that holds with equality at the solution.
#[derive(Debug, Clone, PartialEq)]
pub struct ActiveConstraint {
    /// `"hysteresis"` or `"creep"`.
    pub group: &'static str,
    /// `j` of the partial sum `Σ_{i≤j} w_i`.
    pub index: usize,
    /// Its bound (`ε_H` or 0).
    pub bound: f64,
}

/// An operator named in the report: never excited, or not determined.
#[derive(Debug, Clone, PartialEq)]
pub struct UnexcitedOperator {
    /// `"hysteresis"` or `"creep"`.
    pub group: &'static str,
    /// Index of the operator (its threshold).
    pub index: usize,
    /// Its threshold.
    pub threshold: f64,
}

/// Errors of a model on a stretch of data.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FitErrors {
    /// Samples compared.
    pub samples: usize,
    /// RMS of `W[v] − ς`.
    pub rms: f64,
    /// Max of `|W[v] − ς|`.
    pub max: f64,
    /// `max ς − min ς` over the stretch.
    pub output_range: f64,
}

impl FitErrors {
    /// Errors of `fit` against `y` on `range`.
    pub fn of(fit: &[f64], y: &[f64], range: std::ops::Range<usize>) -> Self {
        let (mut sq, mut max) = (0.0, 0.0f64);
        for k in range.clone() {
            let e = fit[k] - y[k];
            sq += e * e;
            max = max.max(e.abs());
        }
        let n = range.len().max(1);
        Self {
            samples: range.len(),
            rms: (sq / n as f64).sqrt(),
            max,
            output_range: self::range(&y[range]),
        }
    }

    /// RMS error in % of the output range.
    pub fn rms_percent(&self) -> f64 {
        100.0 * self.rms / self.output_range.max(f64::MIN_POSITIVE)
    }

    /// Max error in % of the output range.
    pub fn max_percent(&self) -> f64 {
        100.0 * self.max / self.output_range.max(f64::MIN_POSITIVE)
    }
}

/// How the identification went and how well the model fits.
#[derive(Debug, Clone, PartialEq)]
pub struct FitReport {
    /// Samples in the record.
    pub samples: usize,
    /// The samples fitted, `first..end`.
    pub fitted: std::ops::Range<usize>,
    /// Why the samples before `fitted.start` were left out.
    pub skip_reason: String,
    /// Errors on the fitted samples.
    pub fit: FitErrors,
    /// Errors on the held-out samples at the end, if any.
    pub holdout: Option<FitErrors>,
    /// The fitted output offset (0 when not fitted).
    pub offset: f64,
    /// 2-norm condition number of the reduced regressor (infinite when rank deficient).
    pub condition_number: f64,
    /// Numerical rank of the reduced regressor, and its number of columns.
    pub rank: usize,
    pub unknowns: usize,
    /// Operators whose weights this input does not determine (rank deficiency).
    pub undetermined: Vec<UnexcitedOperator>,
    /// `ε_H` used.
    pub epsilon_h: f64,
    /// Constraints holding with equality at the optimum.
    pub active_constraints: Vec<ActiveConstraint>,
    /// Operators never excited (weight 0).
    pub unexcited: Vec<UnexcitedOperator>,
    /// The worst violation of the KKT conditions of (25), relative to
    /// `‖M‖ ‖d‖` (0 at the exact optimum; rounding is ~1e-16).
    pub kkt_residual: f64,
    /// Steps of the active-set method.
    pub iterations: usize,
}

/// A percentage with four significant digits, in exponent form when tiny.
fn percent(x: f64) -> String {
    if x != 0.0 && x.abs() < 1e-3 {
        format!("{x:.3e} %")
    } else {
        format!("{x:.4} %")
    }
}

impl std::fmt::Display for FitReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "samples              {} ({} fitted: {}..{})",
            self.samples,
            self.fitted.len(),
            self.fitted.start,
            self.fitted.end
        )?;
        if self.fitted.start > 0 {
            writeln!(
                f,
                "skipped              the first {} samples: {}",
                self.fitted.start, self.skip_reason
            )?;
        }
        let e = &self.fit;
        writeln!(
            f,
            "rms error            {:.6e} ({} of the output range {:.6e})",
            e.rms,
            percent(e.rms_percent()),
            e.output_range
        )?;
        writeln!(
            f,
            "max error            {:.6e} ({})",
            e.max,
            percent(e.max_percent())
        )?;
        if let Some(h) = &self.holdout {
            writeln!(
                f,
                "held out             {} samples: rms {:.6e} ({}), max {:.6e} ({})",
                h.samples,
                h.rms,
                percent(h.rms_percent()),
                h.max,
                percent(h.max_percent())
            )?;
        }
        writeln!(f, "offset               {:.6e}", self.offset)?;
        writeln!(f, "cond(Phi)            {:.3e}", self.condition_number)?;
        writeln!(
            f,
            "rank                 {} of {} (singular values below {:e} of the largest count as zero)",
            self.rank, self.unknowns, RANK_TOLERANCE
        )?;
        writeln!(f, "epsilon_H            {:.6e}", self.epsilon_h)?;
        writeln!(
            f,
            "solver               Lawson-Hanson active set, {} steps, KKT residual {:.1e}",
            self.iterations, self.kkt_residual
        )?;
        if self.active_constraints.is_empty() {
            writeln!(f, "active constraints   none")?;
        } else {
            for c in &self.active_constraints {
                writeln!(
                    f,
                    "active constraint    {} partial sum 0..={} = {}",
                    c.group, c.index, c.bound
                )?;
            }
        }
        for u in &self.unexcited {
            writeln!(
                f,
                "warning: {} operator {} (threshold {}) was never excited by the input; its weight is 0",
                u.group, u.index, u.threshold
            )?;
        }
        if !self.undetermined.is_empty() {
            let names: Vec<String> = self
                .undetermined
                .iter()
                .map(|u| format!("{} {} (r = {})", u.group, u.index, u.threshold))
                .collect();
            writeln!(
                f,
                "warning: the input does not determine the weights of {}; the minimum-norm optimum is returned",
                names.join(", ")
            )?;
        }
        Ok(())
    }
}

/// The identified model (virgin state, fitted offset) and its fit report.
#[derive(Debug, Clone)]
pub struct Identification {
    pub model: HysteresisCreepModel,
    pub report: FitReport,
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

/// The first sample at which `|v|` reaches `max|v|`.
pub fn first_at_max(v: &[f64]) -> usize {
    let m = v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    v.iter().position(|x| x.abs() == m).unwrap_or(0)
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
    settings.validate()?;
    if u.len() != y.len() {
        return Err(IdentificationError::LengthMismatch {
            u: u.len(),
            y: y.len(),
        });
    }
    if !(sample_time.is_finite() && sample_time > 0.0) {
        return Err(ModelError::NonPositiveSampleTime { value: sample_time }.into());
    }
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
    let eig = settings
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

    // Operators never excited: thresholds at or above max|v| (a suffix).
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

    let y_range = range(&y[first..end]);
    let u_range = range(u);
    let epsilon_h = settings
        .epsilon_h
        .unwrap_or(1e-3 * y_range.max(f64::MIN_POSITIVE) / u_range);

    // 1. [1 | Φ | ς] on the fitted rows, one pass; then QR.
    let p = nh + nc;
    let q = usize::from(settings.fit_offset);
    let creep_state = if nc > 0 {
        Some(CreepOperator::new(
            r_c[..nc].to_vec(),
            vec![0.0; nc],
            eig.clone(),
            sample_time,
        )?)
    } else {
        None
    };
    let r_aug = regressor_factor(
        u,
        y,
        first..end,
        settings.fit_offset,
        &r_h[..nh],
        creep_state,
    );
    // eliminating the offset (the first column) leaves the rows below it
    let r = Mat::from_fn(p, p, |i, j| r_aug[(q + i, q + j)]);
    let c: Vec<f64> = (0..p).map(|i| r_aug[(q + i, q + p)]).collect();
    let sv = singular_values(&r);
    let smax = sv.first().copied().unwrap_or(0.0);
    let rank = sv.iter().filter(|&&s| s > RANK_TOLERANCE * smax).count();
    let condition_number = if rank < p || smax == 0.0 {
        f64::INFINITY
    } else {
        smax / sv[p - 1]
    };
    let name = |j: usize| {
        if j < nh {
            UnexcitedOperator {
                group: "hysteresis",
                index: j,
                threshold: r_h[j],
            }
        } else {
            UnexcitedOperator {
                group: "creep",
                index: j - nh,
                threshold: r_c[j - nh],
            }
        }
    };
    let undetermined = null_space_members(&r, rank).into_iter().map(name).collect();

    // 2. Non-negative least squares in x = S − b.
    let bounds: Vec<f64> = (0..p)
        .map(|j| if j < nh { epsilon_h } else { 0.0 })
        .collect();
    // M = R D: column j of R D is R_j − R_{j+1} within each group.
    let m = Mat::from_fn(p, p, |i, j| {
        let next = j + 1;
        let same_group = (j < nh && next < nh) || (j >= nh && next < p);
        r[(i, j)] - if same_group { r[(i, next)] } else { 0.0 }
    });
    let d: Vec<f64> = (0..p)
        .map(|i| c[i] - (0..p).map(|j| m[(i, j)] * bounds[j]).sum::<f64>())
        .collect();
    let solution = nnls(&m, &d)?;
    let sums: Vec<f64> = (0..p).map(|j| bounds[j] + solution.x[j]).collect();
    let active_constraints = (0..p)
        .filter(|&j| solution.x[j] == 0.0)
        .map(|j| ActiveConstraint {
            group: if j < nh { "hysteresis" } else { "creep" },
            index: if j < nh { j } else { j - nh },
            bound: bounds[j],
        })
        .collect();

    // 3. Weights from partial sums, such that the recomputed sums hold.
    let mut w_h = weights_from_sums(&sums[..nh], epsilon_h);
    w_h.resize(r_h.len(), 0.0);
    let mut w_c = weights_from_sums(&sums[nh..], 0.0);
    w_c.resize(r_c.len(), 0.0);
    // the offset from the first row of R: r_00 o + r_0j w_j = c_0
    let offset = if settings.fit_offset && r_aug[(0, 0)] != 0.0 {
        let mut w_all = w_h[..nh].to_vec();
        w_all.extend_from_slice(&w_c[..nc]);
        let dot: f64 = (0..p).map(|j| r_aug[(0, 1 + j)] * w_all[j]).sum();
        (r_aug[(0, p + 1)] - dot) / r_aug[(0, 0)]
    } else {
        0.0
    };

    let hysteresis = HysteresisOperator::new(r_h, w_h)?;
    let creep = if r_c.is_empty() {
        None
    } else {
        Some(CreepOperator::new(r_c, w_c, eig, sample_time)?)
    };
    let model = HysteresisCreepModel::new(sample_time, hysteresis, creep)?.with_offset(offset);

    // Fit of the model as it will be used, from the virgin state.
    let fit = model.clone().run(u);
    let report = FitReport {
        samples: n,
        fitted: first..end,
        skip_reason,
        fit: FitErrors::of(&fit, y, first..end),
        holdout: (end < n).then(|| FitErrors::of(&fit, y, end..n)),
        offset,
        condition_number,
        rank,
        unknowns: p,
        undetermined,
        epsilon_h,
        active_constraints,
        unexcited,
        kkt_residual: solution.kkt_residual,
        iterations: solution.iterations,
    };
    Ok(Identification { model, report })
}

/// Errors of `model` (run from the virgin state over the whole record) on a
/// validation record, from the first sample at which `|u|` reaches `max|u|`.
pub fn validate(
    model: &HysteresisCreepModel,
    u: &[f64],
    y: &[f64],
) -> Result<FitErrors, IdentificationError> {
    if u.len() != y.len() {
        return Err(IdentificationError::LengthMismatch {
            u: u.len(),
            y: y.len(),
        });
    }
    check_finite("u", u)?;
    check_finite("y", y)?;
    let mut m = model.clone();
    m.reset();
    let fit = m.run(u);
    Ok(FitErrors::of(&fit, y, first_at_max(u)..u.len()))
}

fn range(x: &[f64]) -> f64 {
    let (lo, hi) = x
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    hi - lo
}

/// Rows of the regressor folded into the triangular factor at a time: the
/// chunk (`CHUNK × (p + 2)` doubles, about 1 MB at the paper's orders) stays
/// in cache, where the whole regressor (40 MB for 40 s) would not.
const CHUNK: usize = 4096;

/// The upper-triangular factor `R` of `[1 | Φ | ς]` on the samples `rows`
/// (the `1` column only with `offset`): play outputs, log(t)-creep outputs
/// (before the update with `v_k`: the one-sample delay of (20)) and the
/// measurement. The operators run from the first sample; only the rows in
/// `rows` enter. The regressor is never stored whole: chunks of [`CHUNK`]
/// rows are stacked under the factor so far and factored again (a streaming
/// "tall-skinny" QR), which gives the factor of the whole (up to the signs
/// of its rows) with the same backward stability.
fn regressor_factor(
    u: &[f64],
    y: &[f64],
    rows: std::ops::Range<usize>,
    offset: bool,
    r_h: &[f64],
    mut creep: Option<CreepOperator>,
) -> Mat<f64> {
    let nh = r_h.len();
    let nc = creep.as_ref().map_or(0, |c| c.thresholds().len());
    let p = nh + nc;
    let q = usize::from(offset);
    let cols = q + p + 1;
    // the factor so far in the first `cols` rows, the new chunk below it
    let mut stack = Mat::<f64>::zeros(cols + CHUNK, cols);
    let mut filled = 0; // chunk rows filled
    let mut have_r = false;
    let mut x = vec![0.0; nh];
    let mut creep_row = vec![0.0; nc];
    for k in 0..rows.end {
        let v = u[k];
        for (xi, &r) in x.iter_mut().zip(r_h) {
            *xi = play(v, r, *xi);
        }
        let keep = k >= rows.start;
        if let Some(c) = &mut creep {
            if keep {
                c.log_creep_outputs_into(&mut creep_row);
            }
            c.advance_state(v);
        }
        if !keep {
            continue;
        }
        let row = cols + filled;
        if offset {
            stack[(row, 0)] = 1.0;
        }
        for (j, &xj) in x.iter().enumerate() {
            stack[(row, q + j)] = xj;
        }
        for (j, &cj) in creep_row.iter().enumerate() {
            stack[(row, q + nh + j)] = cj;
        }
        stack[(row, q + p)] = y[k];
        filled += 1;
        if filled == CHUNK || k + 1 == rows.end {
            fold_chunk(&mut stack, cols, filled, have_r);
            have_r = true;
            filled = 0;
        }
    }
    Mat::from_fn(cols, cols, |i, j| if i <= j { stack[(i, j)] } else { 0.0 })
}

/// Factor the stack `[R; chunk]` (the first `filled` chunk rows) in place and
/// leave the new triangular factor in the first `cols` rows.
fn fold_chunk(stack: &mut Mat<f64>, cols: usize, filled: usize, have_r: bool) {
    let first = if have_r { 0 } else { cols };
    let mut part = stack.as_mut().subrows_mut(first, cols + filled - first);
    thin_r_in_place(part.rb_mut());
    let r = Mat::from_fn(cols, cols, |i, j| {
        if i <= j && i < part.nrows() {
            part[(i, j)]
        } else {
            0.0
        }
    });
    for j in 0..cols {
        for i in 0..cols {
            stack[(i, j)] = r[(i, j)];
        }
    }
}

/// An in-place blocked Householder QR (faer); `R` is left in the upper
/// triangle.
fn thin_r_in_place(mut a: faer::MatMut<'_, f64>) {
    use faer::dyn_stack::{MemBuffer, MemStack};
    use faer::linalg::qr::no_pivoting::factor;
    let (nrows, ncols) = (a.nrows(), a.ncols());
    let size = nrows.min(ncols);
    let block = factor::recommended_block_size::<f64>(nrows, ncols);
    let mut coeff = Mat::<f64>::zeros(block, size);
    let par = faer::Par::Seq;
    let mut buf = MemBuffer::new(factor::qr_in_place_scratch::<f64>(
        nrows,
        ncols,
        block,
        par,
        Default::default(),
    ));
    factor::qr_in_place(
        a.rb_mut(),
        coeff.as_mut(),
        par,
        MemStack::new(&mut buf),
        Default::default(),
    );
}

/// The singular values of a small square matrix, descending.
fn singular_values(a: &Mat<f64>) -> Vec<f64> {
    if a.nrows() == 0 {
        return Vec::new();
    }
    match a.singular_values() {
        Ok(s) => s,
        Err(_) => vec![f64::NAN; a.nrows()],
    }
}

/// The columns (operators) with a large share in the null space of `r`
/// beyond its numerical `rank`: those whose weights the data do not fix.
fn null_space_members(r: &Mat<f64>, rank: usize) -> Vec<usize> {
    let p = r.ncols();
    if rank >= p {
        return Vec::new();
    }
    let Ok(svd) = r.svd() else {
        return Vec::new();
    };
    let v = svd.V();
    // per column: its weight in the null space (the rows of V beyond rank)
    let share: Vec<f64> = (0..p)
        .map(|j| (rank..p).map(|k| v[(j, k)] * v[(j, k)]).sum::<f64>().sqrt())
        .collect();
    let big = share.iter().fold(0.0f64, |m, x| m.max(*x));
    (0..p).filter(|&j| share[j] > 0.1 * big).collect()
}

/// The result of [`nnls`].
struct NnlsSolution {
    x: Vec<f64>,
    kkt_residual: f64,
    iterations: usize,
}

/// Minimum-norm least squares `min ‖A_P z − d‖` on the columns `P` of `a`,
/// through the SVD with the rank cut of [`RANK_TOLERANCE`].
fn least_squares(a: &Mat<f64>, cols: &[usize], d: &[f64]) -> Vec<f64> {
    let rows = a.nrows();
    let sub = Mat::from_fn(rows, cols.len(), |i, k| a[(i, cols[k])]);
    let Ok(svd) = sub.thin_svd() else {
        return vec![0.0; cols.len()];
    };
    let (u, s, v) = (svd.U(), svd.S(), svd.V());
    let smax = (0..s.dim()).map(|k| s[k]).fold(0.0f64, f64::max);
    let mut z = vec![0.0; cols.len()];
    for k in 0..s.dim() {
        if s[k] <= RANK_TOLERANCE * smax || s[k] == 0.0 {
            continue;
        }
        let coef = (0..rows).map(|i| u[(i, k)] * d[i]).sum::<f64>() / s[k];
        for (j, zj) in z.iter_mut().enumerate() {
            *zj += coef * v[(j, k)];
        }
    }
    z
}

/// `min ‖a x − d‖` subject to `x ≥ 0`: the Lawson–Hanson active-set method
/// (Lawson & Hanson, *Solving Least Squares Problems*, 1974, ch. 23). It
/// moves one variable at a time into the passive (free) set where the
/// gradient says the cost falls, solves the least-squares problem on the
/// passive set, and steps back along the segment where a passive variable
/// would turn negative; it ends at the exact optimum.
fn nnls(a: &Mat<f64>, d: &[f64]) -> Result<NnlsSolution, IdentificationError> {
    let (rows, p) = (a.nrows(), a.ncols());
    let a_norm = (0..rows)
        .flat_map(|i| (0..p).map(move |j| (i, j)))
        .map(|(i, j)| a[(i, j)] * a[(i, j)])
        .sum::<f64>()
        .sqrt();
    let d_norm = d.iter().map(|x| x * x).sum::<f64>().sqrt();
    let scale = (a_norm * d_norm).max(f64::MIN_POSITIVE);
    let tol = 10.0 * p.max(1) as f64 * f64::EPSILON * scale;
    // gradient of −½‖a x − d‖²: aᵀ(d − a x)
    let descent = |x: &[f64]| -> Vec<f64> {
        let r: Vec<f64> = (0..rows)
            .map(|i| d[i] - (0..p).map(|j| a[(i, j)] * x[j]).sum::<f64>())
            .collect();
        (0..p)
            .map(|j| (0..rows).map(|i| a[(i, j)] * r[i]).sum())
            .collect()
    };
    let mut x = vec![0.0; p];
    let mut passive = vec![false; p];
    let mut iterations = 0;
    let limit = 30 * (p + 1);
    loop {
        let w = descent(&x);
        let candidate = (0..p)
            .filter(|&j| !passive[j] && w[j] > tol)
            .max_by(|&i, &j| w[i].total_cmp(&w[j]));
        let Some(t) = candidate else { break };
        passive[t] = true;
        loop {
            iterations += 1;
            if iterations > limit {
                return Err(IdentificationError::NotSolved {
                    reason: format!("no convergence in {limit} active-set steps"),
                });
            }
            let cols: Vec<usize> = (0..p).filter(|&j| passive[j]).collect();
            let zp = least_squares(a, &cols, d);
            let mut z = vec![0.0; p];
            for (k, &j) in cols.iter().enumerate() {
                z[j] = zp[k];
            }
            if cols.iter().all(|&j| z[j] > 0.0) {
                x = z;
                break;
            }
            // step from x toward z until the first passive variable hits 0
            let alpha = cols
                .iter()
                .filter(|&&j| z[j] <= 0.0)
                .map(|&j| x[j] / (x[j] - z[j]))
                .fold(f64::INFINITY, f64::min);
            for j in 0..p {
                x[j] += alpha * (z[j] - x[j]);
            }
            for &j in &cols {
                if x[j] <= 0.0 || (z[j] <= 0.0 && x[j] <= 1e-15 * (1.0 + x[j].abs())) {
                    x[j] = 0.0;
                    passive[j] = false;
                }
            }
        }
    }
    // KKT: descent direction zero on the free variables, ≤ 0 on the bound ones
    let w = descent(&x);
    let kkt = (0..p)
        .map(|j| {
            if x[j] > 0.0 {
                w[j].abs()
            } else {
                w[j].max(0.0)
            }
        })
        .fold(0.0f64, f64::max);
    Ok(NnlsSolution {
        x,
        kkt_residual: kkt / scale,
        iterations,
    })
}

/// `w_0 = S_0`, `w_j = S_j − S_{j−1}`, nudged up by ulps where needed so that
/// the partial sums recomputed in floating point (as the operators' checks do)
/// stay at or above `bound`.
fn weights_from_sums(sums: &[f64], bound: f64) -> Vec<f64> {
    let mut w = Vec::with_capacity(sums.len());
    let mut prev_exact = 0.0;
    let mut running = 0.0;
    for &s in sums {
        let s = s.max(bound);
        let mut wj = s - prev_exact;
        while running + wj < bound {
            wj = wj.next_up();
        }
        running += wj;
        prev_exact = s;
        w.push(wj);
    }
    w
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
    fn weights_from_sums_keep_recomputed_sums_at_the_bound() {
        let sums = [0.3, 0.1 + 0.2, 1e-3, 0.7, 1e-3];
        let w = weights_from_sums(&sums, 1e-3);
        let mut s = 0.0;
        for wj in w {
            s += wj;
            assert!(s >= 1e-3);
        }
        let w = weights_from_sums(&[0.5, 0.0, 0.25, 0.0], 0.0);
        let mut s = 0.0;
        for wj in w {
            s += wj;
            assert!(s >= 0.0);
        }
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
