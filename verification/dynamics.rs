//! Linear dynamics `G` after `S[H + C]`: the matched-pole filters against
//! their closed-form impulse responses, the exact inverse through the
//! compensator (f64 to the derived rounding bound, f32 to its own), and the
//! identification of `G` with the weights from several records: without
//! noise the frequencies and damping come back to the solver's precision,
//! the per-record offsets exactly, and a record's offset estimated on a
//! leading stretch is removed.

use mfcbeam::identification::{
    fit_dynamics, fit_dynamics_and_delay, identify_records, validate_record_zeroed, DynamicsParts,
    FitRecord, IdentificationSettings,
};
use mfcbeam::operators::bank::Par;
use mfcbeam::operators::model::{DynamicsData, LowPassData, ResonanceData};
use mfcbeam::prelude::*;
use mfcbeam::realtime::Model;
use mfcbeam::realtime::{
    preview, Dynamics, DynamicsParameters, Inline, ParameterError, Resonance, RoundingBounds,
};

const TS: f64 = 1e-4;

fn resonance(frequency: f64, damping: f64) -> DynamicsParameters {
    DynamicsParameters {
        resonance: Some(Resonance { frequency, damping }),
        ..DynamicsParameters::default()
    }
}

/// The response to a unit impulse after rest at 0.
fn impulse_response(g: &DynamicsParameters, n: usize) -> Vec<f64> {
    let mut d = Dynamics::<f64>::new(g, TS).unwrap();
    d.step(0.0);
    (0..n)
        .map(|k| d.step(if k == 0 { 1.0 } else { 0.0 }))
        .collect()
}

#[test]
fn a_resonance_rings_as_its_continuous_poles_say() {
    // impulse-invariant: the continuous e^{−σt} sin(ω_d t) at t = kT_s,
    // g z⁻¹/(1 + a1 z⁻¹ + a2 z⁻²) with poles r e^{±iθ}: h_k = g r^{k−1} sin(kθ)/sin θ
    let (f, zeta) = (740.0, 0.014);
    let w = std::f64::consts::TAU * f * TS;
    let (r, theta) = ((-zeta * w).exp(), w * (1.0 - zeta * zeta).sqrt());
    let g = 1.0 - 2.0 * r * theta.cos() + r * r;
    let h = impulse_response(&resonance(f, zeta), 400);
    assert_eq!(h[0], 0.0);
    for (k, &hk) in h.iter().enumerate().skip(1) {
        let exact = g * r.powi(k as i32 - 1) * (k as f64 * theta).sin() / theta.sin();
        // a recursion of 400 steps with |poles| < 1: rounding ~ k ε
        assert!(
            (hk - exact).abs() <= 64.0 * (k + 1) as f64 * f64::EPSILON,
            "k {k}: {hk} vs {exact}"
        );
    }
}

#[test]
fn a_low_pass_decays_as_its_pole_says_and_passes_a_constant() {
    let g = DynamicsParameters {
        low_pass: Some(1500.0),
        ..DynamicsParameters::default()
    };
    let p = (-std::f64::consts::TAU * 1500.0 * TS).exp();
    for (k, hk) in impulse_response(&g, 200).into_iter().enumerate() {
        let exact = (1.0 - p) * p.powi(k as i32);
        assert!((hk - exact).abs() <= 16.0 * (k + 1) as f64 * f64::EPSILON);
    }
    let both = DynamicsParameters {
        low_pass: Some(1500.0),
        resonance: Some(Resonance {
            frequency: 600.0,
            damping: 0.05,
        }),
        delay_fraction: 0.3,
    };
    let mut d = Dynamics::<f64>::new(&both, TS).unwrap();
    // the unit DC gain holds to the rounding of the coefficients and the
    // recursion (`RoundingBounds::dynamics_sum`): per step
    // 6 ε (g + Σ|c_j| ‖g/A‖₁) |w|, carried on by ‖1/A‖₁
    let (c, g, _) = d.coefficients();
    let c_abs: f64 = c.iter().map(|c| c.abs()).sum();
    let (g1, a1) = d.gains(TS);
    let bound = 4.0 * 8.0 * f64::EPSILON * (2.0 * g + c_abs * g1) * 3.25 * a1;
    for _ in 0..100 {
        assert!((d.step(3.25) - 3.25).abs() <= bound);
    }
}

#[test]
fn bad_dynamics_are_refused_by_name() {
    let field = |g: DynamicsParameters| match g.validate(TS) {
        Err(ParameterError::OutOfRange { field, .. }) => field,
        other => panic!("{other:?}"),
    };
    assert_eq!(
        field(resonance(5000.0, 0.1)),
        "dynamics.resonance.frequency"
    );
    assert_eq!(field(resonance(100.0, 1.0)), "dynamics.resonance.damping");
    assert_eq!(field(resonance(100.0, 0.0)), "dynamics.resonance.damping");
    let lp = DynamicsParameters {
        low_pass: Some(-1.0),
        ..DynamicsParameters::default()
    };
    assert_eq!(field(lp), "dynamics.low_pass.frequency");
    let fraction = DynamicsParameters {
        delay_fraction: 0.5,
        ..DynamicsParameters::default()
    };
    assert_eq!(field(fraction), "dynamics.delay_fraction");
}

#[test]
fn a_delay_fraction_delays_a_ramp_by_that_fraction() {
    for tau in [-0.45, -0.2, 0.3, 0.49] {
        let g = DynamicsParameters {
            delay_fraction: tau,
            ..DynamicsParameters::default()
        };
        let mut d = Dynamics::<f64>::new(&g, TS).unwrap();
        d.step(0.0);
        for k in 1..50 {
            let y = d.step(k as f64);
            assert!(
                (y - (k as f64 - tau)).abs() <= 4.0 * k as f64 * f64::EPSILON,
                "{tau}: {y}"
            );
        }
    }
}

/// The nominal model (creep and all) with a resonance and a low-pass.
fn dynamic_nominal() -> ModelFile {
    let mut file = nominal_model().to_file().without_state();
    file.sample_time = TS;
    file.dynamics = Some(DynamicsData {
        low_pass: Some(LowPassData { frequency: 1500.0 }),
        resonance: Some(ResonanceData {
            frequency: 740.0,
            damping: 0.014,
        }),
        delay_fraction: Some(0.3),
        state: None,
    });
    file
}

/// 30 raised-cosine cycles of rising amplitude at `rate` Hz after a hold.
fn drive(rate: f64, amplitude: f64) -> Vec<f64> {
    let n = (30.0 / rate / TS) as usize + 500;
    (0..n)
        .map(|k| {
            if k < 500 {
                return -amplitude;
            }
            let t = (k - 500) as f64 * TS;
            let a = amplitude * (0.4 + 0.6 * (k - 500) as f64 / (n - 500) as f64);
            -a * (std::f64::consts::TAU * rate * t).cos()
        })
        .collect()
}

#[test]
fn the_compensator_inverts_the_dynamics_exactly() {
    let file = dynamic_nominal();
    let model = HysteresisCreepModel::from_file(&file).unwrap();
    let y = model.clone().run(&drive(100.0, 600.0));
    let y_max = y.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for (eps, found) in [
        (f64::EPSILON, {
            let mut c = Compensator::<f64, Inline<12, 60>>::from_file(
                &file,
                CompensatorSettings::unlimited(),
            )
            .unwrap();
            let mut m = Model::<f64, Inline<12, 60>>::from_file(&file).unwrap();
            // the resonance's lag: the target leads by one sample
            assert_eq!((c.delay(), m.preview()), (1, 1));
            (0..y.len())
                .map(|k| m.step(c.compensate(preview(&y, 1, k)).u) - y[k])
                .skip(1)
                .collect::<Vec<f64>>()
        }),
        (f32::EPSILON as f64, {
            let mut c = Compensator::<f32, Inline<12, 60>>::from_file(
                &file,
                CompensatorSettings::unlimited(),
            )
            .unwrap();
            let mut m = Model::<f32, Inline<12, 60>>::from_file(&file).unwrap();
            (0..y.len())
                .map(|k| (m.step(c.compensate(preview(&y, 1, k) as f32).u) - y[k] as f32) as f64)
                .skip(1)
                .collect()
        }),
    ] {
        let bound = RoundingBounds {
            parameters: file.parameters(),
            state_max: 0.0,
            eps,
        }
        .identity(1000.0, y_max);
        let worst = found.iter().fold(0.0f64, |m, e| m.max(e.abs()));
        eprintln!("eps {eps:e}: worst |W[W⁻¹[y]] − y| = {worst:e}, bound {bound:e}");
        assert!(worst <= bound, "{worst} > {bound}");
    }
}

/// Records `(u, y)` fitted from their first sample.
fn fitted_whole<'a>(records: [(&'a [f64], &'a [f64]); 2]) -> [FitRecord<'a>; 2] {
    records.map(|(u, y)| FitRecord {
        u,
        y,
        fit_from: Some(0),
    })
}

/// The weights fitted on the truth's thresholds and creep eigenvalues, an
/// offset per record.
fn on_the_truths_grid(truth: &ModelFile) -> IdentificationSettings {
    let h = &truth.hysteresis;
    let c = truth.creep.as_ref().unwrap();
    IdentificationSettings {
        hysteresis_thresholds: Some(h.thresholds.clone()),
        creep_thresholds: Some(c.thresholds.clone()),
        eigenvalues: Some(c.eigenvalues.clone()),
        offset_per_record: true,
        ..IdentificationSettings::default()
    }
}

#[test]
fn dynamics_and_offsets_come_back_from_two_rates() {
    let truth = dynamic_nominal();
    let model = HysteresisCreepModel::from_file(&truth).unwrap();
    let g_true = truth.dynamics.as_ref().unwrap().parameters();
    // two records at 20 and 40 Hz, each with its own sensor offset
    let (u1, u2) = (drive(20.0, 600.0), drive(40.0, 600.0));
    let y1: Vec<f64> = model.clone().run(&u1).iter().map(|v| v + 0.3).collect();
    let y2: Vec<f64> = model.clone().run(&u2).iter().map(|v| v - 1.7).collect();
    let records = fitted_whole([(&u1, &y1), (&u2, &y2)]);
    let settings = on_the_truths_grid(&truth);
    // with G known the weights are linear: back to rounding
    let known = identify_records(
        &records,
        TS,
        &IdentificationSettings {
            dynamics: Some(g_true),
            ..settings.clone()
        },
    )
    .unwrap();
    let offsets: Vec<f64> = known.report.records.iter().map(|r| r.offset).collect();
    assert!(
        (offsets[0] - 0.3).abs() < 1e-9 && (offsets[1] + 1.7).abs() < 1e-9,
        "{offsets:?}"
    );
    for r in &known.report.records {
        assert!(r.fit.rms_percent() < 1e-9, "{:?}", r.fit);
    }
    // and G itself by the output error
    let parts = DynamicsParts {
        low_pass: true,
        resonance: true,
        delay_fraction: true,
    };
    let id = fit_dynamics(&records, TS, &settings, parts, Par::Seq).unwrap();
    // the trials side by side: the same model, bit for bit
    let side_by_side = fit_dynamics(&records, TS, &settings, parts, Par::rayon(2)).unwrap();
    assert_eq!(
        serde_json::to_string(&id.model.to_file()).unwrap(),
        serde_json::to_string(&side_by_side.model.to_file()).unwrap()
    );
    let g = id.report.dynamics.as_ref().unwrap();
    eprintln!("{g:?}");
    let (r, rt) = (g.parameters.resonance.unwrap(), g_true.resonance.unwrap());
    let rel = |a: f64, b: f64| ((a - b) / b).abs();
    assert!(rel(g.parameters.low_pass.unwrap(), 1500.0) < 1e-6);
    assert!(rel(r.frequency, rt.frequency) < 1e-6);
    assert!(rel(r.damping, rt.damping) < 1e-6);
    assert!((g.parameters.delay_fraction - 0.3).abs() < 1e-6);
    // a third rate predicted, its offset zeroed on the hold
    let u3 = drive(100.0, 600.0);
    let y3: Vec<f64> = model.clone().run(&u3).iter().map(|v| v + 4.0).collect();
    let row = validate_record_zeroed(&id.model, "100 Hz", &u3, &y3, 500, 300..500).unwrap();
    let (offset, zeroed) = row.zeroed.unwrap();
    assert!((offset - (4.0 - 0.3)).abs() < 1e-4, "{offset}");
    assert!(zeroed.rms_percent() < 1e-3, "{zeroed:?}");
    assert!(row.errors.rms_percent() > 100.0 * 3.0 / zeroed.output_range);
}

/// The dead times searched side by side leave a start whose delay
/// fraction runs into the next dead time to that one's search: the model
/// is the one the best of the searches on their own gives, bit for bit.
#[test]
fn the_dead_time_search_equals_each_dead_time_searched_alone() {
    let truth = dynamic_nominal();
    let model = HysteresisCreepModel::from_file(&truth).unwrap();
    // two samples of dead time on top of G's fraction of 0.3
    let dead = 2;
    let delayed = |u: &[f64]| {
        let y = model.clone().run(u);
        let mut d = vec![y[0]; dead];
        d.extend_from_slice(&y[..y.len() - dead]);
        d
    };
    let (u1, u2) = (drive(20.0, 600.0), drive(40.0, 600.0));
    let (y1, y2) = (delayed(&u1), delayed(&u2));
    let records = fitted_whole([(&u1, &y1), (&u2, &y2)]);
    let settings = IdentificationSettings {
        delay: dead,
        ..on_the_truths_grid(&truth)
    };
    let parts = DynamicsParts {
        low_pass: true,
        resonance: true,
        delay_fraction: true,
    };
    let found = fit_dynamics_and_delay(&records, TS, &settings, parts, &[], Par::Seq).unwrap();
    // each dead time the search tries (two fewer, one more), alone
    let alone = (dead - 2..=dead + 1)
        .filter_map(|d| {
            let s = IdentificationSettings {
                delay: d,
                ..settings.clone()
            };
            fit_dynamics(&records, TS, &s, parts, Par::Seq).ok()
        })
        .min_by(|a, b| {
            let rms = |id: &mfcbeam::identification::Identification| {
                id.report.dynamics.as_ref().unwrap().rms
            };
            rms(a).total_cmp(&rms(b))
        })
        .unwrap();
    assert_eq!(
        serde_json::to_string(&found.model.to_file()).unwrap(),
        serde_json::to_string(&alone.model.to_file()).unwrap()
    );
    // the truth: its dead time, and G's fraction
    let g = found.report.dynamics.as_ref().unwrap().parameters;
    assert_eq!(found.model.to_file().delay, Some(dead), "{g:?}");
    assert!((g.delay_fraction - 0.3).abs() < 1e-6, "{g:?}");
}

#[test]
fn a_part_the_records_do_not_excite_is_reported_not_guessed() {
    // slow sine records through a model without any resonance: the
    // resonance's parameters do not change the output error
    let mut truth = dynamic_nominal();
    truth.dynamics = None;
    truth.creep = None;
    let model = HysteresisCreepModel::from_file(&truth).unwrap();
    let u = drive(20.0, 600.0);
    let y = model.clone().run(&u);
    let records = [FitRecord {
        u: &u,
        y: &y,
        fit_from: Some(0),
    }];
    let settings = IdentificationSettings {
        hysteresis_thresholds: Some(truth.hysteresis.thresholds.clone()),
        creep_operators: 0,
        ..IdentificationSettings::default()
    };
    let parts = DynamicsParts {
        resonance: true,
        ..DynamicsParts::default()
    };
    match fit_dynamics(&records, TS, &settings, parts, Par::Seq) {
        Err(e) => assert!(
            e.to_string().contains("not determined") || e.to_string().contains("show no such"),
            "{e}"
        ),
        Ok(id) => panic!("guessed {:?}", id.report.dynamics),
    }
}

/// A jagged tracking drive: random levels through a lag, a step of ±15 V
/// every 5 ms on top (what excites a resonance).
fn jagged(seed: u64, n: usize) -> Vec<f64> {
    let mut rng = mfcbeam::suite::conformance::Rng::new(seed);
    let (mut v, mut level) = (0.0f64, 0.0f64);
    (0..n)
        .map(|k| {
            if k.is_multiple_of(200) {
                level = rng.uniform(-700.0, 700.0);
            }
            v += 0.02 * (level - v);
            let jag = if (k / 50).is_multiple_of(2) {
                15.0
            } else {
                -15.0
            };
            (v + jag).clamp(-900.0, 900.0)
        })
        .collect()
}

/// With noise the estimates scatter by their standard errors: on a model
/// class that holds the truth (the thresholds and eigenvalues given), each
/// parameter of `G` lies within 4 of its reported standard errors of the
/// truth (σ̂² (JᵀJ)⁻¹ at the optimum: the linearized least-squares
/// covariance; 4 σ leaves a chance of 6e-5 per parameter for Gaussian
/// noise, and the noise is seeded).
#[test]
fn with_noise_the_dynamics_lie_within_their_standard_errors() {
    let mut truth = nominal_model().to_file().without_state();
    truth.sample_time = TS;
    truth.dynamics = Some(DynamicsData {
        low_pass: None,
        resonance: Some(ResonanceData {
            frequency: 740.0,
            damping: 0.014,
        }),
        delay_fraction: Some(0.3),
        state: None,
    });
    let model = HysteresisCreepModel::from_file(&truth).unwrap();
    let u = jagged(1, 8000);
    let mut rng = mfcbeam::suite::conformance::Rng::new(99);
    let sigma = 0.5;
    let y: Vec<f64> = model
        .clone()
        .run(&u)
        .iter()
        .map(|v| {
            // Box–Muller
            let (a, b) = (rng.uniform(f64::MIN_POSITIVE, 1.0), rng.uniform(0.0, 1.0));
            v + sigma * (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
        })
        .collect();
    let c = truth.creep.as_ref().unwrap();
    let settings = IdentificationSettings {
        hysteresis_thresholds: Some(truth.hysteresis.thresholds.clone()),
        creep_thresholds: Some(c.thresholds.clone()),
        eigenvalues: Some(c.eigenvalues.clone()),
        ..IdentificationSettings::default()
    };
    let records = [FitRecord {
        u: &u,
        y: &y,
        fit_from: Some(0),
    }];
    let parts = DynamicsParts {
        resonance: true,
        delay_fraction: true,
        ..DynamicsParts::default()
    };
    let id = fit_dynamics(&records, TS, &settings, parts, Par::Seq).unwrap();
    let g = id.report.dynamics.as_ref().unwrap();
    eprintln!("{g:?}");
    let r = g.parameters.resonance.unwrap();
    let se = g.standard_errors;
    for (name, found, expected, s) in [
        ("frequency", r.frequency, 740.0, se[1].unwrap()),
        ("damping", r.damping, 0.014, se[2].unwrap()),
        (
            "delay fraction",
            g.parameters.delay_fraction,
            0.3,
            se[3].unwrap(),
        ),
    ] {
        assert!(s > 0.0 && s.is_finite(), "{name}: {s}");
        assert!(
            (found - expected).abs() <= 4.0 * s,
            "{name}: {found} vs {expected}, standard error {s}"
        );
    }
    // and the noise is what is left
    assert!((g.rms / sigma - 1.0).abs() < 0.05, "{} vs {sigma}", g.rms);
}

/// With the rate part off — a `dynamics` entry with no part, or none — the
/// model and its compensator are today's, bit for bit.
#[test]
fn with_the_rate_part_off_the_model_is_todays_bit_for_bit() {
    let plain = nominal_model().to_file().without_state();
    let mut off = plain.clone();
    off.dynamics = Some(DynamicsData {
        low_pass: None,
        resonance: None,
        delay_fraction: None,
        state: None,
    });
    let u = jagged(3, 3000);
    let a = HysteresisCreepModel::from_file(&plain).unwrap().run(&u);
    let b = HysteresisCreepModel::from_file(&off).unwrap().run(&u);
    assert!(a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()));
    let settings = CompensatorSettings::with_limits(-1000.0, 1000.0);
    let mut c1 = Compensator::<f32, Inline<12, 60>>::from_file(&plain, settings).unwrap();
    let mut c2 = Compensator::<f32, Inline<12, 60>>::from_file(&off, settings).unwrap();
    assert_eq!(c2.delay(), 0);
    for &t in &a {
        let (x, y) = (c1.compensate(t as f32), c2.compensate(t as f32));
        assert_eq!(x.u.to_bits(), y.u.to_bits());
        assert_eq!((x.saturated, x.fault), (y.saturated, y.fault));
    }
}

/// A finite target that `G⁻¹` cannot reach in `f32` (it overflows) is a
/// fault, held: no infinity enters `G`'s state, and the identity resumes.
#[test]
fn an_unreachable_huge_target_is_a_fault_and_poisons_nothing() {
    let file = dynamic_nominal();
    let mut c =
        Compensator::<f32, Inline<12, 60>>::from_file(&file, CompensatorSettings::unlimited())
            .unwrap();
    let mut m = Model::<f32, Inline<12, 60>>::from_file(&file).unwrap();
    let y: Vec<f64> = HysteresisCreepModel::from_file(&file)
        .unwrap()
        .run(&drive(100.0, 600.0))
        .into_iter()
        .take(3000)
        .collect();
    let mut worst_after = 0.0f64;
    for k in 0..y.len() {
        let t = if k == 1000 {
            3e38
        } else {
            preview(&y, 1, k) as f32
        };
        let out = c.compensate(t);
        if k == 1000 {
            assert!(out.fault && out.u.is_finite(), "{out:?}");
        }
        let w = m.step(out.u);
        assert!(w.is_finite());
        if k > 1002 {
            worst_after = worst_after.max((w as f64 - y[k]).abs());
        }
    }
    // the held sample is what the plant got, and G's copy followed it: the
    // identity resumes with the next target (within f32's 3e-3 of before)
    eprintln!("worst after the fault: {worst_after:e}");
    assert!(worst_after < 1e-2, "{worst_after}");
}
