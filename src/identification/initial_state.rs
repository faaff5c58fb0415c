//! The unknown memory at the start of a record: the play states, creep
//! states, the state of `G` and the output offset of a fixed model,
//! estimated from the record's first samples (`docs/MATHEMATICS.md`, "The
//! unknown initial memory").
//!
//! A play started in `x` is, at every sample, a clamp of `x` between two
//! bounds that the input alone sets: `p_k(x) = clamp(x, a_k, b_k)`, with
//! `[a_k, b_k]` the play's outputs from its lowest and highest possible
//! states, nested and shrinking until the input wipes the memory out
//! (`a_k = b_k`). So `p_k` is piecewise linear in `x`, slope 1 while the
//! play has not moved and 0 after; a creep element (13) is piecewise linear
//! in its initial value too (slope `Π (1 − g)` over the samples it moved
//! on); `S` is piecewise linear, `G` linear in its input and its state. The
//! model output is piecewise linear in the unknowns, the squared error
//! piecewise quadratic, and its one-sided derivatives exact.
//!
//! The unknowns, each within bounds the operators set:
//! - the play states as differences `d_i = x_i − x_{i−1}` from the first
//!   input `v_0` on (`x_0 = v_0`: the play of threshold 0 is its input),
//!   `|d_i| ≤ r_i − r_{i−1}`: exactly the states some history ending at
//!   `v_0` leaves (1-Lipschitz in `r`, within `r_i` of `v_0`);
//! - per creep eigenvalue, the state at the first creep threshold and the
//!   differences along the thresholds, `|χ_ij − χ_{i−1,j}| ≤ r_i − r_{i−1}`:
//!   the creep dynamics keep that bound from the zero state on, so every
//!   history leaves it;
//! - the state of `G` as its deviation from rest on its first input, and
//!   the offset, free.
//!
//! The method: rounds of a coordinate search over the play differences
//! (a grid and shrinking steps either side, the offset refitted with each:
//! it steps across the kinks where a play just meets the input, which the
//! one-sided slopes cannot see past) and a Levenberg–Marquardt descent
//! whose damped steps solve the box-constrained linear problem exactly
//! (bounded-variable least squares), accepting a step, or half or a
//! quarter of it, only when it lowers the error. The error falls
//! monotonically; a round ends when the steps stall (ten of them together
//! move the RMS error by less than 0.05 %) and the estimate when a search
//! finds nothing.
//!
//! What the window does not show (a play the input never moved) stays at
//! the prior (the model file's state, or virgin), moved only as far as the
//! output level asks: [`StateEstimate::unwiped`] names those plays.

use super::settings::{check_record_signals, IdentificationError};
use crate::operators::heap::Heap;
use crate::operators::model::{HysteresisCreepModel, ModelFile};
use crate::operators::play::play;
use crate::realtime::creep::creep_gain;
use crate::realtime::{Dynamics, DynamicsParameters, Superposition};

/// What [`estimate_state`] estimates, and from which samples.
#[derive(Debug, Clone, PartialEq)]
pub struct StateSettings {
    /// The estimation window: samples `0..until` (default: the whole
    /// record).
    pub until: Option<usize>,
    /// Estimate the output offset (default true); else keep the model's.
    pub fit_offset: bool,
    /// Estimate the creep states (default true); else keep the model's
    /// (zero when it has none).
    pub fit_creep: bool,
    /// Estimate the state of `G` (default true): what its past input left
    /// ringing; else `G` starts at rest on its first input.
    pub fit_dynamics: bool,
    /// Descent iterations at most (default 100).
    pub max_iterations: usize,
}

impl Default for StateSettings {
    fn default() -> Self {
        Self {
            until: None,
            fit_offset: true,
            fit_creep: true,
            fit_dynamics: true,
            max_iterations: 100,
        }
    }
}

impl StateSettings {
    /// Checked against a record of `samples` samples.
    pub fn validate(&self, samples: usize) -> Result<(), IdentificationError> {
        let until = self.until.unwrap_or(samples);
        if until < 2 || until > samples {
            return Err(IdentificationError::InvalidSetting {
                field: "until",
                reason: format!(
                    "the estimation window must hold 2 to {samples} samples (the record's), not {until}"
                ),
            });
        }
        if self.max_iterations == 0 {
            return Err(IdentificationError::InvalidSetting {
                field: "max_iterations",
                reason: "must be at least 1".into(),
            });
        }
        Ok(())
    }
}

/// The estimated memory of a record.
#[derive(Debug, Clone, PartialEq)]
pub struct StateEstimate {
    /// The model in the estimated state at the record's first sample: the
    /// play and creep states, the state of `G` and the offset (the dead
    /// time fills with its first output, as a model not started does).
    pub model: ModelFile,
    /// Samples of the window.
    pub window: usize,
    /// RMS error over the window from the prior (the model's own states,
    /// moved into the first input's band, and its offset) and from the
    /// estimate.
    pub prior_rms: f64,
    pub rms: f64,
    /// Plays whose memory the window did not wipe out, by index: their
    /// states after the window still depend on the estimate's level alone.
    pub unwiped: Vec<usize>,
    /// Descent steps taken (the settings' limit: stopped by it).
    pub iterations: usize,
}

impl StateEstimate {
    /// The model in its state at the end of the window (after `u[..window]`):
    /// where a compensator started up by a short excitation continues.
    pub fn model_after_window(&self, u: &[f64]) -> Result<ModelFile, IdentificationError> {
        let mut model = HysteresisCreepModel::from_file(&self.model)?;
        for &v in &u[..self.window.min(u.len())] {
            model.step(v);
        }
        Ok(model.to_file())
    }
}

/// Estimate the memory of `model` at the start of the record `(u, y)` from
/// its window (module docs). The model's parameters stay as they are.
pub fn estimate_state(
    model: &ModelFile,
    u: &[f64],
    y: &[f64],
    settings: &StateSettings,
) -> Result<StateEstimate, IdentificationError> {
    check_record_signals(u, y)?;
    settings.validate(u.len())?;
    // the model checked once, here
    let prior = HysteresisCreepModel::from_file(model)?;
    let window = settings.until.unwrap_or(u.len());
    let problem = Problem::new(&prior, model, &u[..window], &y[..window], settings);
    let start = problem.start(&prior);
    let prior_cost = problem.cost(&start, &mut Work::new(&problem, false));
    let (theta, iterations) = problem.solve(start, settings.max_iterations);
    let mut work = Work::new(&problem, false);
    let cost = problem.cost(&theta, &mut work);
    let unwiped = (1..problem.plays())
        .filter(|&i| work.alive[i])
        .collect::<Vec<_>>();
    let rms = |c: f64| (c / window as f64).sqrt();
    Ok(StateEstimate {
        model: problem.model_file(model, &theta, work.s[0]),
        window,
        prior_rms: rms(prior_cost),
        rms: rms(cost),
        unwiped,
        iterations,
    })
}

/// The record's window and the model's parts, in the form the simulation
/// and its derivatives take.
struct Problem<'a> {
    u: &'a [f64],
    y: &'a [f64],
    r: Vec<f64>,
    w: Vec<f64>,
    /// `g = β/T_s` of rate-dependent thresholds (0: none)
    rate_gain: f64,
    /// creep: thresholds, `w_i / m`, gains `1 − e^{−aT_s}`; `m`
    creep_r: Vec<f64>,
    creep_w: Vec<f64>,
    gains: Vec<f64>,
    /// `S` (none: the identity)
    superposition: Option<Superposition<f64, Heap>>,
    dynamics: Option<(DynamicsParameters, f64)>,
    delay: usize,
    /// unknowns: `d_1..d_{n−1}`, then the creep states, the deviation of
    /// `G`'s state from rest on its first input, the offset: each block
    /// only if fitted, its first position here
    lower: Vec<f64>,
    upper: Vec<f64>,
    creep_at: Option<usize>,
    dynamics_at: Option<usize>,
    offset_at: Option<usize>,
    dynamics_len: usize,
    /// the creep state and offset when they are not fitted
    creep_fixed: Vec<f64>,
    offset_fixed: f64,
}

/// Buffers of one simulation.
struct Work {
    out: Vec<f64>,
    /// `∂ŷ/∂θ`, column-major (`cols × K`), when asked for
    jac: Vec<f64>,
    x: Vec<f64>,
    alive: Vec<bool>,
    chi: Vec<f64>,
    dchi: Vec<f64>,
    s: Vec<f64>,
}

impl Work {
    fn new(p: &Problem, jacobian: bool) -> Self {
        let k = p.u.len();
        let n = p.plays();
        Self {
            out: vec![0.0; k],
            jac: if jacobian {
                vec![0.0; p.unknowns().max(n) * k + n * k]
            } else {
                Vec::new()
            },
            x: vec![0.0; n],
            alive: vec![true; n],
            chi: vec![0.0; p.creep_r.len() * p.gains.len()],
            dchi: vec![1.0; p.creep_r.len() * p.gains.len()],
            s: vec![0.0; k],
        }
    }
}

impl<'a> Problem<'a> {
    fn new(
        model: &HysteresisCreepModel,
        file: &ModelFile,
        u: &'a [f64],
        y: &'a [f64],
        settings: &StateSettings,
    ) -> Self {
        let h = model.hysteresis();
        let r = h.thresholds().to_vec();
        let (creep_r, creep_w, gains) = match model.creep() {
            Some(c) => {
                let m = c.eigenvalues().len() as f64;
                (
                    c.thresholds().to_vec(),
                    c.weights().iter().map(|w| w / m).collect(),
                    c.eigenvalues()
                        .iter()
                        .map(|&a| creep_gain(a, model.sample_time()))
                        .collect::<Vec<f64>>(),
                )
            }
            None => (Vec::new(), Vec::new(), Vec::new()),
        };

        let fit_creep = settings.fit_creep && !creep_r.is_empty();
        let dynamics_len = match model.dynamics() {
            Some(g) if settings.fit_dynamics => g.state_len(),
            _ => 0,
        };
        let mut lower = Vec::new();
        let mut upper = Vec::new();
        for i in 1..r.len() {
            lower.push(-(r[i] - r[i - 1]));
            upper.push(r[i] - r[i - 1]);
        }
        let creep_at = fit_creep.then_some(lower.len());
        if fit_creep {
            // per threshold and eigenvalue (`i * m + j`): the level at the
            // first threshold, then differences bounded by the thresholds'
            for i in 0..creep_r.len() {
                for _ in &gains {
                    let step = if i == 0 {
                        f64::INFINITY
                    } else {
                        creep_r[i] - creep_r[i - 1]
                    };
                    lower.push(-step);
                    upper.push(step);
                }
            }
        }
        let dynamics_at = (dynamics_len > 0).then_some(lower.len());
        let offset_at = settings.fit_offset.then_some(lower.len() + dynamics_len);
        for _ in 0..dynamics_len + usize::from(settings.fit_offset) {
            lower.push(f64::NEG_INFINITY);
            upper.push(f64::INFINITY);
        }
        Self {
            u,
            y,
            w: h.weights().to_vec(),
            r,
            rate_gain: model.rate_gain().map_or(0.0, |rate| rate.gain()),
            creep_fixed: file
                .creep_state_flat()
                .ok()
                .flatten()
                .unwrap_or_else(|| vec![0.0; creep_r.len() * gains.len()]),
            creep_r,
            creep_w,
            gains,
            superposition: model.superposition().cloned(),
            dynamics: model
                .dynamics()
                .map(|g| (*g.parameters(), model.sample_time())),
            delay: model.delay(),
            lower,
            upper,
            creep_at,
            dynamics_at,
            offset_at,
            dynamics_len,
            offset_fixed: model.offset(),
        }
    }

    fn plays(&self) -> usize {
        self.r.len()
    }

    fn unknowns(&self) -> usize {
        self.lower.len()
    }

    fn creep_len(&self) -> usize {
        self.creep_r.len() * self.gains.len()
    }

    /// The prior as unknowns: the model's play states moved into the band
    /// of the first input as (8) does, its creep states clamped to their
    /// bounds, its offset.
    fn start(&self, model: &HysteresisCreepModel) -> Vec<f64> {
        let v0 = self.u[0];
        let x: Vec<f64> = model
            .hysteresis()
            .play_states()
            .iter()
            .zip(&self.r)
            .map(|(&x, &r)| play(v0, r, x))
            .collect();
        let mut theta: Vec<f64> = (1..x.len()).map(|i| x[i] - x[i - 1]).collect();
        if self.creep_at.is_some() {
            let m = self.gains.len();
            for i in 0..self.creep_r.len() {
                for j in 0..m {
                    let c = self.creep_fixed[i * m + j];
                    theta.push(if i == 0 {
                        c
                    } else {
                        c - self.creep_fixed[(i - 1) * m + j]
                    });
                }
            }
        }
        theta.extend(std::iter::repeat_n(0.0, self.dynamics_len));
        if self.offset_at.is_some() {
            theta.push(self.offset_fixed);
        }
        self.project(&mut theta);
        theta
    }

    fn project(&self, theta: &mut [f64]) {
        for ((t, &lo), &hi) in theta.iter_mut().zip(&self.lower).zip(&self.upper) {
            *t = t.clamp(lo, hi);
        }
    }

    fn offset(&self, theta: &[f64]) -> f64 {
        self.offset_at.map_or(self.offset_fixed, |c| theta[c])
    }

    /// The creep states of their unknowns: per eigenvalue, the level at
    /// the first threshold and the differences.
    fn creep_start(&self, unknowns: &[f64], chi: &mut [f64]) {
        let m = self.gains.len();
        for c in 0..unknowns.len() {
            chi[c] = unknowns[c] + if c >= m { chi[c - m] } else { 0.0 };
        }
    }

    /// `G`'s state: at rest on `s0`, moved by the fitted deviation.
    fn dynamics_state(&self, theta: &[f64], s0: f64) -> Vec<f64> {
        let deviation = match self.dynamics_at {
            Some(c) => &theta[c..c + self.dynamics_len],
            None => &[][..],
        };
        (0..self.dynamics_len)
            .map(|l| s0 + deviation.get(l).copied().unwrap_or(0.0))
            .collect()
    }

    /// The model output over the window into `work.out`, and with
    /// `work.jac` non-empty its derivatives by the unknowns.
    fn simulate(&self, theta: &[f64], work: &mut Work) {
        let k_len = self.u.len();
        let n = self.plays();
        let m = self.gains.len().max(1);
        let jacobian = !work.jac.is_empty();
        let v0 = self.u[0];
        work.x[0] = v0;
        for i in 1..n {
            work.x[i] = work.x[i - 1] + theta[i - 1];
        }
        work.alive.fill(true);
        match self.creep_at {
            Some(at) => self.creep_start(&theta[at..at + self.creep_len()], &mut work.chi),
            None => work.chi.copy_from_slice(&self.creep_fixed),
        }
        work.dchi.fill(1.0);
        // the raw columns: ∂S/∂x_i (plays, `n` of them, after the unknowns'
        // block) and ∂S/∂χ (creep, in the unknowns' block)
        let cols = self.unknowns().max(n);
        let (jac, play_cols) = work
            .jac
            .split_at_mut(if jacobian { cols * k_len } else { 0 });
        for k in 0..k_len {
            let v = self.u[k];
            // the thresholds' widening by the rate, none at the first
            // sample (the model's, started there)
            let widening = match k {
                0 => 0.0,
                _ => self.rate_gain * (v - self.u[k - 1]).abs(),
            };
            let mut z = 0.0;
            for i in 0..n {
                let p = play(v, self.r[i] + widening, work.x[i]);
                work.alive[i] &= p == work.x[i];
                work.x[i] = p;
                z += self.w[i] * p;
            }
            for i in 0..self.creep_r.len() {
                let mut row = 0.0;
                for j in 0..self.gains.len() {
                    row += work.chi[i * m + j];
                }
                z += self.creep_w[i] * row;
            }
            let slope = if jacobian { self.s_slope(z) } else { 0.0 };
            work.s[k] = self.s_apply(z);
            if jacobian {
                for i in 1..n {
                    play_cols[i * k_len + k] = if work.alive[i] {
                        slope * self.w[i]
                    } else {
                        0.0
                    };
                }
                if let Some(at) = self.creep_at {
                    for i in 0..self.creep_r.len() {
                        for j in 0..self.gains.len() {
                            let c = at + i * m + j;
                            jac[c * k_len + k] = slope * self.creep_w[i] * work.dchi[i * m + j];
                        }
                    }
                }
            }
            // the creep moves with `v_k` after its output (13)
            for i in 0..self.creep_r.len() {
                let r = self.creep_r[i];
                for j in 0..self.gains.len() {
                    let c = &mut work.chi[i * m + j];
                    let e = v - *c;
                    let dz = (e - r).max((e + r).min(0.0));
                    if dz != 0.0 {
                        work.dchi[i * m + j] *= 1.0 - self.gains[j];
                    }
                    *c += self.gains[j] * dz;
                }
            }
        }
        let offset = self.offset(theta);
        let state = self.dynamics_state(theta, work.s[0]);
        self.filter(
            &work.s,
            &mut work.out,
            (!state.is_empty()).then_some(&state[..]),
        );
        for o in &mut work.out {
            *o += offset;
        }
        if jacobian {
            // x_i = v_0 + Σ_{l≤i} d_l: ∂/∂d_l = Σ_{i≥l} ∂/∂x_i
            for i in (1..n - 1).rev() {
                let (head, tail) = play_cols.split_at_mut((i + 1) * k_len);
                for (a, b) in head[i * k_len..].iter_mut().zip(&tail[..k_len]) {
                    *a += b;
                }
            }
            let mut column = vec![0.0; k_len];
            for l in 1..n {
                column.copy_from_slice(&play_cols[l * k_len..(l + 1) * k_len]);
                self.filter(&column, &mut jac[(l - 1) * k_len..l * k_len], None);
            }
            if let Some(at) = self.creep_at {
                // χ_ij = c_j + Σ_{l≤i} e_lj: ∂/∂e_lj = Σ_{i≥l} ∂/∂χ_ij
                for c in (at..at + self.creep_len() - m).rev() {
                    let (head, tail) = jac.split_at_mut((c + m) * k_len);
                    for (x, y) in head[c * k_len..(c + 1) * k_len]
                        .iter_mut()
                        .zip(&tail[..k_len])
                    {
                        *x += y;
                    }
                }
                for c in at..at + self.creep_len() {
                    column.copy_from_slice(&jac[c * k_len..(c + 1) * k_len]);
                    self.filter(&column, &mut jac[c * k_len..(c + 1) * k_len], None);
                }
            }
            if let Some(at) = self.dynamics_at {
                // `G` from the unit state, no input: its free response
                column.fill(0.0);
                let mut unit = vec![0.0; self.dynamics_len];
                for l in 0..self.dynamics_len {
                    unit.fill(0.0);
                    unit[l] = 1.0;
                    let c = at + l;
                    self.filter(&column, &mut jac[c * k_len..(c + 1) * k_len], Some(&unit));
                }
            }
            if let Some(c) = self.offset_at {
                jac[c * k_len..(c + 1) * k_len].fill(1.0);
            }
        }
    }

    /// `G` from `state` (`None`: from rest on its first input), then the
    /// dead time: linear in the input and the state together, so the same
    /// map takes a signal and a derivative column.
    fn filter(&self, s: &[f64], out: &mut [f64], state: Option<&[f64]>) {
        match self.dynamics {
            Some((parameters, ts)) => {
                let mut g = Dynamics::<f64>::new(&parameters, ts)
                    .expect("the parameters came from a checked model");
                g.set_state(state)
                    .expect("a state of the length G takes, finite");
                for (o, &v) in out.iter_mut().zip(s) {
                    *o = g.step(v);
                }
            }
            None => out.copy_from_slice(s),
        }
        let d = self.delay.min(out.len());
        if d > 0 {
            out.copy_within(..out.len() - d, d);
            let first = out[d];
            out[..d].fill(first);
        }
    }

    fn s_apply(&self, z: f64) -> f64 {
        self.superposition.as_ref().map_or(z, |s| s.apply(z))
    }

    /// The slope of `S` at `z` (its right-hand one at a kink).
    fn s_slope(&self, z: f64) -> f64 {
        let Some(s) = &self.superposition else {
            return 1.0;
        };
        s.thresholds()
            .iter()
            .zip(s.weights())
            .filter(|&(&r, _)| r == 0.0 || (r > 0.0 && z >= r) || (r < 0.0 && z < r))
            .map(|(_, &w)| w)
            .sum()
    }

    /// `Σ (y − ŷ)²` over the window.
    fn cost(&self, theta: &[f64], work: &mut Work) -> f64 {
        self.simulate(theta, work);
        work.out
            .iter()
            .zip(self.y)
            .map(|(o, y)| (y - o) * (y - o))
            .sum()
    }

    /// Rounds of a coordinate search over the play differences and the
    /// projected Levenberg–Marquardt descent, until a search finds nothing.
    fn solve(&self, mut theta: Vec<f64>, max_iterations: usize) -> (Vec<f64>, usize) {
        let mut plain = Work::new(self, false);
        let mut cost = self.cost(&theta, &mut plain);
        let mut iterations = 0;
        for round in 0..ROUNDS {
            let moved = self.search(&mut theta, &mut cost, &mut plain);
            if round > 0 && !moved {
                break;
            }
            iterations += self.descend(&mut theta, &mut cost, max_iterations - iterations);
            if iterations >= max_iterations {
                break;
            }
        }
        (theta, iterations)
    }

    /// One pass over the play differences, from the largest threshold
    /// down, each tried on a grid over its interval and at steps of
    /// `Δr/2 … Δr/32` either side (the offset refitted with each: the mean
    /// error). The descent's one-sided slopes cannot see past a kink where
    /// a play only just meets the input; a step across it can. Whether it
    /// lowered the cost.
    fn search(&self, theta: &mut [f64], cost: &mut f64, plain: &mut Work) -> bool {
        let k_len = self.y.len() as f64;
        let mut moved = false;
        for l in (0..self.plays() - 1).rev() {
            let (lo, hi) = (self.lower[l], self.upper[l]);
            let width = hi - lo;
            let here = theta[l];
            let grid = (0..=8).map(|j| lo + width * j as f64 / 8.0);
            let steps = (1..=5).flat_map(|j| {
                let h = 0.5 * width / f64::from(1 << j);
                [here - h, here + h]
            });
            for value in grid.chain(steps) {
                let value = value.clamp(lo, hi);
                if value == theta[l] {
                    continue;
                }
                let mut trial = theta.to_vec();
                trial[l] = value;
                self.simulate(&trial, plain);
                let (sum, squares) = self
                    .y
                    .iter()
                    .zip(&plain.out)
                    .fold((0.0, 0.0), |(s, q), (y, o)| {
                        (s + (y - o), q + (y - o) * (y - o))
                    });
                // the best offset moves by the mean error and takes `K m²` off
                let c = match self.offset_at {
                    Some(at) => {
                        trial[at] += sum / k_len;
                        squares - sum * sum / k_len
                    }
                    None => squares,
                };
                if c < *cost * (1.0 - 1e-12) {
                    theta.copy_from_slice(&trial);
                    *cost = c;
                    moved = true;
                }
            }
        }
        moved
    }

    /// The projected Levenberg–Marquardt descent from `theta`, at most
    /// `max_iterations` steps; the steps taken.
    fn descend(&self, theta: &mut Vec<f64>, cost: &mut f64, max_iterations: usize) -> usize {
        let mut plain = Work::new(self, false);
        let k_len = self.u.len();
        let p = self.unknowns();
        let mut work = Work::new(self, true);
        let mut lambda = 1e-3;
        let mut iterations = 0;
        let mut fresh = true;
        let mut normal = vec![0.0; p * p];
        let mut gradient = vec![0.0; p];
        let mut history = vec![*cost];
        while iterations < max_iterations && p > 0 {
            if fresh {
                self.simulate(theta, &mut work);
                let e: Vec<f64> = self.y.iter().zip(&work.out).map(|(y, o)| y - o).collect();
                // JᵀJ and Jᵀe, column by column (a few dozen unknowns)
                let col = |c: usize| &work.jac[c * k_len..(c + 1) * k_len];
                for a in 0..p {
                    gradient[a] = dot(col(a), &e);
                    for b in 0..=a {
                        let v = dot(col(a), col(b));
                        normal[a * p + b] = v;
                        normal[b * p + a] = v;
                    }
                }
                fresh = false;
            }
            iterations += 1;
            // the damped step within the bounds, exactly (a box-constrained
            // quadratic program on the normal equations)
            let live: Vec<usize> = (0..p).filter(|&a| normal[a * p + a] > 0.0).collect();
            if live.is_empty() {
                break;
            }
            let largest = live
                .iter()
                .map(|&a| normal[a * p + a])
                .fold(0.0f64, f64::max);
            let f = live.len();
            let mut a = vec![0.0; f * f];
            let mut b = vec![0.0; f];
            let mut low = vec![0.0; f];
            let mut high = vec![0.0; f];
            for (ia, &ga) in live.iter().enumerate() {
                b[ia] = gradient[ga];
                low[ia] = self.lower[ga] - theta[ga];
                high[ia] = self.upper[ga] - theta[ga];
                for (ib, &gb) in live.iter().enumerate() {
                    a[ia * f + ib] = normal[ga * p + gb];
                }
                a[ia * f + ia] += lambda * (normal[ga * p + ga] + 1e-12 * largest);
            }
            let Some(step) = box_step(&a, &b, &low, &high) else {
                lambda *= 4.0;
                if lambda > 1e16 {
                    break;
                }
                continue;
            };
            if step.iter().all(|&d| d == 0.0) {
                break;
            }
            let free = live;
            // the step, else shorter ones along it: past a kink the linear
            // model no longer holds, short of it it does
            let mut accepted = None;
            for (tries, scale) in [1.0, 0.5, 0.25].into_iter().enumerate() {
                let mut trial = theta.clone();
                for (ia, &ga) in free.iter().enumerate() {
                    trial[ga] += scale * step[ia];
                }
                self.project(&mut trial);
                let c = self.cost(&trial, &mut plain);
                if c < *cost {
                    accepted = Some((trial, c, tries));
                    break;
                }
            }
            match accepted {
                Some((trial, c, tries)) => {
                    let gain = *cost - c;
                    (*theta, *cost) = (trial, c);
                    if tries == 0 {
                        lambda = (lambda / 3.0).max(1e-12);
                    }
                    fresh = true;
                    history.push(*cost);
                    // ten steps that together move the RMS error by less
                    // than 0.05 %: a crawl along a valley of unknowns the
                    // window hardly tells apart
                    if gain <= 1e-12 * *cost
                        || (history.len() > 10
                            && history[history.len() - 11] - *cost < 1e-3 * *cost)
                    {
                        break;
                    }
                }
                None => {
                    lambda *= 4.0;
                    if lambda > 1e16 {
                        break;
                    }
                }
            }
        }
        iterations
    }

    /// `file` with the estimated state (and offset) in it.
    fn model_file(&self, file: &ModelFile, theta: &[f64], s0: f64) -> ModelFile {
        let n = self.plays();
        let mut out = file.clone().without_state();
        let mut x = vec![self.u[0]; n];
        for i in 1..n {
            x[i] = x[i - 1] + theta[i - 1];
        }
        out.hysteresis.state = Some(x.clone());
        if let Some(c) = &mut out.creep {
            let m = self.gains.len();
            let mut chi = self.creep_fixed.clone();
            if let Some(at) = self.creep_at {
                self.creep_start(&theta[at..at + self.creep_len()], &mut chi);
            }
            c.state = Some(chi.chunks(m).map(<[f64]>::to_vec).collect());
        }
        if let (Some(g), Some(_)) = (&mut out.dynamics, self.dynamics_at) {
            g.state = Some(self.dynamics_state(theta, s0));
        }
        let offset = self.offset(theta);
        out.offset = (offset != 0.0).then_some(offset);
        out
    }
}

/// `Σ a_k b_k` in four lanes (which the compiler keeps in registers).
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let mut lanes = [0.0; 4];
    let (a4, b4) = (a.chunks_exact(4), b.chunks_exact(4));
    let tail: f64 = a4
        .remainder()
        .iter()
        .zip(b4.remainder())
        .map(|(x, y)| x * y)
        .sum();
    for (x, y) in a4.zip(b4) {
        for l in 0..4 {
            lanes[l] += x[l] * y[l];
        }
    }
    (lanes[0] + lanes[1]) + (lanes[2] + lanes[3]) + tail
}

/// Rounds of search and descent at most.
const ROUNDS: usize = 6;

/// `min ½ zᵀ a z − bᵀ z` subject to `low ≤ z ≤ high` (`low ≤ 0 ≤ high`)
/// for a symmetric positive definite `a` (row major): the primal active-set
/// method of bounded-variable least squares (Stark & Parker 1995). From
/// `z = 0` it solves on the free variables, steps back to the first bound
/// the solution crosses and holds that variable there, and frees a held one
/// whose multiplier points into the box; it ends at the KKT point. `None`
/// if a free block is not positive definite.
fn box_step(a: &[f64], b: &[f64], low: &[f64], high: &[f64]) -> Option<Vec<f64>> {
    let f = b.len();
    let mut z = vec![0.0; f];
    // held at a bound: those at one whose gradient pushes out of the box
    let mut held: Vec<bool> = (0..f)
        .map(|i| (low[i] >= 0.0 && b[i] < 0.0) || (high[i] <= 0.0 && b[i] > 0.0))
        .collect();
    for _ in 0..3 * f + 3 {
        let free: Vec<usize> = (0..f).filter(|&i| !held[i]).collect();
        let n = free.len();
        // a_FF z_F = b_F − a_FH z_H
        let mut sub = vec![0.0; n * n];
        let mut rhs = vec![0.0; n];
        for (r, &i) in free.iter().enumerate() {
            rhs[r] = b[i]
                - (0..f)
                    .filter(|&j| held[j])
                    .map(|j| a[i * f + j] * z[j])
                    .sum::<f64>();
            for (c, &j) in free.iter().enumerate() {
                sub[r * n + c] = a[i * f + j];
            }
        }
        let target = cholesky_solve(&mut sub, &rhs, n)?;
        // the longest step towards it that stays in the box
        let mut t = 1.0;
        let mut blocking = None;
        for (r, &i) in free.iter().enumerate() {
            let d = target[r] - z[i];
            let room = if d > 0.0 {
                high[i] - z[i]
            } else if d < 0.0 {
                low[i] - z[i]
            } else {
                continue;
            };
            if room / d < t {
                t = (room / d).max(0.0);
                blocking = Some(i);
            }
        }
        for (r, &i) in free.iter().enumerate() {
            z[i] += t * (target[r] - z[i]);
        }
        if let Some(i) = blocking {
            z[i] = if target[free.iter().position(|&j| j == i)?] > z[i] {
                high[i]
            } else {
                low[i]
            };
            z[i] = z[i].clamp(low[i], high[i]);
            held[i] = true;
            continue;
        }
        // at the optimum of the free block: release the held variable
        // whose gradient points furthest into the box
        let mut release = None;
        let mut best = 0.0;
        for i in (0..f).filter(|&i| held[i]) {
            let g = b[i] - (0..f).map(|j| a[i * f + j] * z[j]).sum::<f64>();
            let inward = if z[i] <= low[i] {
                g
            } else if z[i] >= high[i] {
                -g
            } else {
                g.abs()
            };
            if inward > best {
                best = inward;
                release = Some(i);
            }
        }
        match release {
            Some(i) => held[i] = false,
            None => return Some(z),
        }
    }
    Some(z)
}

/// Solve `a z = b` for a symmetric positive definite `a` (`f × f`, row
/// major, overwritten by its Cholesky factor); `None` if it is not.
fn cholesky_solve(a: &mut [f64], b: &[f64], f: usize) -> Option<Vec<f64>> {
    for j in 0..f {
        let mut d = a[j * f + j];
        for k in 0..j {
            d -= a[j * f + k] * a[j * f + k];
        }
        if d.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            return None;
        }
        let d = d.sqrt();
        a[j * f + j] = d;
        for i in j + 1..f {
            let mut s = a[i * f + j];
            for k in 0..j {
                s -= a[i * f + k] * a[j * f + k];
            }
            a[i * f + j] = s / d;
        }
    }
    let mut z = b.to_vec();
    for i in 0..f {
        for k in 0..i {
            z[i] -= a[i * f + k] * z[k];
        }
        z[i] /= a[i * f + i];
    }
    for i in (0..f).rev() {
        for k in i + 1..f {
            z[i] -= a[k * f + i] * z[k];
        }
        z[i] /= a[i * f + i];
    }
    Some(z)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::operators::model::{DynamicsData, ResonanceData, SuperpositionData};
    use crate::operators::nominal::nominal_model_file;

    /// A seeded xorshift: the tests' random walks.
    struct Rng(u64);

    impl Rng {
        fn new(seed: u64) -> Self {
            Self(seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1)
        }

        fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            lo + (hi - lo) * (self.0 >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// The nominal `H + C` with an asymmetric `S`, a resonance, a low-pass,
    /// a fractional and a whole-sample delay and an offset.
    fn full_model() -> ModelFile {
        let mut m = nominal_model_file();
        m.superposition = Some(SuperpositionData {
            thresholds: vec![-500.0, 0.0, 300.0],
            weights: vec![0.3, 1.0, -0.25],
        });
        m.dynamics = Some(DynamicsData {
            low_pass: Some(LowPassData { frequency: 900.0 }),
            resonance: Some(ResonanceData {
                frequency: 400.0,
                damping: 0.05,
            }),
            delay_fraction: Some(0.3),
            state: None,
        });
        m.delay = Some(3);
        m.offset = Some(12.5);
        m
    }
    use crate::operators::model::LowPassData;

    /// A random walk within ±`a`.
    fn walk(rng: &mut Rng, len: usize, a: f64) -> Vec<f64> {
        let mut v = 0.0;
        (0..len)
            .map(|_| {
                v = (v + rng.uniform(-0.03, 0.03) * a).clamp(-a, a);
                v
            })
            .collect()
    }

    /// The model after a history, its dynamics and dead time at rest again
    /// (as the estimate starts them).
    fn after_history(file: &ModelFile, rng: &mut Rng) -> ModelFile {
        let mut m = HysteresisCreepModel::from_file(file).unwrap();
        for v in walk(rng, 3000, 900.0) {
            m.step(v);
        }
        let mut f = m.to_file();
        if let Some(g) = &mut f.dynamics {
            g.state = None;
        }
        f.delay_state = None;
        f
    }

    /// The full model after a history, a walk of `len` samples to run it
    /// on, and the model built from the file.
    fn case(seed: u64, len: usize) -> (ModelFile, Vec<f64>, HysteresisCreepModel) {
        let mut rng = Rng::new(seed);
        let file = after_history(&full_model(), &mut rng);
        let u = walk(&mut rng, len, 900.0);
        let model = HysteresisCreepModel::from_file(&file).unwrap();
        (file, u, model)
    }

    #[test]
    fn the_simulation_is_the_model_from_the_same_state() {
        let (file, u, model) = case(7, 2000);
        let p = Problem::new(&model, &file, &u, &u, &StateSettings::default());
        let theta = p.start(&model);
        let mut work = Work::new(&p, false);
        p.simulate(&theta, &mut work);
        let mut reference = HysteresisCreepModel::from_file(&file).unwrap();
        let scale = 1000.0;
        for (k, &v) in u.iter().enumerate() {
            let y = reference.step(v);
            // the creep update rounds differently (fused or not): a few
            // ulps of the range per sample, accumulated
            let tolerance = 64.0 * f64::EPSILON * scale * (k + 1) as f64;
            assert!(
                (y - work.out[k]).abs() <= tolerance,
                "sample {k}: {y} against {}",
                work.out[k]
            );
        }
    }

    #[test]
    fn the_derivatives_are_the_difference_quotients() {
        let (file, u, model) = case(11, 1500);
        let p = Problem::new(&model, &file, &u, &u, &StateSettings::default());
        let mut theta = p.start(&model);
        // away from the bounds, where both sides' quotients exist
        for (a, t) in theta.iter_mut().enumerate() {
            if p.lower[a].is_finite() {
                let (lo, hi) = (p.lower[a], p.upper[a]);
                *t = t.clamp(lo + 0.05 * (hi - lo), hi - 0.05 * (hi - lo));
            }
        }
        let k_len = u.len();
        let mut work = Work::new(&p, true);
        p.simulate(&theta, &mut work);
        let (mut plus, mut minus) = (Work::new(&p, false), Work::new(&p, false));
        let h = 1e-6;
        for a in 0..p.unknowns() {
            let mut t = theta.clone();
            t[a] += h;
            p.simulate(&t, &mut plus);
            t[a] -= 2.0 * h;
            p.simulate(&t, &mut minus);
            let column = &work.jac[a * k_len..(a + 1) * k_len];
            // piecewise linear: the quotient is the slope exactly, up to
            // the rounding of outputs of size 1000 (a hundred ulps through
            // the sums and G) divided by 2h, unless a kink lies within h
            // (none at this seed)
            let tolerance = 100.0 * f64::EPSILON * 1000.0 / (2.0 * h);
            for (k, (&slope, (hi, lo))) in column
                .iter()
                .zip(plus.out.iter().zip(&minus.out))
                .enumerate()
            {
                let quotient = (hi - lo) / (2.0 * h);
                assert!(
                    (quotient - slope).abs() <= tolerance,
                    "unknown {a}, sample {k}: {slope} against {quotient}"
                );
            }
        }
    }

    #[test]
    fn bad_windows_and_records_are_refused() {
        let file = nominal_model_file();
        let u = vec![0.0, 1.0, 2.0];
        let settings = |until| StateSettings {
            until: Some(until),
            ..StateSettings::default()
        };
        for until in [0, 1, 4] {
            assert!(matches!(
                estimate_state(&file, &u, &u, &settings(until)),
                Err(IdentificationError::InvalidSetting { field: "until", .. })
            ));
        }
        assert!(matches!(
            estimate_state(&file, &u, &u[..2], &StateSettings::default()),
            Err(IdentificationError::LengthMismatch { .. })
        ));
        assert!(matches!(
            estimate_state(
                &file,
                &[0.0, f64::NAN],
                &[0.0, 0.0],
                &StateSettings::default()
            ),
            Err(IdentificationError::NonFinite { signal: "u", .. })
        ));
    }
}
