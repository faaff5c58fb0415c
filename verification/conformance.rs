//! The conformance checks run on every implementation the project has (the
//! fast operators, the naive references, the numerical bisection inverse),
//! and proof that they bite: wrappers that inject known faults each fail at
//! least one property, with a small counterexample.

use mfcbeam::operators::creep::CreepOperator;
use mfcbeam::operators::hysteresis::HysteresisOperator;
use mfcbeam::prelude::*;
use mfcbeam::suite::conformance::{
    bisection_compensator, check_compensator, check_inverse_hysteresis, check_model,
    heap_compensator, heap_inverse_hysteresis, heap_model, inline_compensator,
    inline_inverse_hysteresis, inline_model, reference_compensator, reference_inverse_hysteresis,
    reference_model, ConformanceReport, ConformanceSettings, F32_TOLERANCE_SCALE,
};

/// Capacity for the random cases: `max_plays` = 12 thresholds, up to 6
/// eigenvalues.
const N: usize = 12;
const K: usize = 72;

fn settings() -> ConformanceSettings {
    ConformanceSettings {
        cases: 40,
        dynamics: true,
        ..ConformanceSettings::default()
    }
}

/// The project's own operators meet the exact properties bit for bit.
fn exact() -> ConformanceSettings {
    ConformanceSettings {
        exact: true,
        ..settings()
    }
}

fn assert_passes(report: &ConformanceReport, who: &str) {
    eprintln!("{who}:\n{report}");
    assert!(report.passed(), "{who} fails:\n{report}");
    assert!(report.properties.iter().all(|p| p.cases > 0));
}

#[test]
fn the_fast_model_conforms() {
    assert_passes(&check_model(&heap_model, &exact()).unwrap(), "fast W");
}

#[test]
fn the_reference_model_conforms() {
    assert_passes(
        &check_model(&reference_model, &settings()).unwrap(),
        "reference W",
    );
}

#[test]
fn the_fast_compensator_conforms() {
    assert_passes(
        &check_compensator(&heap_compensator, &exact()).unwrap(),
        "fast W⁻¹",
    );
}

#[test]
fn the_reference_compensator_conforms() {
    assert_passes(
        &check_compensator(&reference_compensator, &settings()).unwrap(),
        "reference W⁻¹",
    );
}

/// The numerical inverse finds `v` to the last bit by bisection: it meets the
/// analytic inverse's tolerances.
#[test]
fn the_bisection_compensator_conforms() {
    assert_passes(
        &check_compensator(&bisection_compensator, &settings()).unwrap(),
        "bisection W⁻¹",
    );
}

/// The real-time core in `f64` runs the same kernels with the same
/// parameter transformations: bit for bit the fast operators' results.
#[test]
fn the_fixed_f64_core_conforms_exactly() {
    assert_passes(
        &check_model(&inline_model::<f64, N, K>, &exact()).unwrap(),
        "fixed f64 W",
    );
    assert_passes(
        &check_compensator(&inline_compensator::<f64, N, K>, &exact()).unwrap(),
        "fixed f64 W⁻¹",
    );
    assert_passes(
        &check_inverse_hysteresis(&inline_inverse_hysteresis::<f64, N>, &exact()).unwrap(),
        "fixed f64 H⁻¹",
    );
}

/// The `f32` core against the `f64` reference, every tolerance scaled by
/// `ε₃₂/ε₆₄` (see `F32_TOLERANCE_SCALE`).
#[test]
fn the_fixed_f32_core_conforms_at_f32_tolerances() {
    let f32_settings = ConformanceSettings {
        tolerance_scale: F32_TOLERANCE_SCALE,
        ..settings()
    };
    assert_passes(
        &check_model(&inline_model::<f32, N, K>, &f32_settings).unwrap(),
        "fixed f32 W",
    );
    assert_passes(
        &check_compensator(&inline_compensator::<f32, N, K>, &f32_settings).unwrap(),
        "fixed f32 W⁻¹",
    );
    assert_passes(
        &check_inverse_hysteresis(&inline_inverse_hysteresis::<f32, N>, &f32_settings).unwrap(),
        "fixed f32 H⁻¹",
    );
}

#[test]
fn the_fast_inverse_hysteresis_conforms() {
    assert_passes(
        &check_inverse_hysteresis(&heap_inverse_hysteresis, &exact()).unwrap(),
        "fast H⁻¹",
    );
}

#[test]
fn the_reference_inverse_hysteresis_conforms() {
    assert_passes(
        &check_inverse_hysteresis(&reference_inverse_hysteresis, &settings()).unwrap(),
        "reference H⁻¹",
    );
}

/// `W` whose creep is driven by `v_k` instead of `v_{k−1}`.
struct CreepWithoutDelay {
    h: HysteresisOperator,
    c: Option<CreepOperator>,
}

impl Operator for CreepWithoutDelay {
    fn step(&mut self, v: f64) -> f64 {
        self.h.step(v) + self.c.as_mut().map_or(0.0, |c| c.advance(v))
    }
    fn reset(&mut self) {
        self.h.reset();
        if let Some(c) = &mut self.c {
            c.reset();
        }
    }
}
impl ActuatorModel for CreepWithoutDelay {}

/// Any operator with its output delayed by one sample.
struct Delayed<T> {
    inner: T,
    last: f64,
}

impl<T: Operator> Operator for Delayed<T> {
    fn step(&mut self, v: f64) -> f64 {
        std::mem::replace(&mut self.last, self.inner.step(v))
    }
    fn reset(&mut self) {
        self.inner.reset();
        self.last = 0.0;
    }
}
impl<T: Operator> ActuatorModel for Delayed<T> {}

/// A compensator that never reports saturation.
struct NoFlag(Compensator<f64, Heap>);

impl ActuatorCompensator for NoFlag {
    fn compensate(&mut self, target: f64) -> Compensated {
        Compensated {
            saturated: false,
            ..self.0.compensate(target)
        }
    }
    fn reset(&mut self) {
        self.0.reset();
    }
    fn delay(&self) -> usize {
        Compensator::delay(&self.0)
    }
}

/// A compensator that does not preview its targets by the dead time.
struct NoPreview(Compensator<f64, Heap>);

impl ActuatorCompensator for NoPreview {
    fn compensate(&mut self, target: f64) -> Compensated {
        self.0.compensate(target)
    }
    fn reset(&mut self) {
        self.0.reset();
    }
}

/// The model file without its dead time.
fn undelayed(file: &ModelFile) -> ModelFile {
    ModelFile {
        delay: None,
        delay_state: None,
        ..file.clone()
    }
}

/// The model file with its last threshold moved by 1e-6 relative.
fn shifted(file: &ModelFile) -> ModelFile {
    let mut f = file.clone();
    let r = &mut f.hysteresis.thresholds;
    let n = r.len();
    r[n - 1] *= 1.0 + 1e-6;
    f
}

/// The model file with the sign of one weight flipped: the largest one
/// whose flip keeps every partial sum positive (11), so the model stays valid.
fn flipped(file: &ModelFile) -> ModelFile {
    let mut f = file.clone();
    let w = &mut f.hysteresis.weights;
    let keeps_11 = |w: &[f64], j: usize| {
        let mut s = 0.0;
        w.iter().enumerate().all(|(i, &x)| {
            s += if i == j { -x } else { x };
            s > 0.0
        })
    };
    let best = (1..w.len())
        .filter(|&j| keeps_11(w, j))
        .max_by(|&a, &b| w[a].abs().total_cmp(&w[b].abs()));
    if let Some(j) = best {
        w[j] = -w[j];
    }
    f
}

fn assert_caught(report: &ConformanceReport, fault: &str) {
    eprintln!("{fault}:\n{report}");
    let failed = report.failed();
    assert!(!failed.is_empty(), "{fault} was not caught");
    for p in failed {
        let c = p
            .counterexample
            .as_ref()
            .expect("a failure has a counterexample");
        // small enough to debug by hand
        assert!(
            c.case.input.len() <= 50,
            "{fault}: {} counterexample has {} samples",
            p.name,
            c.case.input.len()
        );
        eprintln!(
            "  {}: {} plays, {} samples, {}",
            p.name,
            c.case.model.hysteresis.thresholds.len(),
            c.case.input.len(),
            c.failure.message
        );
    }
}

#[test]
fn injected_faults_are_caught_with_small_counterexamples() {
    let s = ConformanceSettings {
        cases: 24,
        ..ConformanceSettings::default()
    };
    let creep_vk = |f: &ModelFile| -> Result<Box<dyn ActuatorModel>, ModelError> {
        let m = HysteresisCreepModel::from_file(f)?;
        Ok(Box::new(CreepWithoutDelay {
            h: m.hysteresis().clone(),
            c: m.creep().cloned(),
        }))
    };
    assert_caught(&check_model(&creep_vk, &s).unwrap(), "creep from v_k");

    let threshold = |f: &ModelFile| heap_model(&shifted(f));
    assert_caught(
        &check_model(&threshold, &s).unwrap(),
        "threshold moved 1e-6",
    );

    let sign = |f: &ModelFile| heap_model(&flipped(f));
    assert_caught(&check_model(&sign, &s).unwrap(), "weight sign flipped");

    let delay = |f: &ModelFile| -> Result<Box<dyn ActuatorModel>, ModelError> {
        Ok(Box::new(Delayed {
            inner: HysteresisCreepModel::from_file(f)?,
            last: 0.0,
        }))
    };
    assert_caught(&check_model(&delay, &s).unwrap(), "one-sample delay");

    let no_flag = |f: &ModelFile,
                   c: CompensatorSettings|
     -> Result<Box<dyn ActuatorCompensator>, ModelError> {
        Ok(Box::new(NoFlag(
            HysteresisCreepModel::from_file(f)?.compensator(c)?,
        )))
    };
    assert_caught(
        &check_compensator(&no_flag, &s).unwrap(),
        "saturated flag dropped",
    );

    let no_dead_time = |f: &ModelFile| heap_model(&undelayed(f));
    assert_caught(
        &check_model(&no_dead_time, &s).unwrap(),
        "dead time ignored",
    );

    let no_preview = |f: &ModelFile,
                      c: CompensatorSettings|
     -> Result<Box<dyn ActuatorCompensator>, ModelError> {
        Ok(Box::new(NoPreview(
            HysteresisCreepModel::from_file(f)?.compensator(c)?,
        )))
    };
    assert_caught(
        &check_compensator(&no_preview, &s).unwrap(),
        "targets not previewed by the dead time",
    );

    let inv_threshold = |f: &ModelFile| heap_inverse_hysteresis(&shifted(f));
    assert_caught(
        &check_inverse_hysteresis(&inv_threshold, &s).unwrap(),
        "H⁻¹ of a threshold moved 1e-6",
    );
}

#[test]
fn bad_settings_are_refused() {
    let s = ConformanceSettings {
        cases: 0,
        ..ConformanceSettings::default()
    };
    assert!(check_model(&heap_model, &s).is_err());
    let s = ConformanceSettings {
        tolerance_scale: 0.5,
        ..ConformanceSettings::default()
    };
    assert!(check_compensator(&heap_compensator, &s).is_err());
}

/// The generators draw one- to three-sample inputs on purpose (first-sample
/// conventions and loop bounds), and longer ones up to `max_samples`.
#[test]
fn short_inputs_are_drawn_on_purpose() {
    let mut rng = mfcbeam::suite::conformance::Rng::new(5);
    let lengths: Vec<usize> = (0..1000)
        .map(|_| mfcbeam::suite::conformance::input_length(&mut rng, 300))
        .collect();
    for n in 1..=3 {
        assert!(lengths.contains(&n), "no input of {n} samples");
    }
    let short = lengths.iter().filter(|&&n| n <= 3).count();
    assert!((150..=250).contains(&short), "{short} of 1000 short");
    assert!(lengths.iter().all(|&n| (1..=300).contains(&n)));
}

/// `intersection` needs a model whose branches cross: it checks that
/// premise on the reference first, so shrinking cannot reduce a failure to
/// a one-play model on which the reference fails it too. On the nominal
/// `H` it still catches a candidate whose branches merge.
#[test]
fn intersection_checks_its_premise_on_the_reference() {
    let s = ConformanceSettings::default();
    let mut nominal = mfcbeam::operators::nominal::nominal_model_file();
    nominal.creep = None;
    let case = |model: ModelFile| mfcbeam::suite::conformance::Case {
        model,
        input: vec![200.0, 1000.0, 900.0],
        limits: None,
    };
    let recheck = |case: &mfcbeam::suite::conformance::Case, f: &ModelFactory| {
        mfcbeam::suite::conformance::model_properties()
            .recheck("intersection", case, f, &s)
            .unwrap()
    };
    let halved = |f: &ModelFile| {
        let mut m = f.clone();
        m.hysteresis.thresholds.iter_mut().for_each(|r| *r *= 0.5);
        heap_model(&m)
    };
    use mfcbeam::suite::conformance::{ModelFactory, Outcome};
    assert!(matches!(
        recheck(&case(nominal.clone()), &heap_model),
        Outcome::Held { .. }
    ));
    assert!(matches!(
        recheck(&case(nominal.clone()), &halved),
        Outcome::Failed(_)
    ));
    let mut one_play = nominal.clone();
    one_play.hysteresis.thresholds.truncate(1);
    one_play.hysteresis.weights.truncate(1);
    assert_eq!(recheck(&case(one_play), &halved), Outcome::Skipped);
}
