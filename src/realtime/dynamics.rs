//! Linear dynamics after the memory part (a Hammerstein structure):
//! `y = G[S[H + C]]`, with `G` a first-order low-pass (a sensor, an
//! amplifier), a lightly damped second-order resonance (the stage's
//! mechanics), or both in series.
//!
//! `G` is discretized by matching its poles, `z = e^{sT_s}`, as an all-pole
//! filter with unit gain at DC:
//!
//! ```text
//! A(q⁻¹) y_k = g w_k,   A(z⁻¹) = (1 − p z⁻¹)(1 + a₁ z⁻¹ + a₂ z⁻²),   g = A(1)
//! p  = e^{−2π f_c T_s}                          (low-pass, cut-off f_c)
//! a₁ = −2 e^{−ζωT_s} cos(ωT_s √(1 − ζ²)),  a₂ = e^{−2ζωT_s},  ω = 2π f_n
//! ```
//!
//! so `y_k = g w_k − Σ_j c_j y_{k−j}` (`c` the coefficients of the product,
//! order 1 to 3). Its poles are inside the unit circle and it has no zeros:
//! the inverse `w_k = (y_k + Σ_j c_j y_{k−j}) / g` is exact, causal and
//! stable, an FIR filter on the output, and needs no preview. The sampling
//! delay of the continuous block (its relative degree) is part of the dead
//! time `d`, whose preview path a compensator already has.
//!
//! The state is the last outputs `y_{k−1}, …` (newest first); before the
//! first sample the filter is at rest on its first input (as the dead time
//! is), so a constant input passes unchanged.

use crate::realtime::error::ParameterError;
use crate::realtime::parameters::check_finite;
use crate::realtime::real::Real;

/// The highest order of `A` (a low-pass and a resonance).
pub const MAX_ORDER: usize = 3;

/// A lightly damped resonance `ω²/(s² + 2ζωs + ω²)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Resonance {
    /// Natural frequency `f_n = ω/2π` (Hz), below the Nyquist frequency.
    pub frequency: f64,
    /// Damping ratio `ζ`, `0 < ζ < 1`.
    pub damping: f64,
}

/// The linear block `G` after `S[H + C]`: either part may be absent.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DynamicsParameters {
    /// Cut-off frequency `f_c` (Hz) of a first-order low-pass
    /// `1/(1 + s/2πf_c)`.
    pub low_pass: Option<f64>,
    pub resonance: Option<Resonance>,
}

impl DynamicsParameters {
    /// Frequencies finite and positive, a resonance below the Nyquist
    /// frequency `1/(2T_s)` with `0 < ζ < 1`.
    pub fn validate(&self, sample_time: f64) -> Result<(), ParameterError> {
        crate::realtime::parameters::check_sample_time(sample_time)?;
        if let Some(f) = self.low_pass {
            check_finite("dynamics.low_pass.frequency", &[f])?;
            if f <= 0.0 {
                return Err(ParameterError::OutOfRange {
                    field: "dynamics.low_pass.frequency",
                    value: f,
                    lower: 0.0,
                    upper: f64::INFINITY,
                });
            }
        }
        if let Some(r) = self.resonance {
            let nyquist = 0.5 / sample_time;
            let field = "dynamics.resonance.frequency";
            check_finite(field, &[r.frequency])?;
            if !(r.frequency > 0.0 && r.frequency < nyquist) {
                return Err(ParameterError::OutOfRange {
                    field,
                    value: r.frequency,
                    lower: 0.0,
                    upper: nyquist,
                });
            }
            let field = "dynamics.resonance.damping";
            check_finite(field, &[r.damping])?;
            if !(r.damping > 0.0 && r.damping < 1.0) {
                return Err(ParameterError::OutOfRange {
                    field,
                    value: r.damping,
                    lower: 0.0,
                    upper: 1.0,
                });
            }
        }
        Ok(())
    }

    /// Neither part: `G` is the identity.
    pub fn is_identity(&self) -> bool {
        self.low_pass.is_none() && self.resonance.is_none()
    }

    /// `A`'s coefficients `c_1 … c_order` and the gain `g = A(1)`, in
    /// `f64`, for sample time `sample_time`.
    pub fn coefficients(&self, sample_time: f64) -> ([f64; MAX_ORDER], usize, f64) {
        let tau = core::f64::consts::TAU;
        // (1 − p z⁻¹) and (1 + a₁ z⁻¹ + a₂ z⁻²), each with its gain at DC
        // computed without cancellation: 1 − p = −expm1(−x)
        let (mut c, mut order, mut gain) = ([0.0; MAX_ORDER + 1], 0, 1.0);
        c[0] = 1.0;
        if let Some(f) = self.low_pass {
            let x = tau * f * sample_time;
            let p = libm::exp(-x);
            c[1] = -p;
            order = 1;
            gain = -libm::expm1(-x);
        }
        if let Some(r) = self.resonance {
            let w = tau * r.frequency * sample_time;
            let (sigma, theta) = (r.damping * w, w * libm::sqrt(1.0 - r.damping * r.damping));
            let e = libm::exp(-sigma);
            let (a1, a2) = (-2.0 * e * libm::cos(theta), e * e);
            // 1 + a₁ + a₂ = (1 − e)² + 2e(1 − cos θ) = expm1(−σ)² + 4e sin²(θ/2)
            let s = libm::sin(0.5 * theta);
            let dc = libm::expm1(-sigma) * libm::expm1(-sigma) + 4.0 * e * s * s;
            let mut next = [0.0; MAX_ORDER + 1];
            for i in 0..=order {
                next[i] += c[i];
                next[i + 1] += a1 * c[i];
                next[i + 2] += a2 * c[i];
            }
            c = next;
            order += 2;
            gain *= dc;
        }
        let mut out = [0.0; MAX_ORDER];
        out[..order].copy_from_slice(&c[1..=order]);
        (out, order, gain)
    }
}

/// `G` in `T` with its state: the last `order` outputs, newest first.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Dynamics<T: Real> {
    c: [T; MAX_ORDER],
    order: usize,
    gain: T,
    y: [T; MAX_ORDER],
    started: bool,
    parameters: DynamicsParameters,
    sample_time: f64,
}

impl<T: Real> Dynamics<T> {
    /// `G` of `parameters` at `sample_time`, not started.
    pub fn new(parameters: &DynamicsParameters, sample_time: f64) -> Result<Self, ParameterError> {
        parameters.validate(sample_time)?;
        let (c64, order, g) = parameters.coefficients(sample_time);
        let mut c = [T::ZERO; MAX_ORDER];
        for (ci, &v) in c.iter_mut().zip(&c64) {
            *ci = T::from_f64(v);
        }
        Ok(Self {
            c,
            order,
            gain: T::from_f64(g),
            y: [T::ZERO; MAX_ORDER],
            started: false,
            parameters: *parameters,
            sample_time,
        })
    }

    pub fn parameters(&self) -> &DynamicsParameters {
        &self.parameters
    }

    /// The order of `A` (the length of the state).
    pub fn order(&self) -> usize {
        self.order
    }

    /// `A`'s coefficients `c_1 …` and the gain `g`, as rounded to `T`.
    pub fn coefficients(&self) -> (&[T], T) {
        (&self.c[..self.order], self.gain)
    }

    /// `Σ_j c_j y_{k−j}`.
    #[inline(always)]
    fn past(&self) -> T {
        let mut s = T::ZERO;
        for j in 0..self.order {
            s += self.c[j] * self.y[j];
        }
        s
    }

    #[inline(always)]
    fn push(&mut self, y: T) {
        if !self.started {
            self.y = [y; MAX_ORDER];
            self.started = true;
            return;
        }
        for j in (1..self.order).rev() {
            self.y[j] = self.y[j - 1];
        }
        self.y[0] = y;
    }

    /// One sample: `y_k = g w_k − Σ_j c_j y_{k−j}`.
    #[inline]
    pub fn step(&mut self, w: T) -> T {
        let y = if self.started {
            self.gain * w - self.past()
        } else {
            w
        };
        self.push(y);
        y
    }

    /// The input that makes the next output `y`: `(y + Σ_j c_j y_{k−j}) / g`
    /// (the state does not change; [`Dynamics::push_output`] or
    /// [`Dynamics::step`] then advances it).
    #[inline]
    pub fn input_for(&self, y: T) -> T {
        if self.started {
            (y + self.past()) / self.gain
        } else {
            y
        }
    }

    /// Advance with a known output `y_k` (what [`Dynamics::input_for`] was
    /// asked for, when the input was applied exactly).
    #[inline]
    pub fn push_output(&mut self, y: T) {
        self.push(y);
    }

    /// The last outputs, newest first, into `out` (length [`order`]);
    /// `None` before the first sample.
    ///
    /// [`order`]: Dynamics::order
    pub fn state_into(&self, out: &mut [T]) -> Option<()> {
        if !self.started || out.len() != self.order {
            return None;
        }
        out.copy_from_slice(&self.y[..self.order]);
        Some(())
    }

    /// Whether a sample has gone in.
    pub fn is_started(&self) -> bool {
        self.started
    }

    /// Set the last outputs (newest first), or `None`: not started.
    pub fn set_state(&mut self, values: Option<&[f64]>) -> Result<(), ParameterError> {
        let Some(values) = values else {
            self.reset();
            return Ok(());
        };
        crate::realtime::parameters::check_length("dynamics.state", self.order, values.len())?;
        check_finite("dynamics.state", values)?;
        for (y, &v) in self.y.iter_mut().zip(values) {
            *y = T::from_f64(v);
        }
        self.started = true;
        Ok(())
    }

    /// Not started: the next sample sets the state at rest.
    pub fn reset(&mut self) {
        self.y = [T::ZERO; MAX_ORDER];
        self.started = false;
    }

    /// The sample time the coefficients were built for (s).
    pub fn sample_time(&self) -> f64 {
        self.sample_time
    }

    /// `(‖g/A‖₁, ‖1/A‖₁)` ([`l1_gains`]).
    pub fn gains(&self) -> (f64, f64) {
        l1_gains(&self.parameters, self.sample_time)
    }
}

/// `(‖g/A‖₁, ‖1/A‖₁)`, the sums of `|h_k|` over the impulse responses of
/// `G` and of `1/A` in `f64`: how much a bounded error at the input of `G`
/// is amplified at its output, and how a rounding error made in one output
/// step is carried on. Summed until the slowest pole has decayed by
/// `1e-12` (at most 10⁷ samples).
pub fn l1_gains(parameters: &DynamicsParameters, sample_time: f64) -> (f64, f64) {
    let (c, order, g) = parameters.coefficients(sample_time);
    let tau = core::f64::consts::TAU;
    let mut log_radius = f64::NEG_INFINITY;
    if let Some(f) = parameters.low_pass {
        log_radius = log_radius.max(-tau * f * sample_time);
    }
    if let Some(r) = parameters.resonance {
        log_radius = log_radius.max(-r.damping * tau * r.frequency * sample_time);
    }
    let samples = if log_radius < 0.0 {
        (libm::log(1e-12) / log_radius).min(1e7) as usize + 16
    } else {
        1
    };
    let mut h = [0.0f64; MAX_ORDER];
    let (mut sum, mut next) = (0.0, 1.0);
    for _ in 0..samples {
        sum += libm::fabs(next);
        for j in (1..order).rev() {
            h[j] = h[j - 1];
        }
        if order > 0 {
            h[0] = next;
        }
        next = -(0..order).map(|j| c[j] * h[j]).sum::<f64>();
    }
    (g * sum, sum)
}
