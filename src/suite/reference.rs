//! Naive reference implementations: the formulas of the paper written down
//! as plainly as possible, to compare any other implementation against.
//!
//! They share nothing with the fast operators of [`crate::operators`] except
//! the validation of the model file: `f64::max`/`f64::min` for the play (20),
//! sequential sums in the paper's order for (10) and (16), a nested
//! threshold-then-eigenvalue loop for the creep operators (15), (20), the
//! direct `O(n²)` sums of the transformation rules (22), and the explicit
//! compensator (21); the superposition operator as its sum of dead zones, and
//! its inverse by locating the segment of the piecewise-linear `S` that holds
//! the value (not by the inverse rules). [`BisectionCompensator`] inverts `W` numerically, the
//! way an operator without an analytic inverse (a Preisach model) must be
//! inverted; it is the peer the analytic inverse is benchmarked against.
//!
//! Every type here implements the traits of [`crate::operators::traits`], so
//! the conformance checks ([`crate::suite::conformance`]) run on them too.

use std::collections::VecDeque;

use crate::error::ModelError;
use crate::operators::compensator::CompensatorSettings;
use crate::operators::model::{HysteresisCreepModel, ModelFile};
use crate::operators::traits::{
    ActuatorCompensator, ActuatorModel, Compensated, InverseHysteresis, Operator,
};

/// The PI hysteresis operator (10) with the discrete play (20), textbook form.
#[derive(Debug, Clone, PartialEq)]
pub struct NaiveHysteresis {
    /// Thresholds `r_i`.
    pub r: Vec<f64>,
    /// Weights `w_i`.
    pub w: Vec<f64>,
    /// Play states `x_i`.
    pub x: Vec<f64>,
}

impl NaiveHysteresis {
    /// The output `Σ w_i max(v − r_i, min(v + r_i, x_i))` of input `v` from
    /// the current state, without changing it.
    pub fn evaluate(&self, v: f64) -> f64 {
        let mut y = 0.0;
        for i in 0..self.r.len() {
            y += self.w[i] * (v - self.r[i]).max((v + self.r[i]).min(self.x[i]));
        }
        y
    }

    /// The inverse operator by the direct sums of (22):
    /// `r'_j = Σ_{i≤j} w_i (r_j − r_i)`, `w'_0 = 1/w_0`,
    /// `w'_j = −w_j / (s_j s_{j−1})`, `x'_j = s_j x_j + Σ_{i>j} w_i x_i`.
    pub fn inverse(&self) -> NaiveHysteresis {
        let n = self.r.len();
        let s = |j: usize| (0..=j).map(|i| self.w[i]).sum::<f64>();
        let r = (0..n)
            .map(|j| (0..=j).map(|i| self.w[i] * (self.r[j] - self.r[i])).sum())
            .collect();
        let w = (0..n)
            .map(|j| {
                if j == 0 {
                    1.0 / self.w[0]
                } else {
                    -self.w[j] / (s(j) * s(j - 1))
                }
            })
            .collect();
        let x = (0..n)
            .map(|j| s(j) * self.x[j] + (j + 1..n).map(|i| self.w[i] * self.x[i]).sum::<f64>())
            .collect();
        NaiveHysteresis { r, w, x }
    }
}

impl Operator for NaiveHysteresis {
    fn step(&mut self, v: f64) -> f64 {
        let mut y = 0.0;
        for i in 0..self.r.len() {
            self.x[i] = (v - self.r[i]).max((v + self.r[i]).min(self.x[i]));
            y += self.w[i] * self.x[i];
        }
        y
    }

    fn reset(&mut self) {
        self.x.iter_mut().for_each(|x| *x = 0.0);
    }
}

impl InverseHysteresis for NaiveHysteresis {}

/// The PI creep operator (16) over log(t)-creep operators (15) with the exact
/// zero-order-hold step (20), textbook form.
#[derive(Debug, Clone, PartialEq)]
pub struct NaiveCreep {
    /// Thresholds `r_i`.
    pub r: Vec<f64>,
    /// Weights `w_i`.
    pub w: Vec<f64>,
    /// Eigenvalues `a_j` (s⁻¹).
    pub a: Vec<f64>,
    /// Sample time (s).
    pub ts: f64,
    /// `chi[i][j]`: threshold `i`, eigenvalue `j`.
    pub chi: Vec<Vec<f64>>,
}

impl NaiveCreep {
    /// `C_k = Σ_i w_i (1/m) Σ_j χ_ij`.
    pub fn output(&self) -> f64 {
        let m = self.a.len() as f64;
        (0..self.r.len())
            .map(|i| self.w[i] * self.chi[i].iter().sum::<f64>() / m)
            .sum()
    }

    /// `χ ← χ + (1 − e^{−a T_s}) d_r(v − χ)`.
    pub fn advance(&mut self, v: f64) {
        for i in 0..self.r.len() {
            for j in 0..self.a.len() {
                let z = v - self.chi[i][j];
                let d = (z - self.r[i]).max((z + self.r[i]).min(0.0));
                self.chi[i][j] += -(-self.a[j] * self.ts).exp_m1() * d;
            }
        }
    }

    fn reset(&mut self) {
        for row in &mut self.chi {
            row.iter_mut().for_each(|c| *c = 0.0);
        }
    }
}

/// The superposition operator `S[z] = Σ w_i d_{r_i}(z)`, textbook form.
#[derive(Debug, Clone, PartialEq)]
pub struct NaiveSuperposition {
    /// Thresholds `r_i`, increasing, one of them 0.
    pub r: Vec<f64>,
    /// Weights `w_i`.
    pub w: Vec<f64>,
    /// `S(r_i)`, and the slopes below the first and above the last threshold.
    at_thresholds: Vec<f64>,
    outer_slopes: (f64, f64),
}

impl NaiveSuperposition {
    /// From checked parameters.
    pub fn new(r: Vec<f64>, w: Vec<f64>) -> Self {
        let mut s = Self {
            r,
            w,
            at_thresholds: Vec::new(),
            outer_slopes: (0.0, 0.0),
        };
        s.at_thresholds = s.r.iter().map(|&r| s.evaluate(r)).collect();
        // difference quotients over a step as wide as the thresholds' span,
        // so that the rounding of S(r) is small against the difference
        let (first, last) = (s.r[0], s.r[s.r.len() - 1]);
        let step = (last - first).max(1.0);
        s.outer_slopes = (
            (s.evaluate(first) - s.evaluate(first - step)) / step,
            (s.evaluate(last + step) - s.evaluate(last)) / step,
        );
        s
    }

    /// `S[z]`: each dead zone, weighted, summed in order.
    pub fn evaluate(&self, z: f64) -> f64 {
        let mut y = 0.0;
        for (&r, &w) in self.r.iter().zip(&self.w) {
            let d = if r > 0.0 {
                f64::max(z - r, 0.0)
            } else if r < 0.0 {
                f64::min(z - r, 0.0)
            } else {
                z
            };
            y += w * d;
        }
        y
    }

    /// `S⁻¹[y]`: the segment of `S` whose values hold `y`, and the straight
    /// line through its ends.
    pub fn invert(&self, y: f64) -> f64 {
        let (r, s) = (&self.r, &self.at_thresholds);
        let n = r.len();
        if y <= s[0] {
            return r[0] + (y - s[0]) / self.outer_slopes.0;
        }
        if y >= s[n - 1] {
            return r[n - 1] + (y - s[n - 1]) / self.outer_slopes.1;
        }
        let k = (0..n - 1).rfind(|&k| s[k] <= y).unwrap_or(0);
        r[k] + (y - s[k]) * (r[k + 1] - r[k]) / (s[k + 1] - s[k])
    }
}

/// The superposition operator of a (validated) model file, if any.
fn naive_superposition(file: &ModelFile) -> Option<NaiveSuperposition> {
    let s = file.superposition.as_ref()?;
    Some(NaiveSuperposition::new(
        s.thresholds.clone(),
        s.weights.clone(),
    ))
}

/// Hysteresis and creep parts of a validated model file.
fn naive_parts(file: &ModelFile) -> Result<(NaiveHysteresis, Option<NaiveCreep>), ModelError> {
    // validation (11), (12), (17), (18), admissibility, shapes: the one rule set
    HysteresisCreepModel::from_file(file)?;
    let h = &file.hysteresis;
    let hysteresis = NaiveHysteresis {
        r: h.thresholds.clone(),
        w: h.weights.clone(),
        x: h.state
            .clone()
            .unwrap_or_else(|| vec![0.0; h.thresholds.len()]),
    };
    let creep = file.creep.as_ref().map(|c| NaiveCreep {
        r: c.thresholds.clone(),
        w: c.weights.clone(),
        a: c.eigenvalues.clone(),
        ts: file.sample_time,
        chi: c
            .state
            .clone()
            .unwrap_or_else(|| vec![vec![0.0; c.eigenvalues.len()]; c.thresholds.len()]),
    });
    Ok((hysteresis, creep))
}

/// One all-pole section `y_k = g x_k − Σ_j a_j y_{k−j}` with `g = 1 + Σ a_j`,
/// at rest on its first input, textbook form.
#[derive(Debug, Clone, PartialEq)]
pub struct NaiveSection {
    /// `a_1, a_2, …`.
    pub a: Vec<f64>,
    /// The last outputs, newest first (empty before the first sample).
    pub y: VecDeque<f64>,
}

impl NaiveSection {
    fn gain(&self) -> f64 {
        1.0 + self.a.iter().sum::<f64>()
    }

    fn past(&self) -> f64 {
        self.a.iter().zip(&self.y).map(|(a, y)| a * y).sum()
    }

    /// One sample forward.
    pub fn step(&mut self, x: f64) -> f64 {
        let y = if self.y.is_empty() {
            x
        } else {
            self.gain() * x - self.past()
        };
        self.push(y);
        y
    }

    /// The input giving the output `y` next (state unchanged).
    pub fn input_for(&self, y: f64) -> f64 {
        if self.y.is_empty() {
            y
        } else {
            (y + self.past()) / self.gain()
        }
    }

    fn push(&mut self, y: f64) {
        if self.y.is_empty() {
            self.y.extend(std::iter::repeat_n(y, self.a.len()));
        } else {
            self.y.pop_back();
            self.y.push_front(y);
        }
    }
}

/// The linear dynamics `G`, textbook form, as a chain: the interpolation
/// `N = (1 − τ) + τ z⁻¹` on the input, the low-pass section
/// `(1 − p)/(1 − p z⁻¹)`, the resonance section
/// `(1 + a₁ + a₂)/(1 + a₁ z⁻¹ + a₂ z⁻²)` and, with a resonance, one sample
/// of delay (its impulse response starts at 0); each pole at `e^{sT_s}` of
/// the continuous one (computed here from `exp`, `cos` and `sqrt`, apart
/// from the fast code's product polynomial).
#[derive(Debug, Clone, PartialEq)]
pub struct NaiveDynamics {
    /// `τ`.
    pub fraction: f64,
    /// The last input (`None` before the first sample).
    pub last_input: Option<f64>,
    /// The one before it.
    pub previous_input: Option<f64>,
    pub sections: Vec<NaiveSection>,
    /// With a resonance, the value of the chain waiting one sample.
    pub lag: Option<Option<f64>>,
}

impl NaiveDynamics {
    /// `G` of a model file, in the file's state; `None` without dynamics.
    pub fn of(file: &ModelFile) -> Option<Self> {
        let g = file.dynamics.as_ref()?;
        let ts = file.sample_time;
        let mut sections = Vec::new();
        if let Some(l) = &g.low_pass {
            let p = (-2.0 * std::f64::consts::PI * l.frequency * ts).exp();
            sections.push(NaiveSection {
                a: vec![-p],
                y: VecDeque::new(),
            });
        }
        if let Some(r) = &g.resonance {
            let w = 2.0 * std::f64::consts::PI * r.frequency * ts;
            let (sigma, theta) = (r.damping * w, w * (1.0 - r.damping * r.damping).sqrt());
            sections.push(NaiveSection {
                a: vec![-2.0 * (-sigma).exp() * theta.cos(), (-2.0 * sigma).exp()],
                y: VecDeque::new(),
            });
        }
        let mut d = Self {
            fraction: g.delay_fraction.unwrap_or(0.0),
            last_input: None,
            previous_input: None,
            sections,
            lag: g.resonance.is_some().then_some(None),
        };
        if let Some(state) = &g.state {
            d.set_state(state);
        }
        Some(d)
    }

    /// The file's state (outputs of the whole `G`, then its last two
    /// inputs, newest first): the sections' states from it. With a
    /// resonance the outputs are the resonance's; the low-pass's last output
    /// follows through the resonance's inverse, and the value waiting in the
    /// lag is `N` of the last two inputs.
    fn set_state(&mut self, state: &[f64]) {
        let order: usize = self.sections.iter().map(|s| s.a.len()).sum();
        let (y, w) = (&state[..order], &state[order..]);
        self.last_input = Some(w[0]);
        self.previous_input = Some(w[1]);
        let x = (1.0 - self.fraction) * w[0] + self.fraction * w[1];
        let n = self.sections.len();
        if n == 0 {
            return;
        }
        let last = &mut self.sections[n - 1];
        last.y = y[..last.a.len()].iter().copied().collect();
        if n == 2 {
            let res = &self.sections[1];
            let x1 = (y[0] + res.a[0] * y[1] + res.a[1] * y[2]) / res.gain();
            self.sections[0].y = VecDeque::from([x1]);
        }
        if let Some(lag) = &mut self.lag {
            *lag = Some(x);
        }
    }

    /// The state as the file holds it (empty before the first sample): the
    /// last outputs of the whole `G` (with both sections, the third from
    /// the low-pass's last output through the resonance's recursion), then
    /// the last two inputs (the one before the last from the value waiting
    /// in the lag, `N` solved for it; the last one again when `τ = 0`).
    pub fn state(&self) -> Vec<f64> {
        let Some(w0) = self.last_input else {
            return Vec::new();
        };
        let mut y: Vec<f64> = match self.sections.last() {
            Some(last) => last.y.iter().copied().collect(),
            None => Vec::new(),
        };
        if self.sections.len() == 2 {
            let (res, x1) = (&self.sections[1], self.sections[0].y[0]);
            y.push((res.gain() * x1 - y[0] - res.a[0] * y[1]) / res.a[1]);
        }
        let w1 = match (self.lag, self.fraction) {
            (Some(Some(x)), t) if t != 0.0 => (x - (1.0 - t) * w0) / t,
            _ => self.previous_input.unwrap_or(w0),
        };
        y.push(w0);
        y.push(w1);
        y
    }

    pub fn step(&mut self, w: f64) -> f64 {
        let previous = self.last_input.unwrap_or(w);
        self.previous_input = Some(previous);
        self.last_input = Some(w);
        let x = (1.0 - self.fraction) * w + self.fraction * previous;
        let x = match &mut self.lag {
            Some(waiting) => waiting.replace(x).unwrap_or(x),
            None => x,
        };
        self.sections.iter_mut().fold(x, |x, s| s.step(x))
    }

    /// The input of `G` that gives the output `ρ` samples later `y` (the
    /// output of the chain before the lag), and each section's output on
    /// the way (for [`NaiveDynamics::push_exact`]).
    pub fn input_for(&self, y: f64) -> (f64, Vec<f64>) {
        let mut outputs = vec![0.0; self.sections.len()];
        let mut x = y;
        for (i, s) in self.sections.iter().enumerate().rev() {
            outputs[i] = x;
            x = s.input_for(x);
        }
        // N's inverse: w = (x − τ w_prev) / (1 − τ)
        let w = match self.last_input {
            Some(previous) => (x - self.fraction * previous) / (1.0 - self.fraction),
            None => x,
        };
        (w, outputs)
    }

    /// Advance, ahead by the lag, with the outputs [`NaiveDynamics::input_for`]
    /// gave and its input `w`.
    pub fn push_exact(&mut self, w: f64, outputs: &[f64]) {
        self.previous_input = Some(self.last_input.unwrap_or(w));
        self.last_input = Some(w);
        for (s, &y) in self.sections.iter_mut().zip(outputs) {
            s.push(y);
        }
    }

    /// Advance, ahead by the lag, with an input `w` applied instead.
    pub fn push_input(&mut self, w: f64) {
        let previous = self.last_input.unwrap_or(w);
        self.previous_input = Some(previous);
        self.last_input = Some(w);
        let x = (1.0 - self.fraction) * w + self.fraction * previous;
        self.sections.iter_mut().fold(x, |x, s| s.step(x));
    }

    /// The same `G` advanced by its lag: what a compensator tracks (the
    /// value waiting in the lag goes through the sections).
    pub fn ahead(&self) -> Self {
        let mut g = self.clone();
        if let Some(Some(x)) = g.lag {
            g.sections.iter_mut().fold(x, |x, s| s.step(x));
        }
        g.lag = None;
        g
    }

    pub fn reset(&mut self) {
        self.last_input = None;
        self.previous_input = None;
        if let Some(lag) = &mut self.lag {
            *lag = None;
        }
        for s in &mut self.sections {
            s.y.clear();
        }
    }
}

/// The model `W = S[H + C]` (6), textbook form.
#[derive(Debug, Clone, PartialEq)]
pub struct NaiveModel {
    /// `H`.
    pub hysteresis: NaiveHysteresis,
    /// `C`, if the model has creep.
    pub creep: Option<NaiveCreep>,
    /// `S`, if the model has one.
    pub superposition: Option<NaiveSuperposition>,
    /// `G`, if the model has dynamics.
    pub dynamics: Option<NaiveDynamics>,
    /// Output offset.
    pub offset: f64,
    /// The dead time `d` (samples).
    pub delay: usize,
    /// The values of `S[H + C]` still to come out, oldest first (`d` of
    /// them once started; empty before the first sample).
    pub pending: VecDeque<f64>,
}

impl NaiveModel {
    /// From a model file (validated), starting from its `state`.
    pub fn from_file(file: &ModelFile) -> Result<Self, ModelError> {
        let (hysteresis, creep) = naive_parts(file)?;
        Ok(Self {
            hysteresis,
            creep,
            superposition: naive_superposition(file),
            dynamics: NaiveDynamics::of(file),
            offset: file.offset.unwrap_or(0.0),
            delay: file.delay.unwrap_or(0),
            pending: file.delay_state.clone().unwrap_or_default().into(),
        })
    }

    /// `y_k = z_{max(k−d, 0)}`: before the first output leaves, the queue
    /// holds `d` copies of the first `z` (the record at rest before it).
    fn delayed(&mut self, z: f64) -> f64 {
        if self.delay == 0 {
            return z;
        }
        if self.pending.is_empty() {
            self.pending.extend(std::iter::repeat_n(z, self.delay));
        }
        self.pending.push_back(z);
        self.pending.pop_front().expect("d ≥ 1 values queued")
    }
}

impl Operator for NaiveModel {
    fn step(&mut self, v: f64) -> f64 {
        // a non-finite input: the previous input held
        let v = if v.is_finite() {
            v
        } else {
            self.hysteresis.x[0]
        };
        let h = self.hysteresis.step(v);
        let w = match &mut self.creep {
            Some(c) => {
                let out = c.output();
                c.advance(v);
                h + out
            }
            None => h,
        };
        let w = match &self.superposition {
            Some(s) => s.evaluate(w),
            None => w,
        };
        let w = match &mut self.dynamics {
            Some(g) => g.step(w),
            None => w,
        };
        self.delayed(w) + self.offset
    }

    fn reset(&mut self) {
        self.pending.clear();
        if let Some(g) = &mut self.dynamics {
            g.reset();
        }
        self.hysteresis.reset();
        if let Some(c) = &mut self.creep {
            c.reset();
        }
    }
}

impl ActuatorModel for NaiveModel {}

/// `H⁻¹` of a model file's hysteresis part with its state, by the direct
/// sums of (22).
pub fn naive_inverse_hysteresis(file: &ModelFile) -> Result<NaiveHysteresis, ModelError> {
    Ok(naive_parts(file)?.0.inverse())
}

/// Clip `v` to `[lower, upper]`, and whether it was clipped.
fn clip(v: f64, settings: &CompensatorSettings) -> (f64, bool) {
    if v < settings.lower_limit {
        (settings.lower_limit, true)
    } else if v > settings.upper_limit {
        (settings.upper_limit, true)
    } else {
        (v, false)
    }
}

/// The compensator (21), textbook form: `v_k = H⁻¹[ς_k − C_k]`, clipped; the
/// forward plays follow the emitted value, and after a clipped sample the
/// inverse is rebuilt from them by the direct sums of (22).
#[derive(Debug, Clone, PartialEq)]
pub struct NaiveCompensator {
    settings: CompensatorSettings,
    initial: (NaiveHysteresis, Option<NaiveCreep>),
    forward: NaiveHysteresis,
    inverse: NaiveHysteresis,
    creep: Option<NaiveCreep>,
    superposition: Option<NaiveSuperposition>,
    dynamics: Option<NaiveDynamics>,
    offset: f64,
    delay: usize,
    last_request: f64,
}

impl NaiveCompensator {
    /// The unclipped value `H⁻¹[ς_k − C_k]` of the last sample.
    pub fn last_request(&self) -> f64 {
        self.last_request
    }

    /// From a model file (validated), with matched states.
    pub fn from_file(file: &ModelFile, settings: CompensatorSettings) -> Result<Self, ModelError> {
        settings.validate()?;
        let (forward, creep) = naive_parts(file)?;
        Ok(Self {
            settings,
            inverse: forward.inverse(),
            initial: (forward.clone(), creep.clone()),
            forward,
            creep,
            superposition: naive_superposition(file),
            // what the target leads by, the compensator's G leads by
            dynamics: NaiveDynamics::of(file).map(|g| g.ahead()),
            offset: file.offset.unwrap_or(0.0),
            delay: file.delay.unwrap_or(0) + lag_of(file),
            last_request: 0.0,
        })
    }
}

impl ActuatorCompensator for NaiveCompensator {
    fn compensate(&mut self, target: f64) -> Compensated {
        if !target.is_finite() {
            // hold the previous output; the creep advances with it
            let u = self.forward.x[0];
            let c = self.creep.as_ref().map_or(0.0, NaiveCreep::output);
            self.advance_dynamics(self.forward.evaluate(u) + c);
            if let Some(cr) = &mut self.creep {
                cr.advance(u);
            }
            return Compensated {
                u,
                saturated: false,
                fault: true,
            };
        }
        let c = self.creep.as_ref().map_or(0.0, NaiveCreep::output);
        let (g_in, g_outputs) = match &self.dynamics {
            Some(g) => g.input_for(target - self.offset),
            None => (target - self.offset, Vec::new()),
        };
        let y = match &self.superposition {
            Some(s) => s.invert(g_in),
            None => g_in,
        };
        let v = self.inverse.step(y - c);
        self.last_request = v;
        let (u, saturated) = clip(v, &self.settings);
        let h = self.forward.step(u);
        if saturated {
            self.inverse = self.forward.inverse();
            self.advance_dynamics(h + c);
        } else if let Some(g) = &mut self.dynamics {
            g.push_exact(g_in, &g_outputs);
        }
        if let Some(cr) = &mut self.creep {
            cr.advance(u);
        }
        Compensated {
            u,
            saturated,
            fault: false,
        }
    }

    fn delay(&self) -> usize {
        self.delay
    }

    fn reset(&mut self) {
        let (mut h, mut c) = self.initial.clone();
        h.reset();
        if let Some(c) = &mut c {
            c.reset();
        }
        self.inverse = h.inverse();
        self.forward = h;
        self.creep = c;
        if let Some(g) = &mut self.dynamics {
            g.reset();
        }
    }
}

impl NaiveCompensator {
    /// `G` advanced with what the plant produces from `H + C = z`.
    fn advance_dynamics(&mut self, z: f64) {
        if let Some(g) = &mut self.dynamics {
            let w = match &self.superposition {
                Some(s) => s.evaluate(z),
                None => z,
            };
            g.push_input(w);
        }
    }
}

/// The lag of a model file's dynamics (1 with a resonance).
fn lag_of(file: &ModelFile) -> usize {
    file.dynamics
        .as_ref()
        .map_or(0, |g| usize::from(g.resonance.is_some()))
}

/// The forward map a bisection searches: `v ↦ S[H_state(v) + C_k]`, or
/// `H_state(v)` without `S`.
struct Forward<'a> {
    h: &'a NaiveHysteresis,
    c: f64,
    s: Option<&'a NaiveSuperposition>,
}

impl Forward<'_> {
    fn evaluate(&self, v: f64) -> f64 {
        match self.s {
            Some(s) => s.evaluate(self.h.evaluate(v) + self.c),
            None => self.h.evaluate(v),
        }
    }
}

/// A numerical inverse of `W`: each sample, bisection on the forward
/// operator for the `v` with `H_state[v] + C_k = ς_k` (`H` is strictly
/// increasing by (11)), then the forward state advances with it. This is how
/// a hysteresis model without an analytic inverse is compensated; here it is
/// the peer the analytic inverse (22) is measured against. Allocation-free.
#[derive(Debug, Clone, PartialEq)]
pub struct BisectionCompensator {
    settings: CompensatorSettings,
    model: NaiveModel,
    initial: NaiveModel,
    /// The model's `G` advanced by its lag (the target leads by it).
    ahead: Option<NaiveDynamics>,
    /// Bisection steps per sample (64 reach the last bit of a double).
    pub iterations: u32,
}

impl BisectionCompensator {
    /// From a model file (validated), with matched states.
    pub fn from_file(file: &ModelFile, settings: CompensatorSettings) -> Result<Self, ModelError> {
        settings.validate()?;
        let model = NaiveModel::from_file(file)?;
        Ok(Self {
            settings,
            initial: model.clone(),
            ahead: model.dynamics.as_ref().map(NaiveDynamics::ahead),
            model,
            iterations: 64,
        })
    }
}

impl ActuatorCompensator for BisectionCompensator {
    fn compensate(&mut self, target: f64) -> Compensated {
        if !target.is_finite() {
            let u = self.model.hysteresis.x[0];
            self.advance_ahead(u);
            self.model.step(u);
            return Compensated {
                u,
                saturated: false,
                fault: true,
            };
        }
        let c = self.model.creep.as_ref().map_or(0.0, NaiveCreep::output);
        let h = &self.model.hysteresis;
        // S[H(v) + C_k] = ς_k − offset; without S, H(v) = ς_k − offset − C_k
        let s = self.model.superposition.as_ref();
        // G's input that gives the target (ρ samples later)
        let t = match &self.ahead {
            Some(g) => g.input_for(target - self.model.offset).0,
            None => target - self.model.offset,
        };
        let goal = match s {
            Some(_) => t,
            None => t - c,
        };
        let h = Forward { h, c, s };
        // A bracket: the limits, or where they are infinite, doubling steps
        // away from the last input (the state of the play with r = 0).
        let centre = h.h.x.first().copied().unwrap_or(0.0);
        let mut lo = self.settings.lower_limit;
        if !lo.is_finite() {
            let mut width = 1.0f64;
            lo = centre - width;
            while h.evaluate(lo) > goal && width < 1e300 {
                width *= 2.0;
                lo = centre - width;
            }
        }
        let mut hi = self.settings.upper_limit;
        if !hi.is_finite() {
            let mut width = 1.0f64;
            hi = centre + width;
            while h.evaluate(hi) < goal && width < 1e300 {
                width *= 2.0;
                hi = centre + width;
            }
        }
        let (u, saturated) = if h.evaluate(lo) > goal {
            (lo, true)
        } else if h.evaluate(hi) < goal {
            (hi, true)
        } else {
            for _ in 0..self.iterations {
                let mid = 0.5 * (lo + hi);
                if mid <= lo || mid >= hi {
                    break;
                }
                if h.evaluate(mid) < goal {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            // the end of the final bracket whose output is nearer the goal
            if (h.evaluate(lo) - goal).abs() <= (h.evaluate(hi) - goal).abs() {
                (lo, false)
            } else {
                (hi, false)
            }
        };
        self.advance_ahead(u);
        self.model.step(u);
        Compensated {
            u,
            saturated,
            fault: false,
        }
    }

    fn delay(&self) -> usize {
        let lag = self
            .model
            .dynamics
            .as_ref()
            .map_or(0, |g| usize::from(g.lag.is_some()));
        self.model.delay + lag
    }

    fn reset(&mut self) {
        self.model = self.initial.clone();
        self.model.reset();
        if let Some(g) = &mut self.ahead {
            g.reset();
        }
    }
}

impl BisectionCompensator {
    /// The lag-ahead `G` advanced with what the plant makes of `u` (before
    /// the model steps: its creep output is this sample's).
    fn advance_ahead(&mut self, u: f64) {
        let Some(g) = &mut self.ahead else { return };
        let c = self.model.creep.as_ref().map_or(0.0, NaiveCreep::output);
        let z = self.model.hysteresis.evaluate(u) + c;
        let w = match &self.model.superposition {
            Some(s) => s.evaluate(z),
            None => z,
        };
        g.push_input(w);
    }
}
