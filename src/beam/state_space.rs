//! The beam as state-space matrices in `nalgebra`, for control engineers who
//! design their own controller or observer around the model.
//!
//! With `x = (η, η̇)` of a [`ModalModel`] (`2n` states for `n` modes):
//!
//! ```text
//! ẋ = A x + B w,   A = [[0, I], [−Ω², −D]],   B = [0; Vᵀb],   y = Cᵀ x,   C = [Vᵀc; 0]
//! ```
//!
//! `w` is the effective voltage (the output of `W`), `y` the tip deflection.
//! The zero-order-hold discretization at `T_s` is exact:
//! `x_{k+1} = Φ x_k + Γ w_k`, `y_k = Cᵀ x_k`, with `Φ = e^{A T_s}` and
//! `Γ = ∫₀^{T_s} e^{As} ds B`, both read off one matrix exponential
//! `exp([[A, B], [0, 0]] T_s) = [[Φ, Γ], [0, 1]]` (Van Loan), which nalgebra
//! evaluates by scaling and squaring with Padé approximants. The simulation
//! ([`crate::beam::simulation::DiscreteBeam`]) discretizes the same model
//! through the complex diagonal form instead: the two are independent, and
//! `verification/beam.rs` checks that they agree.

use nalgebra::{DMatrix, DVector};

use crate::beam::modal::ModalModel;
use crate::beam::BeamError;

/// `ẋ = A x + B w`, `y = cᵀ x` (continuous) or `x_{k+1} = A x_k + B w_k`,
/// `y_k = cᵀ x_k` (discrete); no feedthrough.
#[derive(Debug, Clone, PartialEq)]
pub struct StateSpace {
    pub a: DMatrix<f64>,
    pub b: DVector<f64>,
    pub c: DVector<f64>,
    /// `None` for continuous time, `Some(T_s)` for the sampled model.
    pub sample_time: Option<f64>,
}

impl StateSpace {
    /// Number of states `2n`.
    pub fn order(&self) -> usize {
        self.b.len()
    }

    /// The static gain `y/w` at rest: `−cᵀ A⁻¹ B` (continuous) or
    /// `cᵀ (I − A)⁻¹ B` (discrete); `None` if the matrix is singular.
    pub fn static_gain(&self) -> Option<f64> {
        let n = self.order();
        let m = match self.sample_time {
            None => -self.a.clone(),
            Some(_) => DMatrix::identity(n, n) - &self.a,
        };
        let x = m.lu().solve(&self.b)?;
        Some(self.c.dot(&x))
    }

    /// Simulate a discrete model from `x_0 = 0`: `y_k = cᵀ x_k`, then advance
    /// with `w_k` (the convention of the simulation: the output before the
    /// input acts).
    pub fn simulate(&self, w: &[f64]) -> Vec<f64> {
        let mut x = DVector::zeros(self.order());
        w.iter()
            .map(|&wk| {
                let y = self.c.dot(&x);
                x = &self.a * &x + &self.b * wk;
                y
            })
            .collect()
    }
}

impl ModalModel {
    /// The continuous state-space matrices `(A, B, C)`.
    pub fn state_space(&self) -> StateSpace {
        let n = self.len();
        let mut a = DMatrix::zeros(2 * n, 2 * n);
        let mut b = DVector::zeros(2 * n);
        let mut c = DVector::zeros(2 * n);
        for i in 0..n {
            a[(i, n + i)] = 1.0;
            a[(n + i, i)] = -self.omega[i] * self.omega[i];
            for j in 0..n {
                a[(n + i, n + j)] = -self.damping_at(i, j);
            }
            b[n + i] = self.input[i];
            c[i] = self.output[i];
        }
        StateSpace {
            a,
            b,
            c,
            sample_time: None,
        }
    }

    /// The exact zero-order-hold discretization `(Φ, Γ, C)` at `sample_time`.
    pub fn discrete_state_space(&self, sample_time: f64) -> Result<StateSpace, BeamError> {
        if !(sample_time.is_finite() && sample_time > 0.0) {
            return Err(BeamError::InvalidSetting {
                field: "sample_time",
                reason: format!("must be a finite number > 0, found {sample_time}"),
            });
        }
        let continuous = self.state_space();
        let n = continuous.order();
        let mut m = DMatrix::zeros(n + 1, n + 1);
        m.view_mut((0, 0), (n, n))
            .copy_from(&(&continuous.a * sample_time));
        m.view_mut((0, n), (n, 1))
            .copy_from(&(&continuous.b * sample_time));
        let e = m.exp();
        Ok(StateSpace {
            a: e.view((0, 0), (n, n)).into_owned(),
            b: e.view((0, n), (n, 1)).column(0).into_owned(),
            c: continuous.c,
            sample_time: Some(sample_time),
        })
    }
}
