//! The fixed mode of the conformance checks: a candidate that implements
//! one given model (its parameters compiled in) and reads no model file.
//! Every property that varies only the input runs on that model; the
//! others are reported as not runnable; split and resume goes through the
//! candidate's own save and restore.

use mfcbeam::operators::nominal::nominal_model_file;
use mfcbeam::prelude::*;
use mfcbeam::realtime::Hysteresis;
use mfcbeam::suite::conformance::explain::Hint;
use mfcbeam::suite::conformance::fixed::{
    fixed_compensator_factory, fixed_inverse_hysteresis_factory, fixed_model_factory, Restorable,
    OTHER_MODEL,
};
use mfcbeam::suite::conformance::{
    check_compensator, check_inverse_hysteresis, check_model, ConformanceReport,
    ConformanceSettings,
};

fn settings(fixed: &ModelFile) -> ConformanceSettings {
    ConformanceSettings {
        cases: 12,
        fixed_model: Some(fixed.clone()),
        ..ConformanceSettings::default()
    }
}

fn not_on_fixed(report: &ConformanceReport) -> Vec<&'static str> {
    report
        .properties
        .iter()
        .filter(|p| p.not_on_fixed_model.is_some())
        .map(|p| p.name)
        .collect()
}

/// The nominal model (it has creep) compiled into the project's own `W`:
/// everything that can run holds, split and resume through save and
/// restore; the properties of `H` alone and of `S` alone are listed.
#[test]
fn the_projects_model_as_a_fixed_implementation() {
    let fixed = nominal_model_file();
    let m = fixed.clone();
    let factory = fixed_model_factory(fixed.clone(), move || {
        let b: Box<dyn ActuatorModel> = Box::new(Restorable(HysteresisCreepModel::from_file(&m)?));
        Ok(b)
    });
    let report = check_model(&factory, &settings(&fixed)).unwrap();
    eprintln!("{report}");
    assert!(report.passed(), "{report}");
    for p in [
        "agreement",
        "paper_inputs",
        "odd_symmetry",
        "split_and_resume",
    ] {
        assert!(report.property(p).unwrap().cases > 0, "{p} ran no case");
    }
    let listed = not_on_fixed(&report);
    for p in [
        "superposition_monotone",
        "madelung_return_point",
        "masing",
        "intersection",
    ] {
        assert!(listed.contains(&p), "{p} not listed: {listed:?}");
    }
    assert!(report.to_string().contains("not on a fixed model:"));
    // the deterministic candidate restores bit for bit
    assert_eq!(
        report.property("split_and_resume").unwrap().worst_error,
        0.0
    );
}

/// `H` alone compiled in: the branching rules run on the fixed model too.
#[test]
fn hysteresis_alone_runs_the_branching_rules() {
    let fixed = nominal_model_file().hysteresis_part();
    let m = fixed.clone();
    let factory = fixed_model_factory(fixed.clone(), move || {
        let b: Box<dyn ActuatorModel> = Box::new(Restorable(HysteresisCreepModel::from_file(&m)?));
        Ok(b)
    });
    let s = ConformanceSettings {
        hysteresis_only: true,
        ..settings(&fixed)
    };
    let report = check_model(&factory, &s).unwrap();
    assert!(report.passed(), "{report}");
    for p in [
        "madelung_turning_point",
        "madelung_return_point",
        "madelung_wiping_out",
        "masing",
        "rate_independence",
        "intersection",
    ] {
        assert!(
            report.property(p).unwrap().cases > 0,
            "{p} ran no case\n{report}"
        );
    }
    assert_eq!(
        not_on_fixed(&report),
        vec!["dynamics_after_memory", "superposition_monotone"]
    );
}

#[test]
fn the_projects_compensator_and_inverse_as_fixed_implementations() {
    let fixed = nominal_model_file();
    let m = fixed.clone();
    let factory = fixed_compensator_factory(fixed.clone(), move |s| {
        let b: Box<dyn ActuatorCompensator> =
            Box::new(Restorable(Compensator::<f64, Heap>::from_file(&m, s)?));
        Ok(b)
    });
    let report = check_compensator(&factory, &settings(&fixed)).unwrap();
    eprintln!("{report}");
    assert!(report.passed(), "{report}");
    assert!(report.property("split_and_resume").unwrap().cases > 0);
    assert!(report.property("saturation_recovery").unwrap().cases > 0);
    assert_eq!(
        not_on_fixed(&report),
        vec!["superposition_inverse", "superposition_left_inverse"]
    );

    let h = fixed.clone().hysteresis_part();
    let hm = h.clone();
    let factory = fixed_inverse_hysteresis_factory(h.clone(), move || {
        let b: Box<dyn InverseHysteresis> =
            Box::new(Restorable(Hysteresis::<f64, Heap>::inverse_from_file(&hm)?));
        Ok(b)
    });
    let s = ConformanceSettings {
        hysteresis_only: true,
        ..settings(&h)
    };
    let report = check_inverse_hysteresis(&factory, &s).unwrap();
    assert!(report.passed(), "{report}");
    assert!(report.property("split_and_resume").unwrap().cases > 0);
}

/// A fixed candidate that cannot save its state: split and resume is
/// skipped with the reason, not failed.
#[test]
fn a_candidate_that_cannot_save_is_skipped_for_split_and_resume() {
    let fixed = nominal_model_file();
    let m = fixed.clone();
    let factory = fixed_model_factory(fixed.clone(), move || {
        let b: Box<dyn ActuatorModel> = Box::new(HysteresisCreepModel::from_file(&m)?);
        Ok(b)
    });
    let report = check_model(&factory, &settings(&fixed)).unwrap();
    assert!(report.passed(), "{report}");
    let p = report.property("split_and_resume").unwrap();
    assert_eq!(p.cases, 0);
    assert!(p.skipped > 0);
    assert!(p.skip_reason.as_deref().unwrap().contains("cannot save"));
}

/// A fixed implementation of another model than it claims (thresholds
/// halved): agreement fails on a counterexample of a few samples, the
/// model kept as given (shrinking cannot change a fixed model), and the
/// hint names the mistake.
#[test]
fn a_wrong_fixed_implementation_fails_with_a_small_counterexample() {
    let claimed = nominal_model_file();
    let mut wrong = claimed.clone();
    wrong
        .hysteresis
        .thresholds
        .iter_mut()
        .for_each(|r| *r *= 0.5);
    let factory = fixed_compensator_factory(claimed.clone(), move |s| {
        let b: Box<dyn ActuatorCompensator> =
            Box::new(Restorable(Compensator::<f64, Heap>::from_file(&wrong, s)?));
        Ok(b)
    });
    let report = check_compensator(&factory, &settings(&claimed)).unwrap();
    let p = report.property("agreement").unwrap();
    assert!(p.failures > 0, "{report}");
    let c = p.counterexample.as_ref().unwrap();
    assert_eq!(c.case.model, claimed);
    assert!(
        c.failure.signal.len() <= 10,
        "{} samples",
        c.failure.signal.len()
    );
    let found: Vec<f64> = {
        let mut wrong = claimed.clone();
        wrong
            .hysteresis
            .thresholds
            .iter_mut()
            .for_each(|r| *r *= 0.5);
        let mut comp = Compensator::<f64, Heap>::from_file(
            &wrong,
            match c.case.limits {
                Some((lo, hi)) => CompensatorSettings::with_limits(lo, hi),
                None => CompensatorSettings::unlimited(),
            },
        )
        .unwrap();
        comp.compensate_all(&c.failure.signal)
            .iter()
            .map(|c| c.u)
            .collect()
    };
    let e = mfcbeam::suite::conformance::explain::explain(
        mfcbeam::suite::conformance::explain::Kind::Compensator,
        &c.case.model,
        &c.failure.signal,
        c.case.limits,
        &found,
        c.failure.tolerance,
    );
    assert!(e.hints.contains(&Hint::ThresholdsHalved), "{:?}", e.hints);
}

/// A fixed factory builds its model only: any other file is declined.
#[test]
fn a_fixed_factory_declines_other_models() {
    let fixed = nominal_model_file();
    let factory = fixed_model_factory(fixed.clone(), || {
        let b: Box<dyn ActuatorModel> =
            Box::new(HysteresisCreepModel::from_file(&nominal_model_file())?);
        Ok(b)
    });
    assert!(factory(&fixed).is_ok());
    let mut other = fixed.clone();
    other.offset = Some(1.0);
    match factory(&other) {
        Err(ModelError::Unsupported { part }) => assert_eq!(part, OTHER_MODEL),
        Err(e) => panic!("{e}"),
        Ok(_) => panic!("another model was built"),
    }
}
