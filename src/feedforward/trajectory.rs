//! The flat-output trajectory (28) of the companion paper (Part I), with all
//! its time derivatives.
//!
//! ```text
//! z_d(t) = z_0                                              t < t_0
//! z_d(t) = z_0 + (z_T − z_0) / (1 + exp(−2 w(τ)))          t_0 ≤ t ≤ t_0 + T,  τ = (t − t_0)/T
//! z_d(t) = z_T                                              t > t_0 + T
//! w(τ) = 2 (2τ − 1) / (4τ(1 − τ))^σ
//! ```
//!
//! (`1 + tanh w = 2/(1 + e^{−2w})`, so this is the tanh form of (28) without
//! its cancellation.) The function is of Gevrey class `1 + 1/σ`: every
//! derivative vanishes at both ends, and the transition takes exactly `T`.
//!
//! Derivatives are computed by truncated Taylor-series arithmetic
//! (automatic differentiation in Taylor mode): the coefficients of
//! `a = 4τ(1 − τ)`, `a^{−σ}` (by the recurrence `k a_0 p_k = Σ_j (−σ j − (k − j)) a_j p_{k−j}`),
//! `w`, `exp(±2w)` (`k e_k = Σ_j j g_j e_{k−j}`) and the quotient are
//! propagated exactly in the order of the series. Below `τ = 1/2` the
//! logistic is evaluated as `F/(1 + F)` with `F = e^{2w} ≤ 1`, above as
//! `1 − E/(1 + E)` with `E = e^{−2w} ≤ 1`, so nothing overflows and the small
//! quantities near the two ends keep their relative accuracy. Where `2|w|`
//! exceeds 700 (within about 0.2 % of either end) the transition differs
//! from its end value by less than `e^{−700}` of the stroke and every
//! derivative by less than 1e-100 of its scale: the value is returned as at
//! rest.

use thiserror::Error;

/// Settings of a rest-to-rest transition.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Trajectory {
    /// Start of the transition `t_0` (s).
    pub start: f64,
    /// Duration `T > 0` (s).
    pub duration: f64,
    /// Value before the transition.
    pub initial: f64,
    /// Value after the transition.
    pub last: f64,
    /// Gevrey parameter `σ > 0` (class `1 + 1/σ`).
    pub sigma: f64,
}

/// A trajectory setting out of range.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum TrajectoryError {
    #[error("{field}: {reason}, found {value}")]
    Invalid {
        field: &'static str,
        value: f64,
        reason: &'static str,
    },
}

impl Trajectory {
    /// Check `T > 0`, `σ > 0` and finite values.
    pub fn validate(&self) -> Result<(), TrajectoryError> {
        let checks: [(&'static str, f64, bool, &'static str); 5] = [
            (
                "duration",
                self.duration,
                self.duration > 0.0,
                "must be a finite number > 0",
            ),
            (
                "sigma",
                self.sigma,
                self.sigma > 0.0,
                "must be a finite number > 0",
            ),
            ("start", self.start, true, "must be finite"),
            ("initial", self.initial, true, "must be finite"),
            ("last", self.last, true, "must be finite"),
        ];
        for (field, value, ok, reason) in checks {
            if !(value.is_finite() && ok) {
                return Err(TrajectoryError::Invalid {
                    field,
                    value,
                    reason,
                });
            }
        }
        Ok(())
    }

    /// `[z, ż, z̈, …]` up to order `order` at time `t`, written into `out`
    /// (`out.len() ≥ order + 1`). Uses `scratch` (length ≥ `5 (order + 1)`),
    /// so that sampling a whole trajectory allocates once.
    pub fn derivatives_into(&self, t: f64, order: usize, out: &mut [f64], scratch: &mut [f64]) {
        let n = order + 1;
        let out = &mut out[..n];
        out.fill(0.0);
        let tau = (t - self.start) / self.duration;
        if tau <= 0.0 {
            out[0] = self.initial;
            return;
        }
        if tau >= 1.0 {
            out[0] = self.last;
            return;
        }
        // Within ~0.2 % of either end the transition is below e^{−700} of the
        // stroke and every derivative below 1e-100 of its scale: at rest in
        // double precision. (Computing it would overflow a^{−σ}'s series.)
        let lower_half = tau < 0.5;
        let w0 = 2.0 * (2.0 * tau - 1.0) / (4.0 * tau * (1.0 - tau)).powf(self.sigma);
        if 2.0 * w0.abs() > 700.0 {
            out[0] = if lower_half { self.initial } else { self.last };
            return;
        }
        let (p, rest) = scratch.split_at_mut(n);
        let (w, rest) = rest.split_at_mut(n);
        let (e, rest) = rest.split_at_mut(n);
        let (den, rest) = rest.split_at_mut(n);
        let q = &mut rest[..n];
        // a(δ) = 4(τ+δ)(1−τ−δ) = a0 + a1 δ + a2 δ²
        let a = [4.0 * tau * (1.0 - tau), 4.0 * (1.0 - 2.0 * tau), -4.0];
        // p = a^{−σ}
        let s = -self.sigma;
        p[0] = a[0].powf(s);
        for k in 1..n {
            let mut acc = 0.0;
            for j in 1..=k.min(2) {
                acc += (s * j as f64 - (k - j) as f64) * a[j] * p[k - j];
            }
            p[k] = acc / (k as f64 * a[0]);
        }
        // w = b p, b(δ) = 2(2τ − 1) + 4δ
        let b0 = 2.0 * (2.0 * tau - 1.0);
        for k in 0..n {
            w[k] = b0 * p[k] + if k > 0 { 4.0 * p[k - 1] } else { 0.0 };
        }
        // g = ±2w with the sign that makes e = exp(g) ≤ 1 at δ = 0
        let sign = if lower_half { 2.0 } else { -2.0 };
        e[0] = (sign * w[0]).exp();
        for k in 1..n {
            let mut acc = 0.0;
            for j in 1..=k {
                acc += j as f64 * sign * w[j] * e[k - j];
            }
            e[k] = acc / k as f64;
        }
        // q = e / (1 + e)
        for k in 0..n {
            den[k] = e[k] + if k == 0 { 1.0 } else { 0.0 };
        }
        for k in 0..n {
            let mut acc = e[k];
            for j in 1..=k {
                acc -= den[j] * q[k - j];
            }
            q[k] = acc / den[0];
        }
        // logistic s = q below τ = 1/2, 1 − q above
        let delta = self.last - self.initial;
        let h = 1.0 / self.duration;
        let mut scale = 1.0; // k! h^k
        for k in 0..n {
            let sk = if lower_half {
                q[k]
            } else if k == 0 {
                1.0 - q[0]
            } else {
                -q[k]
            };
            out[k] = if k == 0 {
                if lower_half {
                    self.initial + delta * sk
                } else {
                    // z_T − Δ q: accurate where z is close to z_T
                    self.last - delta * q[0]
                }
            } else {
                delta * sk * scale
            };
            scale *= (k + 1) as f64 * h;
        }
    }

    /// `[z, ż, …]` up to `order` at `t` (allocating convenience form).
    pub fn derivatives(&self, t: f64, order: usize) -> Vec<f64> {
        let mut out = vec![0.0; order + 1];
        let mut scratch = vec![0.0; 5 * (order + 1)];
        self.derivatives_into(t, order, &mut out, &mut scratch);
        out
    }

    /// The value `z_d(t)`.
    pub fn value(&self, t: f64) -> f64 {
        self.derivatives(t, 0)[0]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn paper() -> Trajectory {
        Trajectory {
            start: 0.0,
            duration: 0.075,
            initial: 0.0,
            last: 1.0,
            sigma: 1.1,
        }
    }

    #[test]
    fn rest_before_and_after_and_half_way_in_the_middle() {
        let tr = paper();
        assert_eq!(tr.derivatives(-1.0, 5), vec![0.0; 6]);
        assert_eq!(tr.derivatives(0.075, 3), vec![1.0, 0.0, 0.0, 0.0]);
        assert!((tr.value(0.0375) - 0.5).abs() < 1e-15);
    }

    #[test]
    fn first_derivative_matches_a_difference_quotient() {
        let tr = paper();
        for t in [0.01, 0.03, 0.05, 0.07] {
            let h = 1e-7;
            let fd = (tr.value(t + h) - tr.value(t - h)) / (2.0 * h);
            let d = tr.derivatives(t, 1)[1];
            assert!((fd - d).abs() < 1e-6 * d.abs().max(1.0), "{t}: {fd} vs {d}");
        }
    }

    #[test]
    fn invalid_settings_are_refused() {
        let mut tr = paper();
        tr.duration = 0.0;
        assert!(tr.validate().is_err());
        let mut tr = paper();
        tr.sigma = f64::NAN;
        assert!(tr.validate().is_err());
        assert!(paper().validate().is_ok());
    }
}
