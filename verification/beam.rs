//! The beam (26)–(27): analytic eigenvalues of the uniform beam, the exact
//! static gain of the patched beam, Ritz convergence from above, the
//! converged finite-element model, exact ZOH simulation, the Hammerstein and
//! compensated plants, and step-response identification.

use crate::common;

use common::*;
use mfcbeam::beam::fe::FiniteElementModel;
use mfcbeam::beam::modal::ModalModel;
use mfcbeam::beam::ritz::{clamped_free_roots, RitzModel};
use mfcbeam::beam::simulation::{
    CompensatedPlant, DiscreteBeam, DiscreteBeamFile, HammersteinPlant, MAX_DISCRETE_MODES,
};
use mfcbeam::beam::step_response_fit::*;
use mfcbeam::beam::BeamParameters;
use mfcbeam::prelude::*;

/// The nominal beam without the patch: a uniform cantilever.
fn uniform_beam() -> BeamParameters {
    let mut b = BeamParameters::nominal();
    b.patch.thickness = 0.0;
    b.patch.viscous_damping = 0.0;
    b.patch.kelvin_voigt_damping = 0.0;
    b
}

/// `ω_k = (β_k)² √(Λ/μ)` of the uniform beam.
fn analytic_omega(b: &BeamParameters, n: usize) -> Vec<f64> {
    let c = b.bare();
    clamped_free_roots(n)
        .iter()
        .map(|bl| (bl / b.length).powi(2) * (c.stiffness / c.mass).sqrt())
        .collect()
}

fn max_rel(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| ((x - y) / y).abs())
        .fold(0.0, f64::max)
}

#[test]
fn uniform_beam_ritz_model_has_analytic_frequencies_and_diagonal_mass() {
    let b = uniform_beam();
    let r = RitzModel::new(&b, 15).unwrap();
    let mu_l = b.bare().mass * b.length;
    for i in 0..15 {
        for j in 0..15 {
            let expected = if i == j { mu_l } else { 0.0 };
            assert!(
                (r.mass[(i, j)] - expected).abs() <= 1e-12 * mu_l,
                "M[{i}][{j}] = {}",
                r.mass[(i, j)]
            );
        }
    }
    let m = r.modal().unwrap();
    let err = max_rel(&m.omega[..10], &analytic_omega(&b, 10));
    assert!(err <= 1e-9, "{err:e}");
}

#[test]
fn uniform_beam_full_fe_model_has_analytic_frequencies() {
    let b = uniform_beam();
    let m = FiniteElementModel::new(&b, 240).unwrap().modal(10).unwrap();
    let err = max_rel(&m.omega, &analytic_omega(&b, 10));
    assert!(err <= 1e-6, "{err:e}");
}

#[test]
fn ritz_matrices_are_symmetric_positive_definite() {
    let r = RitzModel::new(&BeamParameters::nominal(), 15).unwrap();
    for mat in [&r.mass, &r.stiffness, &r.damping] {
        for i in 0..15 {
            for j in 0..15 {
                assert_eq!(mat[(i, j)], mat[(j, i)]);
            }
        }
        let ev = mat.self_adjoint_eigenvalues(faer::Side::Lower).unwrap();
        assert!(ev.iter().all(|&e| e > 0.0), "{ev:?}");
    }
}

/// Ritz bounds from above: every frequency falls as the basis grows.
#[test]
fn ritz_frequencies_decrease_monotonically_with_n() {
    let b = BeamParameters::nominal();
    let fe = FiniteElementModel::new(&b, 480).unwrap().modal(5).unwrap();
    let mut prev: Option<Vec<f64>> = None;
    for n in [5, 10, 15, 20, 30] {
        let f = RitzModel::new(&b, n).unwrap().modal().unwrap().omega;
        if let Some(p) = &prev {
            for k in 0..5 {
                assert!(f[k] < p[k], "n = {n}, mode {k}: {} !< {}", f[k], p[k]);
            }
        }
        // and stays above the converged value (Rayleigh–Ritz)
        for (fk, ck) in f.iter().zip(&fe.omega) {
            assert!(fk > ck);
        }
        prev = Some(f);
    }
}

/// The full FE model's static gain is the exact formula (to rounding), the
/// 15-mode model's within 0.1 %; the Ritz model's is ~6 % high.
#[test]
fn static_gain_of_the_patched_beam() {
    let b = BeamParameters::nominal();
    let exact = b.exact_static_gain();
    let fe = FiniteElementModel::new(&b, 240).unwrap();
    assert!(((fe.static_gain() - exact) / exact).abs() <= 1e-9);
    let modal = fe.modal(15).unwrap();
    assert!(((modal.static_gain() - exact) / exact).abs() <= 1e-3);
    let ritz = RitzModel::new(&b, 15).unwrap().modal().unwrap();
    let ritz_err = (ritz.static_gain() - exact) / exact;
    assert!(ritz_err > 0.03 && ritz_err < 0.09, "{ritz_err}");
}

/// The flexibility formulation keeps full accuracy: f₁…f₄ agree to 1e-8
/// between 240 and 480 elements (the discretization error ∝ h⁴ is below it).
#[test]
fn fe_frequencies_are_stable_between_240_and_480_elements() {
    let b = BeamParameters::nominal();
    let a = FiniteElementModel::new(&b, 240).unwrap().modal(4).unwrap();
    let c = FiniteElementModel::new(&b, 480).unwrap().modal(4).unwrap();
    let err = max_rel(&a.omega, &c.omega);
    assert!(err <= 1e-8, "{err:e}");
}

fn step(len: usize, at: usize, level: f64) -> Vec<f64> {
    (0..len).map(|k| if k < at { 0.0 } else { level }).collect()
}

/// A step response settles at the static gain, and the discretization is
/// exact: the same ZOH input at Ts/10 gives the same samples.
#[test]
fn zoh_step_response_converges_to_the_static_gain_and_is_exact() {
    let modal = FiniteElementModel::new(&BeamParameters::nominal(), 120)
        .unwrap()
        .modal(15)
        .unwrap();
    let ts = 2e-4;
    let mut d = DiscreteBeam::new(&modal, ts).unwrap();
    assert!(((d.static_gain() - modal.static_gain()) / modal.static_gain()).abs() < 1e-9);
    let u = step(150_000, 10, 1.0); // 30 s
    let y = d.simulate(&u);
    let g = modal.static_gain();
    // slowest decay e^{−ζ₁ω₁t}: after 29.9 s well below 1e-9 relative
    let zeta_omega = modal.damping_ratios()[0] * modal.omega[0];
    // plus the rounding of the complex eigendecomposition (≤ 1e-9, checked above)
    let bound = 3.0 * g * (-zeta_omega * 29.0).exp() + 1e-9 * g;
    assert!((y[149_999] - g).abs() <= bound, "{} vs {g}", y[149_999]);
    let mut fine = DiscreteBeam::new(&modal, ts / 10.0).unwrap();
    let uf: Vec<f64> = (0..20_000).map(|k| u[k / 10]).collect();
    let yf = fine.simulate(&uf);
    for k in 0..2000 {
        assert!(
            (y[k] - yf[10 * k]).abs() <= 1e-9 * g,
            "k = {k}: {} vs {}",
            y[k],
            yf[10 * k]
        );
    }
}

/// The discretized beam file (what the plant FMU carries) holds every bit:
/// the beam read back from its JSON steps exactly as the one computed.
#[test]
fn a_discretized_beam_read_from_its_file_steps_with_the_same_bits() {
    let modal = modal_model(&BeamParameters::nominal(), BeamModelKind::default()).unwrap();
    let mut computed = DiscreteBeam::new(&modal, 2e-4).unwrap();
    let json = serde_json::to_string(&computed.file()).unwrap();
    let file: DiscreteBeamFile = serde_json::from_str(&json).unwrap();
    assert_eq!(file, computed.file());
    let mut read = DiscreteBeam::from_file(&file).unwrap();
    assert_eq!(read.modes(), computed.modes());
    let u: Vec<f64> = (0..2000).map(|k| 300.0 * (k as f64 * 7e-3).sin()).collect();
    let (a, b) = (computed.simulate(&u), read.simulate(&u));
    assert!(a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()));
}

/// A discretized beam file that is inconsistent is refused, naming its
/// field.
#[test]
fn a_bad_discretized_beam_file_is_refused_naming_its_field() {
    let modal = modal_model(&BeamParameters::nominal(), BeamModelKind::default()).unwrap();
    let good = DiscreteBeam::new(&modal, 2e-4).unwrap().file();
    type Spoil = Box<dyn Fn(&mut DiscreteBeamFile)>;
    let cases: Vec<(&str, Spoil)> = vec![
        ("sample_time", Box::new(|f| f.sample_time = 0.0)),
        ("sample_time", Box::new(|f| f.sample_time = f64::NAN)),
        ("pole", Box::new(|f| f.pole.clear())),
        ("pole", Box::new(|f| f.pole[1][0] = f64::INFINITY)),
        (
            "gain",
            Box::new(|f| {
                f.gain.pop();
            }),
        ),
        ("output", Box::new(|f| f.output[0][1] = f64::NAN)),
        ("equilibrium", Box::new(|f| f.equilibrium.push([0.0, 0.0]))),
        (
            "pole",
            Box::new(|f| f.pole = vec![[0.5, 0.0]; MAX_DISCRETE_MODES + 1]),
        ),
    ];
    for (field, spoil) in cases {
        let mut bad = good.clone();
        spoil(&mut bad);
        let e = DiscreteBeam::from_file(&bad).unwrap_err().to_string();
        assert!(e.starts_with(field), "{field}: {e}");
    }
}

/// One mode against the closed-form step response of a damped oscillator.
#[test]
fn single_mode_step_response_matches_the_closed_form() {
    let (w, zeta, b, c) = (2.0 * std::f64::consts::PI * 10.0, 0.05, 3.0, 0.5);
    let modal = ModalModel {
        omega: vec![w],
        damping: vec![2.0 * zeta * w],
        input: vec![b],
        output: vec![c],
    };
    let ts = 1e-3;
    let y = DiscreteBeam::new(&modal, ts)
        .unwrap()
        .simulate(&step(2000, 1, 1.0));
    let g = b * c / (w * w);
    let wd = w * (1.0 - zeta * zeta).sqrt();
    for (k, &yk) in y.iter().enumerate().skip(1) {
        let t = (k - 1) as f64 * ts; // the step acts from sample 1 on
        let exact = g
            * (1.0
                - (-zeta * w * t).exp()
                    * ((wd * t).cos() + zeta / (1.0 - zeta * zeta).sqrt() * (wd * t).sin()));
        assert!((yk - exact).abs() <= 1e-12 * g, "k = {k}: {yk} vs {exact}");
    }
}

/// The compensated plant `W⁻¹ → W → beam` is the linear beam driven by the
/// target, while the Hammerstein plant alone shows the actuator's creep.
#[test]
fn compensated_plant_is_linear() {
    let modal = FiniteElementModel::new(&BeamParameters::nominal(), 120)
        .unwrap()
        .modal(15)
        .unwrap();
    let beam = DiscreteBeam::new(&modal, 2e-4).unwrap();
    let target = step(20_000, 100, 300.0);
    let linear = beam.clone().simulate(&target);
    let mut comp = CompensatedPlant {
        compensator: nominal_model()
            .compensator(CompensatorSettings::default())
            .unwrap(),
        plant: HammersteinPlant::new(nominal_model(), beam.clone()).unwrap(),
    };
    let out = comp.simulate(&target);
    assert!(out.saturated.iter().all(|s| !s));
    let g = modal.static_gain() * 300.0;
    let err = out
        .y
        .iter()
        .zip(&linear)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(err <= 1e-11 * g, "{err:e}");
    // uncompensated: the same voltage step creeps
    let raw = HammersteinPlant::new(nominal_model(), beam)
        .unwrap()
        .simulate(&target);
    let drift = raw[19_999] - raw[10_000];
    assert!(drift > 1e-3 * g, "creep drift {drift:e}");
}

fn fit_setup() -> (BeamParameters, BeamModelKind, Vec<f64>, Vec<f64>) {
    let mut truth = BeamParameters::nominal();
    truth.basis_functions = 6;
    let kind = BeamModelKind::Modal { elements: 60 };
    let u = step(2500, 50, 100.0);
    let y = simulate_response(&truth, kind, 2e-4, &u).unwrap();
    (truth, kind, u, y)
}

const FIT: [&str; 3] = [
    "youngs_modulus",
    "patch.input_gain",
    "patch.viscous_damping",
];

fn perturbed(truth: &BeamParameters) -> BeamParameters {
    let mut s = truth.clone();
    s.youngs_modulus *= 1.2;
    s.patch.input_gain *= 0.8;
    s.patch.viscous_damping *= 1.5;
    s
}

#[test]
fn step_response_fit_recovers_noise_free_parameters() {
    let (truth, kind, u, y) = fit_setup();
    let start = perturbed(&truth);
    let params: Vec<FitParameter> = FIT
        .iter()
        .map(|n| FitParameter::around(&start, n).unwrap())
        .collect();
    let fit = fit_step_response(
        &start,
        &params,
        kind,
        2e-4,
        &u,
        &y,
        StepFitOptions::SIMULATED,
    )
    .unwrap();
    for (i, n) in FIT.iter().enumerate() {
        let t = parameter(&truth, n).unwrap();
        assert!(
            ((fit.values[i] - t) / t).abs() <= 1e-6,
            "{n}: {} vs {t}",
            fit.values[i]
        );
    }
    assert!(fit.rms_residual < 1e-6 * fit.initial_rms_residual);
    assert_eq!(
        parameter(&fit.beam, "youngs_modulus").unwrap(),
        fit.values[0]
    );
}

#[test]
fn step_response_fit_with_noise_lands_within_three_standard_errors() {
    let (truth, kind, u, y) = fit_setup();
    let stroke = y.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let noise = gaussian(&mut Lcg(4242), y.len(), 0.01 * stroke);
    let noisy: Vec<f64> = y.iter().zip(&noise).map(|(v, e)| v + e).collect();
    let start = perturbed(&truth);
    let params: Vec<FitParameter> = FIT
        .iter()
        .map(|n| FitParameter::around(&start, n).unwrap())
        .collect();
    let fit = fit_step_response(
        &start,
        &params,
        kind,
        2e-4,
        &u,
        &noisy,
        StepFitOptions::SIMULATED,
    )
    .unwrap();
    for (i, n) in FIT.iter().enumerate() {
        let t = parameter(&truth, n).unwrap();
        let se = fit.standard_errors[i];
        assert!(se > 0.0);
        assert!(
            (fit.values[i] - t).abs() <= 3.0 * se,
            "{n}: {} vs {t}, se {se:e}",
            fit.values[i]
        );
    }
    // the residual is the noise
    assert!((fit.rms_residual / (0.01 * stroke) - 1.0).abs() < 0.1);
}

#[test]
fn non_identifiable_subset_is_refused_with_its_parameters_named() {
    let (truth, kind, u, y) = fit_setup();
    let names = [
        "density",
        "youngs_modulus",
        "patch.density",
        "patch.stiffness",
        "viscous_damping",
        "patch.viscous_damping",
        "kelvin_voigt_damping",
        "patch.kelvin_voigt_damping",
        "patch.input_gain",
    ];
    let params: Vec<FitParameter> = names
        .iter()
        .map(|n| FitParameter::around(&truth, n).unwrap())
        .collect();
    let e = fit_step_response(
        &truth,
        &params,
        kind,
        2e-4,
        &u,
        &y,
        StepFitOptions::SIMULATED,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("not identifiable"), "{e}");
    for n in names {
        assert!(e.contains(n), "{n} missing: {e}");
    }
    let e = FitParameter::around(&truth, "colour")
        .unwrap_err()
        .to_string();
    assert!(e.contains("unknown parameter 'colour'"), "{e}");
}

/// The measured-record model with the step time on a sample and no offset
/// is the discrete simulation: the closed-form continuous step response and
/// the exact ZOH agree at the samples (the fit of a simulated record then
/// lands on the step time and a zero offset).
#[test]
fn the_continuous_step_model_matches_the_zoh_simulation_at_the_samples() {
    let (truth, kind, u, y) = fit_setup();
    let params = [FitParameter::around(&truth, "youngs_modulus").unwrap()];
    let fit = fit_step_response(
        &truth,
        &params,
        kind,
        2e-4,
        &u,
        &y,
        StepFitOptions::default(),
    )
    .unwrap();
    let stroke = y.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(fit.rms_residual <= 1e-9 * stroke, "{}", fit.rms_residual);
    let (offset, _) = fit.offset.unwrap();
    let (t_s, _) = fit.step_time.unwrap();
    assert!(offset.abs() <= 1e-9 * stroke, "{offset}");
    assert!((t_s - 50.0 * 2e-4).abs() <= 1e-9, "{t_s}");
}

/// A measured record: the step falls between two samples (at 0.3 of a
/// sample after the logged switch), the sensor has an offset, there is
/// noise. The fit finds the parameters, the offset and the step time within
/// three standard errors.
#[test]
fn a_measured_step_with_offset_and_unknown_step_time_is_fitted() {
    let (truth, kind, u, _) = fit_setup();
    let ts = 2e-4;
    // the true response: the continuous step at (50 + 0.3) Ts (the logged
    // switch is at sample 50), plus an offset
    let t_true = 50.3 * ts;
    let modal = modal_model(&truth, kind).unwrap();
    let form = mfcbeam::beam::simulation::DiagonalForm::new(&modal).unwrap();
    let g = |t: f64| -> f64 {
        if t <= 0.0 {
            return 0.0;
        }
        (0..form.poles.len())
            .map(|j| {
                let l = form.poles[j];
                let r = form.output[j] * form.input[j] * form.weight(j);
                (r * ((l * t).exp() - 1.0) / l).re
            })
            .sum()
    };
    let offset = 3e-5;
    let clean: Vec<f64> = (0..u.len())
        .map(|k| offset + 100.0 * g(k as f64 * ts - t_true))
        .collect();
    let stroke = clean.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let noise = gaussian(&mut Lcg(77), clean.len(), 0.005 * stroke);
    let y: Vec<f64> = clean.iter().zip(&noise).map(|(v, e)| v + e).collect();
    let start = perturbed(&truth);
    let params: Vec<FitParameter> = FIT
        .iter()
        .map(|n| FitParameter::around(&start, n).unwrap())
        .collect();
    let fit =
        fit_step_response(&start, &params, kind, ts, &u, &y, StepFitOptions::default()).unwrap();
    for (i, n) in FIT.iter().enumerate() {
        let t = parameter(&truth, n).unwrap();
        let se = fit.standard_errors[i];
        assert!(
            (fit.values[i] - t).abs() <= 3.0 * se,
            "{n}: {} vs {t} (se {se:e})",
            fit.values[i]
        );
    }
    let (o, o_se) = fit.offset.unwrap();
    assert!(
        (o - offset).abs() <= 3.0 * o_se,
        "offset {o} vs {offset} (se {o_se:e})"
    );
    let (t, t_se) = fit.step_time.unwrap();
    assert!(
        (t - t_true).abs() <= 3.0 * t_se,
        "step time {t} vs {t_true} (se {t_se:e})"
    );
    assert!(
        t_se < 0.1 * ts,
        "the step time is found to a tenth of a sample: se {t_se:e}"
    );
    assert!((fit.rms_residual / (0.005 * stroke) - 1.0).abs() < 0.1);
    // without the step time and offset the same record fits much worse
    let plain =
        fit_step_response(&start, &params, kind, ts, &u, &y, StepFitOptions::SIMULATED).unwrap();
    assert!(
        plain.rms_residual > 1.5 * fit.rms_residual,
        "{} vs {}",
        plain.rms_residual,
        fit.rms_residual
    );
}

/// The nalgebra state space: the continuous matrices have the modal model's
/// structure and static gain; the discrete `(Φ, Γ)` from one matrix
/// exponential reproduce the closed-form step response of one mode and the
/// independent diagonal-form simulation of the nominal 15-mode FE beam.
#[test]
fn state_space_matrices_agree_with_the_closed_form_and_the_diagonal_simulation() {
    // one mode: Φ = e^{AT} in closed form, the step response exact
    let (w, zeta, b, c) = (2.0 * std::f64::consts::PI * 10.0, 0.05, 3.0, 0.5);
    let one = ModalModel {
        omega: vec![w],
        damping: vec![2.0 * zeta * w],
        input: vec![b],
        output: vec![c],
    };
    let ts = 1e-3;
    let ss = one.discrete_state_space(ts).unwrap();
    let (sigma, wd) = (zeta * w, w * (1.0 - zeta * zeta).sqrt());
    let e = (-sigma * ts).exp();
    let (s, co) = (wd * ts).sin_cos();
    let phi = [
        [e * (co + sigma / wd * s), e * s / wd],
        [-e * w * w / wd * s, e * (co - sigma / wd * s)],
    ];
    for (i, row) in phi.iter().enumerate() {
        for (j, &p) in row.iter().enumerate() {
            // Padé with scaling and squaring: backward error ≤ ε, ‖AT‖ ≈ 0.07
            assert!(
                (ss.a[(i, j)] - p).abs() <= 16.0 * f64::EPSILON * w.max(1.0),
                "Φ[{i},{j}]"
            );
        }
    }
    let g = b * c / (w * w);
    let y = ss.simulate(&step(2000, 1, 1.0));
    for (k, &yk) in y.iter().enumerate().skip(1) {
        let t = (k - 1) as f64 * ts;
        let exact = g
            * (1.0
                - (-zeta * w * t).exp()
                    * ((wd * t).cos() + zeta / (1.0 - zeta * zeta).sqrt() * (wd * t).sin()));
        assert!((yk - exact).abs() <= 1e-12 * g, "k = {k}: {yk} vs {exact}");
    }

    // the nominal FE beam, 15 modes = 30 states
    let modal = FiniteElementModel::new(&BeamParameters::nominal(), 120)
        .unwrap()
        .modal(15)
        .unwrap();
    let continuous = modal.state_space();
    assert_eq!(continuous.order(), 30);
    assert_eq!(continuous.a[(0, 15)], 1.0);
    assert_eq!(continuous.a[(15, 0)], -modal.omega[0] * modal.omega[0]);
    let g = modal.static_gain();
    let gc = continuous.static_gain().unwrap();
    assert!(((gc - g) / g).abs() < 1e-12, "{gc} vs {g}");
    let ts = 2e-4;
    let discrete = modal.discrete_state_space(ts).unwrap();
    let gd = discrete.static_gain().unwrap();
    // (I − Φ)⁻¹ Γ: Φ's slowest pole is 1 − ζ₁ω₁T_s, so relative rounding is
    // amplified by 1/(ζ₁ω₁T_s)
    let amplification = 1.0 / (modal.damping_ratios()[0] * modal.omega[0] * ts);
    assert!(
        ((gd - g) / g).abs() <= 64.0 * f64::EPSILON * amplification,
        "{gd} vs {g}"
    );
    // against the complex diagonal form, from rest, on a rich input
    let u: Vec<f64> = (0..20_000)
        .map(|k| (k as f64 * 3e-3).sin() + if (k / 700) % 2 == 0 { 0.5 } else { -0.5 })
        .collect();
    let mut diagonal = DiscreteBeam::new(&modal, ts).unwrap();
    let y_diag: Vec<f64> = u.iter().map(|&uk| diagonal.step(uk)).collect();
    let y_ss = discrete.simulate(&u);
    let scale = y_diag.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let worst = y_diag
        .iter()
        .zip(&y_ss)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    eprintln!("state space vs diagonal form: {worst:.3e} of max |y| = {scale:.3e}");
    // both exact ZOH; they differ by rounding, dominated by the complex
    // eigendecomposition's (≤ 1e-9 relative, as its static gain above)
    assert!(worst <= 1e-9 * scale);
    assert!(modal.discrete_state_space(0.0).is_err());
}
