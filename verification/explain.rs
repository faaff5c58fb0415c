//! Reading a failure: a candidate that declines a part is skipped, not
//! failed; the case before shrinking is kept; the reference is split into
//! its parts; and each known mistake, made on purpose, is named by its hint
//! (and a correct candidate gets none).

use mfcbeam::io::format_f64;
use mfcbeam::operators::nominal::nominal_model_file;
use mfcbeam::prelude::*;
use mfcbeam::suite::conformance::explain::{explain, reference_run, Hint, Kind};
use mfcbeam::suite::conformance::{
    check_model, heap_model, model_properties, path, with_state_after, ConformanceSettings, Outcome,
};
use mfcbeam::suite::reference::NaiveModel;

fn run(file: &ModelFile, u: &[f64]) -> Vec<f64> {
    NaiveModel::from_file(file).unwrap().run(u)
}

/// A nominal input: up, down, up again, beyond the largest threshold.
fn input() -> Vec<f64> {
    path(&[0.0, 900.0, -400.0, 600.0], 12)
}

/// `H` alone, as most published code is: a model with any other part is
/// declined with `ModelError::Unsupported`.
fn hysteresis_alone(f: &ModelFile) -> Result<Box<dyn ActuatorModel>, ModelError> {
    if f.creep.is_some()
        || f.superposition.is_some()
        || f.delay.unwrap_or(0) > 0
        || f.offset.is_some()
    {
        return Err(ModelError::Unsupported {
            part: "creep, S, dead time or offset".into(),
        });
    }
    heap_model(f)
}

#[test]
fn declined_cases_are_skipped_and_counted_not_failed() {
    let s = ConformanceSettings {
        cases: 24,
        ..ConformanceSettings::default()
    };
    let report = check_model(&hysteresis_alone, &s).unwrap();
    eprintln!("{report}");
    assert!(report.passed(), "{report}");
    let (ran, skipped) = report.coverage();
    assert!(ran > 0 && skipped > 0, "ran {ran}, skipped {skipped}");
    // the paper's inputs use the nominal model, which has creep: all skipped
    let paper = report.property("paper_inputs").unwrap();
    assert_eq!((paper.cases, paper.failures), (0, 0));
    assert!(paper.skipped > 0);
    assert!(paper.skip_reason.as_deref().unwrap().contains("creep"));
    // the H properties ran on hysteresis-only models
    assert!(report.property("madelung_return_point").unwrap().cases > 0);
    assert!(report.to_string().contains("coverage:"));
}

/// A declined case stays declined whatever the outputs were: the recheck
/// of one case says `Unsupported`, not `Failed`.
#[test]
fn a_declined_case_rechecks_as_unsupported() {
    let case = mfcbeam::suite::conformance::Case {
        model: nominal_model_file(),
        input: input(),
        limits: None,
    };
    let s = ConformanceSettings::default();
    let outcome = model_properties()
        .recheck("agreement", &case, &hysteresis_alone, &s)
        .unwrap();
    assert!(matches!(outcome, Outcome::Unsupported(_)), "{outcome:?}");
}

#[test]
fn the_case_before_shrinking_is_kept() {
    // thresholds read as band widths: every threshold halved
    let halved = |f: &ModelFile| {
        let mut m = f.clone();
        m.hysteresis.thresholds.iter_mut().for_each(|r| *r *= 0.5);
        m.hysteresis.state = None;
        heap_model(&m)
    };
    let s = ConformanceSettings {
        cases: 12,
        ..ConformanceSettings::default()
    };
    let report = check_model(&halved, &s).unwrap();
    let agreement = report.property("agreement").unwrap();
    let c = agreement.counterexample.as_ref().expect("caught");
    assert!(c.unshrunk_case.input.len() >= c.case.input.len());
    // the kept case is the one that failed first: it fails again
    let again = model_properties()
        .recheck("agreement", &c.unshrunk_case, &halved, &s)
        .unwrap();
    assert!(matches!(again, Outcome::Failed(_)));
}

#[test]
fn the_reference_is_split_into_its_parts() {
    let mut file = nominal_model_file();
    file.offset = Some(3.5);
    file.delay = Some(2);
    let u = input();
    let y = run(&file, &u);
    let k = 20;
    let inner = ModelFile {
        delay: None,
        offset: None,
        ..file.clone()
    };
    let h = run(&file.clone().hysteresis_part(), &u);
    let hc = run(&inner, &u);
    // a candidate off at sample k only
    let mut found = y.clone();
    found[k] += 1.0;
    let e = explain(Kind::Model, &file, &u, None, &found, 1e-9);
    assert_eq!(e.sample, k);
    let text = e.parts.join("\n");
    // y_k = H_{k-d} + C_{k-d} + offset, each part from its own run
    let j = k - 2;
    for line in [
        format!("H[u] at sample {j} = {}", format_f64(h[j])),
        format!("C[u] at sample {j} = {}", format_f64(hc[j] - h[j])),
        "offset = 3.5".to_string(),
        format!("y[{k}] (the reference) = {}", format_f64(y[k])),
    ] {
        assert!(text.contains(&line), "{line} missing from\n{text}");
    }
    // the parts add up (closed form of the model)
    assert!((h[j] + (hc[j] - h[j]) + 3.5 - y[k]).abs() <= 8.0 * f64::EPSILON * y[k].abs());
}

/// Each mistake, made on purpose, gets its hint and no other; a correct
/// candidate gets none.
#[test]
fn known_mistakes_are_named() {
    let u = input();
    let nominal = nominal_model_file();
    let h = nominal.clone().hysteresis_part();
    let tol = 1e-9;
    let hints =
        |kind, file: &ModelFile, found: &[f64]| explain(kind, file, &u, None, found, tol).hints;

    // correct: no hint
    assert!(hints(Kind::Model, &nominal, &run(&nominal, &u)).is_empty());

    // creep missing
    let no_creep = ModelFile {
        creep: None,
        ..nominal.clone()
    };
    assert_eq!(
        hints(Kind::Model, &nominal, &run(&no_creep, &u)),
        [Hint::CreepMissing]
    );

    // thresholds halved, doubled (virgin models)
    let scaled = |f: f64| {
        let mut m = h.clone();
        m.hysteresis.thresholds.iter_mut().for_each(|r| *r *= f);
        m
    };
    assert_eq!(
        hints(Kind::Model, &h, &run(&scaled(0.5), &u)),
        [Hint::ThresholdsHalved]
    );
    assert_eq!(
        hints(Kind::Model, &h, &run(&scaled(2.0), &u)),
        [Hint::ThresholdsDoubled]
    );

    // with a state no longer admissible for the halved thresholds: the plays
    // of the mistaken candidate, summed by hand
    let with_state = with_state_after(&h, &[700.0, -100.0]);
    let state = with_state.hysteresis.state.clone().unwrap();
    let mut z = state.clone();
    let halved: Vec<f64> = u
        .iter()
        .map(|&x| {
            z.iter_mut()
                .zip(&h.hysteresis.thresholds)
                .zip(&h.hysteresis.weights)
                .map(|((z, r), w)| {
                    *z = z.clamp(x - 0.5 * r, x + 0.5 * r);
                    w * *z
                })
                .sum()
        })
        .collect();
    assert!(hints(Kind::Model, &with_state, &halved).contains(&Hint::ThresholdsHalved));

    // the state ignored
    assert_eq!(
        hints(Kind::Model, &with_state, &run(&h, &u)),
        [Hint::StateIgnored]
    );

    // the first input skipped: the initial state's output at sample 0
    let initial: f64 = h
        .hysteresis
        .weights
        .iter()
        .zip(&state)
        .map(|(w, z)| w * z)
        .sum();
    let mut skipped = vec![initial];
    skipped.extend(run(&with_state, &u[1..]));
    assert_eq!(
        hints(Kind::Model, &with_state, &skipped),
        [Hint::FirstInputSkipped]
    );

    // only the first sample off, nothing more precise
    let mut first = run(&h, &u);
    first[0] += 0.25;
    assert_eq!(hints(Kind::Model, &h, &first), [Hint::FirstSample]);

    // offset and dead time
    let mut offset = nominal.clone();
    offset.offset = Some(2.0);
    assert_eq!(
        hints(Kind::Model, &offset, &run(&nominal, &u)),
        [Hint::OffsetMissing]
    );
    let mut delayed = nominal.clone();
    delayed.delay = Some(3);
    assert_eq!(
        hints(Kind::Model, &delayed, &run(&nominal, &u)),
        [Hint::DeadTimeIgnored]
    );

    // the inverse with halved thresholds
    let y = run(&h, &u);
    let inv_halved = reference_run(Kind::InverseHysteresis, &scaled(0.5), &y, None).unwrap();
    let e = explain(Kind::InverseHysteresis, &h, &y, None, &inv_halved, tol);
    assert_eq!(e.hints, [Hint::ThresholdsHalved]);

    // the inverse with halved thresholds from a state that is no longer
    // admissible for them: the textbook H⁻¹ (22) of the mistaken H
    let mut halved_state = with_state.clone();
    halved_state
        .hysteresis
        .thresholds
        .iter_mut()
        .for_each(|r| *r *= 0.5);
    assert!(reference_run(Kind::InverseHysteresis, &halved_state, &y, None).is_none());
    let mut mistaken = NaiveModel::from_file(&with_state).unwrap().hysteresis;
    mistaken.r = halved_state.hysteresis.thresholds.clone();
    let found = mistaken.inverse().run(&y);
    let e = explain(Kind::InverseHysteresis, &with_state, &y, None, &found, tol);
    assert_eq!(e.hints, [Hint::ThresholdsHalved]);

    // the compensator without its creep part
    let targets: Vec<f64> = u.iter().map(|x| 0.4 * x).collect();
    let limits = Some((-1e300, 1e300));
    let no_creep_u = reference_run(Kind::Compensator, &no_creep, &targets, limits).unwrap();
    let e = explain(
        Kind::Compensator,
        &nominal,
        &targets,
        limits,
        &no_creep_u,
        tol,
    );
    assert_eq!(e.hints, [Hint::CreepMissing]);
    assert!(e
        .parts
        .iter()
        .any(|p| p.starts_with("C[u] of the reference's u")));
}
