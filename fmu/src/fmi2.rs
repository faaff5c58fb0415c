//! FMI 2.0 Co-Simulation functions.

#![allow(non_snake_case)]
// The importer owns the pointers; each is checked for null before use.
#![allow(clippy::missing_safety_doc)]

use std::ffi::{c_char, c_int, c_void, CString};

use mfcbeam::fmi::{Component, FmuError};

use crate::{c_str, guard, guard_plain, log_to, no_variable, resource_folder, slice, slice_mut};
use crate::{Instance, Logger, ERROR, OK};

type Fmi2Component = *mut c_void;
type Fmi2Status = c_int;

/// `fmi2CallbackFunctions`.
#[repr(C)]
pub struct Fmi2CallbackFunctions {
    pub logger: Option<
        unsafe extern "C" fn(*mut c_void, *const c_char, i32, *const c_char, *const c_char, ...),
    >,
    pub allocate_memory: Option<unsafe extern "C" fn(usize, usize) -> *mut c_void>,
    pub free_memory: Option<unsafe extern "C" fn(*mut c_void)>,
    pub step_finished: Option<unsafe extern "C" fn(*mut c_void, c_int)>,
    pub component_environment: *mut c_void,
}

static TYPES_PLATFORM: &[u8] = b"default\0";
static VERSION: &[u8] = b"2.0\0";

#[no_mangle]
pub extern "C" fn fmi2GetTypesPlatform() -> *const c_char {
    TYPES_PLATFORM.as_ptr().cast()
}

#[no_mangle]
pub extern "C" fn fmi2GetVersion() -> *const c_char {
    VERSION.as_ptr().cast()
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetDebugLogging(
    c: Fmi2Component,
    logging_on: c_int,
    _n: usize,
    _categories: *const *const c_char,
) -> Fmi2Status {
    guard(c, "fmi2SetDebugLogging", |i| {
        i.logging_on = logging_on != 0;
        Ok(OK)
    })
}

/// Instantiate a Co-Simulation instance (type 1); NULL with a logged
/// message for anything else, a wrong GUID or broken resources.
#[no_mangle]
pub unsafe extern "C" fn fmi2Instantiate(
    instance_name: *const c_char,
    fmu_type: c_int,
    guid: *const c_char,
    resource_location: *const c_char,
    functions: *const Fmi2CallbackFunctions,
    _visible: c_int,
    logging_on: c_int,
) -> Fmi2Component {
    let made = guard_plain(|| {
        // SAFETY: a non-null pointer to the importer's callbacks
        let logger = match unsafe { functions.as_ref() } {
            Some(f) => Logger::V2(f.logger, f.component_environment),
            None => Logger::V2(None, std::ptr::null_mut()),
        };
        let name = c_str(instance_name, "instanceName")
            .unwrap_or("mfcbeam")
            .to_string();
        let fail = |e: FmuError| {
            let n = CString::new(name.replace('\0', "")).unwrap_or_default();
            log_to(
                logger,
                &n,
                ERROR,
                "logStatusError",
                &format!("fmi2Instantiate: {e}"),
            );
            None
        };
        if fmu_type != 1 {
            return fail(FmuError::Invalid(
                "only Co-Simulation (fmi2CoSimulation) is supported".into(),
            ));
        }
        let made = c_str(guid, "fmuGUID").and_then(|g| {
            let loc = c_str(resource_location, "fmuResourceLocation")?;
            Component::new(&resource_folder(loc), g)
        });
        match made {
            Ok(component) => Some(Box::new(Instance::new(
                component,
                &name,
                logger,
                logging_on != 0,
            ))),
            Err(e) => fail(e),
        }
    });
    match made {
        Some(b) => Box::into_raw(b).cast(),
        None => std::ptr::null_mut(),
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2FreeInstance(c: Fmi2Component) {
    if !c.is_null() {
        // SAFETY: an instance Instantiate made, freed once
        let _ = guard_plain(|| {
            drop(unsafe { Box::from_raw(c as *mut Instance) });
            Some(())
        });
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetupExperiment(
    c: Fmi2Component,
    _tolerance_defined: c_int,
    _tolerance: f64,
    start_time: f64,
    _stop_time_defined: c_int,
    _stop_time: f64,
) -> Fmi2Status {
    guard(c, "fmi2SetupExperiment", |i| {
        if !start_time.is_finite() {
            return Err(FmuError::Invalid(format!("start time {start_time}")));
        }
        i.start_time = start_time;
        Ok(OK)
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2EnterInitializationMode(c: Fmi2Component) -> Fmi2Status {
    guard(c, "fmi2EnterInitializationMode", |i| {
        let t = i.start_time;
        i.component.enter_initialization(t)?;
        Ok(OK)
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2ExitInitializationMode(c: Fmi2Component) -> Fmi2Status {
    guard(c, "fmi2ExitInitializationMode", |i| {
        i.component.exit_initialization()?;
        Ok(OK)
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2Terminate(c: Fmi2Component) -> Fmi2Status {
    guard(c, "fmi2Terminate", |i| {
        i.component.terminate()?;
        Ok(OK)
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2Reset(c: Fmi2Component) -> Fmi2Status {
    crate::reset(c)
}

/// A getter of one type, through `Component::$get` (converted by `$conv`).
macro_rules! getter {
    ($($name:ident($ty:ty, $get:ident, $conv:expr)),* $(,)?) => {$(
        #[no_mangle]
        pub unsafe extern "C" fn $name(
            c: Fmi2Component,
            vr: *const u32,
            n: usize,
            value: *mut $ty,
        ) -> Fmi2Status {
            guard(c, stringify!($name), |i| {
                let (vr, out) = (slice(vr, n, "vr")?, slice_mut(value, n, "value")?);
                for (r, o) in vr.iter().zip(out) {
                    *o = $conv(i.component.$get(*r)?);
                }
                Ok(OK)
            })
        }
    )*};
}

getter!(
    fmi2GetReal(f64, get_float64, |x: f64| x),
    fmi2GetInteger(c_int, get_int32, |x: i32| x),
    fmi2GetBoolean(c_int, get_boolean, c_int::from),
);

#[no_mangle]
pub unsafe extern "C" fn fmi2GetString(
    c: Fmi2Component,
    vr: *const u32,
    n: usize,
    value: *mut *const c_char,
) -> Fmi2Status {
    guard(c, "fmi2GetString", |i| {
        let (vr, out) = (slice(vr, n, "vr")?, slice_mut(value, n, "value")?);
        i.strings.clear();
        for r in vr {
            let s = i.component.get_string(*r)?;
            i.strings.push(CString::new(s).unwrap_or_default());
        }
        for (o, s) in out.iter_mut().zip(&i.strings) {
            *o = s.as_ptr();
        }
        Ok(OK)
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetReal(
    c: Fmi2Component,
    vr: *const u32,
    n: usize,
    value: *const f64,
) -> Fmi2Status {
    guard(c, "fmi2SetReal", |i| {
        let (vr, v) = (slice(vr, n, "vr")?, slice(value, n, "value")?);
        for (r, x) in vr.iter().zip(v) {
            i.component.set_float64(*r, *x)?;
        }
        Ok(OK)
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetInteger(
    c: Fmi2Component,
    vr: *const u32,
    n: usize,
    _value: *const c_int,
) -> Fmi2Status {
    guard(c, "fmi2SetInteger", |_| no_variable(vr, n))
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetBoolean(
    c: Fmi2Component,
    vr: *const u32,
    n: usize,
    _value: *const c_int,
) -> Fmi2Status {
    guard(c, "fmi2SetBoolean", |_| no_variable(vr, n))
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetString(
    c: Fmi2Component,
    vr: *const u32,
    n: usize,
    value: *const *const c_char,
) -> Fmi2Status {
    guard(c, "fmi2SetString", |i| {
        let (vr, v) = (slice(vr, n, "vr")?, slice(value, n, "value")?);
        for (r, x) in vr.iter().zip(v) {
            i.component.set_string(*r, c_str(*x, "value")?)?;
        }
        Ok(OK)
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetFMUstate(c: Fmi2Component, state: *mut *mut c_void) -> Fmi2Status {
    crate::get_state(c, state, "fmi2GetFMUstate")
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetFMUstate(c: Fmi2Component, state: *mut c_void) -> Fmi2Status {
    crate::set_state(c, state, "fmi2SetFMUstate")
}

#[no_mangle]
pub unsafe extern "C" fn fmi2FreeFMUstate(c: Fmi2Component, state: *mut *mut c_void) -> Fmi2Status {
    crate::free_state(c, state, "fmi2FreeFMUstate")
}

macro_rules! unsupported {
    ($name:ident ( $($arg:ident : $ty:ty),* )) => {
        #[no_mangle]
        pub unsafe extern "C" fn $name(c: Fmi2Component, $($arg: $ty),*) -> Fmi2Status {
            $(let _ = $arg;)*
            guard(c, stringify!($name), |_| {
                Err(FmuError::Invalid("not supported by this FMU".into()))
            })
        }
    };
}

unsupported!(fmi2SerializedFMUstateSize(state: *mut c_void, size: *mut usize));
unsupported!(fmi2SerializeFMUstate(state: *mut c_void, bytes: *mut c_char, size: usize));
unsupported!(fmi2DeSerializeFMUstate(bytes: *const c_char, size: usize, state: *mut *mut c_void));
unsupported!(fmi2GetDirectionalDerivative(
    unknown: *const u32,
    n_unknown: usize,
    known: *const u32,
    n_known: usize,
    dv_known: *const f64,
    dv_unknown: *mut f64
));
unsupported!(fmi2SetRealInputDerivatives(vr: *const u32, n: usize, order: *const c_int, value: *const f64));
unsupported!(fmi2GetRealOutputDerivatives(vr: *const u32, n: usize, order: *const c_int, value: *mut f64));
unsupported!(fmi2CancelStep());
unsupported!(fmi2GetStatus(kind: c_int, value: *mut c_int));
unsupported!(fmi2GetRealStatus(kind: c_int, value: *mut f64));
unsupported!(fmi2GetIntegerStatus(kind: c_int, value: *mut c_int));
unsupported!(fmi2GetBooleanStatus(kind: c_int, value: *mut c_int));
unsupported!(fmi2GetStringStatus(kind: c_int, value: *mut *const c_char));

#[no_mangle]
pub unsafe extern "C" fn fmi2DoStep(
    c: Fmi2Component,
    current: f64,
    step: f64,
    _no_set_prior: c_int,
) -> Fmi2Status {
    guard(c, "fmi2DoStep", |i| {
        i.component.do_step(current, step)?;
        Ok(if i.component.input_fault() {
            i.log(
                crate::WARNING,
                "logStatusWarning",
                "fmi2DoStep: the input was not a finite number: the previous one is held (output 'fault')",
            );
            crate::WARNING
        } else {
            OK
        })
    })
}
