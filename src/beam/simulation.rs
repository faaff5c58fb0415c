//! Time-discrete simulation of the beam and of the Hammerstein plant
//! `u → W → beam → y` (`docs/MATHEMATICS.md` §6, the paper's Fig. 7).
//!
//! State space `x = (η, η̇)` of a [`ModalModel`]:
//! `ẋ = A x + B u`, `A = [[0, I], [−Ω², −D]]`, `B = [0; b]`, `y = [cᵀ, 0] x`.
//! Discretization: exact zero-order hold at `T_s`. `A` is diagonalized once,
//! `A = V Λ V⁻¹` (complex; the modes come in conjugate pairs), and each
//! decoupled mode is propagated exactly,
//!
//! ```text
//! z_{k+1} = e^{λ T_s} z_k + (e^{λ T_s} − 1)/λ · (V⁻¹B) u_k,     y_k = Re Σ (C V)_j z_j
//! ```
//!
//! keeping one member of each conjugate pair (weight 2): `n` complex
//! multiply-adds per sample instead of a dense `2n × 2n` product.
//! `e^{λT_s} − 1` is evaluated without cancellation
//! (`expm1(Re) cos(Im) − 2 sin²(Im/2) + i e^{Re} sin(Im)`).
//!
//! Conventions (`docs/MATHEMATICS.md` §6): row `k` of a trace holds `u_k` and the output
//! *before* `u_k` acts, `y_k = C x_k`; a simulation starts at rest in the
//! equilibrium of its first input.
//!
//! The discretization's coefficients are a [`DiscreteBeamFile`]: the plant
//! FMU carries them rather than the beam, so that it needs no eigensolver
//! and steps with the same bits on every platform (without the `beam`
//! feature only that file and the step are compiled).

#[cfg(feature = "beam")]
use faer::linalg::solvers::Solve;
#[cfg(feature = "beam")]
use faer::{c64, Mat};
use serde::{Deserialize, Serialize};

#[cfg(feature = "beam")]
use crate::beam::modal::ModalModel;
use crate::beam::BeamError;
use crate::operators::model::HysteresisCreepModel;
use crate::operators::traits::Operator;

/// The state-space model of a [`ModalModel`] in diagonal (complex modal)
/// coordinates: `ż_j = λ_j z_j + (V⁻¹B)_j u`, `y = Re Σ w_j (CV)_j z_j`, keeping
/// one pole of each conjugate pair (`w_j = 2`) and the real poles (`w_j = 1`).
#[cfg(feature = "beam")]
#[derive(Debug, Clone)]
pub struct DiagonalForm {
    /// Poles `λ_j` with `Im λ_j ≥ 0`.
    pub poles: Vec<c64>,
    /// `(V⁻¹B)_j`.
    pub input: Vec<c64>,
    /// `(CV)_j`.
    pub output: Vec<c64>,
}

#[cfg(feature = "beam")]
impl DiagonalForm {
    /// Diagonalize `A = [[0, I], [−Ω², −D]]`; refuses a (nearly) defective `A`.
    pub fn new(modal: &ModalModel) -> Result<Self, BeamError> {
        let n = modal.len();
        let a = Mat::<f64>::from_fn(2 * n, 2 * n, |i, j| {
            if i < n {
                if j == n + i {
                    1.0
                } else {
                    0.0
                }
            } else if j < n {
                if j == i - n {
                    -modal.omega[j] * modal.omega[j]
                } else {
                    0.0
                }
            } else {
                -modal.damping_at(i - n, j - n)
            }
        });
        let evd = a.eigen().map_err(|_| {
            BeamError::Numerical("eigen decomposition of A did not converge".into())
        })?;
        let v = evd.U().to_owned();
        let lambda: Vec<c64> = (0..2 * n).map(|j| evd.S()[j]).collect();
        // residual check: ‖A V − V Λ‖ relative, so a defective A is refused
        let scale = modal.omega.iter().fold(1.0f64, |m, w| m.max(w * w));
        let ac = Mat::<c64>::from_fn(2 * n, 2 * n, |i, j| c64::new(a[(i, j)], 0.0));
        let av = &ac * &v;
        let mut res = 0.0f64;
        for i in 0..2 * n {
            for j in 0..2 * n {
                let r = av[(i, j)] - v[(i, j)] * lambda[j];
                res = res.max(r.norm());
            }
        }
        if res > 1e-8 * scale {
            return Err(BeamError::Numerical(format!(
                "the state matrix is (nearly) defective: eigen residual {res:e}"
            )));
        }
        let b = Mat::<c64>::from_fn(2 * n, 1, |i, _| {
            c64::new(if i >= n { modal.input[i - n] } else { 0.0 }, 0.0)
        });
        let vinv_b = v.partial_piv_lu().solve(&b);
        let mut form = Self {
            poles: vec![],
            input: vec![],
            output: vec![],
        };
        for (j, &l) in lambda.iter().enumerate() {
            if l.im < 0.0 {
                continue; // the conjugate of a kept pole
            }
            form.poles.push(l);
            form.input.push(vinv_b[(j, 0)]);
            form.output
                .push((0..n).map(|i| v[(i, j)] * modal.output[i]).sum());
        }
        Ok(form)
    }

    /// 2 for a member of a conjugate pair, 1 for a real pole.
    pub fn weight(&self, j: usize) -> f64 {
        if self.poles[j].im > 0.0 {
            2.0
        } else {
            1.0
        }
    }

    /// `G(0) = Σ_j w_j Re(−(CV)_j (V⁻¹B)_j / λ_j)`.
    pub fn static_gain(&self) -> f64 {
        (0..self.poles.len())
            .map(|j| self.weight(j) * (-(self.output[j] * self.input[j]) / self.poles[j]).re)
            .sum()
    }
}

/// The exact ZOH discretization of a [`ModalModel`], propagated in decoupled
/// complex modal coordinates.
#[derive(Debug, Clone)]
pub struct DiscreteBeam {
    sample_time: f64,
    pole_re: Vec<f64>,
    pole_im: Vec<f64>,
    gain_re: Vec<f64>,
    gain_im: Vec<f64>,
    out_re: Vec<f64>,
    out_im: Vec<f64>,
    /// Equilibrium state per unit input, `−(V⁻¹B)/λ`.
    eq_re: Vec<f64>,
    eq_im: Vec<f64>,
    z_re: Vec<f64>,
    z_im: Vec<f64>,
}

/// The coefficients of a [`DiscreteBeam`] at its sample time, one entry
/// per kept mode `j`, each complex number as `[re, im]`: the discrete pole
/// `e^{λ_j T_s}`, the input gain `(e^{λ_j T_s} − 1)/λ_j · (V⁻¹B)_j`, the
/// output weight `w_j (CV)_j` and the equilibrium per unit input
/// `−(V⁻¹B)_j/λ_j`. JSON keeps every bit (`docs/FILES.md`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DiscreteBeamFile {
    /// `T_s` (s).
    pub sample_time: f64,
    pub pole: Vec<[f64; 2]>,
    pub gain: Vec<[f64; 2]>,
    pub output: Vec<[f64; 2]>,
    pub equilibrium: Vec<[f64; 2]>,
}

/// The most modes a discretized beam file may hold: twice the most a beam
/// model has (the finite elements' two degrees of freedom per node).
pub const MAX_DISCRETE_MODES: usize = 2 * (crate::realtime::limits::MAX_ELEMENTS + 1);

/// `e^{s} − 1` for complex `s` without cancellation, with the `libm`
/// crate's functions: the same bits on every platform (`std`'s call the
/// platform's C library).
#[cfg(feature = "beam")]
pub(crate) fn cexpm1(s: c64) -> c64 {
    let (sin, cos) = libm::sincos(s.im);
    let half = libm::sin(0.5 * s.im);
    c64::new(
        libm::expm1(s.re) * cos - 2.0 * half * half,
        libm::exp(s.re) * sin,
    )
}

impl DiscreteBeam {
    /// Discretize `modal` at sample time `sample_time`.
    #[cfg(feature = "beam")]
    pub fn new(modal: &ModalModel, sample_time: f64) -> Result<Self, BeamError> {
        if !(sample_time.is_finite() && sample_time > 0.0) {
            return Err(BeamError::InvalidSetting {
                field: "sample_time",
                reason: format!("must be a finite number > 0, found {sample_time}"),
            });
        }
        let modes = DiagonalForm::new(modal)?;
        let mut beam = Self {
            sample_time,
            pole_re: vec![],
            pole_im: vec![],
            gain_re: vec![],
            gain_im: vec![],
            out_re: vec![],
            out_im: vec![],
            eq_re: vec![],
            eq_im: vec![],
            z_re: vec![],
            z_im: vec![],
        };
        for j in 0..modes.poles.len() {
            let (l, vb, cv) = (modes.poles[j], modes.input[j], modes.output[j]);
            let lt = l * sample_time;
            let pole = cexpm1(lt) + c64::new(1.0, 0.0);
            let gain = cexpm1(lt) / l * vb;
            let cv = cv * modes.weight(j);
            let eq = -vb / l;
            beam.pole_re.push(pole.re);
            beam.pole_im.push(pole.im);
            beam.gain_re.push(gain.re);
            beam.gain_im.push(gain.im);
            beam.out_re.push(cv.re);
            beam.out_im.push(cv.im);
            beam.eq_re.push(eq.re);
            beam.eq_im.push(eq.im);
        }
        let m = beam.pole_re.len();
        beam.z_re = vec![0.0; m];
        beam.z_im = vec![0.0; m];
        Ok(beam)
    }

    /// The beam from its coefficients, at rest at zero; an error names the
    /// field that is wrong.
    pub fn from_file(file: &DiscreteBeamFile) -> Result<Self, BeamError> {
        let invalid =
            |field: &'static str, reason: String| BeamError::InvalidSetting { field, reason };
        let ts = file.sample_time;
        if !(ts.is_finite() && ts > 0.0) {
            return Err(invalid(
                "sample_time",
                format!("must be a finite number > 0, found {ts}"),
            ));
        }
        let n = file.pole.len();
        if n == 0 || n > MAX_DISCRETE_MODES {
            return Err(invalid(
                "pole",
                format!("must hold 1 to {MAX_DISCRETE_MODES} modes, found {n}"),
            ));
        }
        let fields = [
            ("pole", &file.pole),
            ("gain", &file.gain),
            ("output", &file.output),
            ("equilibrium", &file.equilibrium),
        ];
        for (field, values) in fields {
            if values.len() != n {
                return Err(invalid(
                    field,
                    format!("has {} entries, but pole has {n}", values.len()),
                ));
            }
            if let Some(j) = values
                .iter()
                .position(|c| !(c[0].is_finite() && c[1].is_finite()))
            {
                return Err(invalid(field, format!("entry {j} is not finite")));
            }
        }
        let re = |v: &[[f64; 2]]| v.iter().map(|c| c[0]).collect::<Vec<_>>();
        let im = |v: &[[f64; 2]]| v.iter().map(|c| c[1]).collect::<Vec<_>>();
        Ok(Self {
            sample_time: ts,
            pole_re: re(&file.pole),
            pole_im: im(&file.pole),
            gain_re: re(&file.gain),
            gain_im: im(&file.gain),
            out_re: re(&file.output),
            out_im: im(&file.output),
            eq_re: re(&file.equilibrium),
            eq_im: im(&file.equilibrium),
            z_re: vec![0.0; n],
            z_im: vec![0.0; n],
        })
    }

    /// Its coefficients, which [`from_file`](Self::from_file) reads back to
    /// the same bits.
    pub fn file(&self) -> DiscreteBeamFile {
        let pairs = |re: &[f64], im: &[f64]| re.iter().zip(im).map(|(&r, &i)| [r, i]).collect();
        DiscreteBeamFile {
            sample_time: self.sample_time,
            pole: pairs(&self.pole_re, &self.pole_im),
            gain: pairs(&self.gain_re, &self.gain_im),
            output: pairs(&self.out_re, &self.out_im),
            equilibrium: pairs(&self.eq_re, &self.eq_im),
        }
    }

    /// Sample time (s).
    pub fn sample_time(&self) -> f64 {
        self.sample_time
    }

    /// Static gain of the discrete model (equals the modal model's).
    pub fn static_gain(&self) -> f64 {
        (0..self.eq_re.len())
            .map(|j| self.out_re[j] * self.eq_re[j] - self.out_im[j] * self.eq_im[j])
            .sum()
    }

    /// Put the beam at rest in the equilibrium of a constant input `u`.
    pub fn set_equilibrium(&mut self, u: f64) {
        for j in 0..self.z_re.len() {
            self.z_re[j] = self.eq_re[j] * u;
            self.z_im[j] = self.eq_im[j] * u;
        }
    }

    /// Output of the current state without advancing (the same sum, in the
    /// same order, as [`step`](DiscreteBeam::step) returns).
    #[inline]
    pub fn output(&self) -> f64 {
        let mut y = 0.0;
        for j in 0..self.z_re.len() {
            y += self.out_re[j] * self.z_re[j] - self.out_im[j] * self.z_im[j];
        }
        y
    }

    /// The state in the decoupled complex modal coordinates: real and
    /// imaginary parts of `z_j`, one per mode (the output is
    /// `Σ_j Re(c_j z_j)` with `c_j` the mode's output weight).
    pub fn modal_state(&self) -> (&[f64], &[f64]) {
        (&self.z_re, &self.z_im)
    }

    /// Number of modes (entries of [`modal_state`](DiscreteBeam::modal_state)).
    pub fn modes(&self) -> usize {
        self.z_re.len()
    }

    /// Output `y_k` of the current state, then advance with `u_k`.
    /// Allocation-free.
    #[inline]
    pub fn step(&mut self, u: f64) -> f64 {
        let mut y = 0.0;
        for j in 0..self.z_re.len() {
            let (zr, zi) = (self.z_re[j], self.z_im[j]);
            y += self.out_re[j] * zr - self.out_im[j] * zi;
            self.z_re[j] = self.pole_re[j] * zr - self.pole_im[j] * zi + self.gain_re[j] * u;
            self.z_im[j] = self.pole_re[j] * zi + self.pole_im[j] * zr + self.gain_im[j] * u;
        }
        y
    }

    /// Simulate a whole trace from rest in the equilibrium of `u[0]`.
    pub fn simulate(&mut self, u: &[f64]) -> Vec<f64> {
        if let Some(&u0) = u.first() {
            self.set_equilibrium(u0);
        }
        u.iter().map(|&uk| self.step(uk)).collect()
    }
}

/// The Hammerstein plant of the paper's Fig. 7: `u → W → beam → y`.
#[derive(Debug, Clone)]
pub struct HammersteinPlant {
    pub actuator: HysteresisCreepModel,
    pub beam: DiscreteBeam,
}

impl HammersteinPlant {
    /// Chain `W` and the discretized beam; the sample times must agree.
    pub fn new(actuator: HysteresisCreepModel, beam: DiscreteBeam) -> Result<Self, BeamError> {
        let (a, b) = (actuator.sample_time(), beam.sample_time());
        if (a - b).abs() > 1e-12 * a {
            return Err(BeamError::InvalidSetting {
                field: "sample_time",
                reason: format!("actuator model has {a} s, beam {b} s"),
            });
        }
        Ok(Self { actuator, beam })
    }

    /// Tip deflection `y_k` (before `u_k` acts), then advance with `u_k`.
    #[inline]
    pub fn step(&mut self, u: f64) -> f64 {
        let v = self.actuator.step(u);
        self.beam.step(v)
    }

    /// Simulate from the beam at rest in the equilibrium of the first
    /// effective voltage `W[u]_0` (the actuator starts from its own state).
    pub fn simulate(&mut self, u: &[f64]) -> Vec<f64> {
        let v = self.actuator.run(u);
        self.beam.simulate(&v)
    }
}

/// The compensated plant `ς_d → W⁻¹ → W → beam → y`: with matched models the
/// chain is linear, `y = beam[ς_d]` while the compensator is not saturated.
#[derive(Debug, Clone)]
pub struct CompensatedPlant {
    pub compensator: crate::operators::compensator::Compensator<f64, crate::operators::heap::Heap>,
    pub plant: HammersteinPlant,
}

/// A simulated compensated trace.
#[derive(Debug, Clone, PartialEq)]
pub struct CompensatedTrace {
    /// Balanced voltage the compensator emitted.
    pub u: Vec<f64>,
    /// Whether each sample was clipped.
    pub saturated: Vec<bool>,
    /// Tip deflection (m).
    pub y: Vec<f64>,
}

impl CompensatedPlant {
    /// Simulate from the beam at rest in the equilibrium of the first
    /// effective voltage.
    pub fn simulate(&mut self, targets: &[f64]) -> CompensatedTrace {
        let mut u = Vec::with_capacity(targets.len());
        let mut saturated = Vec::with_capacity(targets.len());
        for &t in targets {
            let c = self.compensator.compensate(t);
            u.push(c.u);
            saturated.push(c.saturated);
        }
        let y = self.plant.simulate(&u);
        CompensatedTrace { u, saturated, y }
    }
}
