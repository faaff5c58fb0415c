//! The paper's Ritz (Galerkin) model of the beam (26)–(27): `n` clamped-free
//! eigenfunctions of the *uniform* beam as basis.
//!
//! Weak form with test functions `φ_i`: `M_ij = ∫ μ φ_i φ_j`,
//! `K_ij = ∫ Λ φ_i'' φ_j''`, `D_ij = ∫ γ_e φ_i φ_j + ∫ γ_i φ_i'' φ_j''`,
//! `b_i = 2 Γ_p (φ_i'(x_p + L_p) − φ_i'(x_p))`, `c_i = φ_i(L)`.
//!
//! The basis is `φ(x) = cosh βx − cos βx − σ (sinh βx − sin βx)`,
//! `σ = (cosh βL + cos βL)/(sinh βL + sin βL)`, with `βL` the roots of
//! `1 + cos βL cosh βL = 0`. The textbook form cancels all digits by
//! `βL ≈ 30`; here `cosh z − σ sinh z = ½(1−σ)eᶻ + ½(1+σ)e⁻ᶻ` with
//! `1 − σ = 2 (sin βL − cos βL − e^{−βL}) e^{−βL} / (1 − e^{−2βL} + 2 sin βL e^{−βL})`,
//! so `½(1−σ)eᶻ` is evaluated as a product with `e^{z−βL} ≤ 1`: no term is
//! larger than the result by more than a few units.
//!
//! Quadrature: each of the three segments of constant coefficients is split
//! into sub-intervals with `β_n h ≤ π/2` and integrated with 20-point
//! Gauss–Legendre. The integrands are products of two functions of the form
//! `e^{±βx}`, `cos βx`, `sin βx` with `β ≤ β_n`; on such a sub-interval their
//! Taylor series converges like `(2β_n h / 2)^k / k!`, and a 20-point rule is
//! exact to degree 39, so the relative error is below `π^40 / 40! ≈ 1e-28`:
//! the quadrature is exact to rounding for the highest mode.
//!
//! Because the stiffness jumps at the patch ends while every basis function is
//! smooth, this model converges only like `1/n`: at `n = 15`
//! its f₁ is about 4 % and its static gain about 6 % above the converged
//! values. It is the paper's model, kept for reproduction; the default is the
//! converged [`crate::beam::fe`] model.

use faer::Mat;

use crate::beam::modal::{generalized_eigen, project, project_vector, ModalModel};
use crate::beam::{BeamError, BeamParameters};

/// `β_k L`, `k = 1..n`: the roots of `1 + cos x cosh x = 0`, by Newton on
/// the equivalent `cos x + 1/cosh x = 0` (which does not overflow).
pub fn clamped_free_roots(n: usize) -> Vec<f64> {
    (1..=n)
        .map(|k| {
            let mut x = if k == 1 {
                1.875
            } else {
                (k as f64 - 0.5) * std::f64::consts::PI
            };
            for _ in 0..50 {
                let sech = 1.0 / x.cosh();
                let f = x.cos() + sech;
                let df = -x.sin() - sech * x.tanh();
                let dx = f / df;
                x -= dx;
                if dx.abs() <= 1e-16 * x {
                    break;
                }
            }
            x
        })
        .collect()
}

/// One clamped-free eigenfunction of the uniform beam, evaluated without
/// cancellation.
#[derive(Debug, Clone, Copy)]
pub struct ClampedFreeMode {
    beta: f64,
    beta_l: f64,
    sigma: f64,
    /// `(sin βL − cos βL − e^{−βL}) / (1 − e^{−2βL} + 2 sin βL e^{−βL})`.
    growing: f64,
}

impl ClampedFreeMode {
    /// The mode with root `β L = beta_l` on a beam of length `length`.
    pub fn new(beta_l: f64, length: f64) -> Self {
        let e = (-beta_l).exp();
        let (s, c) = beta_l.sin_cos();
        let growing = (s - c - e) / (1.0 - e * e + 2.0 * s * e);
        let one_minus_sigma = 2.0 * growing * e;
        Self {
            beta: beta_l / length,
            beta_l,
            sigma: 1.0 - one_minus_sigma,
            growing,
        }
    }

    /// `[φ, φ', φ'', φ''']` at `x`.
    #[inline]
    pub fn eval(&self, x: f64) -> [f64; 4] {
        let z = self.beta * x;
        let plus = self.growing * (z - self.beta_l).exp(); // ½(1−σ)eᶻ
        let minus = (1.0 - self.growing * (-self.beta_l).exp()) * (-z).exp(); // ½(1+σ)e⁻ᶻ
        let (s, c) = z.sin_cos();
        let b = self.beta;
        [
            plus + minus - c + self.sigma * s,
            b * (plus - minus + s + self.sigma * c),
            b * b * (plus + minus + c - self.sigma * s),
            b * b * b * (plus - minus - s - self.sigma * c),
        ]
    }
}

/// Gauss–Legendre nodes and weights on `[-1, 1]` (Newton on `P_q`).
pub fn gauss_legendre(q: usize) -> Vec<(f64, f64)> {
    (0..q)
        .map(|i| {
            let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (q as f64 + 0.5)).cos();
            let mut dp = 0.0;
            for _ in 0..100 {
                let (mut p0, mut p1) = (1.0, x);
                for k in 2..=q {
                    let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                    p0 = p1;
                    p1 = p2;
                }
                dp = q as f64 * (x * p1 - p0) / (x * x - 1.0);
                let dx = p1 / dp;
                x -= dx;
                if dx.abs() < 1e-16 {
                    break;
                }
            }
            (x, 2.0 / ((1.0 - x * x) * dp * dp))
        })
        .collect()
}

/// The assembled Ritz model `M q̈ + D q̇ + K q = b u`, `y = cᵀ q`.
#[derive(Debug, Clone)]
pub struct RitzModel {
    pub mass: Mat<f64>,
    pub stiffness: Mat<f64>,
    pub damping: Mat<f64>,
    pub input: Vec<f64>,
    pub output: Vec<f64>,
}

impl RitzModel {
    /// Assemble with `n` basis functions.
    pub fn new(beam: &BeamParameters, n: usize) -> Result<Self, BeamError> {
        beam.validate()?;
        if n == 0 {
            return Err(BeamError::InvalidSetting {
                field: "basis_functions",
                reason: "must be at least 1".into(),
            });
        }
        let modes: Vec<ClampedFreeMode> = clamped_free_roots(n)
            .into_iter()
            .map(|bl| ClampedFreeMode::new(bl, beam.length))
            .collect();
        let beta_max = modes[n - 1].beta;
        let rule = gauss_legendre(20);
        let mut m = Mat::<f64>::zeros(n, n);
        let mut k = Mat::<f64>::zeros(n, n);
        let mut d = Mat::<f64>::zeros(n, n);
        let mut phi = vec![0.0; n];
        let mut phi2 = vec![0.0; n];
        for seg in beam.segments() {
            let len = seg.end - seg.start;
            let pieces = ((beta_max * len / std::f64::consts::FRAC_PI_2).ceil() as usize).max(1);
            let h = len / pieces as f64;
            let co = seg.coefficients;
            for p in 0..pieces {
                let a = seg.start + p as f64 * h;
                for &(t, w) in &rule {
                    let x = a + 0.5 * h * (t + 1.0);
                    let wq = 0.5 * h * w;
                    for (i, mode) in modes.iter().enumerate() {
                        let e = mode.eval(x);
                        phi[i] = e[0];
                        phi2[i] = e[2];
                    }
                    for i in 0..n {
                        for j in 0..=i {
                            let pp = wq * phi[i] * phi[j];
                            let cc = wq * phi2[i] * phi2[j];
                            m[(i, j)] += co.mass * pp;
                            k[(i, j)] += co.stiffness * cc;
                            d[(i, j)] += co.viscous * pp + co.kelvin_voigt * cc;
                        }
                    }
                }
            }
        }
        for i in 0..n {
            for j in 0..i {
                m[(j, i)] = m[(i, j)];
                k[(j, i)] = k[(i, j)];
                d[(j, i)] = d[(i, j)];
            }
        }
        let (xp, xe) = (beam.patch.start, beam.patch.start + beam.patch.length);
        let g = beam.moment_per_volt();
        let input = modes
            .iter()
            .map(|md| g * (md.eval(xe)[1] - md.eval(xp)[1]))
            .collect();
        let output = modes.iter().map(|md| md.eval(beam.length)[0]).collect();
        Ok(Self {
            mass: m,
            stiffness: k,
            damping: d,
            input,
            output,
        })
    }

    /// Undamped mass-normalized modal form.
    pub fn modal(&self) -> Result<ModalModel, BeamError> {
        let (lambda, v) = generalized_eigen(&self.stiffness, &self.mass)?;
        if lambda.iter().any(|&l| l.is_nan() || l <= 0.0) {
            return Err(BeamError::Numerical(
                "stiffness matrix is not positive definite".into(),
            ));
        }
        Ok(ModalModel {
            omega: lambda.iter().map(|l| l.sqrt()).collect(),
            damping: project(&self.damping, &v),
            input: project_vector(&self.input, &v),
            output: project_vector(&self.output, &v),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn roots_match_the_tabulated_values() {
        let r = clamped_free_roots(5);
        let table = [
            1.8751040687,
            4.6940911330,
            7.8547574382,
            10.9955407349,
            14.1371683910,
        ];
        for (a, b) in r.iter().zip(table) {
            assert!((a - b).abs() < 1e-10, "{a} vs {b}");
        }
        // and they are roots to rounding, even at βL ≈ 94
        for x in clamped_free_roots(30) {
            assert!((x.cos() + 1.0 / x.cosh()).abs() < 1e-14);
        }
    }

    #[test]
    fn gauss_legendre_integrates_polynomials_exactly() {
        let rule = gauss_legendre(20);
        let s: f64 = rule.iter().map(|&(_, w)| w).sum();
        assert!((s - 2.0).abs() < 1e-14);
        let x38: f64 = rule.iter().map(|&(x, w)| w * x.powi(38)).sum();
        assert!((x38 - 2.0 / 39.0).abs() < 1e-15);
    }

    #[test]
    fn mode_satisfies_the_boundary_conditions_without_cancellation() {
        for bl in clamped_free_roots(30) {
            let m = ClampedFreeMode::new(bl, 1.0);
            let [w0, d0, _, _] = m.eval(0.0);
            let [_, _, m_l, v_l] = m.eval(1.0);
            let scale = [1.0, bl, bl * bl, bl * bl * bl];
            assert!(w0.abs() < 1e-14 && d0.abs() < 1e-14 * scale[1]);
            // free end: moment and shear vanish
            assert!(m_l.abs() < 1e-12 * scale[2], "{bl}: {m_l}");
            assert!(v_l.abs() < 1e-12 * scale[3], "{bl}: {v_l}");
            // |φ(L)| = 2 for every clamped-free mode
            assert!((m.eval(1.0)[0].abs() - 2.0).abs() < 1e-12);
        }
    }
}
