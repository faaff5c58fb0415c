//! The baseline: a filtered PID on the tip error `e_k = m_k − y_d,k`,
//!
//! ```text
//! I_k = I_{k−1} + T_s e_k,
//! D_k = (T_f D_{k−1} + K_d (e_k − e_{k−1})) / (T_f + T_s),
//! Δ_k = −(K_p e_k + K_i I_k + D_k),
//! ```
//!
//! the integral and the filtered derivative by backward Euler. Gains by pole
//! placement on the first mode alone, `G₁(s) = k₁ω₁²/(s² + 2ζ₁ω₁s + ω₁²)`
//! (`k₁ = b₁c₁/ω₁²`): the closed-loop characteristic polynomial
//! `(s + ω)(s² + 2ζ_c ω s + ω²)` gives
//!
//! ```text
//! K_p = ((1 + 2ζ_c)ω² − ω₁²)/(k₁ω₁²),  K_i = ω³/(k₁ω₁²),
//! K_d = ((1 + 2ζ_c)ω − 2ζ₁ω₁)/(k₁ω₁²),  T_f = (K_d/K_p)/N,
//! ```
//!
//! with `ω = ω₁`, `ζ_c = 0.7` and `N = 2` by default. The derivative filter
//! is heavy (`N = 2` where 5 to 20 is usual) because the tip is not
//! collocated with the patches: the third mode's residue has the opposite
//! sign, and less filtering makes the loop unstable (`docs/MATHEMATICS.md`
//! §11.2 gives the margins).

use super::{ControlError, Controller, LoopSample};
#[cfg(feature = "control")]
use crate::beam::modal::ModalModel;

/// The design rule's parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PidSettings {
    /// `ω/ω₁`: the closed-loop frequency relative to the first mode.
    pub frequency_ratio: f64,
    /// `ζ_c`: damping of the closed-loop pole pair.
    pub damping: f64,
    /// `N`: the derivative filter's `T_f = T_d/N`.
    pub derivative_filter: f64,
}

impl Default for PidSettings {
    fn default() -> Self {
        Self {
            frequency_ratio: 1.0,
            damping: 0.7,
            derivative_filter: 2.0,
        }
    }
}

impl PidSettings {
    /// Every parameter finite and `> 0`.
    pub fn validate(&self) -> Result<(), ControlError> {
        for (field, v) in [
            ("frequency_ratio", self.frequency_ratio),
            ("damping", self.damping),
            ("derivative_filter", self.derivative_filter),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(ControlError::Invalid {
                    field,
                    reason: format!("must be a finite number > 0, found {v}"),
                });
            }
        }
        Ok(())
    }
}

/// The gains of a filtered PID.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PidGains {
    pub kp: f64,
    pub ki: f64,
    pub kd: f64,
    /// Derivative filter time constant `T_f` (s).
    pub tf: f64,
}

impl PidGains {
    /// Every gain finite and `≥ 0`, `T_f > 0`.
    pub fn validate(&self) -> Result<(), ControlError> {
        for (field, v) in [("kp", self.kp), ("ki", self.ki), ("kd", self.kd)] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(ControlError::Invalid {
                    field,
                    reason: format!("must be a finite number >= 0, found {v}"),
                });
            }
        }
        if !(self.tf.is_finite() && self.tf > 0.0) {
            return Err(ControlError::Invalid {
                field: "tf",
                reason: format!("must be a finite number > 0, found {}", self.tf),
            });
        }
        Ok(())
    }

    /// The rule applied to the first mode of `modal`.
    #[cfg(feature = "control")]
    pub fn design(modal: &ModalModel, settings: &PidSettings) -> Result<Self, ControlError> {
        settings.validate()?;
        if modal.is_empty() {
            return Err(ControlError::Design("the beam model has no mode".into()));
        }
        let w1 = modal.omega[0];
        let zeta1 = modal.damping_at(0, 0) / (2.0 * w1);
        let k1 = modal.input[0] * modal.output[0] / (w1 * w1);
        if !(k1.is_finite() && k1 != 0.0 && w1.is_finite() && w1 > 0.0) {
            return Err(ControlError::Design(format!(
                "the first mode has no usable gain (k1 = {k1}, omega1 = {w1})"
            )));
        }
        let (w, zc) = (settings.frequency_ratio * w1, settings.damping);
        let scale = k1 * w1 * w1;
        let kp = ((1.0 + 2.0 * zc) * w * w - w1 * w1) / scale;
        let ki = w * w * w / scale;
        let kd = ((1.0 + 2.0 * zc) * w - 2.0 * zeta1 * w1) / scale;
        if !(kp > 0.0 && kd > 0.0) {
            return Err(ControlError::Design(format!(
                "frequency_ratio {} with damping {zc} gives K_p = {kp:e}, K_d = {kd:e}: \
                 both must be > 0 (raise frequency_ratio)",
                settings.frequency_ratio
            )));
        }
        Ok(Self {
            kp,
            ki,
            kd,
            tf: kd / kp / settings.derivative_filter,
        })
    }
}

/// A filtered PID with its state.
#[derive(Debug, Clone, PartialEq)]
pub struct Pid {
    gains: PidGains,
    sample_time: f64,
    integral: f64,
    derivative: f64,
    last_error: Option<f64>,
}

impl Pid {
    /// At rest.
    pub fn new(gains: PidGains, sample_time: f64) -> Result<Self, ControlError> {
        gains.validate()?;
        if !(sample_time.is_finite() && sample_time > 0.0) {
            return Err(ControlError::Invalid {
                field: "sample_time",
                reason: format!("must be a finite number > 0, found {sample_time}"),
            });
        }
        Ok(Self {
            gains,
            sample_time,
            integral: 0.0,
            derivative: 0.0,
            last_error: None,
        })
    }

    /// Its gains.
    pub fn gains(&self) -> PidGains {
        self.gains
    }

    /// Its state: the integral, the filtered derivative and the last error.
    pub fn state(&self) -> (f64, f64, Option<f64>) {
        (self.integral, self.derivative, self.last_error)
    }
}

impl Controller for Pid {
    fn name(&self) -> String {
        "PID".into()
    }

    fn step(&mut self, s: &LoopSample) -> Result<Option<f64>, ControlError> {
        let e = s.measurement - s.reference;
        if !e.is_finite() {
            return Ok(None); // held by the loop; the state stays valid
        }
        let PidGains { kp, ki, kd, tf } = self.gains;
        let ts = self.sample_time;
        let last = self.last_error.unwrap_or(e); // no derivative kick
        let integral = self.integral + ts * e;
        let derivative = (tf * self.derivative + kd * (e - last)) / (tf + ts);
        let correction = -(kp * e + ki * integral + derivative);
        // an overflow is held: it never enters the state
        if !(correction.is_finite() && integral.is_finite() && derivative.is_finite()) {
            return Ok(None);
        }
        (self.integral, self.derivative, self.last_error) = (integral, derivative, Some(e));
        Ok(Some(correction))
    }
}
