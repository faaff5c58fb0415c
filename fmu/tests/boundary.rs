//! The C boundary of the FMU library, called as an importer calls it: a
//! panic becomes an error status with a logged message and never unwinds
//! into C; a wrong token, missing or malformed resources, a step that is
//! not a whole number of samples, calls out of order and NULL pointers are
//! logged errors; a non-finite input is held and flagged; instances are
//! independent; a saved state restores bit for bit.

use std::ffi::{c_char, c_void, CStr, CString};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use mfcbeam::fmi::variables::{vr, FmiVersion, FmuConfig, FmuKind, CONFIG_FILE};
use mfcbeam_fmu::fmi3::*;
use mfcbeam_fmu::{ERROR, OK, WARNING};

const TOKEN: &str = "{test-token}";

/// Messages the FMU logged, for the instance whose environment this is.
struct Log(Mutex<Vec<(i32, String)>>);

unsafe extern "C" fn log_message(
    env: *mut c_void,
    status: i32,
    _cat: *const c_char,
    msg: *const c_char,
) {
    let log = unsafe { &*(env as *const Log) };
    let text = unsafe { CStr::from_ptr(msg) }
        .to_string_lossy()
        .into_owned();
    log.0.lock().unwrap().push((status, text));
}

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// A scratch folder, removed when dropped.
struct Scratch(PathBuf);

impl std::ops::Deref for Scratch {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.0
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// A resources folder of an FMU of `kind` with the nominal model.
fn resources(name: &str, kind: FmuKind) -> Scratch {
    let dir = std::env::temp_dir().join(format!(
        "mfcbeam-fmu-boundary-{}-{name}",
        std::process::id()
    ));
    std::fs::create_dir_all(&dir).unwrap();
    let config = FmuConfig {
        kind,
        fmi_version: FmiVersion::Fmi3,
        token: TOKEN.into(),
        model: "model.json".into(),
        beam: None,
        beam_model: None,
        modes: 0,
    };
    std::fs::write(
        dir.join(CONFIG_FILE),
        serde_json::to_string(&config).unwrap(),
    )
    .unwrap();
    std::fs::copy(
        root().join("golden/nominal_model.json"),
        dir.join("model.json"),
    )
    .unwrap();
    Scratch(dir)
}

struct Fmu {
    instance: *mut c_void,
    log: Box<Log>,
}

impl Fmu {
    fn try_new(resources: &Path, token: &str) -> (Option<Self>, Box<Log>) {
        let log = Box::new(Log(Mutex::new(Vec::new())));
        let env = &*log as *const Log as *mut c_void;
        let name = CString::new("test").unwrap();
        let token = CString::new(token).unwrap();
        let path = CString::new(format!("{}/", resources.display())).unwrap();
        let instance = unsafe {
            fmi3InstantiateCoSimulation(
                name.as_ptr(),
                token.as_ptr(),
                path.as_ptr(),
                false,
                true,
                false,
                false,
                std::ptr::null(),
                0,
                env,
                Some(log_message),
                std::ptr::null(),
            )
        };
        if instance.is_null() {
            (None, log)
        } else {
            (
                Some(Self {
                    instance,
                    log: Box::new(Log(Mutex::new(Vec::new()))),
                }),
                log,
            )
        }
    }

    fn new(resources: &Path) -> Self {
        let (f, log) = Self::try_new(resources, TOKEN);
        let mut f = f.unwrap_or_else(|| panic!("instantiate failed: {:?}", log.0.lock().unwrap()));
        f.log = log;
        f
    }

    fn init(&self) -> i32 {
        unsafe {
            let s = fmi3EnterInitializationMode(self.instance, false, 0.0, 0.0, false, 0.0);
            if s != OK {
                return s;
            }
            fmi3ExitInitializationMode(self.instance)
        }
    }

    fn set(&self, r: u32, v: f64) -> i32 {
        unsafe { fmi3SetFloat64(self.instance, &r, 1, &v, 1) }
    }

    fn get(&self, r: u32) -> f64 {
        let mut v = f64::NAN;
        assert_eq!(
            unsafe { fmi3GetFloat64(self.instance, &r, 1, &mut v, 1) },
            OK
        );
        v
    }

    fn flag(&self, r: u32) -> bool {
        let mut v = false;
        assert_eq!(
            unsafe { fmi3GetBoolean(self.instance, &r, 1, &mut v, 1) },
            OK
        );
        v
    }

    fn step(&self, t: f64, h: f64) -> i32 {
        let (mut a, mut b, mut c, mut d) = (false, false, false, 0.0);
        unsafe { fmi3DoStep(self.instance, t, h, true, &mut a, &mut b, &mut c, &mut d) }
    }

    fn messages(&self) -> Vec<(i32, String)> {
        self.log.0.lock().unwrap().clone()
    }
}

impl Drop for Fmu {
    fn drop(&mut self) {
        unsafe { fmi3FreeInstance(self.instance) };
    }
}

const TS: f64 = 2e-4;

#[test]
fn a_wrong_token_is_refused_with_a_message() {
    let dir = resources("token", FmuKind::Compensator);
    let (f, log) = Fmu::try_new(&dir, "{another}");
    assert!(f.is_none());
    let log = log.0.lock().unwrap();
    assert!(
        log.iter()
            .any(|(s, m)| *s == ERROR && m.contains("instantiation token")),
        "{log:?}"
    );
}

#[test]
fn missing_and_malformed_resources_are_refused_with_a_message() {
    let dir = resources("missing", FmuKind::Compensator);
    std::fs::remove_file(dir.join("model.json")).unwrap();
    let (f, log) = Fmu::try_new(&dir, TOKEN);
    assert!(f.is_none());
    assert!(log
        .0
        .lock()
        .unwrap()
        .iter()
        .any(|(_, m)| m.contains("model.json")));

    let dir = resources("malformed", FmuKind::Compensator);
    std::fs::write(
        dir.join("model.json"),
        "{\"sample_time\": 2e-4, \"hysteresis\": ",
    )
    .unwrap();
    let (f, log) = Fmu::try_new(&dir, TOKEN);
    assert!(f.is_none());
    assert!(log
        .0
        .lock()
        .unwrap()
        .iter()
        .any(|(_, m)| m.contains("model.json")));

    let dir = resources("config", FmuKind::Compensator);
    std::fs::write(dir.join(CONFIG_FILE), "not json").unwrap();
    let (f, log) = Fmu::try_new(&dir, TOKEN);
    assert!(f.is_none());
    assert!(log
        .0
        .lock()
        .unwrap()
        .iter()
        .any(|(_, m)| m.contains(CONFIG_FILE)));

    // another model through the string parameter, broken: refused when it loads
    let dir = resources("param", FmuKind::Compensator);
    let f = Fmu::new(&dir);
    let bad = CString::new(dir.join("nowhere.json").display().to_string()).unwrap();
    let p = bad.as_ptr();
    assert_eq!(
        unsafe { fmi3SetString(f.instance, &vr::MODEL_FILE, 1, &p, 1) },
        OK
    );
    assert_eq!(f.init(), ERROR);
    assert!(f.messages().iter().any(|(_, m)| m.contains("nowhere.json")));
}

#[test]
fn a_step_that_is_not_whole_samples_is_an_error() {
    let dir = resources("step", FmuKind::Model);
    let f = Fmu::new(&dir);
    assert_eq!(f.init(), OK);
    assert_eq!(f.step(0.0, 1.5 * TS), ERROR);
    assert_eq!(f.step(0.0, 0.0), ERROR);
    assert_eq!(f.step(0.0, f64::NAN), ERROR);
    assert!(
        f.messages()
            .iter()
            .any(|(_, m)| m.contains("whole multiple")),
        "{:?}",
        f.messages()
    );
    // three samples in one step are three samples
    assert_eq!(f.set(vr::INPUT, 300.0), OK);
    assert_eq!(f.step(0.0, 3.0 * TS), OK);
    let g = Fmu::new(&dir);
    assert_eq!(g.init(), OK);
    g.set(vr::INPUT, 300.0);
    for k in 0..3 {
        assert_eq!(g.step(k as f64 * TS, TS), OK);
    }
    assert_eq!(f.get(vr::OUTPUT), g.get(vr::OUTPUT));
}

#[test]
fn calls_out_of_order_and_null_pointers_are_errors() {
    let dir = resources("order", FmuKind::Model);
    let f = Fmu::new(&dir);
    // a step before initialization
    assert_eq!(f.step(0.0, TS), ERROR);
    assert_eq!(f.init(), OK);
    // a fixed parameter after initialization, an unknown variable
    let s = CString::new("x.json").unwrap();
    let p = s.as_ptr();
    assert_eq!(
        unsafe { fmi3SetString(f.instance, &vr::MODEL_FILE, 1, &p, 1) },
        ERROR
    );
    assert_eq!(f.set(12345, 1.0), ERROR);
    assert_eq!(
        unsafe { fmi3GetFloat64(f.instance, std::ptr::null(), 1, std::ptr::null_mut(), 1) },
        ERROR
    );
    assert_eq!(
        unsafe {
            fmi3DoStep(
                std::ptr::null_mut(),
                0.0,
                TS,
                true,
                std::ptr::null_mut(),
                std::ptr::null_mut(),
                std::ptr::null_mut(),
                std::ptr::null_mut(),
            )
        },
        ERROR
    );
    assert!(f.messages().len() >= 3);
}

#[test]
fn a_non_finite_target_is_held_and_flagged() {
    let dir = resources("nan", FmuKind::Compensator);
    let f = Fmu::new(&dir);
    assert_eq!(f.init(), OK);
    f.set(vr::INPUT, 200.0);
    assert_eq!(f.step(0.0, TS), OK);
    let u = f.get(vr::OUTPUT);
    assert!(!f.flag(vr::FAULT));
    for (k, bad) in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY]
        .into_iter()
        .enumerate()
    {
        f.set(vr::INPUT, bad);
        assert_eq!(f.step((k + 1) as f64 * TS, TS), WARNING);
        assert!(f.flag(vr::FAULT));
        assert_eq!(f.get(vr::OUTPUT), u, "the previous output is held");
    }
    f.set(vr::INPUT, 250.0);
    assert_eq!(f.step(4.0 * TS, TS), OK);
    assert!(!f.flag(vr::FAULT));
    assert!(f.get(vr::OUTPUT).is_finite());
}

#[test]
fn instances_are_independent_and_states_restore_bit_for_bit() {
    let dir = resources("independent", FmuKind::Compensator);
    let targets: Vec<f64> = (0..200).map(|k| 700.0 * (k as f64 * 0.05).sin()).collect();
    let run_alone = || {
        let f = Fmu::new(&dir);
        assert_eq!(f.init(), OK);
        targets
            .iter()
            .enumerate()
            .map(|(k, &y)| {
                f.set(vr::INPUT, y);
                assert_eq!(f.step(k as f64 * TS, TS), OK);
                f.get(vr::OUTPUT)
            })
            .collect::<Vec<f64>>()
    };
    let alone = run_alone();
    // two interleaved, the second on negated targets
    let (a, b) = (Fmu::new(&dir), Fmu::new(&dir));
    assert_eq!((a.init(), b.init()), (OK, OK));
    let mut inter = Vec::new();
    for (k, &y) in targets.iter().enumerate() {
        a.set(vr::INPUT, y);
        b.set(vr::INPUT, -y);
        assert_eq!(b.step(k as f64 * TS, TS), OK);
        assert_eq!(a.step(k as f64 * TS, TS), OK);
        inter.push(a.get(vr::OUTPUT));
        assert_eq!(
            b.get(vr::OUTPUT),
            -alone[k],
            "odd symmetry from the virgin state"
        );
    }
    assert_eq!(inter, alone);
    // save half way, run something else, restore, continue
    let f = Fmu::new(&dir);
    assert_eq!(f.init(), OK);
    let mut state: *mut c_void = std::ptr::null_mut();
    let mut out = Vec::new();
    for (k, &y) in targets.iter().enumerate() {
        if k == 100 {
            assert_eq!(unsafe { fmi3GetFMUState(f.instance, &mut state) }, OK);
            for j in 0..37 {
                f.set(vr::INPUT, 900.0 - j as f64);
                assert_eq!(f.step((k + j) as f64 * TS, TS), OK);
            }
            assert_eq!(unsafe { fmi3SetFMUState(f.instance, state) }, OK);
        }
        f.set(vr::INPUT, y);
        assert_eq!(f.step(k as f64 * TS, TS), OK);
        out.push(f.get(vr::OUTPUT));
    }
    assert_eq!(unsafe { fmi3FreeFMUState(f.instance, &mut state) }, OK);
    assert!(state.is_null());
    assert_eq!(out, alone);
}

/// A panic inside a call: an error status and a logged message, the
/// instance unusable afterwards but freeable; the process goes on.
#[test]
fn a_panic_never_crosses_the_c_boundary() {
    let dir = resources("panic", FmuKind::Model);
    let f = Fmu::new(&dir);
    let status = mfcbeam_fmu::guard_for_tests(f.instance, "fmi3DoStep", || panic!("on purpose"));
    assert_eq!(status, ERROR);
    let msgs = f.messages();
    assert!(
        msgs.iter()
            .any(|(_, m)| m.contains("on purpose") && m.contains("internal error")),
        "{msgs:?}"
    );
    // unusable now, but no crash
    assert_eq!(f.init(), ERROR);
    assert_eq!(unsafe { fmi3Reset(f.instance) }, OK);
    assert_eq!(f.init(), OK);
}

/// Another model through the string parameter `model_file`: loaded when
/// initialization starts; the calculated parameters follow it.
#[test]
fn another_model_file_is_loaded_through_the_string_parameter() {
    let dir = resources("other", FmuKind::Model);
    let mut model: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(root().join("golden/nominal_model.json")).unwrap(),
    )
    .unwrap();
    model["delay"] = serde_json::json!(2);
    model["sample_time"] = serde_json::json!(1e-3);
    let other = dir.join("other.json");
    std::fs::write(&other, model.to_string()).unwrap();
    let f = Fmu::new(&dir);
    let path = CString::new(other.display().to_string()).unwrap();
    let p = path.as_ptr();
    assert_eq!(
        unsafe { fmi3SetString(f.instance, &vr::MODEL_FILE, 1, &p, 1) },
        OK
    );
    unsafe {
        assert_eq!(
            fmi3EnterInitializationMode(f.instance, false, 0.0, 0.0, false, 0.0),
            OK
        );
        let mut d = 0i32;
        assert_eq!(fmi3GetInt32(f.instance, &vr::DELAY, 1, &mut d, 1), OK);
        assert_eq!(d, 2);
        assert_eq!(fmi3ExitInitializationMode(f.instance), OK);
    }
    assert_eq!(f.get(vr::SAMPLE_TIME), 1e-3);
    // y_k = z_max(k-2, 0): z_0 three times, then z_1 (creep has moved)
    let mut y = Vec::new();
    for k in 0..4 {
        f.set(vr::INPUT, 400.0);
        assert_eq!(f.step(k as f64 * 1e-3, 1e-3), OK);
        y.push(f.get(vr::OUTPUT));
    }
    assert!(y[0] == y[1] && y[1] == y[2] && y[3] > y[2], "{y:?}");
    // a step of the packaged model's 0.2 ms is no longer whole samples
    assert_eq!(f.step(4e-3, TS), ERROR);
}
