//! The discrete algebraic Riccati equation (DARE)
//!
//! ```text
//! X = AᵀXA − AᵀXB (R + BᵀXB)⁻¹ BᵀXA + Q,
//! ```
//!
//! solved for its stabilizing solution by the structured doubling algorithm
//! (Chu, Fan, Lin, Wang 2004): with `A₀ = A`, `G₀ = B R⁻¹ Bᵀ`, `H₀ = Q`,
//!
//! ```text
//! W = I + G_j H_j,   A_{j+1} = A_j W⁻¹ A_j,
//! G_{j+1} = G_j + A_j W⁻¹ G_j A_jᵀ,   H_{j+1} = H_j + A_jᵀ H_j W⁻¹ A_j,
//! ```
//!
//! `H_j → X` quadratically: step `j` sums `2^j` steps of the Riccati
//! recursion. No maintained Rust crate solves the DARE with nalgebra 0.34
//! (the candidates found iterate the recursion step by step, or are
//! ndarray-based), so it is here, with its residual checked on return.

use nalgebra::{DMatrix, DVector};

use super::ControlError;

/// The stabilizing solution `X` of the DARE for one input (`B` a column,
/// `R > 0` a scalar), and the gain `K = (R + BᵀXB)⁻¹ BᵀXA` of `u = −K x`.
#[derive(Debug, Clone, PartialEq)]
pub struct Riccati {
    pub x: DMatrix<f64>,
    pub gain: DVector<f64>,
    /// `‖X − (AᵀXA − AᵀXB(R+BᵀXB)⁻¹BᵀXA + Q)‖_F / ‖X‖_F`.
    pub residual: f64,
    /// Doubling steps taken.
    pub steps: usize,
}

/// Solve the DARE for `(A, b, Q, r)`.
pub fn solve_dare(
    a: &DMatrix<f64>,
    b: &DVector<f64>,
    q: &DMatrix<f64>,
    r: f64,
) -> Result<Riccati, ControlError> {
    let n = a.nrows();
    let bad = |reason: String| ControlError::Design(format!("Riccati equation: {reason}"));
    if a.ncols() != n || b.len() != n || q.shape() != (n, n) {
        return Err(bad("the dimensions of A, B and Q differ".into()));
    }
    if !(r.is_finite() && r > 0.0) {
        return Err(bad(format!("R must be a finite number > 0, found {r}")));
    }
    let finite = |m: &DMatrix<f64>| m.iter().all(|v| v.is_finite());
    if !finite(a) || !finite(q) || !b.iter().all(|v| v.is_finite()) {
        return Err(bad("A, B or Q is not finite".into()));
    }
    let identity = DMatrix::<f64>::identity(n, n);
    let (mut aj, mut g, mut h) = (a.clone(), b * b.transpose() / r, q.clone());
    for step in 1..=64 {
        let w = (&identity + &g * &h)
            .lu()
            .try_inverse()
            .ok_or_else(|| bad("I + G H is singular (no stabilizing solution)".into()))?;
        let wa = &w * &aj;
        let h_next = &h + aj.transpose() * &h * &wa;
        let g_next = &g + &aj * &w * &g * aj.transpose();
        aj = &aj * &wa;
        let change = (&h_next - &h).norm();
        // symmetrize against drift
        h = (&h_next + h_next.transpose()) * 0.5;
        g = (&g_next + g_next.transpose()) * 0.5;
        if !finite(&h) {
            return Err(bad("the iteration diverged".into()));
        }
        if change <= 1e-14 * h.norm() || aj.norm() <= 1e-300 {
            return finish(a, b, q, r, h, step);
        }
    }
    Err(bad(
        "no convergence in 64 doubling steps (is (A, B) stabilizable?)".into(),
    ))
}

fn finish(
    a: &DMatrix<f64>,
    b: &DVector<f64>,
    q: &DMatrix<f64>,
    r: f64,
    x: DMatrix<f64>,
    steps: usize,
) -> Result<Riccati, ControlError> {
    let xb = &x * b;
    let denominator = r + b.dot(&xb);
    let gain = a.transpose() * &xb / denominator;
    let rhs = a.transpose() * &x * a - &gain * xb.transpose() * a + q;
    let residual = (&x - rhs).norm() / x.norm().max(f64::MIN_POSITIVE);
    let closed = a - b * gain.transpose();
    let radius = closed
        .complex_eigenvalues()
        .iter()
        .fold(0.0f64, |m, l| m.max(l.norm()));
    if !(residual < 1e-8 && radius < 1.0) {
        return Err(ControlError::Design(format!(
            "Riccati equation: no stabilizing solution (residual {residual:e}, \
             closed-loop spectral radius {radius})"
        )));
    }
    Ok(Riccati {
        x,
        gain,
        residual,
        steps,
    })
}
