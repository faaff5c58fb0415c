//! Linear dynamics after the memory part (a Hammerstein structure):
//! `y = G[S[H + C]]`, with `G` a first-order low-pass (a sensor, an
//! amplifier), a lightly damped second-order resonance (the stage's
//! mechanics), a delay of a fraction of a sample, or any of them in series.
//!
//! ```text
//! G(z) = g · z^{−ρ} N(z) / A(z),   g = A(1) (unit gain at DC)
//! N(z⁻¹) = (1 − τ) + τ z⁻¹                      (delay fraction τ, |τ| < 1/2)
//! A(z⁻¹) = (1 − p z⁻¹)(1 + a₁ z⁻¹ + a₂ z⁻²)
//! p  = e^{−2π f_c T_s}                          (low-pass, cut-off f_c)
//! a₁ = −2 e^{−ζωT_s} cos(ωT_s √(1 − ζ²)),  a₂ = e^{−2ζωT_s},  ω = 2π f_n
//! ```
//!
//! Poles are matched, `z = e^{sT_s}`. The resonance is impulse-invariant:
//! its sampled impulse response is the continuous one's, which starts at 0,
//! so it carries one sample of delay (`ρ = 1`, its relative degree; `ρ = 0`
//! without a resonance); its delay at low frequencies is then the
//! continuous `2ζ/ω` to first order. The low-pass (relative degree 1
//! continuous, but its impulse response starts at its peak) has none. `N`
//! is a linear interpolation between two samples: a delay of `τ` samples at
//! low frequencies, with its zero `−τ/(1 − τ)` inside the unit circle for
//! `|τ| < 1/2`. With the whole samples of the dead time, `d + τ` is any
//! delay.
//!
//! `A`'s zeros (the poles) lie inside the unit circle and so does `N`'s
//! zero: `G` is stable and minimum phase, and its inverse is exact and
//! causal given a preview of `ρ` samples — the dead time's path, so a
//! compensator's preview is `d + ρ`. Per output step (`w` the input):
//!
//! ```text
//! y_k   = g (b₀ w_{k−ρ} + b₁ w_{k−ρ−1}) − Σ_j c_j y_{k−j}          (b = (1 − τ, τ))
//! w_k   = ((y_{k+ρ} + Σ_j c_j y_{k+ρ−j}) / g − b₁ w_{k−1}) / b₀   (the inverse)
//! ```
//!
//! The state is the last `order` outputs and the last two inputs, newest
//! first; before the first sample `G` rests on its first input (as the dead
//! time does), so a constant input passes unchanged.

use crate::realtime::checks::check_finite;
use crate::realtime::error::ParameterError;
use crate::realtime::real::Real;

/// The highest order of `A` (a low-pass and a resonance).
pub const MAX_ORDER: usize = 3;
/// Inputs kept in the state.
pub const INPUTS: usize = 2;

/// A lightly damped resonance `ω²/(s² + 2ζωs + ω²)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Resonance {
    /// Natural frequency `f_n = ω/2π` (Hz), below the Nyquist frequency.
    pub frequency: f64,
    /// Damping ratio `ζ`, `0 < ζ < 1`.
    pub damping: f64,
}

/// The linear block `G` after `S[H + C]`: every part may be absent.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DynamicsParameters {
    /// Cut-off frequency `f_c` (Hz) of a first-order low-pass
    /// `1/(1 + s/2πf_c)`.
    pub low_pass: Option<f64>,
    pub resonance: Option<Resonance>,
    /// A delay of `τ` samples, `−1/2 < τ < 1/2` (0: none), on top of the
    /// dead time's whole samples.
    pub delay_fraction: f64,
}

/// `G`'s coefficients in `f64` ([`DynamicsParameters::coefficients`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Coefficients {
    /// `c_1 … c_order` of `A`.
    pub c: [f64; MAX_ORDER],
    pub order: usize,
    /// `g = A(1)`.
    pub gain: f64,
    /// `b₀ = 1 − τ`, `b₁ = τ`.
    pub b: [f64; INPUTS],
    /// `ρ`: samples of delay before `N/A` (1 with a resonance).
    pub lag: usize,
}

fn out_of_range(field: &'static str, value: f64, lower: f64, upper: f64) -> ParameterError {
    ParameterError::OutOfRange {
        field,
        value,
        lower,
        upper,
    }
}

impl DynamicsParameters {
    /// Frequencies finite and positive, a resonance below the Nyquist
    /// frequency `1/(2T_s)` with `0 < ζ < 1`, `|τ| < 1/2`.
    pub fn validate(&self, sample_time: f64) -> Result<(), ParameterError> {
        crate::realtime::checks::check_sample_time(sample_time)?;
        if let Some(f) = self.low_pass {
            let field = "dynamics.low_pass.frequency";
            check_finite(field, &[f])?;
            if f <= 0.0 {
                return Err(out_of_range(field, f, 0.0, f64::INFINITY));
            }
        }
        if let Some(r) = self.resonance {
            let nyquist = 0.5 / sample_time;
            let field = "dynamics.resonance.frequency";
            check_finite(field, &[r.frequency])?;
            if !(r.frequency > 0.0 && r.frequency < nyquist) {
                return Err(out_of_range(field, r.frequency, 0.0, nyquist));
            }
            let field = "dynamics.resonance.damping";
            check_finite(field, &[r.damping])?;
            if !(r.damping > 0.0 && r.damping < 1.0) {
                return Err(out_of_range(field, r.damping, 0.0, 1.0));
            }
        }
        let field = "dynamics.delay_fraction";
        check_finite(field, &[self.delay_fraction])?;
        if self.delay_fraction.abs() >= 0.5 {
            return Err(out_of_range(field, self.delay_fraction, -0.5, 0.5));
        }
        Ok(())
    }

    /// No part: `G` is the identity.
    pub fn is_identity(&self) -> bool {
        self.low_pass.is_none() && self.resonance.is_none() && self.delay_fraction == 0.0
    }

    /// The samples of delay before `N/A` (1 with a resonance, else 0).
    pub fn lag(&self) -> usize {
        usize::from(self.resonance.is_some())
    }

    /// The state's length: the order of `A` and the inputs kept.
    pub fn state_len(&self) -> usize {
        usize::from(self.low_pass.is_some()) + 2 * usize::from(self.resonance.is_some()) + INPUTS
    }

    /// `G`'s coefficients at sample time `sample_time`, in `f64`.
    pub fn coefficients(&self, sample_time: f64) -> Coefficients {
        let tau = core::f64::consts::TAU;
        // (1 − p z⁻¹) and (1 + a₁ z⁻¹ + a₂ z⁻²), each with its gain at DC
        // computed without cancellation: 1 − p = −expm1(−x)
        let (mut c, mut order, mut gain) = ([0.0; MAX_ORDER + 1], 0, 1.0);
        c[0] = 1.0;
        if let Some(f) = self.low_pass {
            let x = tau * f * sample_time;
            c[1] = -libm::exp(-x);
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
        Coefficients {
            c: out,
            order,
            gain,
            b: [1.0 - self.delay_fraction, self.delay_fraction],
            lag: self.lag(),
        }
    }
}

/// `G` in `T` with its state: the last outputs and inputs, newest first.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Dynamics<T: Real> {
    c: [T; MAX_ORDER],
    order: usize,
    gain: T,
    b: [T; INPUTS],
    lag: usize,
    y: [T; MAX_ORDER],
    w: [T; INPUTS],
    started: bool,
    parameters: DynamicsParameters,
}

impl<T: Real> Dynamics<T> {
    /// `G` of `parameters` at `sample_time`, not started.
    pub fn new(parameters: &DynamicsParameters, sample_time: f64) -> Result<Self, ParameterError> {
        parameters.validate(sample_time)?;
        Ok(Self::build(parameters, sample_time))
    }

    /// `G` of parameters checked before at `sample_time`.
    pub(crate) fn build(parameters: &DynamicsParameters, sample_time: f64) -> Self {
        let k = parameters.coefficients(sample_time);
        let mut c = [T::ZERO; MAX_ORDER];
        for (ci, &v) in c.iter_mut().zip(&k.c) {
            *ci = T::from_f64(v);
        }
        Self {
            c,
            order: k.order,
            gain: T::from_f64(k.gain),
            b: [T::from_f64(k.b[0]), T::from_f64(k.b[1])],
            lag: k.lag,
            y: [T::ZERO; MAX_ORDER],
            w: [T::ZERO; INPUTS],
            started: false,
            parameters: *parameters,
        }
    }

    pub fn parameters(&self) -> &DynamicsParameters {
        &self.parameters
    }

    /// The order of `A`.
    pub fn order(&self) -> usize {
        self.order
    }

    /// `ρ`: the samples a compensator's target must lead, on top of the
    /// dead time.
    pub fn lag(&self) -> usize {
        self.lag
    }

    /// The same `G` without its lag (`g N/A`), for a caller that keeps the
    /// lag with the dead time (the identification's alignment).
    pub fn without_lag(mut self) -> Self {
        self.lag = 0;
        self
    }

    /// The state's length: `order` outputs and [`INPUTS`] inputs.
    pub fn state_len(&self) -> usize {
        self.order + INPUTS
    }

    /// `A`'s coefficients `c_1 …`, the gain `g` and `N`'s `(b₀, b₁)`, as
    /// rounded to `T`.
    pub fn coefficients(&self) -> (&[T], T, [T; INPUTS]) {
        (&self.c[..self.order], self.gain, self.b)
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
    fn push(&mut self, y: T, w: T) {
        for j in (1..self.order).rev() {
            self.y[j] = self.y[j - 1];
        }
        if self.order > 0 {
            self.y[0] = y;
        }
        self.w[1] = self.w[0];
        self.w[0] = w;
    }

    #[inline(always)]
    fn rest(&mut self, value: T) {
        self.y = [value; MAX_ORDER];
        self.w = [value; INPUTS];
        self.started = true;
    }

    /// One sample: `y_k = g (b₀ w_{k−ρ} + b₁ w_{k−ρ−1}) − Σ_j c_j y_{k−j}`.
    #[inline]
    pub fn step(&mut self, w: T) -> T {
        if !self.started {
            self.rest(w);
            return w;
        }
        let x = if self.lag == 0 {
            self.b[0] * w + self.b[1] * self.w[0]
        } else {
            self.b[0] * self.w[0] + self.b[1] * self.w[1]
        };
        let y = self.gain * x - self.past();
        self.push(y, w);
        y
    }

    /// The same `G` advanced by its lag without a new input: the outputs
    /// the inputs so far already fix (`ρ` of them), so that the next input
    /// makes the output `ρ` samples ahead. What a compensator tracks.
    pub fn ahead(&self) -> Self {
        let mut g = *self;
        if self.lag == 1 && self.started {
            let y = self.gain * (self.b[0] * self.w[0] + self.b[1] * self.w[1]) - self.past();
            for j in (1..self.order).rev() {
                g.y[j] = g.y[j - 1];
            }
            if self.order > 0 {
                g.y[0] = y;
            }
        }
        g
    }

    /// On a state [`ahead`](Dynamics::ahead): the input that makes the
    /// output `ρ` samples later `y` (the state does not change;
    /// [`Dynamics::push_exact`] or [`Dynamics::push_input`] then advances
    /// it).
    #[inline]
    pub fn input_for(&self, y: T) -> T {
        if !self.started {
            return y;
        }
        ((y + self.past()) / self.gain - self.b[1] * self.w[0]) / self.b[0]
    }

    /// On a state ahead: advance with the output `y` that
    /// [`Dynamics::input_for`] was asked for and the input `w` it gave.
    #[inline]
    pub fn push_exact(&mut self, y: T, w: T) {
        if !self.started {
            self.rest(y);
            return;
        }
        self.push(y, w);
    }

    /// On a state ahead: advance with an input `w` (applied instead of the
    /// one asked for).
    #[inline]
    pub fn push_input(&mut self, w: T) {
        if !self.started {
            self.rest(w);
            return;
        }
        let y = self.gain * (self.b[0] * w + self.b[1] * self.w[0]) - self.past();
        self.push(y, w);
    }

    /// The state into `out` (length [`state_len`](Dynamics::state_len)):
    /// the last `order` outputs, then the last two inputs, newest first;
    /// `None` before the first sample.
    pub fn state_into(&self, out: &mut [T]) -> Option<()> {
        if !self.started || out.len() != self.state_len() {
            return None;
        }
        out[..self.order].copy_from_slice(&self.y[..self.order]);
        out[self.order..].copy_from_slice(&self.w);
        Some(())
    }

    /// Whether a sample has gone in.
    pub fn is_started(&self) -> bool {
        self.started
    }

    /// Set the state (as [`Dynamics::state_into`] gives it), or `None`: not
    /// started.
    pub fn set_state(&mut self, values: Option<&[f64]>) -> Result<(), ParameterError> {
        let Some(values) = values else {
            self.reset();
            return Ok(());
        };
        crate::realtime::checks::check_length("dynamics.state", self.state_len(), values.len())?;
        check_finite("dynamics.state", values)?;
        for (y, &v) in self.y.iter_mut().zip(&values[..self.order]) {
            *y = T::from_f64(v);
        }
        for (w, &v) in self.w.iter_mut().zip(&values[self.order..]) {
            *w = T::from_f64(v);
        }
        self.started = true;
        Ok(())
    }

    /// Not started: the next sample sets the state at rest.
    pub fn reset(&mut self) {
        self.y = [T::ZERO; MAX_ORDER];
        self.w = [T::ZERO; INPUTS];
        self.started = false;
    }

    /// `(‖G‖₁, ‖1/A‖₁)` ([`l1_gains`]) at `sample_time`, the one it was
    /// built for (its model's).
    pub fn gains(&self, sample_time: f64) -> (f64, f64) {
        l1_gains(&self.parameters, sample_time)
    }
}

/// `(‖G‖₁, ‖1/A‖₁)`, the sums of `|h_k|` over the impulse responses of
/// `G = g z^{−ρ} N/A` and of `1/A` in `f64`: how much a bounded error at the
/// input of `G` is amplified at its output, and how a rounding error made
/// in one output step is carried on. Summed until the slowest pole has
/// decayed by `1e-12` (at most 10⁷ samples).
pub fn l1_gains(parameters: &DynamicsParameters, sample_time: f64) -> (f64, f64) {
    let k = parameters.coefficients(sample_time);
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
        2
    };
    let mut h = [0.0f64; MAX_ORDER];
    let (mut sum_a, mut sum_g, mut next, mut previous) = (0.0, 0.0, 1.0, 0.0);
    for _ in 0..samples {
        sum_a += libm::fabs(next);
        // N/A's impulse response: b₀ h_k + b₁ h_{k−1}
        sum_g += libm::fabs(k.b[0] * next + k.b[1] * previous);
        previous = next;
        for j in (1..k.order).rev() {
            h[j] = h[j - 1];
        }
        if k.order > 0 {
            h[0] = next;
        }
        next = -(0..k.order).map(|j| k.c[j] * h[j]).sum::<f64>();
    }
    sum_g += libm::fabs(k.b[1] * previous);
    (k.gain * sum_g, sum_a)
}
