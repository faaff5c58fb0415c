//! Stage 3 of an identification: what the fit achieved — errors on the
//! fitted, held-out and validation samples, the active constraints, the rank
//! and the operators the data do not determine — and its printout.

pub(super) use super::settings::check_record_signals;
use super::settings::IdentificationError;
use super::solve::RANK_TOLERANCE;
use crate::operators::model::HysteresisCreepModel;

/// A constraint that holds with equality at the solution.
#[derive(Debug, Clone, PartialEq)]
pub struct ActiveConstraint {
    /// `"hysteresis"`, `"creep"`, `"superposition above"` or
    /// `"superposition below"` (the dead zones of `S⁻¹` above and below the
    /// output's mid-point; their partial sums are the slopes of `S⁻¹` less 1).
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

/// One record of a multi-record identification.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordFit {
    pub samples: usize,
    /// Its samples fitted.
    pub fitted: std::ops::Range<usize>,
    /// Its errors there, with its own offset.
    pub fit: FitErrors,
    /// Its output offset (the model file keeps the first record's).
    pub offset: f64,
}

/// The fitted linear dynamics and how well the records determine them.
#[derive(Debug, Clone, PartialEq)]
pub struct DynamicsReport {
    pub parameters: crate::realtime::DynamicsParameters,
    /// Standard errors of the low-pass frequency, the resonance frequency
    /// and damping, and the delay fraction (`None` for a part not fitted),
    /// from the Jacobian of the output error at the optimum.
    pub standard_errors: [Option<f64>; 4],
    /// Gauss–Newton steps taken.
    pub iterations: usize,
    /// The output error's rms before (static model) and after.
    pub rms_static: f64,
    pub rms: f64,
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
    /// The model's dead time (samples).
    pub delay: usize,
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
    /// The solved weights in the regressor's column order: the excited
    /// plays, the excited creep operators, then the dead zones of `S⁻¹`
    /// (above the output's mid-point outward, then below it outward).
    pub weights: Vec<f64>,
    /// Their standard errors as unconstrained least squares gives them (the
    /// residual's RMS times `√((RᵀR)⁻¹)_jj`); meaningful where no
    /// constraint is active, infinite when the rank is deficient.
    pub standard_errors: Vec<f64>,
    /// The fitted superposition operator `S` (thresholds, weights), if one
    /// was fitted.
    pub superposition: Option<(Vec<f64>, Vec<f64>)>,
    /// With several records, each one's fit (the main fields are the first
    /// record's); empty for one record.
    pub records: Vec<RecordFit>,
    /// The fitted dynamics, if they were fitted.
    pub dynamics: Option<DynamicsReport>,
    /// The first 5 % of the fitted samples against the rest.
    pub start: StartCheck,
    /// The creep penalty's `λ` and the weights' effective parameters there
    /// (the trace of the unconstrained fit's hat matrix, offsets left out;
    /// at most `unknowns`), where one was asked for.
    pub creep_regularisation: Option<(f64, f64)>,
}

/// The errors at the start of the fitted samples against the rest: a start
/// transient the model does not describe (a jump that rings the stage)
/// shows as a start much worse than the rest.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StartCheck {
    /// Samples in the start (5 % of the fitted ones, at least 1).
    pub samples: usize,
    /// RMS error of the start and of the rest.
    pub rms: f64,
    pub rest_rms: f64,
}

impl StartCheck {
    /// A start more than this many times worse than the rest is warned of.
    pub const RATIO: f64 = 2.0;

    /// Of `fit` against `y` on the fitted samples `range`.
    pub fn of(fit: &[f64], y: &[f64], range: std::ops::Range<usize>) -> Self {
        let samples = (range.len() / 20).max(1).min(range.len());
        let split = range.start + samples;
        Self {
            samples,
            rms: FitErrors::of(fit, y, range.start..split).rms,
            rest_rms: FitErrors::of(fit, y, split..range.end).rms,
        }
    }

    /// Whether the start is much worse than the rest.
    pub fn is_transient(&self) -> bool {
        self.rms > Self::RATIO * self.rest_rms
    }
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
        if self.delay > 0 {
            writeln!(
                f,
                "dead time            {} samples: y_k is fitted by the memory part at k − {}",
                self.delay, self.delay
            )?;
        }
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
        let st = &self.start;
        writeln!(
            f,
            "start                first {} fitted samples: rms {:.6e}, the rest {:.6e}",
            st.samples, st.rms, st.rest_rms
        )?;
        writeln!(f, "offset               {:.6e}", self.offset)?;
        if let Some((lambda, df)) = self.creep_regularisation {
            writeln!(
                f,
                "creep penalty        λ = {lambda:.3e}: {df:.2} effective parameters of {}",
                self.unknowns
            )?;
        }
        if let Some((r, w)) = &self.superposition {
            let list = |x: &[f64]| {
                let s: Vec<String> = x.iter().map(|v| format!("{v:.6e}")).collect();
                s.join(", ")
            };
            writeln!(f, "superposition S      thresholds [{}]", list(r))?;
            writeln!(f, "                     weights    [{}]", list(w))?;
        }
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
                if c.group.starts_with("superposition") {
                    writeln!(
                        f,
                        "active constraint    slope of S^-1 {} its kink {} = {}",
                        c.group,
                        c.index,
                        1.0 + c.bound
                    )?;
                } else {
                    writeln!(
                        f,
                        "active constraint    {} partial sum 0..={} = {}",
                        c.group, c.index, c.bound
                    )?;
                }
            }
        }
        if st.is_transient() {
            writeln!(
                f,
                "warning: the first {} fitted samples fit {:.1} times worse than the rest ({:.3e} against {:.3e} rms): a start transient the model does not describe? (--fit-from 0.1s leaves a start out)",
                st.samples,
                st.rms / st.rest_rms.max(f64::MIN_POSITIVE),
                st.rms,
                st.rest_rms
            )?;
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

/// The first sample at which `|v|` reaches `max|v|`.
pub fn first_at_max(v: &[f64]) -> usize {
    let m = v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    v.iter().position(|x| x.abs() == m).unwrap_or(0)
}

/// Errors of `model` (run from the virgin state over the whole record) on a
/// validation record, from the first sample at which `|u|` reaches `max|u|`
/// ([`super::validate_record`] from there).
pub fn validate(
    model: &HysteresisCreepModel,
    u: &[f64],
    y: &[f64],
) -> Result<FitErrors, IdentificationError> {
    let from = first_at_max(u);
    Ok(super::validate_record(model, "", u, y, from)?.errors)
}

pub(super) fn range(x: &[f64]) -> f64 {
    let (lo, hi) = x
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    hi - lo
}
