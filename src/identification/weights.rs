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
//! Solved as follows:
//!
//! 1. `Φ` is built in one pass over the input (the plays and creep operators
//!    are stepped once per sample) and augmented with the measured column
//!    `ς`; one thin Householder QR of `[Φ | ς]` (faer) gives the triangular
//!    `R`, `c = Qᵀ ς` and the residual norm, so `‖Φ w − ς‖² = ‖R w − c‖² + ρ²`
//!    and the QP no longer depends on the number of samples.
//! 2. The unknowns are the partial sums `S_j` themselves (`w = D S`, `D` the
//!    difference operator per group), so the constraints are simple bounds
//!    `S ≥ (ε_H, …, 0, …)`. clarabel solves `min ½‖e‖²` subject to
//!    `R D S − e = c` (zero cone) and the bounds (non-negative cone).
//! 3. The active set clarabel finds is polished: the equality-constrained
//!    least-squares problem on that set is solved exactly by a small QR, and
//!    kept if it is feasible and its multipliers are non-negative (the KKT
//!    conditions), so that exact data give exact weights rather than weights
//!    to the interior-point tolerance.
//! 4. The weights are rebuilt from the partial sums so that the recomputed
//!    partial sums satisfy the bounds in floating point: the identified model
//!    always satisfies (11) and (17), so its inverse (22) exists.
//!
//! Operators whose threshold the input never exceeds (`r_i ≥ max|v|`) are
//! never excited: their columns are zero. They keep weight 0 (which leaves the
//! partial sums, and so (11), intact) and are named in the report.

use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettingsBuilder, DefaultSolver, IPSolver, SolverStatus, SupportedConeT,
};
use faer::linalg::solvers::SolveLstsq;
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
    /// The QP solver did not reach a solution.
    #[error("the constrained least-squares problem was not solved: clarabel status {status}")]
    NotSolved { status: String },
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

/// An operator the input never excited.
#[derive(Debug, Clone, PartialEq)]
pub struct UnexcitedOperator {
    /// `"hysteresis"` or `"creep"`.
    pub group: &'static str,
    /// Index of the operator (its threshold).
    pub index: usize,
    /// Its threshold, at or above `max |v|`.
    pub threshold: f64,
}

/// How well the identified model fits the data.
#[derive(Debug, Clone, PartialEq)]
pub struct FitReport {
    /// Number of samples.
    pub samples: usize,
    /// RMS of `W[v] − ς`.
    pub rms_error: f64,
    /// Max of `|W[v] − ς|`.
    pub max_error: f64,
    /// `max ς − min ς`.
    pub output_range: f64,
    /// RMS error in % of the output range.
    pub rms_error_percent: f64,
    /// Max error in % of the output range.
    pub max_error_percent: f64,
    /// 2-norm condition number of `Φ` (excited columns).
    pub condition_number: f64,
    /// `ε_H` used.
    pub epsilon_h: f64,
    /// Constraints holding with equality.
    pub active_constraints: Vec<ActiveConstraint>,
    /// Operators never excited (weight 0).
    pub unexcited: Vec<UnexcitedOperator>,
    /// Interior-point iterations of clarabel.
    pub solver_iterations: u32,
    /// Whether the active-set polish replaced clarabel's solution.
    pub polished: bool,
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
        writeln!(f, "samples              {}", self.samples)?;
        writeln!(
            f,
            "rms error            {:.6e} ({} of the output range {:.6e})",
            self.rms_error,
            percent(self.rms_error_percent),
            self.output_range
        )?;
        writeln!(
            f,
            "max error            {:.6e} ({})",
            self.max_error,
            percent(self.max_error_percent)
        )?;
        writeln!(f, "cond(Phi)            {:.3e}", self.condition_number)?;
        writeln!(f, "epsilon_H            {:.6e}", self.epsilon_h)?;
        writeln!(
            f,
            "solver               clarabel, {} iterations{}",
            self.solver_iterations,
            if self.polished {
                ", active set polished"
            } else {
                ""
            }
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
        Ok(())
    }
}

/// The identified model (virgin state) and its fit report.
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

/// Identify a model from input `u` (V) and measured output `y`, sampled at
/// `sample_time`, starting from the virgin state.
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
    let unknowns = r_h.len() + r_c.len();
    let needed = 2 * unknowns + 1;
    if n < needed {
        return Err(IdentificationError::TooFewSamples {
            found: n,
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

    let y_range = range(y);
    let u_range = range(u);
    let epsilon_h = settings
        .epsilon_h
        .unwrap_or(1e-3 * y_range.max(f64::MIN_POSITIVE) / u_range);

    // 1. Φ (excited columns) with ς appended, one pass; then QR.
    let p = nh + nc;
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
    let mut phi = build_regressor(u, y, &r_h[..nh], creep_state);
    let r_aug = thin_r(&mut phi);
    let r = Mat::from_fn(p, p, |i, j| r_aug[(i, j)]);
    let c: Vec<f64> = (0..p).map(|i| r_aug[(i, p)]).collect();
    let condition_number = condition_number(&r);

    // 2. The QP in partial sums: w = D S, bounds S ≥ (ε_H…, 0…).
    let bounds: Vec<f64> = (0..p)
        .map(|j| if j < nh { epsilon_h } else { 0.0 })
        .collect();
    // M = R D: column j of R D is R_j − R_{j+1} within each group.
    let m = Mat::from_fn(p, p, |i, j| {
        let next = j + 1;
        let same_group = (j < nh && next < nh) || (j >= nh && next < p);
        r[(i, j)] - if same_group { r[(i, next)] } else { 0.0 }
    });
    let qp = solve_qp(&m, &c, &bounds)?;
    let iterations = qp.iterations;

    // 3. Polish on the active set.
    let (sums, polished) = match polish(&m, &c, &bounds, &qp.active) {
        Some(s) => (s, true),
        None => (
            qp.sums
                .iter()
                .zip(&bounds)
                .map(|(s, b)| s.max(*b))
                .collect(),
            false,
        ),
    };
    let active_constraints = (0..p)
        .filter(|&j| sums[j] <= bounds[j])
        .map(|j| ActiveConstraint {
            group: if j < nh { "hysteresis" } else { "creep" },
            index: if j < nh { j } else { j - nh },
            bound: bounds[j],
        })
        .collect();

    // 4. Weights from partial sums, such that the recomputed sums hold.
    let mut w_h = weights_from_sums(&sums[..nh], epsilon_h);
    w_h.resize(r_h.len(), 0.0);
    let mut w_c = weights_from_sums(&sums[nh..], 0.0);
    w_c.resize(r_c.len(), 0.0);

    let hysteresis = HysteresisOperator::new(r_h, w_h)?;
    let creep = if r_c.is_empty() {
        None
    } else {
        Some(CreepOperator::new(r_c, w_c, eig, sample_time)?)
    };
    let model = HysteresisCreepModel::new(sample_time, hysteresis, creep)?;

    // Fit of the model as it will be used.
    let fit = model.clone().run(u);
    let (mut sq, mut max_error) = (0.0, 0.0f64);
    for (a, b) in fit.iter().zip(y) {
        let e = a - b;
        sq += e * e;
        max_error = max_error.max(e.abs());
    }
    let rms_error = (sq / n as f64).sqrt();
    let pct = |e: f64| 100.0 * e / y_range.max(f64::MIN_POSITIVE);
    let report = FitReport {
        samples: n,
        rms_error,
        max_error,
        output_range: y_range,
        rms_error_percent: pct(rms_error),
        max_error_percent: pct(max_error),
        condition_number,
        epsilon_h,
        active_constraints,
        unexcited,
        solver_iterations: iterations,
        polished,
    };
    Ok(Identification { model, report })
}

fn range(x: &[f64]) -> f64 {
    let (lo, hi) = x
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    hi - lo
}

/// `[Φ | ς]`: play outputs, log(t)-creep outputs (before the update with
/// `v_k`: the one-sample delay of (20)) and the measurement, column-major.
fn build_regressor(
    u: &[f64],
    y: &[f64],
    r_h: &[f64],
    mut creep: Option<CreepOperator>,
) -> Mat<f64> {
    const BLOCK: usize = 256;
    let n = u.len();
    let nh = r_h.len();
    let nc = creep.as_ref().map_or(0, |c| c.thresholds().len());
    let p = nh + nc;
    let mut phi = Mat::<f64>::zeros(n, p + 1);
    let mut x = vec![0.0; nh];
    let mut block = vec![0.0; BLOCK * p];
    for k0 in (0..n).step_by(BLOCK) {
        let len = BLOCK.min(n - k0);
        for (row, &v) in block.chunks_exact_mut(p).zip(&u[k0..k0 + len]) {
            for ((xi, &r), out) in x.iter_mut().zip(r_h).zip(row.iter_mut()) {
                *xi = play(v, r, *xi);
                *out = *xi;
            }
            if let Some(c) = &mut creep {
                c.log_creep_outputs_into(&mut row[nh..]);
                c.advance(v);
            }
        }
        for j in 0..p {
            let col = &mut phi.col_as_slice_mut(j)[k0..k0 + len];
            for (dst, row) in col.iter_mut().zip(block.chunks_exact(p)) {
                *dst = row[j];
            }
        }
        phi.col_as_slice_mut(p)[k0..k0 + len].copy_from_slice(&y[k0..k0 + len]);
    }
    phi
}

/// The `(p+1) × (p+1)` upper-triangular factor of `[Φ | ς]`, by an in-place
/// blocked Householder QR (faer).
fn thin_r(a: &mut Mat<f64>) -> Mat<f64> {
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
        a.as_mut(),
        coeff.as_mut(),
        par,
        MemStack::new(&mut buf),
        Default::default(),
    );
    Mat::from_fn(size, ncols, |i, j| if i <= j { a[(i, j)] } else { 0.0 })
}

/// `σ_max / σ_min` of `R` (the same as of `Φ`).
fn condition_number(r: &Mat<f64>) -> f64 {
    match r.singular_values() {
        Ok(s) if !s.is_empty() => {
            let (max, min) = (s[0], s[s.len() - 1]);
            if min > 0.0 {
                max / min
            } else {
                f64::INFINITY
            }
        }
        _ => f64::NAN,
    }
}

/// clarabel: `min ½‖e‖²` s.t. `M S − e = c`, `S ≥ bounds`. Returns `S`.
///
/// Solved in scaled variables `S̃_j = ‖M_j‖ S_j / ‖c‖` (unit columns, unit
/// right-hand side) so that the interior-point method sees a problem of
/// order one whatever the units of `u` and `ς`.
fn solve_qp(m: &Mat<f64>, c: &[f64], bounds: &[f64]) -> Result<QpSolution, IdentificationError> {
    let p = c.len();
    let c_norm = c
        .iter()
        .map(|x| x * x)
        .sum::<f64>()
        .sqrt()
        .max(f64::MIN_POSITIVE);
    let col: Vec<f64> = (0..p)
        .map(|j| {
            let n = (0..p).map(|i| m[(i, j)] * m[(i, j)]).sum::<f64>().sqrt();
            if n > 0.0 {
                n
            } else {
                1.0
            }
        })
        .collect();
    // variables x = (S̃, e); P = diag(0, I)
    let mut p_rows = Vec::with_capacity(2 * p);
    for i in 0..2 * p {
        let mut row = vec![0.0; 2 * p];
        if i >= p {
            row[i] = 1.0;
        }
        p_rows.push(row);
    }
    let p_mat = CscMatrix::from(p_rows.iter().map(|r| r.iter()));
    let q = vec![0.0; 2 * p];
    // rows 0..p: [M̃, −I] x = c̃ (zero cone); rows p..2p: [−I, 0] x + s = −b̃.
    let mut a_rows = Vec::with_capacity(2 * p);
    for i in 0..p {
        let mut row = vec![0.0; 2 * p];
        for j in 0..p {
            row[j] = m[(i, j)] / col[j];
        }
        row[p + i] = -1.0;
        a_rows.push(row);
    }
    for i in 0..p {
        let mut row = vec![0.0; 2 * p];
        row[i] = -1.0;
        a_rows.push(row);
    }
    let a_mat = CscMatrix::from(a_rows.iter().map(|r| r.iter()));
    let mut b: Vec<f64> = c.iter().map(|x| x / c_norm).collect();
    b.extend(bounds.iter().zip(&col).map(|(x, s)| -x * s / c_norm));
    let cones = [
        SupportedConeT::ZeroConeT(p),
        SupportedConeT::NonnegativeConeT(p),
    ];
    let settings = DefaultSettingsBuilder::default()
        .verbose(false)
        .max_iter(200)
        .build()
        .map_err(|e| IdentificationError::NotSolved {
            status: format!("settings: {e}"),
        })?;
    let mut solver = DefaultSolver::new(&p_mat, &q, &a_mat, &b, &cones, settings).map_err(|e| {
        IdentificationError::NotSolved {
            status: format!("setup: {e}"),
        }
    })?;
    solver.solve();
    let status = solver.solution.status;
    if status != SolverStatus::Solved {
        return Err(IdentificationError::NotSolved {
            status: format!("{status:?}"),
        });
    }
    let sol = &solver.solution;
    Ok(QpSolution {
        sums: (0..p).map(|j| sol.x[j] * c_norm / col[j]).collect(),
        // strict complementarity: a bound is active where its dual exceeds its slack
        active: (0..p).map(|j| sol.z[p + j] > sol.s[p + j]).collect(),
        iterations: sol.iterations,
    })
}

/// Partial sums, the active bounds and the iteration count of the QP.
struct QpSolution {
    sums: Vec<f64>,
    active: Vec<bool>,
    iterations: u32,
}

/// Equality-constrained least squares on the active set: `S_A = bounds_A`,
/// `S_F` minimizing `‖M_F S_F − (c − M_A b_A)‖`. Accepted if `S_F ≥ bounds_F`
/// and the multipliers `g_A = (Mᵀ(M S − c))_A` are non-negative (KKT).
fn polish(m: &Mat<f64>, c: &[f64], bounds: &[f64], active: &[bool]) -> Option<Vec<f64>> {
    let p = c.len();
    let free: Vec<usize> = (0..p).filter(|&j| !active[j]).collect();
    let mut s: Vec<f64> = (0..p)
        .map(|j| if active[j] { bounds[j] } else { 0.0 })
        .collect();
    if !free.is_empty() {
        let mf = Mat::from_fn(p, free.len(), |i, k| m[(i, free[k])]);
        let rhs = Mat::from_fn(p, 1, |i, _| {
            c[i] - (0..p)
                .filter(|&j| active[j])
                .map(|j| m[(i, j)] * bounds[j])
                .sum::<f64>()
        });
        let sol = mf.qr().solve_lstsq(&rhs);
        for (k, &j) in free.iter().enumerate() {
            s[j] = sol[(k, 0)];
        }
    }
    let scale = s.iter().fold(0.0f64, |a, x| a.max(x.abs())).max(1e-300);
    if free.iter().any(|&j| s[j] < bounds[j] - 1e-12 * scale) || s.iter().any(|x| !x.is_finite()) {
        return None;
    }
    // residual and gradient g = Mᵀ (M S − c)
    let res: Vec<f64> = (0..p)
        .map(|i| (0..p).map(|j| m[(i, j)] * s[j]).sum::<f64>() - c[i])
        .collect();
    let g_scale: f64 = (0..p)
        .map(|j| (0..p).map(|i| m[(i, j)].abs() * c[i].abs()).sum::<f64>())
        .fold(0.0, f64::max);
    for j in (0..p).filter(|&j| active[j]) {
        let g: f64 = (0..p).map(|i| m[(i, j)] * res[i]).sum();
        if g < -1e-9 * g_scale {
            return None;
        }
    }
    for j in free {
        s[j] = s[j].max(bounds[j]);
    }
    Some(s)
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
