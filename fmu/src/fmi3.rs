//! FMI 3.0 Co-Simulation functions (Model Exchange and Scheduled
//! Execution instantiate to NULL; the functions of features this FMU does
//! not declare return an error).

#![allow(non_snake_case)]
#![allow(clippy::missing_safety_doc)]

use std::ffi::{c_char, c_int, c_void, CString};

use mfcbeam::fmi::{Component, FmuError};

use crate::{c_str, guard, guard_plain, log_to, no_variable, resource_folder, slice, slice_mut};
use crate::{Instance, Logger, ERROR, OK};

type Fmi3Instance = *mut c_void;
type Fmi3Status = c_int;
type Fmi3LogMessage = unsafe extern "C" fn(*mut c_void, i32, *const c_char, *const c_char);

static VERSION: &[u8] = b"3.0\0";

#[no_mangle]
pub extern "C" fn fmi3GetVersion() -> *const c_char {
    VERSION.as_ptr().cast()
}

#[no_mangle]
pub unsafe extern "C" fn fmi3SetDebugLogging(
    instance: Fmi3Instance,
    logging_on: bool,
    _n: usize,
    _categories: *const *const c_char,
) -> Fmi3Status {
    guard(instance, "fmi3SetDebugLogging", |i| {
        i.logging_on = logging_on;
        Ok(OK)
    })
}

/// The other interface types: NULL, with the reason logged.
fn only_co_simulation(
    environment: *mut c_void,
    log_message: Option<Fmi3LogMessage>,
    call: &str,
) -> Fmi3Instance {
    let n = CString::new("mfcbeam").unwrap_or_default();
    log_to(
        Logger::V3(log_message, environment),
        &n,
        ERROR,
        "logStatusError",
        &format!("{call}: only Co-Simulation is supported"),
    );
    std::ptr::null_mut()
}

#[no_mangle]
pub unsafe extern "C" fn fmi3InstantiateModelExchange(
    _name: *const c_char,
    _token: *const c_char,
    _resources: *const c_char,
    _visible: bool,
    _logging_on: bool,
    environment: *mut c_void,
    log_message: Option<Fmi3LogMessage>,
) -> Fmi3Instance {
    only_co_simulation(environment, log_message, "fmi3InstantiateModelExchange")
}

#[no_mangle]
pub unsafe extern "C" fn fmi3InstantiateScheduledExecution(
    _name: *const c_char,
    _token: *const c_char,
    _resources: *const c_char,
    _visible: bool,
    _logging_on: bool,
    environment: *mut c_void,
    log_message: Option<Fmi3LogMessage>,
    _clock_update: *const c_void,
    _lock: *const c_void,
    _unlock: *const c_void,
) -> Fmi3Instance {
    only_co_simulation(
        environment,
        log_message,
        "fmi3InstantiateScheduledExecution",
    )
}

/// Instantiate; NULL with a logged message for a wrong token or broken
/// resources, or if event mode or early return is asked for.
#[no_mangle]
pub unsafe extern "C" fn fmi3InstantiateCoSimulation(
    name: *const c_char,
    token: *const c_char,
    resource_path: *const c_char,
    _visible: bool,
    logging_on: bool,
    event_mode_used: bool,
    _early_return_allowed: bool,
    _required: *const u32,
    _n_required: usize,
    environment: *mut c_void,
    log_message: Option<Fmi3LogMessage>,
    _intermediate_update: *const c_void,
) -> Fmi3Instance {
    let made = guard_plain(|| {
        let logger = Logger::V3(log_message, environment);
        let name = c_str(name, "instanceName").unwrap_or("mfcbeam").to_string();
        let fail = |e: FmuError| {
            let n = CString::new(name.replace('\0', "")).unwrap_or_default();
            log_to(
                logger,
                &n,
                ERROR,
                "logStatusError",
                &format!("fmi3InstantiateCoSimulation: {e}"),
            );
            None
        };
        if event_mode_used {
            return fail(FmuError::Invalid("this FMU has no event mode".into()));
        }
        let made = c_str(token, "instantiationToken").and_then(|t| {
            let path = c_str(resource_path, "resourcePath")?;
            Component::new(&resource_folder(path), t)
        });
        match made {
            Ok(c) => Some(Box::new(Instance::new(c, &name, logger, logging_on))),
            Err(e) => fail(e),
        }
    });
    match made {
        Some(b) => Box::into_raw(b).cast(),
        None => std::ptr::null_mut(),
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi3FreeInstance(instance: Fmi3Instance) {
    if !instance.is_null() {
        let _ = guard_plain(|| {
            // SAFETY: an instance Instantiate made, freed once
            drop(unsafe { Box::from_raw(instance as *mut Instance) });
            Some(())
        });
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi3EnterInitializationMode(
    instance: Fmi3Instance,
    _tolerance_defined: bool,
    _tolerance: f64,
    start_time: f64,
    _stop_time_defined: bool,
    _stop_time: f64,
) -> Fmi3Status {
    guard(instance, "fmi3EnterInitializationMode", |i| {
        i.component.enter_initialization(start_time)?;
        Ok(OK)
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi3ExitInitializationMode(instance: Fmi3Instance) -> Fmi3Status {
    guard(instance, "fmi3ExitInitializationMode", |i| {
        i.component.exit_initialization()?;
        Ok(OK)
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi3Terminate(instance: Fmi3Instance) -> Fmi3Status {
    guard(instance, "fmi3Terminate", |i| {
        i.component.terminate()?;
        Ok(OK)
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi3Reset(instance: Fmi3Instance) -> Fmi3Status {
    crate::reset(instance)
}

/// A getter of scalar variables: `n_values` must equal the count.
fn scalars(n_vr: usize, n_values: usize) -> Result<(), FmuError> {
    if n_vr == n_values {
        Ok(())
    } else {
        Err(FmuError::Invalid(format!(
            "{n_values} values for {n_vr} scalar variables"
        )))
    }
}

/// A getter of scalar variables of one type, through `Component::$get`.
macro_rules! scalar_getter {
    ($($name:ident($ty:ty, $get:ident)),* $(,)?) => {$(
        #[no_mangle]
        pub unsafe extern "C" fn $name(
            instance: Fmi3Instance,
            vr: *const u32,
            n_vr: usize,
            values: *mut $ty,
            n_values: usize,
        ) -> Fmi3Status {
            guard(instance, stringify!($name), |i| {
                scalars(n_vr, n_values)?;
                let (vr, out) = (
                    slice(vr, n_vr, "vr")?,
                    slice_mut(values, n_values, "values")?,
                );
                for (r, o) in vr.iter().zip(out) {
                    *o = i.component.$get(*r)?;
                }
                Ok(OK)
            })
        }
    )*};
}

scalar_getter!(
    fmi3GetFloat64(f64, get_float64),
    fmi3GetInt32(i32, get_int32),
    fmi3GetBoolean(bool, get_boolean),
);

#[no_mangle]
pub unsafe extern "C" fn fmi3GetString(
    instance: Fmi3Instance,
    vr: *const u32,
    n_vr: usize,
    values: *mut *const c_char,
    n_values: usize,
) -> Fmi3Status {
    guard(instance, "fmi3GetString", |i| {
        scalars(n_vr, n_values)?;
        let (vr, out) = (
            slice(vr, n_vr, "vr")?,
            slice_mut(values, n_values, "values")?,
        );
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
pub unsafe extern "C" fn fmi3SetFloat64(
    instance: Fmi3Instance,
    vr: *const u32,
    n_vr: usize,
    values: *const f64,
    n_values: usize,
) -> Fmi3Status {
    guard(instance, "fmi3SetFloat64", |i| {
        scalars(n_vr, n_values)?;
        let (vr, v) = (slice(vr, n_vr, "vr")?, slice(values, n_values, "values")?);
        for (r, x) in vr.iter().zip(v) {
            i.component.set_float64(*r, *x)?;
        }
        Ok(OK)
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi3SetString(
    instance: Fmi3Instance,
    vr: *const u32,
    n_vr: usize,
    values: *const *const c_char,
    n_values: usize,
) -> Fmi3Status {
    guard(instance, "fmi3SetString", |i| {
        scalars(n_vr, n_values)?;
        let (vr, v) = (slice(vr, n_vr, "vr")?, slice(values, n_values, "values")?);
        for (r, x) in vr.iter().zip(v) {
            i.component.set_string(*r, c_str(*x, "value")?)?;
        }
        Ok(OK)
    })
}

/// Getters and setters of types this FMU has no variable of: any value
/// reference is unknown.
macro_rules! no_variables {
    ($($name:ident($ty:ty)),* $(,)?) => {$(
        #[no_mangle]
        pub unsafe extern "C" fn $name(
            instance: Fmi3Instance,
            vr: *const u32,
            n_vr: usize,
            _values: $ty,
            _n_values: usize,
        ) -> Fmi3Status {
            guard(instance, stringify!($name), |_| no_variable(vr, n_vr))
        }
    )*};
}

no_variables!(
    fmi3GetFloat32(*mut f32),
    fmi3GetInt8(*mut i8),
    fmi3GetUInt8(*mut u8),
    fmi3GetInt16(*mut i16),
    fmi3GetUInt16(*mut u16),
    fmi3GetUInt32(*mut u32),
    fmi3GetInt64(*mut i64),
    fmi3GetUInt64(*mut u64),
    fmi3SetFloat32(*const f32),
    fmi3SetInt8(*const i8),
    fmi3SetUInt8(*const u8),
    fmi3SetInt16(*const i16),
    fmi3SetUInt16(*const u16),
    fmi3SetInt32(*const i32),
    fmi3SetUInt32(*const u32),
    fmi3SetInt64(*const i64),
    fmi3SetUInt64(*const u64),
    fmi3SetBoolean(*const bool),
);

#[no_mangle]
pub unsafe extern "C" fn fmi3GetBinary(
    instance: Fmi3Instance,
    vr: *const u32,
    n_vr: usize,
    _sizes: *mut usize,
    _values: *mut *const u8,
    _n_values: usize,
) -> Fmi3Status {
    guard(instance, "fmi3GetBinary", |_| no_variable(vr, n_vr))
}

#[no_mangle]
pub unsafe extern "C" fn fmi3SetBinary(
    instance: Fmi3Instance,
    vr: *const u32,
    n_vr: usize,
    _sizes: *const usize,
    _values: *const *const u8,
    _n_values: usize,
) -> Fmi3Status {
    guard(instance, "fmi3SetBinary", |_| no_variable(vr, n_vr))
}

#[no_mangle]
pub unsafe extern "C" fn fmi3GetFMUState(
    instance: Fmi3Instance,
    state: *mut *mut c_void,
) -> Fmi3Status {
    crate::get_state(instance, state, "fmi3GetFMUState")
}

#[no_mangle]
pub unsafe extern "C" fn fmi3SetFMUState(instance: Fmi3Instance, state: *mut c_void) -> Fmi3Status {
    crate::set_state(instance, state, "fmi3SetFMUState")
}

#[no_mangle]
pub unsafe extern "C" fn fmi3FreeFMUState(
    instance: Fmi3Instance,
    state: *mut *mut c_void,
) -> Fmi3Status {
    crate::free_state(instance, state, "fmi3FreeFMUState")
}

#[no_mangle]
pub unsafe extern "C" fn fmi3DoStep(
    instance: Fmi3Instance,
    current: f64,
    step: f64,
    _no_set_prior: bool,
    event_handling_needed: *mut bool,
    terminate_simulation: *mut bool,
    early_return: *mut bool,
    last_successful_time: *mut f64,
) -> Fmi3Status {
    guard(instance, "fmi3DoStep", |i| {
        // SAFETY (the out-parameters): written where the importer gave them
        let report = |t: f64| unsafe {
            if let Some(e) = event_handling_needed.as_mut() {
                *e = false;
            }
            if let Some(e) = terminate_simulation.as_mut() {
                *e = false;
            }
            if let Some(e) = early_return.as_mut() {
                *e = false;
            }
            if let Some(e) = last_successful_time.as_mut() {
                *e = t;
            }
        };
        report(i.component.time());
        i.component.do_step(current, step)?;
        report(i.component.time());
        Ok(if i.component.input_fault() {
            i.log(
                crate::WARNING,
                "logStatusWarning",
                "fmi3DoStep: the input was not a finite number: the previous one is held (output 'fault')",
            );
            crate::WARNING
        } else {
            OK
        })
    })
}

macro_rules! unsupported {
    ($($name:ident ( $($arg:ident : $ty:ty),* );)*) => {$(
        #[no_mangle]
        pub unsafe extern "C" fn $name(instance: Fmi3Instance, $($arg: $ty),*) -> Fmi3Status {
            $(let _ = $arg;)*
            guard(instance, stringify!($name), |_| {
                Err(FmuError::Invalid("not supported by this FMU".into()))
            })
        }
    )*};
}

unsupported! {
    fmi3EnterEventMode();
    fmi3GetClock(vr: *const u32, n: usize, values: *mut bool);
    fmi3SetClock(vr: *const u32, n: usize, values: *const bool);
    fmi3GetNumberOfVariableDependencies(vr: u32, n: *mut usize);
    fmi3GetVariableDependencies(
        dependent: u32,
        element_dependent: *mut usize,
        independents: *mut u32,
        element_independents: *mut usize,
        kinds: *mut c_int,
        n: usize
    );
    fmi3SerializedFMUStateSize(state: *mut c_void, size: *mut usize);
    fmi3SerializeFMUState(state: *mut c_void, bytes: *mut u8, size: usize);
    fmi3DeserializeFMUState(bytes: *const u8, size: usize, state: *mut *mut c_void);
    fmi3GetDirectionalDerivative(
        unknowns: *const u32,
        n_unknowns: usize,
        knowns: *const u32,
        n_knowns: usize,
        seed: *const f64,
        n_seed: usize,
        sensitivity: *mut f64,
        n_sensitivity: usize
    );
    fmi3GetAdjointDerivative(
        unknowns: *const u32,
        n_unknowns: usize,
        knowns: *const u32,
        n_knowns: usize,
        seed: *const f64,
        n_seed: usize,
        sensitivity: *mut f64,
        n_sensitivity: usize
    );
    fmi3EnterConfigurationMode();
    fmi3ExitConfigurationMode();
    fmi3GetIntervalDecimal(vr: *const u32, n: usize, intervals: *mut f64, qualifiers: *mut c_int);
    fmi3GetIntervalFraction(
        vr: *const u32,
        n: usize,
        counters: *mut u64,
        resolutions: *mut u64,
        qualifiers: *mut c_int
    );
    fmi3GetShiftDecimal(vr: *const u32, n: usize, shifts: *mut f64);
    fmi3GetShiftFraction(vr: *const u32, n: usize, counters: *mut u64, resolutions: *mut u64);
    fmi3SetIntervalDecimal(vr: *const u32, n: usize, intervals: *const f64);
    fmi3SetIntervalFraction(vr: *const u32, n: usize, counters: *const u64, resolutions: *const u64);
    fmi3SetShiftDecimal(vr: *const u32, n: usize, shifts: *const f64);
    fmi3SetShiftFraction(vr: *const u32, n: usize, counters: *const u64, resolutions: *const u64);
    fmi3EvaluateDiscreteStates();
    fmi3UpdateDiscreteStates(
        needs_update: *mut bool,
        terminate: *mut bool,
        nominals_changed: *mut bool,
        values_changed: *mut bool,
        next_defined: *mut bool,
        next_time: *mut f64
    );
    fmi3EnterContinuousTimeMode();
    fmi3CompletedIntegratorStep(
        no_set_prior: bool,
        enter_event: *mut bool,
        terminate: *mut bool
    );
    fmi3SetTime(time: f64);
    fmi3SetContinuousStates(states: *const f64, n: usize);
    fmi3GetContinuousStateDerivatives(derivatives: *mut f64, n: usize);
    fmi3GetEventIndicators(indicators: *mut f64, n: usize);
    fmi3GetContinuousStates(states: *mut f64, n: usize);
    fmi3GetNominalsOfContinuousStates(nominals: *mut f64, n: usize);
    fmi3GetNumberOfEventIndicators(n: *mut usize);
    fmi3GetNumberOfContinuousStates(n: *mut usize);
    fmi3EnterStepMode();
    fmi3GetOutputDerivatives(vr: *const u32, n: usize, orders: *const i32, values: *mut f64, n_values: usize);
    fmi3ActivateModelPartition(clock: u32, time: f64);
}
