//! Identification of beam parameters from a step response (the paper's
//! section 4.2): least squares between a measured and a simulated tip
//! response over a chosen subset of the physical parameters, by
//! Levenberg–Marquardt (the `levenberg-marquardt` crate, on nalgebra).
//!
//! Parameters are fitted in log coordinates `p = ln θ` (they are all
//! positive, and relative steps suit quantities spanning many decades),
//! clamped to their bounds. Their Jacobian columns are central differences
//! (step 1e-4 in `ln θ`).
//!
//! A measured record ([`StepFitOptions::default`]) has two more unknowns: the
//! sensor's offset, and the time of the step, which a logger does not place
//! on a sample. For a single step `u_0 → u_1` at time `t_s` the response is
//! `y_k = offset + G(0) u_0 + (u_1 − u_0) s(k T_s − t_s)` with `s` the beam's
//! exact continuous unit step response from the modal form, so `t_s` is a
//! continuous parameter; the Jacobian columns of the offset (1) and of `t_s`
//! (minus the impulse response) are exact.
//!
//! From one tip response not every parameter is identifiable: scaling
//! `μ, Λ, γ_e, γ_i, Γ_p` together changes nothing. Before fitting, the
//! Jacobian's singular values are inspected (columns scaled to unit norm); if
//! the smallest is below `1e-5` of the largest, the fit is refused with the
//! parameters that make up the null direction. The standard errors are
//! `σ √diag((JᵀJ)⁻¹)`, `σ² = ‖r‖² / (N − p)`, mapped back from log coordinates.

use faer::linalg::solvers::Solve;
use faer::{Mat, Side};
use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt};
use nalgebra::{storage::Owned, DMatrix, DVector, Dyn};

use crate::beam::fe::FiniteElementModel;
use crate::beam::modal::ModalModel;
use crate::beam::ritz::RitzModel;
use crate::beam::simulation::{cexpm1, DiagonalForm, DiscreteBeam};
use crate::beam::{BeamError, BeamParameters};

/// Central-difference step in log coordinates: truncation error `~h² ≈ 1e-8`,
/// rounding of the simulated response (`~1e-12` relative) amplified to
/// `~1e-12/h ≈ 1e-8`: balanced.
const FD_STEP: f64 = 1e-4;

/// Singular value ratio below which a Jacobian direction counts as null:
/// well above the finite-difference error (~1e-8, see [`FD_STEP`]) that a
/// true null direction shows, and a direction this weak would need a noise
/// level of 1e-5 of the signal to be seen at all.
const RANK_TOLERANCE: f64 = 1e-5;

/// Which discretization of the beam to use.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BeamModelKind {
    /// The paper's Ritz model with `basis_functions` uniform-beam modes.
    Ritz,
    /// The converged finite-element model reduced to `basis_functions` modes.
    Modal { elements: usize },
}

impl Default for BeamModelKind {
    fn default() -> Self {
        BeamModelKind::Modal {
            elements: crate::beam::fe::DEFAULT_ELEMENTS,
        }
    }
}

/// The modal model of `beam` with `beam.basis_functions` modes.
pub fn modal_model(beam: &BeamParameters, kind: BeamModelKind) -> Result<ModalModel, BeamError> {
    match kind {
        BeamModelKind::Ritz => RitzModel::new(beam, beam.basis_functions)?.modal(),
        BeamModelKind::Modal { elements } => {
            FiniteElementModel::new(beam, elements)?.modal(beam.basis_functions)
        }
    }
}

/// Names of the parameters that can be fitted.
pub const PARAMETER_NAMES: [&str; 16] = [
    "length",
    "width",
    "thickness",
    "density",
    "youngs_modulus",
    "viscous_damping",
    "kelvin_voigt_damping",
    "patch.start",
    "patch.length",
    "patch.width",
    "patch.thickness",
    "patch.density",
    "patch.stiffness",
    "patch.viscous_damping",
    "patch.kelvin_voigt_damping",
    "patch.input_gain",
];

fn field_mut<'a>(beam: &'a mut BeamParameters, name: &str) -> Option<&'a mut f64> {
    Some(match name {
        "length" => &mut beam.length,
        "width" => &mut beam.width,
        "thickness" => &mut beam.thickness,
        "density" => &mut beam.density,
        "youngs_modulus" => &mut beam.youngs_modulus,
        "viscous_damping" => &mut beam.viscous_damping,
        "kelvin_voigt_damping" => &mut beam.kelvin_voigt_damping,
        "patch.start" => &mut beam.patch.start,
        "patch.length" => &mut beam.patch.length,
        "patch.width" => &mut beam.patch.width,
        "patch.thickness" => &mut beam.patch.thickness,
        "patch.density" => &mut beam.patch.density,
        "patch.stiffness" => &mut beam.patch.stiffness,
        "patch.viscous_damping" => &mut beam.patch.viscous_damping,
        "patch.kelvin_voigt_damping" => &mut beam.patch.kelvin_voigt_damping,
        "patch.input_gain" => &mut beam.patch.input_gain,
        _ => return None,
    })
}

/// The value of a named parameter.
pub fn parameter(beam: &BeamParameters, name: &str) -> Option<f64> {
    let mut b = beam.clone();
    field_mut(&mut b, name).map(|v| *v)
}

/// One parameter to fit, with bounds.
#[derive(Debug, Clone, PartialEq)]
pub struct FitParameter {
    pub name: String,
    pub lower: f64,
    pub upper: f64,
}

impl FitParameter {
    /// Bounds a factor 100 either side of the starting value.
    pub fn around(beam: &BeamParameters, name: &str) -> Result<Self, BeamError> {
        let v = parameter(beam, name).ok_or_else(|| unknown(name))?;
        Ok(Self {
            name: name.to_string(),
            lower: v / 100.0,
            upper: v * 100.0,
        })
    }
}

fn unknown(name: &str) -> BeamError {
    BeamError::InvalidSetting {
        field: "fit",
        reason: format!(
            "unknown parameter '{name}' (one of: {})",
            PARAMETER_NAMES.join(", ")
        ),
    }
}

/// Result of a step-response fit.
#[derive(Debug, Clone, PartialEq)]
pub struct BeamFit {
    /// The beam with the fitted values.
    pub beam: BeamParameters,
    /// Fitted values, in the order requested.
    pub values: Vec<f64>,
    /// Standard errors of the fitted values.
    pub standard_errors: Vec<f64>,
    /// RMS of the final residual (m).
    pub rms_residual: f64,
    /// RMS of the residual at the start (m).
    pub initial_rms_residual: f64,
    /// Fitted output offset (m) and its standard error, if fitted.
    pub offset: Option<(f64, f64)>,
    /// Fitted step time (s) and its standard error, if fitted.
    pub step_time: Option<(f64, f64)>,
    /// Residual evaluations of Levenberg–Marquardt.
    pub iterations: usize,
}

/// Simulated tip response of `beam` to the effective voltage `u`.
pub fn simulate_response(
    beam: &BeamParameters,
    kind: BeamModelKind,
    sample_time: f64,
    u: &[f64],
) -> Result<Vec<f64>, BeamError> {
    let modal = modal_model(beam, kind)?;
    Ok(DiscreteBeam::new(&modal, sample_time)?.simulate(u))
}

/// What else a measured step record needs besides the beam's parameters.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StepFitOptions {
    /// Fit a constant output offset (a sensor's zero), in metres.
    pub offset: bool,
    /// Fit the time of the step (continuous, not a sample index): the input
    /// must then be a single step, `u_0` before and `u_1` after.
    pub step_time: bool,
}

impl StepFitOptions {
    /// A record simulated from rest: no offset, the step where `u` has it.
    pub const SIMULATED: Self = Self {
        offset: false,
        step_time: false,
    };
}

impl Default for StepFitOptions {
    /// A measured record: both.
    fn default() -> Self {
        Self {
            offset: true,
            step_time: true,
        }
    }
}

/// A single step in an input trace: the sample where it switches and the
/// levels before and after.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepInput {
    pub sample: usize,
    pub before: f64,
    pub after: f64,
}

impl StepInput {
    /// The step in `u`: the largest jump between samples, with `u` constant
    /// (to 1e-3 of the jump) on both sides.
    pub fn detect(u: &[f64]) -> Result<Self, BeamError> {
        let bad = |reason: String| BeamError::InvalidSetting {
            field: "input",
            reason,
        };
        let k = (1..u.len())
            .max_by(|&a, &b| (u[a] - u[a - 1]).abs().total_cmp(&(u[b] - u[b - 1]).abs()))
            .ok_or_else(|| bad("a step needs at least two samples".into()))?;
        let (before, after) = (u[k - 1], u[k]);
        let jump = (after - before).abs();
        let flat = |part: &[f64], level: f64| part.iter().all(|v| (v - level).abs() <= 1e-3 * jump);
        if jump == 0.0 || !flat(&u[..k], before) || !flat(&u[k..], after) {
            return Err(bad(
                "column u is not a single step (constant before and after); fit without the step time".into(),
            ));
        }
        Ok(Self {
            sample: k,
            before,
            after,
        })
    }
}

/// The exact continuous response of `form` at `t` to a unit step at time 0
/// from rest (0 for `t ≤ 0`), and its derivative (the impulse response):
/// `s(t) = Σ_j w_j Re[(CV)_j (V⁻¹B)_j (e^{λ_j t} − 1)/λ_j]`.
fn unit_step(form: &DiagonalForm, t: f64) -> (f64, f64) {
    if t <= 0.0 {
        return (0.0, 0.0);
    }
    let (mut s, mut h) = (0.0, 0.0);
    for j in 0..form.poles.len() {
        let l = form.poles[j];
        let r = form.output[j] * form.input[j] * form.weight(j);
        s += (r * cexpm1(l * t) / l).re;
        h += (r * (l * t).exp()).re;
    }
    (s, h)
}

/// A step-response fit as a least-squares problem for the
/// `levenberg-marquardt` crate: parameters `[ln θ…, offset?, t_s?]`.
struct StepProblem<'a> {
    start: &'a BeamParameters,
    parameters: &'a [FitParameter],
    lo: Vec<f64>,
    hi: Vec<f64>,
    kind: BeamModelKind,
    sample_time: f64,
    u: &'a [f64],
    y: &'a [f64],
    step: Option<StepInput>,
    options: StepFitOptions,
    x: DVector<f64>,
}

impl StepProblem<'_> {
    fn beam(&self, x: &DVector<f64>) -> BeamParameters {
        let mut b = self.start.clone();
        for (k, fp) in self.parameters.iter().enumerate() {
            *field_mut(&mut b, &fp.name).expect("checked") = x[k].exp();
        }
        b
    }

    fn offset(&self, x: &DVector<f64>) -> f64 {
        if self.options.offset {
            x[self.parameters.len()]
        } else {
            0.0
        }
    }

    fn step_time(&self, x: &DVector<f64>) -> Option<f64> {
        self.options
            .step_time
            .then(|| x[self.parameters.len() + usize::from(self.options.offset)])
    }

    /// The model response and, for a step, `∂y/∂t_s`.
    fn response(&self, x: &DVector<f64>) -> Result<(Vec<f64>, Vec<f64>), BeamError> {
        let beam = self.beam(x);
        let offset = self.offset(x);
        match (self.step, self.step_time(x)) {
            (Some(step), Some(t_s)) => {
                let form = DiagonalForm::new(&modal_model(&beam, self.kind)?)?;
                let g0 = form.static_gain();
                let du = step.after - step.before;
                let mut y = Vec::with_capacity(self.u.len());
                let mut dy = Vec::with_capacity(self.u.len());
                for k in 0..self.u.len() {
                    let (s, h) = unit_step(&form, k as f64 * self.sample_time - t_s);
                    y.push(offset + g0 * step.before + du * s);
                    dy.push(-du * h);
                }
                Ok((y, dy))
            }
            _ => {
                let y = simulate_response(&beam, self.kind, self.sample_time, self.u)?;
                Ok((y.iter().map(|v| v + offset).collect(), Vec::new()))
            }
        }
    }

    fn residual_vec(&self, x: &DVector<f64>) -> Option<Vec<f64>> {
        let (y, _) = self.response(x).ok()?;
        Some(y.iter().zip(self.y).map(|(a, b)| a - b).collect())
    }
}

impl LeastSquaresProblem<f64, Dyn, Dyn> for StepProblem<'_> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;

    /// Log parameters are kept inside their bounds.
    fn set_params(&mut self, x: &DVector<f64>) {
        self.x = x.clone();
        for k in 0..self.parameters.len() {
            self.x[k] = self.x[k].clamp(self.lo[k], self.hi[k]);
        }
    }

    fn params(&self) -> DVector<f64> {
        self.x.clone()
    }

    fn residuals(&self) -> Option<DVector<f64>> {
        self.residual_vec(&self.x).map(DVector::from_vec)
    }

    /// Central differences in the log parameters; the offset's column is 1
    /// and the step time's the (negated, scaled) impulse response.
    fn jacobian(&self) -> Option<DMatrix<f64>> {
        let n = self.u.len();
        let p = self.parameters.len();
        let cols = self.x.len();
        let mut j = DMatrix::<f64>::zeros(n, cols);
        for k in 0..p {
            let (mut a, mut b) = (self.x.clone(), self.x.clone());
            a[k] += FD_STEP;
            b[k] -= FD_STEP;
            let (ra, rb) = (self.residual_vec(&a)?, self.residual_vec(&b)?);
            for i in 0..n {
                j[(i, k)] = (ra[i] - rb[i]) / (2.0 * FD_STEP);
            }
        }
        let mut c = p;
        if self.options.offset {
            j.column_mut(c).fill(1.0);
            c += 1;
        }
        if self.step.is_some() && self.options.step_time {
            let (_, dy) = self.response(&self.x).ok()?;
            for i in 0..n {
                j[(i, c)] = dy[i];
            }
        }
        Some(j)
    }
}

/// Fit `parameters` of `start` to a measured tip response `y` to the input
/// `u`, with an output offset and a continuous step time as `options` say,
/// by Levenberg–Marquardt (the `levenberg-marquardt` crate) in log
/// coordinates within the parameters' bounds. A subset the response cannot
/// identify is refused first, naming the parameters. A record simulated from
/// rest takes [`StepFitOptions::SIMULATED`].
pub fn fit_step_response(
    start: &BeamParameters,
    parameters: &[FitParameter],
    kind: BeamModelKind,
    sample_time: f64,
    u: &[f64],
    y: &[f64],
    options: StepFitOptions,
) -> Result<BeamFit, BeamError> {
    start.validate()?;
    let p = parameters.len();
    if p == 0 {
        return Err(BeamError::InvalidSetting {
            field: "fit",
            reason: "name at least one parameter".into(),
        });
    }
    let extra = usize::from(options.offset) + usize::from(options.step_time);
    if u.len() != y.len() || u.len() <= p + extra {
        return Err(BeamError::InvalidSetting {
            field: "input",
            reason: format!(
                "need more samples than parameters and equal lengths (u: {}, y: {})",
                u.len(),
                y.len()
            ),
        });
    }
    for (i, fp) in parameters.iter().enumerate() {
        let v = parameter(start, &fp.name).ok_or_else(|| unknown(&fp.name))?;
        if parameters[..i].iter().any(|q| q.name == fp.name) {
            return Err(BeamError::InvalidSetting {
                field: "fit",
                reason: format!("parameter '{}' named twice", fp.name),
            });
        }
        if !(fp.lower > 0.0 && fp.lower <= v && v <= fp.upper && fp.upper.is_finite()) {
            return Err(BeamError::InvalidSetting {
                field: "fit",
                reason: format!(
                    "bounds of '{}' must satisfy 0 < lower <= start <= upper, found {} <= {} <= {}",
                    fp.name, fp.lower, v, fp.upper
                ),
            });
        }
    }
    let step = if options.step_time {
        Some(StepInput::detect(u)?)
    } else {
        None
    };
    let mut x0: Vec<f64> = parameters
        .iter()
        .map(|f| parameter(start, &f.name).expect("checked").ln())
        .collect();
    if options.offset {
        x0.push(0.0); // set from the starting residual below
    }
    if let Some(s) = step {
        x0.push(s.sample as f64 * sample_time);
    }
    let mut problem = StepProblem {
        start,
        parameters,
        lo: parameters.iter().map(|f| f.lower.ln()).collect(),
        hi: parameters.iter().map(|f| f.upper.ln()).collect(),
        kind,
        sample_time,
        u,
        y,
        step,
        options,
        x: DVector::from_vec(x0),
    };
    let mut r0 = problem
        .residual_vec(&problem.x)
        .ok_or_else(|| BeamError::Numerical("the starting model does not simulate".into()))?;
    if options.offset {
        // start the offset where the data say; the residual is linear in it
        let mean = r0.iter().sum::<f64>() / r0.len() as f64;
        problem.x[p] = -mean;
        r0.iter_mut().for_each(|r| *r -= mean);
    }
    let initial_rms = (r0.iter().map(|v| v * v).sum::<f64>() / r0.len() as f64).sqrt();
    let j0 = problem
        .jacobian()
        .ok_or_else(|| BeamError::Numerical("the Jacobian could not be formed".into()))?;
    let mut names: Vec<String> = parameters.iter().map(|f| f.name.clone()).collect();
    if options.offset {
        names.push("offset".into());
    }
    if options.step_time {
        names.push("step_time".into());
    }
    check_identifiable(&to_faer(&j0), &names)?;

    let (problem, report) = LevenbergMarquardt::new()
        .with_patience(200)
        .minimize(problem);
    if !report.termination.was_successful() {
        return Err(BeamError::Numerical(format!(
            "Levenberg-Marquardt stopped: {:?}",
            report.termination
        )));
    }
    let x = problem.x.clone();
    let r = problem
        .residual_vec(&x)
        .ok_or_else(|| BeamError::Numerical("the fitted model does not simulate".into()))?;
    let j = problem
        .jacobian()
        .ok_or_else(|| BeamError::Numerical("the Jacobian could not be formed".into()))?;
    finish(
        &problem.beam(&x),
        x.as_slice(),
        p,
        options,
        &r,
        &to_faer(&j),
        initial_rms,
        report.number_of_evaluations,
    )
}

fn to_faer(j: &DMatrix<f64>) -> Mat<f64> {
    Mat::from_fn(j.nrows(), j.ncols(), |i, k| j[(i, k)])
}

#[allow(clippy::too_many_arguments)]
fn finish(
    beam: &BeamParameters,
    x: &[f64],
    p: usize,
    options: StepFitOptions,
    r: &[f64],
    j: &Mat<f64>,
    initial_rms_residual: f64,
    iterations: usize,
) -> Result<BeamFit, BeamError> {
    let cols = x.len();
    let n = r.len();
    let ss: f64 = r.iter().map(|x| x * x).sum();
    let sigma2 = ss / (n - cols) as f64;
    let jtj = j.transpose() * j;
    let inv = jtj
        .llt(Side::Lower)
        .map(|l| l.solve(&Mat::<f64>::identity(cols, cols)))
        .map_err(|_| BeamError::Numerical("JᵀJ is singular at the solution".into()))?;
    let se = |k: usize| (sigma2 * inv[(k, k)]).max(0.0).sqrt();
    let values: Vec<f64> = x[..p].iter().map(|l| l.exp()).collect();
    // log coordinates: d θ = θ d ln θ
    let standard_errors = (0..p).map(|k| values[k] * se(k)).collect();
    let mut c = p;
    let offset = options.offset.then(|| {
        c += 1;
        (x[c - 1], se(c - 1))
    });
    let step_time = options.step_time.then(|| (x[c], se(c)));
    Ok(BeamFit {
        beam: beam.clone(),
        values,
        standard_errors,
        offset,
        step_time,
        rms_residual: (ss / n as f64).sqrt(),
        initial_rms_residual,
        iterations,
    })
}

/// Refuse a rank-deficient Jacobian, naming the parameters of its null
/// direction.
fn check_identifiable(j: &Mat<f64>, names: &[String]) -> Result<(), BeamError> {
    let p = j.ncols();
    let norms: Vec<f64> = (0..p)
        .map(|k| {
            (0..j.nrows())
                .map(|i| j[(i, k)] * j[(i, k)])
                .sum::<f64>()
                .sqrt()
        })
        .collect();
    if let Some(k) = norms.iter().position(|&n| n == 0.0) {
        return Err(BeamError::InvalidSetting {
            field: "fit",
            reason: format!(
                "parameter '{}' is not identifiable: the response does not depend on it",
                names[k]
            ),
        });
    }
    let js = Mat::from_fn(j.nrows(), p, |i, k| j[(i, k)] / norms[k]);
    let svd = js
        .thin_svd()
        .map_err(|_| BeamError::Numerical("SVD of the Jacobian did not converge".into()))?;
    let s = svd.S();
    let (smax, smin) = (s[0], s[p - 1]);
    if smin <= RANK_TOLERANCE * smax {
        // the null direction in (unscaled) log coordinates: relative changes
        let v = svd.V();
        let dir: Vec<f64> = (0..p).map(|k| v[(k, p - 1)] / norms[k]).collect();
        let big = dir.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let names: Vec<&str> = (0..p)
            .filter(|&k| dir[k].abs() > 0.1 * big)
            .map(|k| names[k].as_str())
            .collect();
        return Err(BeamError::InvalidSetting {
            field: "fit",
            reason: format!(
                "parameters {} are not identifiable together from this response: changing them in \
                 proportion leaves it unchanged (singular value ratio {:.1e}); fix at least one of them",
                names.join(", "),
                smin / smax
            ),
        });
    }
    Ok(())
}
