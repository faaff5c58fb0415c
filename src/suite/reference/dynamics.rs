//! The linear dynamics `G` as a chain of all-pole sections, textbook form.

use std::collections::VecDeque;

use crate::operators::model::ModelFile;

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
