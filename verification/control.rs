//! The closed loop (`mfcbeam::control`): the Riccati solver against closed
//! forms, the PID rule's placed poles, the loop against an independent
//! simulation of the same loop, the open loop against Fig. 14 bit for bit,
//! robustness of the designs on the full beam, held answers, and any
//! program through the per-sample protocol.

use std::time::Duration;

use mfcbeam::control::pid::{Pid, PidGains, PidSettings};
use mfcbeam::control::process::ProcessController;
use mfcbeam::control::riccati::solve_dare;
use mfcbeam::control::state_feedback::{StateFeedback, StateFeedbackDesign, StateFeedbackSettings};
use mfcbeam::control::*;
use mfcbeam::suite::scenarios::{run, scenario, ScenarioContext};
use nalgebra::{DMatrix, DVector};

fn bench() -> Benchmark {
    Benchmark::nominal().unwrap()
}

#[test]
fn riccati_matches_the_scalar_closed_form() {
    // x = a²x − a²b²x²/(r + b²x) + q  ⇔  b²x² + (r(1 − a²) − qb²)x − qr = 0
    for (a, b, q, r) in [
        (0.9f64, 1.0f64, 1.0f64, 1.0f64),
        (1.2, 0.5, 2.0, 0.1),
        (0.999_77, 3e-9, 1e6, 1e-6),
        (-1.5, 2.0, 1e-3, 10.0),
    ] {
        let (p, c) = (b * b, r * (1.0 - a * a) - q * b * b);
        let exact = (-c + (c * c + 4.0 * p * q * r).sqrt()) / (2.0 * p);
        let sol = solve_dare(
            &DMatrix::from_element(1, 1, a),
            &DVector::from_element(1, b),
            &DMatrix::from_element(1, 1, q),
            r,
        )
        .unwrap();
        let rel = (sol.x[(0, 0)] - exact).abs() / exact;
        // the quadratic's roots and the doubling both round to a few ε
        // times the conditioning 1/(1 − |a_cl|); 1e-9 covers a_cl ≈ 0.9999
        assert!(rel < 1e-9, "a={a}: {} vs {exact} ({rel:e})", sol.x[(0, 0)]);
        let a_cl = a - b * sol.gain[0];
        assert!(a_cl.abs() < 1.0, "not stabilizing: {a_cl}");
    }
}

#[test]
fn riccati_solutions_of_the_designs_satisfy_their_equations() {
    let b = bench();
    let d = StateFeedbackDesign::design(
        &b.beam,
        b.settings.sample_time,
        &b.feedforward.y_d,
        &b.feedforward.u_d,
        &StateFeedbackSettings::default(),
    )
    .unwrap();
    assert_eq!(d.modes, 4, "modes below 500 Hz: 12, 50, 161, 306 Hz");
    // relative residual: ε times the size and the conditioning of the
    // lightly damped modes (|λ| ≈ 1 − 1e-4)
    assert!(
        d.residuals[0] < 1e-10 && d.residuals[1] < 1e-10,
        "{:?}",
        d.residuals
    );
    assert!(d.disturbance_increment > 0.07 && d.disturbance_increment < 0.08);
}

#[test]
fn a_non_stabilizable_pair_is_refused() {
    // a = 2, b = 0: the unstable mode cannot be moved
    let e = solve_dare(
        &DMatrix::from_element(1, 1, 2.0),
        &DVector::from_element(1, 0.0),
        &DMatrix::from_element(1, 1, 1.0),
        1.0,
    );
    assert!(e.is_err(), "{e:?}");
    let e = solve_dare(
        &DMatrix::from_element(1, 1, 0.5),
        &DVector::from_element(1, 1.0),
        &DMatrix::from_element(1, 1, 1.0),
        0.0,
    )
    .unwrap_err();
    assert!(e.to_string().contains("R must be"), "{e}");
}

#[test]
fn the_pid_rule_places_the_closed_loop_poles_of_the_first_mode() {
    let b = bench();
    let s = PidSettings::default();
    let g = PidGains::design(&b.beam, &s).unwrap();
    let (w1, z1) = (b.beam.omega[0], b.beam.damping_ratios()[0]);
    let k1 = b.beam.input[0] * b.beam.output[0] / (w1 * w1);
    // s(s² + 2ζ₁ω₁s + ω₁²) + k₁ω₁²(K_d s² + K_p s + K_i) against
    // (s + ω)(s² + 2ζ_c ω s + ω²), ω = ω₁
    let got = [
        2.0 * z1 * w1 + k1 * w1 * w1 * g.kd,
        w1 * w1 + k1 * w1 * w1 * g.kp,
        k1 * w1 * w1 * g.ki,
    ];
    let w = w1;
    let want = [
        (1.0 + 2.0 * s.damping) * w,
        (1.0 + 2.0 * s.damping) * w * w,
        w * w * w,
    ];
    for (a, b) in got.iter().zip(want) {
        assert!((a - b).abs() <= 1e-13 * b, "{a} vs {b}");
    }
    assert!((g.tf - g.kd / g.kp / s.derivative_filter).abs() <= 1e-16);
    let bad = PidSettings {
        frequency_ratio: 0.5,
        ..s
    };
    assert!(
        PidGains::design(&b.beam, &bad).is_err(),
        "K_p < 0 is refused"
    );
}

#[test]
fn the_zero_controller_is_fig14_bit_for_bit() {
    let b = bench();
    let r = b.run("nominal", &mut ZeroController).unwrap();
    let fig14 = run(
        scenario("feedforward").unwrap(),
        &ScenarioContext::nominal(),
    )
    .unwrap();
    for (ours, theirs) in [
        ("tip", &r.trace.tip),
        ("u", &r.trace.u),
        ("u_fs", &r.trace.u_fs),
    ] {
        let want = fig14.col(ours);
        assert_eq!(want.len(), theirs.len());
        for (k, (x, y)) in want.iter().zip(theirs.iter()).enumerate() {
            assert_eq!(x.to_bits(), y.to_bits(), "{ours} at {k}: {x} vs {y}");
        }
    }
    assert_eq!(r.scores.held, 0);
    assert!(r.trace.correction.iter().all(|c| *c == 0.0));
}

/// The loop, written again from its definition on the other
/// discretization (nalgebra's matrix exponential, Van Loan), with the
/// actuator `gain · ς` in place of `W ∘ W⁻¹` — exact for matched models
/// while unsaturated.
fn linear_loop(b: &Benchmark, setup: &LoopSetup, gain: f64, c: &mut dyn Controller) -> Vec<f64> {
    let ts = setup.sample_time;
    let plant = b.beam.discrete_state_space(ts).unwrap();
    let tip = mfcbeam::beam::modal::ModalModel {
        input: b.beam.output.clone(),
        ..b.beam.clone()
    }
    .discrete_state_space(ts)
    .unwrap();
    let mut x = DVector::zeros(plant.order());
    let mut last = 0.0;
    let mut y = Vec::new();
    for k in 0..setup.reference.len() {
        let yk = plant.c.dot(&x);
        let sample = LoopSample {
            k,
            t: k as f64 * ts,
            reference: setup.reference[k],
            measurement: yk + setup.noise[k],
        };
        let delta = match c.step(&sample).unwrap() {
            Some(v) if v.is_finite() => v,
            _ => last,
        };
        last = delta;
        let w = gain * (setup.feedforward[k] + delta);
        x = &plant.a * &x + &plant.b * w + &tip.b * setup.force[k];
        y.push(yk);
    }
    y
}

#[test]
fn the_loop_is_an_independent_simulation_of_the_same_loop() {
    let b = bench();
    let mut setup = b.setup("impulse").unwrap();
    setup.noise = gaussian_noise(setup.reference.len(), NOISE, 7);
    for kind in [BuiltinController::Pid, BuiltinController::StateFeedback] {
        let trace = run_loop(&setup, b.controller(kind).unwrap().as_mut()).unwrap();
        assert!(!trace.saturated.iter().any(|s| *s));
        let y = linear_loop(&b, &setup, 1.0, b.controller(kind).unwrap().as_mut());
        // W∘W⁻¹ = id to 1e-13 V here, negligible; the two discretizations
        // agree to 1e-9 relative (the complex eigendecomposition's accuracy,
        // verification/beam.rs), amplified up to 1/(2ζ₁) ≈ 33 near the
        // first resonance, of the tip's scale
        let scale = y.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let tol = 1e-9 / (2.0 * b.beam.damping_ratios()[0]) * scale;
        let worst = y
            .iter()
            .zip(&trace.tip)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        eprintln!("{kind:?}: the two loops differ by {worst:.2e} m (tolerance {tol:.2e})");
        assert!(worst < tol, "{kind:?}: {worst:e} m (tolerance {tol:e})");
    }
}

#[test]
fn both_designs_stay_stable_with_the_plant_gain_off_by_30_percent() {
    // on the full 15-mode beam (the LQ design keeps 4): an impulse rings
    // down whatever the actuator's gain in [0.7, 1.3]
    let b = bench();
    let mut setup = b.setup("nominal").unwrap();
    setup.feedforward.fill(0.0);
    setup.reference.fill(0.0);
    setup.force[100] = IMPULSE / setup.sample_time;
    for kind in [BuiltinController::Pid, BuiltinController::StateFeedback] {
        for gain in [0.7, 1.0, 1.3] {
            let y = linear_loop(&b, &setup, gain, b.controller(kind).unwrap().as_mut());
            let peak = |ys: &[f64]| ys.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            // the slowest closed-loop pole (the PID at gain 0.7) has a time
            // constant of about 0.12 s: 3.6 s later, e^-30
            let (first, last) = (peak(&y[..2000]), peak(&y[y.len() - 2000..]));
            assert!(
                last < 1e-3 * first,
                "{kind:?} at gain {gain}: {first:e} -> {last:e}"
            );
        }
    }
}

/// Holds `Δ` on the samples in `gaps`, answering nothing or NaN or ∞.
struct Gappy<C> {
    inner: C,
    gaps: std::ops::Range<usize>,
}

impl<C: Controller> Controller for Gappy<C> {
    fn name(&self) -> String {
        "gappy".into()
    }
    fn step(&mut self, s: &LoopSample) -> Result<Option<f64>, ControlError> {
        let v = self.inner.step(s)?;
        Ok(match s.k {
            k if self.gaps.contains(&k) => [None, Some(f64::NAN), Some(f64::INFINITY)][k % 3],
            _ => v,
        })
    }
}

#[test]
fn nothing_nan_and_infinity_are_held_and_flagged() {
    let b = bench();
    let setup = b.setup("step-load").unwrap();
    let gaps = 16_100..16_130;
    let mut gappy = Gappy {
        inner: Pid::new(
            PidGains::design(&b.beam, &PidSettings::default()).unwrap(),
            b.settings.sample_time,
        )
        .unwrap(),
        gaps: gaps.clone(),
    };
    let tr = run_loop(&setup, &mut gappy).unwrap();
    assert_eq!(score(&tr, 2.9, 2.975).held, gaps.len());
    for k in gaps.clone() {
        assert!(tr.held[k]);
        assert_eq!(tr.correction[k], tr.correction[gaps.start - 1]);
    }
    assert!(tr.tip.iter().chain(&tr.u).all(|v| v.is_finite()));
    // a measurement that is not finite: the built-in designs answer
    // nothing and keep their state
    let mut lq = StateFeedback::new(
        StateFeedbackDesign::design(
            &b.beam,
            b.settings.sample_time,
            &b.feedforward.y_d,
            &b.feedforward.u_d,
            &StateFeedbackSettings::default(),
        )
        .unwrap(),
    )
    .unwrap();
    let before = lq.estimate().to_vec();
    let nan = LoopSample {
        k: 0,
        t: 0.0,
        reference: 0.0,
        measurement: f64::NAN,
    };
    assert_eq!(lq.step(&nan).unwrap(), None);
    assert_eq!(lq.estimate(), &before[..]);
}

#[test]
fn scores_of_a_known_trace() {
    let n = 101;
    let t: Vec<f64> = (0..n).map(|k| k as f64 * 0.01).collect();
    // error 2 before t = 0.5, then alternating ±1
    let tip: Vec<f64> = (0..n)
        .map(|k| {
            if k < 50 {
                2.0
            } else if k % 2 == 0 {
                1.0
            } else {
                -1.0
            }
        })
        .collect();
    let tr = LoopTrace {
        reference: vec![0.0; n],
        u_fs: vec![600.0; n],
        u_bs: vec![400.0; n],
        saturated: (0..n).map(|k| k < 3).collect(),
        held: vec![false; n],
        compute_time: vec![1e-6; n],
        t,
        tip,
        ..LoopTrace::default()
    };
    let s = score(&tr, 0.1, 0.5);
    assert_eq!((s.during_rms, s.during_max), (2.0, 2.0));
    assert_eq!((s.after_rms, s.after_max), (1.0, 1.0));
    assert_eq!((s.max_error, s.residual, s.peak_voltage), (2.0, 1.0, 600.0));
    assert!((s.saturated_time - 0.03).abs() < 1e-15);
    assert!((s.compute_mean - 1e-6).abs() < 1e-18);
}

#[test]
fn the_noise_is_gaussian_with_the_stated_deviation() {
    let n = 200_000;
    let x = gaussian_noise(n, 2.0, 1);
    let mean = x.iter().sum::<f64>() / n as f64;
    let var = x.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / n as f64;
    // standard errors: σ/√n = 0.0045 for the mean, σ²√(2/n) = 0.013 for
    // the variance; 5 of them
    assert!(mean.abs() < 0.023, "{mean}");
    assert!((var - 4.0).abs() < 0.064, "{var}");
    assert_eq!(gaussian_noise(5, 1.0, 9), gaussian_noise(5, 1.0, 9));
    assert_ne!(gaussian_noise(5, 1.0, 9), gaussian_noise(5, 1.0, 10));
}

fn sh(script: &str) -> Result<ProcessController, ControlError> {
    ProcessController::spawn(
        "sh",
        &["-c".into(), script.into()],
        &[],
        Duration::from_secs(2),
    )
}

fn sample(k: usize) -> LoopSample {
    LoopSample {
        k,
        t: k as f64 * 2e-4,
        reference: 1e-3,
        measurement: 0.5e-3,
    }
}

#[test]
fn a_program_through_the_protocol_runs_the_same_loop() {
    // a P controller in Python: Δ = −k (m − r), in the same IEEE arithmetic
    let b = bench();
    let setup = b.setup("step-load").unwrap();
    let gain = 2e4;
    let script = format!(
        "import sys\n\
         for line in iter(sys.stdin.readline, ''):\n\
         \x20   k, t, r, m = line.split(',')\n\
         \x20   print(repr(-{gain:?} * (float(m) - float(r))), flush=True)\n"
    );
    let mut program = ProcessController::spawn(
        "python3",
        &["-c".into(), script],
        &[],
        Duration::from_secs(5),
    )
    .unwrap();
    let ours = run_loop(&setup, &mut program).unwrap();
    struct P(f64);
    impl Controller for P {
        fn name(&self) -> String {
            "P".into()
        }
        fn step(&mut self, s: &LoopSample) -> Result<Option<f64>, ControlError> {
            Ok(Some(-self.0 * (s.measurement - s.reference)))
        }
    }
    let theirs = run_loop(&setup, &mut P(gain)).unwrap();
    assert_eq!(ours.tip, theirs.tip);
    assert_eq!(ours.correction, theirs.correction);
}

#[test]
fn a_program_that_dies_hangs_or_writes_garbage_is_named() {
    let cases = [
        ("read l; echo 1.5; read l; exit 3", 1, "exited"),
        (
            "read l; echo 'zero point five'",
            0,
            "'zero point five' is not a number",
        ),
        ("read l; sleep 30", 0, "no answer within 0.3 s"),
        ("exit 0", 0, "exited"),
    ];
    for (script, at, message) in cases {
        let mut c = ProcessController::spawn(
            "sh",
            &["-c".into(), script.into()],
            &[],
            Duration::from_millis(300),
        )
        .unwrap();
        let started = std::time::Instant::now();
        let mut result = Ok(None);
        for k in 0..=at {
            result = c.step(&sample(k));
        }
        let e = result.unwrap_err().to_string();
        assert!(
            e.contains(message) && e.contains(&format!("at sample {at}")),
            "{script}: {e}"
        );
        assert!(started.elapsed() < Duration::from_secs(5), "{script}: hung");
    }
    // nothing and nan are held, not errors
    let mut c = sh("read l; echo; read l; echo nan; read l; echo -2.5e1").unwrap();
    assert_eq!(c.step(&sample(0)).unwrap(), None);
    assert_eq!(c.step(&sample(1)).unwrap(), None);
    assert_eq!(c.step(&sample(2)).unwrap(), Some(-25.0));
    let missing =
        ProcessController::spawn("/nonexistent/controller", &[], &[], Duration::from_secs(1));
    assert!(missing
        .err()
        .unwrap()
        .to_string()
        .contains("could not start"));
}

#[test]
fn the_protocol_line_carries_the_sample_exactly() {
    // the program echoes the measurement back: the loop gets its bits
    let mut c = sh("while IFS=, read k t r m; do echo \"$m\"; done").unwrap();
    let s = LoopSample {
        k: 3,
        t: 6e-4,
        reference: 0.1,
        measurement: 1.234_567_890_123_456_7e-4,
    };
    assert_eq!(c.step(&s).unwrap(), Some(s.measurement));
}

#[test]
fn a_controller_file_round_trips_and_a_bad_one_is_named() {
    use mfcbeam::control::file::ControllerFile;
    let b = bench();
    for kind in [BuiltinController::Pid, BuiltinController::StateFeedback] {
        let file = b.controller_file(kind).unwrap();
        let text = serde_json::to_string(&file).unwrap();
        let back: ControllerFile = serde_json::from_str(&text).unwrap();
        assert_eq!(back, file, "float_roundtrip keeps every bit");
    }
    let pid = r#"{"sample_time": 2e-4, "pid": {"kp": 1, "ki": 1, "kd": 1, "tf": 1e-3}}"#;
    assert!(serde_json::from_str::<ControllerFile>(pid)
        .unwrap()
        .build()
        .is_ok());
    let bad = [
        (
            r#"{"sample_time": 0, "pid": {"kp": 1, "ki": 1, "kd": 1, "tf": 1e-3}}"#,
            "sample_time",
        ),
        (
            r#"{"sample_time": 2e-4, "pid": {"kp": -1, "ki": 1, "kd": 1, "tf": 1e-3}}"#,
            "kp",
        ),
        (
            r#"{"sample_time": 2e-4, "pid": {"kp": 1, "ki": 1, "kd": 1, "tf": 0}}"#,
            "tf",
        ),
        (
            r#"{"sample_time": 2e-4, "state_feedback": {"modes": 1, "a": [1, 0, 0], "b": [0, 1],
                "c": [1, 0], "observer": [1, 1], "feedback": [1, 1], "residuals": [0, 0],
                "disturbance_increment": 0.1}}"#,
            "a: 3 entries; 2 states need 4",
        ),
        (
            r#"{"sample_time": 2e-4, "state_feedback": {"modes": 0, "a": [], "b": [],
                "c": [], "observer": [], "feedback": [], "residuals": [0, 0],
                "disturbance_increment": 0.1}}"#,
            "b: 0 states",
        ),
    ];
    for (text, needle) in bad {
        let e = serde_json::from_str::<ControllerFile>(text)
            .unwrap()
            .build()
            .unwrap_err();
        assert!(e.to_string().contains(needle), "{e}");
    }
    // unknown fields and designs are refused by the parser
    assert!(serde_json::from_str::<ControllerFile>(
        r#"{"sample_time": 2e-4, "pid": {"kp": 1, "ki": 1, "kd": 1, "tf": 1e-3, "kx": 2}}"#
    )
    .is_err());
    assert!(serde_json::from_str::<ControllerFile>(r#"{"sample_time": 2e-4, "mpc": {}}"#).is_err());
}

#[test]
fn an_overflow_is_held_and_never_enters_the_state() {
    let b = bench();
    for kind in [BuiltinController::Pid, BuiltinController::StateFeedback] {
        let mut c = b.controller_file(kind).unwrap().build().unwrap();
        let at = |k: usize, m: f64| LoopSample {
            k,
            t: k as f64 * 2e-4,
            reference: 0.0,
            measurement: m,
        };
        assert!(c.step(&at(0, 1e-6)).unwrap().is_some());
        // gains of 1e5..1e7 V/m on 1e304 m overflow: nothing, state kept
        assert_eq!(c.step(&at(1, 1e304)).unwrap(), None, "{kind:?}");
        assert!(c.state_is_finite());
        assert!(c.step(&at(2, 1e-6)).unwrap().unwrap().is_finite());
    }
}
