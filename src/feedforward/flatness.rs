//! Flatness-based feedforward (companion paper, Part I; this paper's
//! section 4.3 and Fig. 14).
//!
//! For the finite-dimensional beam `G(s) = N(s)/D(s)`, `D(0) = 1`, the flat
//! output `z` parametrizes input and output: `u = D(d/dt) z`,
//! `y = N(d/dt) z`. With the poles `λ_j` of the modal state space and the
//! residues `r_j = (CV)_j (V⁻¹B)_j`,
//!
//! ```text
//! D(s) = Π_j (1 − s/λ_j),      N(s) = G(s) D(s) = Σ_j (−r_j/λ_j) Π_{i≠j} (1 − s/λ_i)
//! ```
//!
//! Nothing is expanded into a degree-`2n` polynomial: the factors are applied
//! one at a time to the derivative sequence of `z`
//! (`(1 − s/λ)` maps `a_k ↦ a_k − a_{k+1}/λ`; a conjugate pair is applied as
//! the real quadratic `1 − 2 Re(λ)/|λ|² s + s²/|λ|²`). The flat output runs
//! from `z_0` to `z_T = y_T / G(0)`, so `u_d` settles at `y_T / G(0)` (the
//! static gain) and `y_d` at `y_T`.
//!
//! The nominal input `u_d` is an *effective* voltage; it goes through the
//! compensator `W⁻¹` (21) to become the balanced voltage `u`, split into the
//! patch voltages of (1), with saturation to the supply limits reported.

use faer::c64;

use crate::beam::modal::ModalModel;
use crate::beam::simulation::DiagonalForm;
use crate::beam::BeamError;
use crate::error::ModelError;
use crate::feedforward::trajectory::{Trajectory, TrajectoryError};
use crate::operators::compensator::CompensatorSettings;
use crate::operators::model::HysteresisCreepModel;
use crate::operators::supply::Supply;

/// A factor of `D(s)`: `1 − s/λ` (real pole) or `1 − p s + q s²` (pair).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Factor {
    Real { inv: f64 },
    Pair { p: f64, q: f64 },
}

impl Factor {
    fn degree(&self) -> usize {
        match self {
            Factor::Real { .. } => 1,
            Factor::Pair { .. } => 2,
        }
    }

    /// Apply to the derivative sequence `a` in place; the result is valid for
    /// the first `a.len() − degree` entries.
    fn apply(&self, a: &mut [f64]) {
        match *self {
            Factor::Real { inv } => {
                for k in 0..a.len().saturating_sub(1) {
                    a[k] -= inv * a[k + 1];
                }
            }
            Factor::Pair { p, q } => {
                for k in 0..a.len().saturating_sub(2) {
                    a[k] = a[k] - p * a[k + 1] + q * a[k + 2];
                }
            }
        }
    }
}

/// The flatness-based parametrization `u = D(d/dt) z`, `y = N(d/dt) z` of a
/// beam model.
#[derive(Debug, Clone)]
pub struct FlatParametrization {
    factors: Vec<Factor>,
    /// Per kept pole: `−w_j r_j / λ_j` and the pole.
    terms: Vec<(c64, c64)>,
    /// Index of each term's own factor in `factors`.
    own_factor: Vec<usize>,
    order: usize,
    static_gain: f64,
}

impl FlatParametrization {
    /// From the modal model of the beam.
    pub fn new(modal: &ModalModel) -> Result<Self, BeamError> {
        let form = DiagonalForm::new(modal)?;
        let mut factors = Vec::new();
        let mut terms = Vec::new();
        let mut own_factor = Vec::new();
        for j in 0..form.poles.len() {
            let l = form.poles[j];
            let f = if l.im > 0.0 {
                let m2 = l.re * l.re + l.im * l.im;
                Factor::Pair {
                    p: 2.0 * l.re / m2,
                    q: 1.0 / m2,
                }
            } else {
                Factor::Real { inv: 1.0 / l.re }
            };
            own_factor.push(factors.len());
            factors.push(f);
            let r = form.output[j] * form.input[j];
            terms.push((-(r / l) * form.weight(j), l));
        }
        let order = factors.iter().map(Factor::degree).sum();
        Ok(Self {
            factors,
            terms,
            own_factor,
            order,
            static_gain: form.static_gain(),
        })
    }

    /// The degree of `D`: the derivative order of `z` that `u` needs (`2n`).
    pub fn order(&self) -> usize {
        self.order
    }

    /// `G(0) = N(0)`: the static gain (m per effective volt).
    pub fn static_gain(&self) -> f64 {
        self.static_gain
    }

    /// `u = D(d/dt) z` from `z, ż, …, z^{(2n)}` (at least `order + 1` values).
    /// `work` must hold `order + 1` values.
    pub fn input(&self, z: &[f64], work: &mut [f64]) -> f64 {
        let n = self.order + 1;
        let a = &mut work[..n];
        a.copy_from_slice(&z[..n]);
        let mut len = n;
        for f in &self.factors {
            f.apply(&mut a[..len]);
            len -= f.degree();
        }
        a[0]
    }

    /// `y = N(d/dt) z`. `work` must hold `order + 1` values.
    pub fn output(&self, z: &[f64], work: &mut [f64]) -> f64 {
        let n = self.order + 1;
        let mut y = 0.0;
        for (&(coef, pole), &own) in self.terms.iter().zip(&self.own_factor) {
            let a = &mut work[..n];
            a.copy_from_slice(&z[..n]);
            let mut len = n;
            for (i, f) in self.factors.iter().enumerate() {
                if i == own {
                    continue;
                }
                f.apply(&mut a[..len]);
                len -= f.degree();
            }
            // the conjugate partner's linear factor (1 − s/λ̄) for a pair
            let value = if pole.im > 0.0 {
                let inv = c64::new(1.0, 0.0) / pole.conj();
                c64::new(a[0], 0.0) - inv * a[1]
            } else {
                c64::new(a[0], 0.0)
            };
            y += (coef * value).re;
        }
        y
    }
}

/// Settings of a feedforward design.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FeedforwardSettings {
    /// Start of the transition (s).
    pub start: f64,
    /// Duration `T` (s).
    pub duration: f64,
    /// Final tip deflection `y_T` (m), from rest at 0.
    pub y_final: f64,
    /// Gevrey parameter `σ`.
    pub sigma: f64,
    /// End of the trace (s).
    pub end: f64,
    /// Sample time (s).
    pub sample_time: f64,
}

impl Default for FeedforwardSettings {
    /// The paper's case: 1 mm in 75 ms from 2.9 s, σ = 1.1, 4 s at 5 kHz.
    fn default() -> Self {
        Self {
            start: 2.9,
            duration: 0.075,
            y_final: 1e-3,
            sigma: 1.1,
            end: 4.0,
            sample_time: 2e-4,
        }
    }
}

/// What can go wrong designing a feedforward.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum FeedforwardError {
    #[error(transparent)]
    Trajectory(#[from] TrajectoryError),
    #[error(transparent)]
    Beam(#[from] BeamError),
    #[error(transparent)]
    Model(#[from] ModelError),
    #[error("{field}: {reason}")]
    Invalid { field: &'static str, reason: String },
}

impl From<crate::realtime::ParameterError> for FeedforwardError {
    fn from(e: crate::realtime::ParameterError) -> Self {
        Self::Model(e.into())
    }
}

/// A sampled feedforward design.
#[derive(Debug, Clone, PartialEq)]
pub struct Feedforward {
    pub t: Vec<f64>,
    /// Desired tip deflection (m).
    pub y_d: Vec<f64>,
    /// Nominal effective voltage (V).
    pub u_d: Vec<f64>,
    /// `max |u_d|` (V).
    pub peak: f64,
}

impl FeedforwardSettings {
    fn validate(&self) -> Result<(), FeedforwardError> {
        if !(self.sample_time.is_finite() && self.sample_time > 0.0) {
            return Err(FeedforwardError::Invalid {
                field: "sample_time",
                reason: format!("must be a finite number > 0, found {}", self.sample_time),
            });
        }
        if !(self.end.is_finite() && self.end >= 0.0) {
            return Err(FeedforwardError::Invalid {
                field: "end",
                reason: format!("must be a finite number >= 0, found {}", self.end),
            });
        }
        if !self.y_final.is_finite() {
            return Err(FeedforwardError::Invalid {
                field: "y_final",
                reason: format!("must be finite, found {}", self.y_final),
            });
        }
        crate::realtime::limits::generated_samples(self.end, self.sample_time).map_err(|e| {
            FeedforwardError::Invalid {
                field: "end",
                reason: e.to_string(),
            }
        })?;
        Ok(())
    }
}

/// Sample `y_d` and `u_d` at `k T_s`, `k = 0..=end/T_s`.
pub fn design(
    flat: &FlatParametrization,
    settings: &FeedforwardSettings,
) -> Result<Feedforward, FeedforwardError> {
    settings.validate()?;
    let z_t = settings.y_final / flat.static_gain();
    let traj = Trajectory {
        start: settings.start,
        duration: settings.duration,
        initial: 0.0,
        last: z_t,
        sigma: settings.sigma,
    };
    traj.validate()?;
    let order = flat.order();
    let count = (settings.end / settings.sample_time).round() as usize + 1;
    let mut z = vec![0.0; order + 1];
    let mut scratch = vec![0.0; 5 * (order + 1)];
    let mut work = vec![0.0; order + 1];
    let mut out = Feedforward {
        t: Vec::with_capacity(count),
        y_d: Vec::with_capacity(count),
        u_d: Vec::with_capacity(count),
        peak: 0.0,
    };
    let gain = flat.static_gain();
    for k in 0..count {
        let t = k as f64 * settings.sample_time;
        traj.derivatives_into(t, order, &mut z, &mut scratch);
        let tau = (t - settings.start) / settings.duration;
        let (u, y) = if tau > 0.0 && tau < 1.0 {
            (flat.input(&z, &mut work), flat.output(&z, &mut work))
        } else {
            // at rest: D(0) = 1, N(0) = G(0)
            (z[0], gain * z[0])
        };
        out.t.push(t);
        out.u_d.push(u);
        out.y_d.push(y);
        out.peak = out.peak.max(u.abs());
    }
    Ok(out)
}

/// The compensated voltages of a design.
#[derive(Debug, Clone, PartialEq)]
pub struct CompensatedFeedforward {
    /// Balanced voltage `u = W⁻¹[u_d]` (V).
    pub u: Vec<f64>,
    /// Front patch `u_fs = ū + u` (V).
    pub u_fs: Vec<f64>,
    /// Back patch `u_bs = ū − u` (V).
    pub u_bs: Vec<f64>,
    /// Samples clipped to the supply.
    pub saturated: Vec<bool>,
    /// `max |u|` (V), after clipping.
    pub peak: f64,
}

/// `u_d → W⁻¹ → (u_fs, u_bs)` with the supply limits of (1); a model with
/// dead time `d` gets `u_d` `d` samples ahead (the trajectory is planned),
/// so that `W[u] = u_d` from sample `d` on.
pub fn compensate(
    u_d: &[f64],
    model: &HysteresisCreepModel,
    supply: &Supply,
) -> Result<CompensatedFeedforward, FeedforwardError> {
    let (lo, hi) = supply.balanced_limits();
    let mut comp = model.compensator(CompensatorSettings::with_limits(lo, hi))?;
    let mut out = CompensatedFeedforward {
        u: Vec::with_capacity(u_d.len()),
        u_fs: Vec::with_capacity(u_d.len()),
        u_bs: Vec::with_capacity(u_d.len()),
        saturated: Vec::with_capacity(u_d.len()),
        peak: 0.0,
    };
    for k in 0..u_d.len() {
        let c = comp.compensate(crate::realtime::preview(u_d, comp.delay(), k));
        let (p, _) = supply.patch_voltages_saturating(c.u);
        out.u.push(c.u);
        out.u_fs.push(p.front);
        out.u_bs.push(p.back);
        out.saturated.push(c.saturated);
        out.peak = out.peak.max(c.u.abs());
    }
    Ok(out)
}
