//! Observer-based state feedback on the modal model: LQ state feedback with
//! a Kalman observer of the modal state and of a constant input
//! disturbance, in the deviation from the flat reference.
//!
//! Design model: the modes below `max_frequency_ratio · f_s` (default a
//! tenth of the sample rate: four modes of the nominal beam), discretized
//! exactly (zero-order hold), `x_{k+1} = Φx_k + Γ(Δ_k + d_k)`, `ỹ_k = cᵀx_k`,
//! in the deviation `ỹ = y − y_d` from the reference. The input disturbance
//! `d` stands for everything the compensator does not cancel (the error of
//! its `W`, creep, a load) and is a random walk.
//!
//! * **LQ** (Bryson's rule): minimize `Σ ỹ_k²/y_max² + Δ_k²/u_max²` with
//!   `y_max` the stroke of the reference and `u_max` the supply's balanced
//!   limit; `Δ = −Kx̂ − d̂` (the disturbance estimate is cancelled).
//! * **Kalman observer** of `(x, d)`: measurement noise `σ_v` (the sensor's),
//!   disturbance increments `σ_d = δ · max_k |u_d,k+1 − u_d,k|` per sample
//!   (`δ` the relative uncertainty of `W` designed for, 10 %), steady-state
//!   gain `L`, current-estimator form:
//!   `x̂⁺ = x̂ + L(ỹ_k − cᵀx̂)`, `Δ_k = −[K 1] x̂⁺`, `x̂ ← A x̂⁺ + B Δ_k`.
//!
//! Both gains solve a discrete Riccati equation ([`super::riccati`]).

#[cfg(feature = "control")]
use nalgebra::{DMatrix, DVector};

#[cfg(feature = "control")]
use super::riccati::solve_dare;
use super::{ControlError, Controller, LoopSample};
#[cfg(feature = "control")]
use crate::beam::modal::ModalModel;

/// The design rule's parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StateFeedbackSettings {
    /// Keep the modes below this fraction of the sample rate.
    pub max_frequency_ratio: f64,
    /// `y_max` (m); `None`: the stroke `max |y_d|` of the reference.
    pub output_limit: Option<f64>,
    /// `u_max` (V): the balanced supply limit.
    pub voltage_limit: f64,
    /// `σ_v` (m): the sensor noise assumed by the observer.
    pub sensor_noise: f64,
    /// `δ`: relative uncertainty of `W` the disturbance model covers.
    pub model_uncertainty: f64,
}

impl Default for StateFeedbackSettings {
    fn default() -> Self {
        Self {
            max_frequency_ratio: 0.1,
            output_limit: None,
            voltage_limit: 1000.0,
            sensor_noise: 1e-6,
            model_uncertainty: 0.1,
        }
    }
}

impl StateFeedbackSettings {
    /// Every parameter finite and `> 0`.
    pub fn validate(&self) -> Result<(), ControlError> {
        let checks = [
            ("max_frequency_ratio", Some(self.max_frequency_ratio)),
            ("output_limit", self.output_limit),
            ("voltage_limit", Some(self.voltage_limit)),
            ("sensor_noise", Some(self.sensor_noise)),
            ("model_uncertainty", Some(self.model_uncertainty)),
        ];
        for (field, v) in checks {
            if let Some(v) = v {
                if !(v.is_finite() && v > 0.0) {
                    return Err(ControlError::Invalid {
                        field,
                        reason: format!("must be a finite number > 0, found {v}"),
                    });
                }
            }
        }
        Ok(())
    }
}

/// The designed gains and the observer model (`n = 2·modes + 1` states, the
/// last the input disturbance), row-major.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StateFeedbackDesign {
    /// Modes in the design model.
    pub modes: usize,
    /// Observer transition `A` (`n × n`).
    pub a: Vec<f64>,
    /// Observer input `B` (`n`).
    pub b: Vec<f64>,
    /// Output `cᵀ` (`n`).
    pub c: Vec<f64>,
    /// Observer gain `L` (`n`).
    pub observer: Vec<f64>,
    /// Feedback `[K 1]` (`n`).
    pub feedback: Vec<f64>,
    /// Relative residuals of the two Riccati equations.
    pub residuals: [f64; 2],
    /// `σ_d` (V per sample).
    pub disturbance_increment: f64,
}

impl StateFeedbackDesign {
    /// The rule applied to `modal` at `sample_time`, for the reference `y_d`
    /// and feedforward `u_d`.
    #[cfg(feature = "control")]
    pub fn design(
        modal: &ModalModel,
        sample_time: f64,
        reference: &[f64],
        feedforward: &[f64],
        settings: &StateFeedbackSettings,
    ) -> Result<Self, ControlError> {
        settings.validate()?;
        if !(sample_time.is_finite() && sample_time > 0.0) {
            return Err(ControlError::Invalid {
                field: "sample_time",
                reason: format!("must be a finite number > 0, found {sample_time}"),
            });
        }
        let f_max = settings.max_frequency_ratio / sample_time;
        let modes = modal
            .frequencies_hz()
            .iter()
            .filter(|&&f| f < f_max)
            .count();
        if modes == 0 {
            return Err(ControlError::Design(format!(
                "no mode below {f_max} Hz (max_frequency_ratio × sample rate)"
            )));
        }
        let y_max = match settings.output_limit {
            Some(y) => y,
            None => reference.iter().fold(0.0f64, |m, v| m.max(v.abs())),
        };
        if !(y_max.is_finite() && y_max > 0.0) {
            return Err(ControlError::Design(format!(
                "the reference's stroke is {y_max}: set output_limit"
            )));
        }
        let max_step = feedforward
            .windows(2)
            .fold(0.0f64, |m, w| m.max((w[1] - w[0]).abs()));
        let sigma_d = settings.model_uncertainty * max_step;
        if !(sigma_d.is_finite() && sigma_d > 0.0) {
            return Err(ControlError::Design(format!(
                "the feedforward's largest step is {max_step}: no disturbance model"
            )));
        }
        let plant = modal.truncated(modes).discrete_state_space(sample_time)?;
        let (phi, gamma, c) = (&plant.a, &plant.b, &plant.c);
        let n = phi.nrows();
        // LQ on the modal state
        let q = c * c.transpose() / (y_max * y_max);
        let u_max = settings.voltage_limit;
        let lq = solve_dare(phi, gamma, &q, 1.0 / (u_max * u_max))?;
        // Kalman on (x, d): the dual equation with Aᵀ, cᵀ
        let mut a = DMatrix::<f64>::zeros(n + 1, n + 1);
        a.view_mut((0, 0), (n, n)).copy_from(phi);
        a.view_mut((0, n), (n, 1)).copy_from(gamma);
        a[(n, n)] = 1.0;
        let mut b = DVector::<f64>::zeros(n + 1);
        b.rows_mut(0, n).copy_from(gamma);
        let mut ca = DVector::<f64>::zeros(n + 1);
        ca.rows_mut(0, n).copy_from(c);
        let mut w = DMatrix::<f64>::zeros(n + 1, n + 1);
        w[(n, n)] = sigma_d * sigma_d;
        let v = settings.sensor_noise * settings.sensor_noise;
        let kalman = solve_dare(&a.transpose(), &ca, &w, v)?;
        let pc = &kalman.x * &ca;
        let observer = &pc / (ca.dot(&pc) + v);
        let mut feedback: Vec<f64> = lq.gain.iter().copied().collect();
        feedback.push(1.0);
        let design = Self {
            modes,
            a: (0..n + 1)
                .flat_map(|i| (0..n + 1).map(move |j| (i, j)))
                .map(|ij| a[ij])
                .collect(),
            b: b.iter().copied().collect(),
            c: ca.iter().copied().collect(),
            observer: observer.iter().copied().collect(),
            feedback,
            residuals: [lq.residual, kalman.residual],
            disturbance_increment: sigma_d,
        };
        if design.residuals.iter().any(|r| r.is_nan() || *r >= 1e-8) {
            return Err(ControlError::Design(format!(
                "the Riccati residuals {:?} are too large",
                design.residuals
            )));
        }
        Ok(design)
    }

    /// Number of observer states.
    pub fn order(&self) -> usize {
        self.b.len()
    }

    /// Consistent sizes (`n ≤` [`MAX_ORDER`]) and finite entries: what a
    /// design read from a file must be before it runs.
    pub fn validate(&self) -> Result<(), ControlError> {
        let n = self.b.len();
        if n == 0 || n > MAX_ORDER {
            return Err(ControlError::Invalid {
                field: "b",
                reason: format!("{n} states; between 1 and {MAX_ORDER}"),
            });
        }
        for (field, v, len) in [
            ("a", &self.a, n * n),
            ("c", &self.c, n),
            ("observer", &self.observer, n),
            ("feedback", &self.feedback, n),
        ] {
            if v.len() != len {
                return Err(ControlError::Invalid {
                    field,
                    reason: format!("{} entries; {n} states need {len}", v.len()),
                });
            }
        }
        for (field, v) in [
            ("a", &self.a),
            ("b", &self.b),
            ("c", &self.c),
            ("observer", &self.observer),
            ("feedback", &self.feedback),
        ] {
            if let Some(i) = v.iter().position(|x| !x.is_finite()) {
                return Err(ControlError::Invalid {
                    field,
                    reason: format!("entry {i} is {}", v[i]),
                });
            }
        }
        Ok(())
    }
}

/// The most observer states a design may have (201: 100 modes and the
/// disturbance).
pub const MAX_ORDER: usize = 2 * crate::realtime::limits::MAX_BASIS_FUNCTIONS + 1;

/// The observer-based state feedback with its state.
#[derive(Debug, Clone, PartialEq)]
pub struct StateFeedback {
    design: StateFeedbackDesign,
    estimate: Vec<f64>,
    corrected: Vec<f64>,
    next: Vec<f64>,
}

impl StateFeedback {
    /// At rest (zero deviation, zero disturbance); the design is checked
    /// ([`StateFeedbackDesign::validate`]).
    pub fn new(design: StateFeedbackDesign) -> Result<Self, ControlError> {
        design.validate()?;
        let n = design.order();
        Ok(Self {
            design,
            estimate: vec![0.0; n],
            corrected: vec![0.0; n],
            next: vec![0.0; n],
        })
    }

    /// Its design.
    pub fn design(&self) -> &StateFeedbackDesign {
        &self.design
    }

    /// The current estimate `x̂` (before the next measurement); the last
    /// entry is the input disturbance (V).
    pub fn estimate(&self) -> &[f64] {
        &self.estimate
    }
}

impl Controller for StateFeedback {
    fn name(&self) -> String {
        "LQ + observer".into()
    }

    fn step(&mut self, s: &LoopSample) -> Result<Option<f64>, ControlError> {
        let deviation = s.measurement - s.reference;
        if !deviation.is_finite() {
            return Ok(None); // held by the loop; the estimate stays valid
        }
        let d = &self.design;
        let n = d.order();
        let innovation = deviation - dot(&d.c, &self.estimate);
        for i in 0..n {
            self.corrected[i] = self.estimate[i] + d.observer[i] * innovation;
        }
        let correction = -dot(&d.feedback, &self.corrected);
        for i in 0..n {
            self.next[i] = dot(&d.a[i * n..(i + 1) * n], &self.corrected) + d.b[i] * correction;
        }
        // an overflow (a design or a measurement far out of scale) is held:
        // it never enters the estimate
        if !(correction.is_finite() && self.next.iter().all(|x| x.is_finite())) {
            return Ok(None);
        }
        std::mem::swap(&mut self.estimate, &mut self.next);
        Ok(Some(correction))
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}
