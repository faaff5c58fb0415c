//! The fuzz targets' bodies: one function per parser or entry point, each
//! taking the fuzzer's bytes. An input may be refused (that is the point);
//! it must never panic, abort or allocate beyond the documented limits, and
//! what is accepted must keep the properties asserted here. `fuzz/run.sh`
//! builds them with libFuzzer's coverage instrumentation on the stable
//! toolchain and runs each for a bounded time.

use std::ffi::{c_char, CString};
use std::path::Path;

use mfcbeam::beam::simulation::DiscreteBeam;
use mfcbeam::beam::step_response_fit::{modal_model, BeamModelKind};
use mfcbeam::beam::BeamParameters;
use mfcbeam::identification::{identify, IdentificationSettings};
use mfcbeam::io::Trace;
use mfcbeam::operators::compensator::CompensatorSettings;
use mfcbeam::operators::model::{HysteresisCreepModel, ModelFile};
use mfcbeam::operators::traits::Operator;

/// Numbers from the bytes after the text: 8 bytes each, any bit pattern
/// (NaN, infinities, subnormals, huge), at most `most`.
fn numbers(bytes: &[u8], most: usize) -> Vec<f64> {
    bytes
        .chunks_exact(8)
        .take(most)
        .map(|c| f64::from_le_bytes(c.try_into().unwrap_or_default()))
        .collect()
}

/// Split at the first NUL: text before, numbers after.
fn text_and_numbers(data: &[u8]) -> (&[u8], Vec<f64>) {
    match data.iter().position(|&b| b == 0) {
        Some(k) => (&data[..k], numbers(&data[k + 1..], 64)),
        None => (data, vec![0.0, 1.0, -1.0, f64::NAN, 2.0]),
    }
}

/// A model file: parsed, built, run, its compensator run, its state saved
/// and read back.
pub fn model_json(data: &[u8]) {
    let (text, inputs) = text_and_numbers(data);
    let Ok(file) = serde_json::from_slice::<ModelFile>(text) else {
        return;
    };
    check_model_file(&file, &inputs);
}

fn check_model_file(file: &ModelFile, inputs: &[f64]) {
    let Ok(mut model) = HysteresisCreepModel::from_file(file) else {
        return;
    };
    let mut last = None;
    for &v in inputs {
        if v.is_finite() {
            model.step(v);
            last = Some(v);
        } else if let Some(held) = last {
            // a non-finite input is the last input held: it cannot poison
            // the state (the first play's state is that input)
            let mut twin = model.clone();
            let y = model.step(v);
            let y_twin = twin.step(held);
            assert!(
                y.to_bits() == y_twin.to_bits() || (y.is_nan() && y_twin.is_nan()),
                "a non-finite input gave {y}, the held input {y_twin}"
            );
        } else {
            model.step(v);
        }
    }
    // a finite state the model reached is one a model file may hold (a
    // model whose numbers overflow, weights of 1e308 say, may reach
    // infinite ones, which no file holds)
    let saved = model.to_file();
    let finite = |x: &[f64]| x.iter().all(|v| v.is_finite());
    let state_finite = saved.hysteresis.state.as_deref().is_none_or(finite)
        && saved
            .creep
            .as_ref()
            .and_then(|c| c.state.as_ref())
            .is_none_or(|rows| rows.iter().all(|r| finite(r)))
        && saved.delay_state.as_deref().is_none_or(finite)
        && saved
            .dynamics
            .as_ref()
            .and_then(|g| g.state.as_deref())
            .is_none_or(finite);
    if state_finite {
        if let Err(e) = HysteresisCreepModel::from_file(&saved) {
            panic!("the saved state is refused: {e}");
        }
    }
    // the compensator, with limits from the inputs where they are valid
    let settings = match inputs {
        [lo, hi, ..] if lo < hi => CompensatorSettings::with_limits(*lo, *hi),
        _ => CompensatorSettings::default(),
    };
    let Ok(fresh) = HysteresisCreepModel::from_file(file) else {
        return;
    };
    let Ok(mut comp) = fresh.compensator(settings) else {
        return;
    };
    let mut previous: Option<f64> = None;
    for &target in inputs {
        let out = comp.compensate(target);
        if !target.is_finite() {
            assert!(out.fault, "a non-finite target {target} is not flagged");
            if let Some(p) = previous {
                assert!(
                    out.u.to_bits() == p.to_bits(),
                    "a non-finite target changed the held voltage {p} to {}",
                    out.u
                );
            }
        }
        previous = Some(out.u);
    }
}

/// Structure-aware: the nominal model (with creep, superposition operator
/// and dead time switched on or off by the first byte) with one field
/// replaced by a hostile value the next bytes choose, as JSON text through
/// the Rust reader and the C API's constructors.
pub fn model_fields(data: &[u8]) {
    let Some((&shape, rest)) = data.split_first() else {
        return;
    };
    let Some((&field, rest)) = rest.split_first() else {
        return;
    };
    let Some((&kind, rest)) = rest.split_first() else {
        return;
    };
    let mut file = mfcbeam::operators::nominal::nominal_model().to_file();
    if shape & 1 == 0 {
        file.creep = None;
    }
    if shape & 2 != 0 {
        file.superposition = Some(mfcbeam::operators::model::SuperpositionData {
            thresholds: vec![-500.0, -200.0, 0.0, 150.0, 400.0],
            weights: vec![0.25, -0.25, 1.0, -0.2, -0.15],
        });
    }
    if shape & 4 != 0 {
        file.delay = Some(2);
    }
    if shape & 8 == 0 {
        file = file.without_state();
    }
    let Ok(mut value) = serde_json::to_value(&file) else {
        return;
    };
    let paths = leaf_paths(&value);
    let path = &paths[field as usize % paths.len()];
    let hostile = hostile_value(kind, rest);
    if let Some(slot) = value.pointer_mut(path) {
        *slot = hostile;
    }
    let text = value.to_string();
    model_json(text.as_bytes());
    capi_constructors(text.as_bytes(), &[0.5, f64::NAN, -0.5, 1e300]);
}

/// Every path to a number, an array or an object in `v` (JSON pointers).
fn leaf_paths(v: &serde_json::Value) -> Vec<String> {
    fn walk(v: &serde_json::Value, at: String, out: &mut Vec<String>) {
        out.push(at.clone());
        match v {
            serde_json::Value::Object(m) => {
                for (k, x) in m {
                    walk(x, format!("{at}/{k}"), out);
                }
            }
            serde_json::Value::Array(a) => {
                for (i, x) in a.iter().enumerate() {
                    walk(x, format!("{at}/{i}"), out);
                }
            }
            _ => {}
        }
    }
    let mut out = Vec::new();
    walk(v, String::new(), &mut out);
    // the whole document is not a field
    out.remove(0);
    out
}

/// A hostile JSON value: huge, negative, fractional counts, extreme floats,
/// empty and long arrays, wrong types.
fn hostile_value(kind: u8, rest: &[u8]) -> serde_json::Value {
    use serde_json::json;
    let x = numbers(rest, 1).first().copied().unwrap_or(0.0);
    let n = rest.first().copied().unwrap_or(3) as usize;
    match kind % 16 {
        0 => json!(1_000_000_000_000u64),
        1 => json!(u64::MAX),
        2 => json!(-1),
        3 => json!(0),
        4 => json!(1e308),
        5 => json!(-1e308),
        6 => json!(5e-324),
        7 => json!([]),
        // a long array of one value: memory in proportion to the text
        8 => serde_json::Value::Array(vec![json!(if x.is_finite() { x } else { 1.0 }); n * 97]),
        9 => json!("text"),
        10 => serde_json::Value::Null,
        11 => json!({"nested": [[[1]]]}),
        12 => json!(100_001),
        13 => json!(0.5),
        14 => json!([[1.0, 2.0], [3.0]]),
        _ => json!(if x.is_finite() { x } else { 7.0 }),
    }
}

/// A beam file: parsed, checked, reduced to modes (Ritz and finite
/// elements), sampled and stepped.
pub fn beam_json(data: &[u8]) {
    let (text, inputs) = text_and_numbers(data);
    let Ok(beam) = serde_json::from_slice::<BeamParameters>(text) else {
        return;
    };
    if beam.validate().is_err() {
        return;
    }
    // few elements: the fuzzer's time goes to the input, not to eigen solves
    let elements = 3 + inputs.len() % 20;
    for kind in [BeamModelKind::Ritz, BeamModelKind::Modal { elements }] {
        let Ok(modal) = modal_model(&beam, kind) else {
            continue;
        };
        let Ok(mut discrete) = DiscreteBeam::new(&modal, 2e-4) else {
            continue;
        };
        for &u in inputs.iter().take(16) {
            discrete.step(u);
        }
    }
}

/// A trace: parsed with and without its time column, every column read,
/// and, when it has `u` and `y`, a small identification run on it.
pub fn trace_csv(data: &[u8]) {
    let Ok(trace) = Trace::parse(Path::new("fuzz.csv"), data) else {
        return;
    };
    for name in trace.header().to_vec() {
        let _ = trace.column(&name);
    }
    let ts = trace.sample_time_from_t().unwrap_or(2e-4);
    let _ = trace.check_time_column(2e-4);
    let (Ok(u), Ok(y)) = (trace.column("u"), trace.column("y")) else {
        return;
    };
    if !(4..=4000).contains(&u.len()) {
        return;
    }
    let settings = IdentificationSettings {
        hysteresis_operators: 4,
        creep_operators: 2,
        creep_eigenvalues: 2,
        ..IdentificationSettings::default()
    };
    if let Ok(id) = identify(&u, &y, ts, &settings) {
        let run = id.model.clone().run(&u);
        assert_eq!(run.len(), u.len());
    }
}

/// A conformance candidate's output for an input of 8 rows, as `conform`
/// reads it: size bound, CSV, the output column, the row count.
pub fn candidate_output(data: &[u8]) {
    use mfcbeam::suite::conformance::external::parse_output;
    let Ok(trace) = parse_output(Path::new("candidate.csv"), data, 8) else {
        return;
    };
    for column in ["y", "u", "saturated"] {
        let _ = trace.column(column);
    }
}

/// The C API: the model file text (up to the first NUL) through every JSON
/// constructor, then every step function with the numbers after it.
pub fn capi(data: &[u8]) {
    let (text, inputs) = text_and_numbers(data);
    capi_constructors(text, &inputs);
}

fn capi_constructors(text: &[u8], inputs: &[f64]) {
    let Ok(json) = CString::new(text) else {
        return;
    };
    let mut err = [0 as c_char; 256];
    let (lo, hi) = match inputs {
        [lo, hi, ..] => (*lo, *hi),
        _ => (-1000.0, 1000.0),
    };
    // SAFETY: a NUL-terminated string, a buffer of the stated length, and
    // handles used only while alive.
    unsafe {
        let model = capi::mfcbeam_model_from_json(json.as_ptr(), err.as_mut_ptr(), err.len());
        check_refusal(model.is_null(), &err);
        for &v in inputs {
            capi::mfcbeam_model_step(model, v);
        }
        capi::mfcbeam_model_free(model);
        let comp =
            capi::mfcbeam_compensator_from_json(json.as_ptr(), lo, hi, err.as_mut_ptr(), err.len());
        check_refusal(comp.is_null(), &err);
        let mut flags = 0;
        for &v in inputs {
            capi::mfcbeam_compensator_compensate(comp, v, &mut flags);
            if !v.is_finite() && !comp.is_null() {
                assert!(
                    flags & capi::MFCBEAM_FLAG_NON_FINITE_TARGET != 0,
                    "a non-finite target is not flagged"
                );
            }
        }
        capi::mfcbeam_compensator_free(comp);

        // caller-owned storage (zeroed: refused until initialised)
        macro_rules! storage {
            ($ty:ty, $init:ident $(, $limit:expr)*) => {{
                let mut storage: Box<$ty> = Box::new(std::mem::zeroed());
                let r = capi::$init(&mut *storage, json.as_ptr() $(, $limit)*, err.as_mut_ptr(), err.len());
                check_refusal(r != 0, &err);
                storage
            }};
        }
        let mut c32 = storage!(
            capi::MfcbeamCompensatorStorageF32,
            mfcbeam_compensator_f32_init_json,
            lo,
            hi
        );
        let mut c64 = storage!(
            capi::MfcbeamCompensatorStorageF64,
            mfcbeam_compensator_f64_init_json,
            lo,
            hi
        );
        let mut m32 = storage!(capi::MfcbeamModelStorageF32, mfcbeam_model_f32_init_json);
        let mut m64 = storage!(capi::MfcbeamModelStorageF64, mfcbeam_model_f64_init_json);
        for &v in inputs {
            capi::mfcbeam_compensator_f32_compensate(&mut *c32, v as f32, &mut flags);
            capi::mfcbeam_compensator_f64_compensate(&mut *c64, v, &mut flags);
            capi::mfcbeam_model_f32_step(&mut *m32, v as f32);
            capi::mfcbeam_model_f64_step(&mut *m64, v);
        }
    }
}

/// A refusal carries a message of one line.
fn check_refusal(refused: bool, err: &[c_char]) {
    if refused {
        let len = err.iter().position(|&c| c == 0).unwrap_or(err.len());
        assert!(len > 0, "refused without a message");
        assert!(
            !err[..len].contains(&(b'\n' as c_char)),
            "a message of more than one line"
        );
    }
}

/// A controller file (the controller FMU's): parsed, built, and stepped on
/// the numbers as (reference, measurement) pairs; its state stays finite
/// whatever comes.
pub fn controller_json(data: &[u8]) {
    use mfcbeam::control::file::ControllerFile;
    use mfcbeam::control::{Controller, LoopSample};
    let (text, inputs) = text_and_numbers(data);
    let Ok(file) = serde_json::from_slice::<ControllerFile>(text) else {
        return;
    };
    let Ok(mut c) = file.build() else {
        return;
    };
    for (k, pair) in inputs.chunks(2).enumerate() {
        let sample = LoopSample {
            k,
            t: k as f64 * file.sample_time,
            reference: pair[0],
            measurement: pair.get(1).copied().unwrap_or(0.0),
        };
        match c.step(&sample) {
            Ok(Some(v)) => assert!(v.is_finite(), "a correction {v} escaped"),
            Ok(None) => {}
            Err(e) => panic!("a built-in controller failed: {e}"),
        }
        assert!(c.state_is_finite(), "the state was poisoned at sample {k}");
    }
}

/// A shared library's header as an FMU carries it (the importer and the
/// packing read it before anything is loaded): any bytes give a platform
/// or a reason, never a panic or an overflow, and a file passed as whole
/// is the platform its header names.
pub fn library_header(data: &[u8]) {
    use mfcbeam::fmi::platform::check_library;
    use mfcbeam::fmi::Platform;
    match check_library(data) {
        Ok(p) => assert_eq!(Platform::of_library(data), Ok(p)),
        Err(why) => assert!(!why.is_empty() && !why.contains('\n'), "{why:?}"),
    }
}
