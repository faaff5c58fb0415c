//! The PI creep operator (16) over log(t)-creep operators (15), each
//! stepped exactly over a sample (20), textbook form.

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

    pub(super) fn reset(&mut self) {
        for row in &mut self.chi {
            row.iter_mut().for_each(|c| *c = 0.0);
        }
    }
}
