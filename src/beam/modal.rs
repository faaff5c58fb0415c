//! Modal form of a finite-dimensional beam model and modal analysis.
//!
//! Both discretizations of (26) end up as `M q̈ + D q̇ + K q = b u`,
//! `y = cᵀ q`. In mass-normalized undamped modal coordinates `q = V η`
//! (`Vᵀ M V = I`, `Vᵀ K V = Ω² = diag(ω_k²)`) this is
//!
//! ```text
//! η̈ + Vᵀ D V η̇ + Ω² η = Vᵀ b u,     y = (Vᵀ c)ᵀ η
//! ```
//!
//! which is what [`ModalModel`] holds. The generalized symmetric-definite
//! eigenproblem `K v = ω² M v` is reduced with the Cholesky factor of `M`
//! (`M = L Lᵀ`, `L⁻¹ K L⁻ᵀ y = ω² y`, `v = L⁻ᵀ y`), as faer has no direct
//! solver for it.

use faer::linalg::triangular_solve::{
    solve_lower_triangular_in_place, solve_upper_triangular_in_place,
};
use faer::{Mat, Par, Side};

use crate::beam::BeamError;

/// A beam model in undamped, mass-normalized modal coordinates.
#[derive(Debug, Clone, PartialEq)]
pub struct ModalModel {
    /// Undamped natural angular frequencies `ω_k` (rad/s), ascending.
    pub omega: Vec<f64>,
    /// Modal damping matrix `Vᵀ D V` (row-major, `n × n`).
    pub damping: Vec<f64>,
    /// Modal input vector `Vᵀ b` (per effective volt).
    pub input: Vec<f64>,
    /// Modal output vector `Vᵀ c` (tip deflection).
    pub output: Vec<f64>,
}

impl ModalModel {
    /// Number of modes.
    pub fn len(&self) -> usize {
        self.omega.len()
    }

    /// Whether there is no mode.
    pub fn is_empty(&self) -> bool {
        self.omega.is_empty()
    }

    /// `D_kl` of the modal damping matrix.
    pub fn damping_at(&self, k: usize, l: usize) -> f64 {
        self.damping[k * self.len() + l]
    }

    /// Undamped natural frequencies `ω_k / 2π` (Hz).
    pub fn frequencies_hz(&self) -> Vec<f64> {
        self.omega
            .iter()
            .map(|w| w / (2.0 * std::f64::consts::PI))
            .collect()
    }

    /// Modal damping ratios `ζ_k = D_kk / (2 ω_k)` (the diagonal of the
    /// projected damping; off-diagonal coupling is kept in simulation).
    pub fn damping_ratios(&self) -> Vec<f64> {
        (0..self.len())
            .map(|k| self.damping_at(k, k) / (2.0 * self.omega[k]))
            .collect()
    }

    /// Static tip deflection per effective volt of these modes:
    /// `Σ_k c_k b_k / ω_k²`.
    pub fn static_gain(&self) -> f64 {
        self.omega
            .iter()
            .zip(&self.input)
            .zip(&self.output)
            .map(|((w, b), c)| b * c / (w * w))
            .sum()
    }

    /// The first `n` modes.
    pub fn truncated(&self, n: usize) -> ModalModel {
        let n = n.min(self.len());
        let full = self.len();
        ModalModel {
            omega: self.omega[..n].to_vec(),
            damping: (0..n)
                .flat_map(|k| (0..n).map(move |l| self.damping[k * full + l]))
                .collect(),
            input: self.input[..n].to_vec(),
            output: self.output[..n].to_vec(),
        }
    }
}

/// Mass-normalized eigenpairs of `K v = λ M v` (`K` symmetric, `M` symmetric
/// positive definite), eigenvalues ascending; the eigenvectors are the
/// columns of the returned matrix.
pub fn generalized_eigen(k: &Mat<f64>, m: &Mat<f64>) -> Result<(Vec<f64>, Mat<f64>), BeamError> {
    let n = k.nrows();
    let llt = m
        .llt(Side::Lower)
        .map_err(|_| BeamError::Numerical("mass matrix is not positive definite".into()))?;
    let l = llt.L();
    // C = L⁻¹ K L⁻ᵀ: solve L X = K, then L Cᵀ = Xᵀ.
    let mut x = k.clone();
    solve_lower_triangular_in_place(l, x.as_mut(), Par::Seq);
    let mut c = x.transpose().to_owned();
    solve_lower_triangular_in_place(l, c.as_mut(), Par::Seq);
    // symmetrize the rounding
    let c = Mat::from_fn(n, n, |i, j| 0.5 * (c[(i, j)] + c[(j, i)]));
    let evd = c
        .self_adjoint_eigen(Side::Lower)
        .map_err(|_| BeamError::Numerical("symmetric eigensolver did not converge".into()))?;
    let lambda: Vec<f64> = (0..n).map(|i| evd.S()[i]).collect();
    let mut v = evd.U().to_owned();
    solve_upper_triangular_in_place(l.transpose(), v.as_mut(), Par::Seq);
    Ok((lambda, v))
}

/// `Vᵀ A V` for a symmetric `A` (`n × n`) and `V` (`n × r`), row-major `r × r`.
pub fn project(a: &Mat<f64>, v: &Mat<f64>) -> Vec<f64> {
    let av = a * v;
    let p = v.transpose() * &av;
    let r = v.ncols();
    (0..r)
        .flat_map(|i| (0..r).map(move |j| (i, j)))
        .map(|(i, j)| 0.5 * (p[(i, j)] + p[(j, i)]))
        .collect()
}

/// `Vᵀ x`.
pub fn project_vector(x: &[f64], v: &Mat<f64>) -> Vec<f64> {
    (0..v.ncols())
        .map(|j| (0..v.nrows()).map(|i| v[(i, j)] * x[i]).sum())
        .collect()
}
