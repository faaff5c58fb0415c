//! The PI hysteresis operator (10) with the discrete play (20), and `H⁻¹`
//! by the direct sums of (22), textbook form.

use super::naive_parts;
use crate::error::ModelError;
use crate::operators::model::ModelFile;
use crate::operators::traits::{InverseHysteresis, Operator};

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

/// `H⁻¹` of a model file's hysteresis part with its state, by the direct
/// sums of (22).
pub fn naive_inverse_hysteresis(file: &ModelFile) -> Result<NaiveHysteresis, ModelError> {
    Ok(naive_parts(file)?.0.inverse())
}
