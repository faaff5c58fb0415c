//! The converged model of the beam (26)–(27) (`--model modal`, the default):
//! cubic-Hermite finite elements on the piecewise beam, with nodes at the
//! patch ends, reduced to its first `n` undamped mass-normalized modes.
//!
//! Cubic Hermite elements reproduce the static solution of (26) exactly at the
//! nodes (the load is a pair of nodal moments and the coefficients are
//! constant per element), and their eigenvalue error falls like `h⁴`.
//!
//! **Conditioning.** The assembled stiffness matrix has condition number
//! `∝ elements⁴`, and a generalized eigen solver applied to it loses about
//! 1e-5 in f₁ at 240 elements. This module never forms it. It works in
//! *element deformation* coordinates `d_e = (δw_e, δθ_e)` with
//! `δθ_e = θ_e − θ_{e−1}` and `δw_e = w_e − w_{e−1} − h_e θ_{e−1}`: the strain
//! energy is block diagonal in `d` (`K_d`, one well-conditioned 2×2 block
//! `Λ/h³ [[12, −6h], [−6h, 4h²]]` per element, with the closed-form Cholesky
//! factor `[[√(12Λ/h³), 0], [−√(3Λ/h), √(Λ/h)]]`), and the map `q = S d` from
//! deformations to nodal displacements is a cumulative sum, evaluated exactly
//! as `w_i = w_e + θ_e (x_i − x_e)` without ever inverting anything. With
//! `W = S L_K⁻ᵀ` the eigenproblem becomes the *flexibility* problem
//! `Wᵀ M W y = (1/ω²) y`, whose largest eigenvalues — the lowest modes — a
//! symmetric eigen solver returns to full relative accuracy. Static solutions
//! use `K⁻¹ = S K_d⁻¹ Sᵀ` the same way.

use faer::{Mat, Side};

use crate::beam::modal::ModalModel;
use crate::beam::{BeamError, BeamParameters, SectionCoefficients};

/// Default number of finite elements.
pub const DEFAULT_ELEMENTS: usize = 240;

/// The finite-element discretization (not reduced).
#[derive(Debug, Clone)]
pub struct FiniteElementModel {
    /// Node positions `x_0 = 0 < … < x_N = L`.
    nodes: Vec<f64>,
    /// Coefficients of element `e` (between nodes `e` and `e + 1`).
    coefficients: Vec<SectionCoefficients>,
    /// Node indices of the patch ends.
    patch_nodes: (usize, usize),
    /// `2 Γ_p`.
    moment_per_volt: f64,
}

impl FiniteElementModel {
    /// About `elements` elements, distributed over the three segments in
    /// proportion to their length (at least one each), nodes at the patch ends.
    pub fn new(beam: &BeamParameters, elements: usize) -> Result<Self, BeamError> {
        beam.validate()?;
        if elements < 3 {
            return Err(BeamError::InvalidSetting {
                field: "elements",
                reason: format!("at least 3 elements are needed, found {elements}"),
            });
        }
        crate::realtime::limits::check("elements", crate::realtime::limits::MAX_ELEMENTS, elements)
            .map_err(|e| BeamError::InvalidSetting {
                field: "elements",
                reason: e.reason(),
            })?;
        let mut nodes = vec![0.0];
        let mut coefficients = Vec::new();
        let mut patch_nodes = (0, 0);
        for (s, seg) in beam.segments().iter().enumerate() {
            let len = seg.end - seg.start;
            let count = ((elements as f64 * len / beam.length).round() as usize).max(1);
            for k in 1..=count {
                // the last node of a segment is its end point exactly
                let x = if k == count {
                    seg.end
                } else {
                    seg.start + len * k as f64 / count as f64
                };
                nodes.push(x);
                coefficients.push(seg.coefficients);
            }
            match s {
                0 => patch_nodes.0 = nodes.len() - 1,
                1 => patch_nodes.1 = nodes.len() - 1,
                _ => {}
            }
        }
        Ok(Self {
            nodes,
            coefficients,
            patch_nodes,
            moment_per_volt: beam.moment_per_volt(),
        })
    }

    /// Number of elements.
    pub fn elements(&self) -> usize {
        self.coefficients.len()
    }

    /// Node positions.
    pub fn nodes(&self) -> &[f64] {
        &self.nodes
    }

    fn h(&self, e: usize) -> f64 {
        self.nodes[e + 1] - self.nodes[e]
    }

    /// Static tip deflection per effective volt of the full FE model,
    /// `cᵀ S K_d⁻¹ Sᵀ b`: a constant moment `2Γ_p` on the patch elements gives
    /// `δθ = h M/Λ`, `δw = h² M/(2Λ)`, and the tip moves by
    /// `Σ_e δw_e + δθ_e (L − x_{e+1})`.
    pub fn static_gain(&self) -> f64 {
        let l = *self.nodes.last().unwrap();
        let (a, b) = self.patch_nodes;
        (a..b)
            .map(|e| {
                let h = self.h(e);
                let lam = self.coefficients[e].stiffness;
                let m = self.moment_per_volt;
                h * h * m / (2.0 * lam) + h * m / lam * (l - self.nodes[e + 1])
            })
            .sum()
    }

    /// `W = S L_K⁻ᵀ` (`2N × 2N`, rows `(w_i, θ_i)` of nodes `1..=N`, columns
    /// two per element).
    fn flexibility_factor(&self) -> Mat<f64> {
        let ne = self.elements();
        let mut w = Mat::<f64>::zeros(2 * ne, 2 * ne);
        for e in 0..ne {
            let h = self.h(e);
            let lam = self.coefficients[e].stiffness;
            // L_K = [[a, 0], [b, c]]; L_K⁻ᵀ = [[1/a, −b/(a c)], [0, 1/c]]
            let a = (12.0 * lam / (h * h * h)).sqrt();
            let b = -(3.0 * lam / h).sqrt();
            let c = (lam / h).sqrt();
            let cols = [(1.0 / a, 0.0), (-b / (a * c), 1.0 / c)]; // (δw, δθ) per column
            for (k, &(dw, dth)) in cols.iter().enumerate() {
                let col = 2 * e + k;
                let x_e = self.nodes[e + 1];
                for i in e..ne {
                    // node i+1 (rows 2i, 2i+1)
                    w[(2 * i, col)] = dw + dth * (self.nodes[i + 1] - x_e);
                    w[(2 * i + 1, col)] = dth;
                }
            }
        }
        w
    }

    /// `A X` for the consistent mass-shaped matrix with line density
    /// `density(e)` (the mass, or the viscous damping `γ_e`).
    fn mass_like_times(
        &self,
        x: &Mat<f64>,
        density: impl Fn(&SectionCoefficients) -> f64,
    ) -> Mat<f64> {
        let ne = self.elements();
        let mut out = Mat::<f64>::zeros(x.nrows(), x.ncols());
        for e in 0..ne {
            let h = self.h(e);
            let s = density(&self.coefficients[e]) * h / 420.0;
            let me = [
                [156.0, 22.0 * h, 54.0, -13.0 * h],
                [22.0 * h, 4.0 * h * h, 13.0 * h, -3.0 * h * h],
                [54.0, 13.0 * h, 156.0, -22.0 * h],
                [-13.0 * h, -3.0 * h * h, -22.0 * h, 4.0 * h * h],
            ];
            // global rows of (w_e, θ_e, w_{e+1}, θ_{e+1}); node 0 is clamped
            let rows: [Option<usize>; 4] = if e == 0 {
                [None, None, Some(0), Some(1)]
            } else {
                [
                    Some(2 * e - 2),
                    Some(2 * e - 1),
                    Some(2 * e),
                    Some(2 * e + 1),
                ]
            };
            for (a, ra) in rows.iter().enumerate() {
                let Some(ra) = *ra else { continue };
                for (b, rb) in rows.iter().enumerate() {
                    let Some(rb) = *rb else { continue };
                    let f = s * me[a][b];
                    for j in 0..x.ncols() {
                        out[(ra, j)] += f * x[(rb, j)];
                    }
                }
            }
        }
        out
    }

    /// The first `n` undamped mass-normalized modes (all `2N` if `n` is larger).
    pub fn modal(&self, n: usize) -> Result<ModalModel, BeamError> {
        let ne = self.elements();
        let w = self.flexibility_factor();
        // each 2N × 2N intermediate dropped as soon as it is used, and the
        // product symmetrized in place: at the element limit they are 8 MB
        // each, and the peak is what counts (docs/FILES.md, "Limits")
        let mut c = {
            let mw = self.mass_like_times(&w, |c| c.mass);
            w.transpose() * &mw
        };
        for j in 0..2 * ne {
            for i in j + 1..2 * ne {
                let s = 0.5 * (c[(i, j)] + c[(j, i)]);
                c[(i, j)] = s;
                c[(j, i)] = s;
            }
        }
        let evd = c
            .self_adjoint_eigen(Side::Lower)
            .map_err(|_| BeamError::Numerical("symmetric eigensolver did not converge".into()))?;
        drop(c);
        let total = 2 * ne;
        let n = n.min(total);
        // largest flexibility eigenvalues first: μ_k = 1/ω_k²
        let idx: Vec<usize> = (0..n).map(|k| total - 1 - k).collect();
        let mu: Vec<f64> = idx.iter().map(|&i| evd.S()[i]).collect();
        if mu.iter().any(|&m| m.is_nan() || m <= 0.0) {
            return Err(BeamError::Numerical(
                "flexibility matrix is not positive definite".into(),
            ));
        }
        let y = Mat::from_fn(total, n, |r, k| evd.U()[(r, idx[k])]);
        // mass-normalized mode shapes v_k = W y_k / √μ_k
        let scale: Vec<f64> = mu.iter().map(|m| 1.0 / m.sqrt()).collect();
        let wy = &w * &y;
        let v = Mat::from_fn(total, n, |r, k| wy[(r, k)] * scale[k]);
        // damping: γ_e mass-like, γ_i stiffness-like (block-diagonal in d:
        // L_K⁻¹ K_γi L_K⁻ᵀ = (γ_i/Λ) I per element)
        let dv = self.mass_like_times(&v, |c| c.viscous);
        let mut damping = vec![0.0; n * n];
        for k in 0..n {
            for l in 0..n {
                let viscous: f64 = (0..total).map(|r| v[(r, k)] * dv[(r, l)]).sum();
                let kelvin: f64 = (0..ne)
                    .map(|e| {
                        let co = &self.coefficients[e];
                        co.kelvin_voigt / co.stiffness
                            * (y[(2 * e, k)] * y[(2 * e, l)]
                                + y[(2 * e + 1, k)] * y[(2 * e + 1, l)])
                    })
                    .sum::<f64>()
                    * scale[k]
                    * scale[l];
                damping[k * n + l] = viscous + kelvin;
            }
        }
        for k in 0..n {
            for l in 0..k {
                let s = 0.5 * (damping[k * n + l] + damping[l * n + k]);
                damping[k * n + l] = s;
                damping[l * n + k] = s;
            }
        }
        let (pa, pb) = self.patch_nodes;
        let g = self.moment_per_volt;
        // b: moments −g at node pa, +g at node pb (θ rows 2(i−1)+1)
        let input = (0..n)
            .map(|k| g * (v[(2 * pb - 1, k)] - v[(2 * pa - 1, k)]))
            .collect();
        let output = (0..n).map(|k| v[(2 * ne - 2, k)]).collect();
        Ok(ModalModel {
            omega: mu.iter().map(|m| 1.0 / m.sqrt()).collect(),
            damping,
            input,
            output,
        })
    }
}
