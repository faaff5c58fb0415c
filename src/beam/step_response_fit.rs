//! Identification of beam parameters from a step response (the paper's
//! section 4.2): Levenberg–Marquardt on the mean square error between a
//! measured and a simulated tip response, over a chosen subset of the
//! physical parameters.
//!
//! Parameters are fitted in log coordinates `p = ln θ` (they are all
//! positive, and relative steps suit quantities spanning many decades),
//! clamped to their bounds. The Jacobian is formed by central differences
//! (relative step 1e-4); the damped normal equations
//! `(JᵀJ + λ diag JᵀJ) δ = −Jᵀ r` are solved with a Cholesky factor.
//!
//! From one tip response not every parameter is identifiable: scaling
//! `μ, Λ, γ_e, γ_i, Γ_p` together changes nothing. Before fitting, the
//! Jacobian's singular values are inspected (columns scaled to unit norm); if
//! the smallest is below `1e-5` of the largest, the fit is refused with the
//! parameters that make up the null direction. The standard errors are
//! `σ √diag((JᵀJ)⁻¹)`, `σ² = ‖r‖² / (N − p)`, mapped back from log coordinates.

use faer::linalg::solvers::Solve;
use faer::{Mat, Side};

use crate::beam::fe::FiniteElementModel;
use crate::beam::modal::ModalModel;
use crate::beam::ritz::RitzModel;
use crate::beam::simulation::DiscreteBeam;
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
    /// Levenberg–Marquardt iterations.
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

/// Fit `parameters` of `start` so that the simulated response to `u` matches
/// `y` in the least-squares sense.
pub fn fit_step_response(
    start: &BeamParameters,
    parameters: &[FitParameter],
    kind: BeamModelKind,
    sample_time: f64,
    u: &[f64],
    y: &[f64],
) -> Result<BeamFit, BeamError> {
    start.validate()?;
    let p = parameters.len();
    if p == 0 {
        return Err(BeamError::InvalidSetting {
            field: "fit",
            reason: "name at least one parameter".into(),
        });
    }
    if u.len() != y.len() || u.len() <= p {
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
    let lo: Vec<f64> = parameters.iter().map(|f| f.lower.ln()).collect();
    let hi: Vec<f64> = parameters.iter().map(|f| f.upper.ln()).collect();
    let with = |logp: &[f64]| -> BeamParameters {
        let mut b = start.clone();
        for (fp, &l) in parameters.iter().zip(logp) {
            *field_mut(&mut b, &fp.name).expect("checked above") = l.exp();
        }
        b
    };
    let residual = |logp: &[f64]| -> Result<Vec<f64>, BeamError> {
        let sim = simulate_response(&with(logp), kind, sample_time, u)?;
        Ok(sim.iter().zip(y).map(|(a, b)| a - b).collect())
    };
    let cost = |r: &[f64]| r.iter().map(|x| x * x).sum::<f64>();
    let jacobian = |logp: &[f64]| -> Result<Mat<f64>, BeamError> {
        let h = FD_STEP;
        let mut j = Mat::<f64>::zeros(u.len(), p);
        for k in 0..p {
            let mut a = logp.to_vec();
            let mut b = logp.to_vec();
            a[k] += h;
            b[k] -= h;
            let (ra, rb) = (residual(&a)?, residual(&b)?);
            for i in 0..u.len() {
                j[(i, k)] = (ra[i] - rb[i]) / (2.0 * h);
            }
        }
        Ok(j)
    };

    let mut logp: Vec<f64> = parameters
        .iter()
        .map(|f| parameter(start, &f.name).unwrap().ln())
        .collect();
    let mut r = residual(&logp)?;
    let initial_rms = (cost(&r) / r.len() as f64).sqrt();
    let mut j = jacobian(&logp)?;
    check_identifiable(&j, parameters)?;

    let mut lambda = 1e-3;
    let mut iterations = 0;
    for _ in 0..100 {
        iterations += 1;
        let jtj = j.transpose() * &j;
        let jtr: Vec<f64> = (0..p)
            .map(|k| (0..r.len()).map(|i| j[(i, k)] * r[i]).sum())
            .collect();
        let c0 = cost(&r);
        let mut improved = false;
        for _ in 0..30 {
            let a = Mat::from_fn(p, p, |i, k| {
                jtj[(i, k)]
                    + if i == k {
                        lambda * jtj[(i, i)].max(1e-300)
                    } else {
                        0.0
                    }
            });
            let rhs = Mat::from_fn(p, 1, |i, _| -jtr[i]);
            let Ok(llt) = a.llt(Side::Lower) else {
                lambda *= 10.0;
                continue;
            };
            let delta = llt.solve(&rhs);
            let trial: Vec<f64> = (0..p)
                .map(|k| (logp[k] + delta[(k, 0)]).clamp(lo[k], hi[k]))
                .collect();
            let rt = residual(&trial)?;
            if cost(&rt) < c0 {
                let step: f64 = (0..p)
                    .map(|k| (trial[k] - logp[k]).abs())
                    .fold(0.0, f64::max);
                let rel = (c0 - cost(&rt)) / c0.max(f64::MIN_POSITIVE);
                logp = trial;
                r = rt;
                lambda = (lambda / 10.0).max(1e-12);
                improved = true;
                if step < 1e-12 || rel < 1e-14 {
                    return finish(
                        &with(&logp),
                        &logp,
                        &r,
                        &jacobian(&logp)?,
                        initial_rms,
                        iterations,
                    );
                }
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
        j = jacobian(&logp)?;
    }
    // `j` is the Jacobian at `logp` here: it is refreshed after every accepted step
    finish(&with(&logp), &logp, &r, &j, initial_rms, iterations)
}

fn finish(
    beam: &BeamParameters,
    logp: &[f64],
    r: &[f64],
    j: &Mat<f64>,
    initial_rms_residual: f64,
    iterations: usize,
) -> Result<BeamFit, BeamError> {
    let p = logp.len();
    let n = r.len();
    let ss: f64 = r.iter().map(|x| x * x).sum();
    let sigma2 = ss / (n - p) as f64;
    let jtj = j.transpose() * j;
    let inv = jtj
        .llt(Side::Lower)
        .map(|l| l.solve(&Mat::<f64>::identity(p, p)))
        .map_err(|_| BeamError::Numerical("JᵀJ is singular at the solution".into()))?;
    let values: Vec<f64> = logp.iter().map(|l| l.exp()).collect();
    let standard_errors = (0..p)
        .map(|k| values[k] * (sigma2 * inv[(k, k)]).max(0.0).sqrt())
        .collect();
    Ok(BeamFit {
        beam: beam.clone(),
        values,
        standard_errors,
        rms_residual: (ss / n as f64).sqrt(),
        initial_rms_residual,
        iterations,
    })
}

/// Refuse a rank-deficient Jacobian, naming the parameters of its null
/// direction.
fn check_identifiable(j: &Mat<f64>, parameters: &[FitParameter]) -> Result<(), BeamError> {
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
                parameters[k].name
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
            .map(|k| parameters[k].name.as_str())
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
