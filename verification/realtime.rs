//! The real-time core (`mfcbeam::realtime`): in `f64` it is the heap
//! operators bit for bit; in `f32` its error against the `f64` reference on
//! the paper's scenarios stays inside the rounding bound derived for binary32
//! (`RoundingBounds` with `ε₃₂`). Also its errors, capacity and footprint.

use mfcbeam::prelude::*;
use mfcbeam::realtime::{
    nominal, Compensator, CompensatorSettings, CreepParameters, Dynamics, HysteresisParameters,
    Inline, Model, ModelParameters, ParameterError, RoundingBounds, Superposition,
};
use mfcbeam::suite::conformance::{inline_compensator, inline_model};
use mfcbeam::suite::scenarios::{run, scenario, ScenarioContext, ScenarioTrace};

fn context<T: mfcbeam::realtime::Real>() -> ScenarioContext {
    ScenarioContext {
        plant: Box::new(inline_model::<T, 12, 60>),
        compensator: Box::new(inline_compensator::<T, 12, 60>),
        ..ScenarioContext::nominal()
    }
}

/// The scenarios that run targets through `W⁻¹` then `W`: (id, target
/// column, compensator output column, plant output column).
const COMPENSATED: [(&str, &str, &str, &str); 3] = [
    ("compensated", "y_d", "u", "y"),
    ("step", "v", "u", "w"),
    ("feedforward", "u_d", "u", "w"),
];

fn trace(id: &str, ctx: &ScenarioContext) -> ScenarioTrace {
    run(scenario(id).unwrap(), ctx).unwrap()
}

fn max_abs(x: &[f64]) -> f64 {
    x.iter().fold(0.0f64, |m, v| m.max(v.abs()))
}

fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
}

#[test]
fn f64_core_is_the_heap_operators_bit_for_bit_on_the_papers_scenarios() {
    let heap = ScenarioContext::nominal();
    let fixed = context::<f64>();
    for (id, ..) in COMPENSATED {
        let (a, b) = (trace(id, &heap), trace(id, &fixed));
        for ((name, x), (_, y)) in a.columns.iter().zip(&b.columns) {
            let same = x.iter().zip(y).all(|(p, q)| p.to_bits() == q.to_bits());
            assert!(same, "{id}: column {name} differs");
        }
    }
}

#[test]
fn f32_core_accuracy_on_the_papers_scenarios() {
    let reference = ScenarioContext::nominal();
    let single = context::<f32>();
    let bounds = |eps| RoundingBounds {
        parameters: nominal::PARAMETERS,
        state_max: 0.0,
        eps,
    };
    let (lo, hi) = Supply::default().balanced_limits();
    let range = hi - lo;
    for (id, target, u_col, y_col) in COMPENSATED {
        let (a, b) = (trace(id, &reference), trace(id, &single));
        let y_d = a.col(target);
        let (u64_, u32_) = (a.col(u_col), b.col(u_col));
        let identity32 = max_diff(b.col(y_col), y_d);
        let identity64 = max_diff(a.col(y_col), y_d);
        let deviation = max_diff(u32_, u64_);
        let (v_max, y_max) = (max_abs(u64_).max(max_abs(u32_)), max_abs(y_d));
        // W[W⁻¹[y]] in binary32, plant and compensator sharing the creep
        // arithmetic (the target rounded to f32 on entry is inside the same
        // first-order terms); two compensators, each against exact
        // arithmetic over the scenario's samples from virgin: their bounds
        // add.
        let samples = y_d.len() as u64;
        let identity_bound = bounds(f32::EPSILON as f64).identity(v_max, y_max);
        let deviation_bound = bounds(f32::EPSILON as f64).compensator_over(v_max, y_max, samples)
            + bounds(f64::EPSILON).compensator_over(v_max, y_max, samples);
        eprintln!(
            "{id}: max|W[W⁻¹[y]] − y| f32 {identity32:.3e} V (f64 {identity64:.3e} V, bound {identity_bound:.3e} V); \
             max|u₃₂ − u₆₄| {deviation:.3e} V = {:.3e} of the {range} V range (bound over its {samples} samples {deviation_bound:.3e} V)",
            deviation / range
        );
        assert!(
            identity32 <= identity_bound,
            "{id}: {identity32} > {identity_bound}"
        );
        assert!(
            deviation <= deviation_bound,
            "{id}: {deviation} > {deviation_bound}"
        );
        // f32 is a real difference, not a copy of the f64 run
        assert!(deviation > 0.0);
    }
}

#[test]
fn paper_sized_storage_and_its_footprint() {
    let f32_bytes = std::mem::size_of::<Compensator<f32, nominal::Capacity>>();
    let f64_bytes = std::mem::size_of::<Compensator<f64, nominal::Capacity>>();
    // Arrays: H⁻¹ (r', w', x') and H (r, w, s, room for x) of 12, creep
    // (r, w, a, g, w/m, χ) of 60, and 7 more for χ to start off a page
    // boundary; then where χ starts and the address it was placed for
    // (2); one length per array (13), the
    // sample time, offset, limits, the last voltage, creep output and last
    // input, and the creep's presence; `S⁻¹` with capacity 0 (the paper's
    // model has none) is two lengths, its zero index and its presence; the
    // model's dead time is one count (the compensator has no delay line);
    // the room for linear dynamics G (absent here) and, for them, `S`
    // itself and the plays' last output; the room for a rate gain of the
    // thresholds (absent here) with the plant's last input; whether the
    // layout is the paper's (a flag, padded to a number's size).
    let extra = |size: usize| {
        if size == 4 {
            std::mem::size_of::<Option<Dynamics<f32>>>()
                + std::mem::size_of::<Option<Superposition<f32, nominal::Capacity>>>()
                + std::mem::size_of::<Option<mfcbeam::realtime::RateGain<f32>>>()
                + 4
        } else {
            std::mem::size_of::<Option<Dynamics<f64>>>()
                + std::mem::size_of::<Option<Superposition<f64, nominal::Capacity>>>()
                + std::mem::size_of::<Option<mfcbeam::realtime::RateGain<f64>>>()
                + 8
        }
    };
    for (bytes, size) in [(f32_bytes, 4), (f64_bytes, 8)] {
        let arrays = (7 * 12 + 6 * 60 + 7) * size;
        let lengths = (2 + 13 + 5) * std::mem::size_of::<usize>() + extra(size) + size;
        eprintln!("Compensator<_, nominal::Capacity>: {bytes} bytes with {size}-byte numbers ({arrays} in arrays)");
        assert!(
            bytes >= arrays + lengths && bytes <= arrays + lengths + 8 * 8,
            "{bytes} bytes"
        );
    }
    let m = std::mem::size_of::<Model<f32, nominal::Capacity>>();
    eprintln!("Model<f32, nominal::Capacity>: {m} bytes");
}

#[test]
fn parameters_beyond_the_capacity_are_refused() {
    let e = Compensator::<f64, Inline<8, 60>>::new(
        &nominal::PARAMETERS.validate().unwrap(),
        CompensatorSettings::with_limits(-1e3, 1e3),
    )
    .unwrap_err();
    assert!(matches!(
        e,
        ParameterError::ExceedsCapacity {
            capacity: 8,
            found: 12,
            ..
        }
    ));
    let e =
        Model::<f32, Inline<12, 59>>::new(&nominal::PARAMETERS.validate().unwrap()).unwrap_err();
    assert!(matches!(
        e,
        ParameterError::ExceedsCapacity {
            field: "creep",
            capacity: 59,
            found: 60
        }
    ));
    // the paper's orders fit, and smaller ones at run time too
    let small = ModelParameters {
        sample_time: 1e-3,
        hysteresis: HysteresisParameters {
            thresholds: &[0.0, 1.0],
            weights: &[1.0, 0.5],
        },
        creep: Some(CreepParameters {
            thresholds: &[0.0],
            weights: &[0.1],
            eigenvalues: &[10.0],
        }),
        superposition: None,
        dynamics: None,
        delay: 0,
        offset: 0.0,
        rate_gain: 0.0,
    };
    let mut w = Model::<f32, nominal::Capacity>::new(&small.validate().unwrap()).unwrap();
    let mut c = Compensator::<f32, nominal::Capacity>::new(
        &small.validate().unwrap(),
        CompensatorSettings::with_limits(-10.0, 10.0),
    )
    .unwrap();
    for k in 0..200 {
        let y = 3.0 * (k as f32 * 0.05).sin();
        let out = w.step(c.compensate(y).u);
        assert!((out - y).abs() <= 1e-5, "{out} vs {y}");
    }
}

#[test]
fn broken_parameters_name_the_field() {
    let bad = |f: fn(&mut [f64; 12])| {
        let mut w = nominal::HYSTERESIS_WEIGHTS;
        f(&mut w);
        let p = ModelParameters {
            hysteresis: HysteresisParameters {
                thresholds: &nominal::THRESHOLDS,
                weights: &w,
            },
            ..nominal::PARAMETERS
        };
        // refused where they are checked, once: by `validate`
        p.validate().unwrap_err()
    };
    assert!(matches!(
        bad(|w| w[0] = -1.0),
        ParameterError::PartialSumNotPositive { index: 0, .. }
    ));
    assert!(matches!(
        bad(|w| w[3] = f64::NAN),
        ParameterError::NonFinite {
            field: "hysteresis.weights",
            index: 3,
            ..
        }
    ));
    let e = Compensator::<f64, nominal::Capacity>::new(
        &nominal::PARAMETERS.validate().unwrap(),
        CompensatorSettings::with_limits(1.0, -1.0),
    )
    .unwrap_err();
    assert!(matches!(e, ParameterError::InvalidLimits { .. }));
    assert!(e.to_string().contains("limits"));
    let e = Compensator::<f64, nominal::Capacity>::new(
        &nominal::PARAMETERS.validate().unwrap(),
        CompensatorSettings::with_limits(f64::NAN, 1.0),
    )
    .unwrap_err();
    assert!(matches!(e, ParameterError::InvalidLimits { .. }));
    // the std error carries the same message
    let m: ModelError = e.into();
    assert_eq!(m.to_string(), e.to_string());
}

#[test]
fn f32_limits_are_rounded_inward_and_faults_hold_the_voltage() {
    // 0.1 is not a binary32 number: to nearest it rounds up, past the limit
    let upper = 0.1f64;
    assert!((upper as f32) as f64 > upper);
    let mut c = Compensator::<f32, nominal::Capacity>::new(
        &nominal::PARAMETERS.validate().unwrap(),
        CompensatorSettings::with_limits(-upper, upper),
    )
    .unwrap();
    let out = c.compensate(500.0);
    assert!(out.saturated && (out.u as f64) <= upper && (out.u as f64) > upper * (1.0 - 1e-7));
    let out = c.compensate(-500.0);
    assert!(out.saturated && (out.u as f64) >= -upper);

    let mut c = Compensator::<f32, nominal::Capacity>::new(
        &nominal::PARAMETERS.validate().unwrap(),
        CompensatorSettings::with_limits(-1e3, 1e3),
    )
    .unwrap();
    let mut w =
        Model::<f32, nominal::Capacity>::new(&nominal::PARAMETERS.validate().unwrap()).unwrap();
    let u = c.compensate(200.0).u;
    w.step(u);
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        let held = c.compensate(bad);
        assert!(held.fault && !held.saturated);
        assert_eq!(held.u, u);
        w.step(held.u);
    }
    // the identity resumes with the next finite target
    let y = w.step(c.compensate(150.0).u);
    assert!((y - 150.0).abs() < 1e-3, "{y}");
}
