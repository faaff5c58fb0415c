//! The C side of an imported FMU: the types of the FMI 2.0 and 3.0
//! functions a sampled Co-Simulation run calls (looked up by name in
//! `fmu`), and the loggers and memory callbacks handed to it.

use std::ffi::{c_char, c_int, c_void, CStr};
use std::sync::Mutex;

pub(super) type Handle = *mut c_void;

/// FMI 2's logger is variadic; the message is taken as given (its format
/// arguments, if any, are not expanded): a non-variadic callee reads the
/// fixed arguments correctly on the C calling conventions in use.
pub(super) type Fmi2Logger =
    unsafe extern "C" fn(*mut c_void, *const c_char, c_int, *const c_char, *const c_char);

#[repr(C)]
pub(super) struct Fmi2Callbacks {
    pub(super) logger: Fmi2Logger,
    pub(super) allocate: unsafe extern "C" fn(usize, usize) -> *mut c_void,
    pub(super) free: unsafe extern "C" fn(*mut c_void),
    pub(super) step_finished: Option<unsafe extern "C" fn(*mut c_void, c_int)>,
    pub(super) environment: *mut c_void,
}

unsafe extern "C" {
    pub(super) fn calloc(n: usize, size: usize) -> *mut c_void;
    pub(super) fn free(p: *mut c_void);
}

pub(super) unsafe extern "C" fn fmi2_logger(
    env: *mut c_void,
    _instance: *const c_char,
    status: c_int,
    category: *const c_char,
    message: *const c_char,
) {
    // SAFETY: `env` is the instance's log, alive while the instance is
    let log = unsafe { &*(env as *const Mutex<Vec<String>>) };
    unsafe { push_log(log, status, category, message) };
}

pub(super) unsafe extern "C" fn fmi3_logger(
    env: *mut c_void,
    status: c_int,
    category: *const c_char,
    message: *const c_char,
) {
    // SAFETY: as in fmi2_logger
    let log = unsafe { &*(env as *const Mutex<Vec<String>>) };
    unsafe { push_log(log, status, category, message) };
}

/// Keep the last few messages of an instance for its errors.
pub(super) unsafe fn push_log(
    log: &Mutex<Vec<String>>,
    status: c_int,
    category: *const c_char,
    message: *const c_char,
) {
    let text = |p: *const c_char| {
        if p.is_null() {
            String::new()
        } else {
            // SAFETY: the FMU passes NUL-terminated strings
            unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned()
        }
    };
    let line = format!("[{} {status}] {}", text(category), text(message));
    if let Ok(mut l) = log.lock() {
        if l.len() >= 16 {
            l.remove(0);
        }
        l.push(line);
    }
}

#[derive(Clone, Copy)]
pub(super) struct Fmi2Api {
    pub(super) instantiate: unsafe extern "C" fn(
        *const c_char,
        c_int,
        *const c_char,
        *const c_char,
        *const Fmi2Callbacks,
        c_int,
        c_int,
    ) -> Handle,
    pub(super) free_instance: unsafe extern "C" fn(Handle),
    pub(super) setup_experiment: unsafe extern "C" fn(Handle, c_int, f64, f64, c_int, f64) -> c_int,
    pub(super) enter_initialization: unsafe extern "C" fn(Handle) -> c_int,
    pub(super) exit_initialization: unsafe extern "C" fn(Handle) -> c_int,
    pub(super) terminate: unsafe extern "C" fn(Handle) -> c_int,
    pub(super) set_real: unsafe extern "C" fn(Handle, *const u32, usize, *const f64) -> c_int,
    pub(super) get_real: unsafe extern "C" fn(Handle, *const u32, usize, *mut f64) -> c_int,
    pub(super) get_integer: unsafe extern "C" fn(Handle, *const u32, usize, *mut c_int) -> c_int,
    pub(super) get_boolean: unsafe extern "C" fn(Handle, *const u32, usize, *mut c_int) -> c_int,
    pub(super) do_step: unsafe extern "C" fn(Handle, f64, f64, c_int) -> c_int,
    pub(super) get_state: unsafe extern "C" fn(Handle, *mut Handle) -> c_int,
    pub(super) set_state: unsafe extern "C" fn(Handle, Handle) -> c_int,
    pub(super) free_state: unsafe extern "C" fn(Handle, *mut Handle) -> c_int,
}

pub(super) type Fmi3Logger = unsafe extern "C" fn(*mut c_void, c_int, *const c_char, *const c_char);

#[derive(Clone, Copy)]
pub(super) struct Fmi3Api {
    pub(super) instantiate: unsafe extern "C" fn(
        *const c_char,
        *const c_char,
        *const c_char,
        bool,
        bool,
        bool,
        bool,
        *const u32,
        usize,
        *mut c_void,
        Fmi3Logger,
        *const c_void,
    ) -> Handle,
    pub(super) free_instance: unsafe extern "C" fn(Handle),
    pub(super) enter_initialization:
        unsafe extern "C" fn(Handle, bool, f64, f64, bool, f64) -> c_int,
    pub(super) exit_initialization: unsafe extern "C" fn(Handle) -> c_int,
    pub(super) terminate: unsafe extern "C" fn(Handle) -> c_int,
    pub(super) set_float64:
        unsafe extern "C" fn(Handle, *const u32, usize, *const f64, usize) -> c_int,
    pub(super) get_float64:
        unsafe extern "C" fn(Handle, *const u32, usize, *mut f64, usize) -> c_int,
    pub(super) get_int32: unsafe extern "C" fn(Handle, *const u32, usize, *mut i32, usize) -> c_int,
    pub(super) get_boolean:
        unsafe extern "C" fn(Handle, *const u32, usize, *mut bool, usize) -> c_int,
    pub(super) do_step: unsafe extern "C" fn(
        Handle,
        f64,
        f64,
        bool,
        *mut bool,
        *mut bool,
        *mut bool,
        *mut f64,
    ) -> c_int,
    pub(super) get_state: unsafe extern "C" fn(Handle, *mut Handle) -> c_int,
    pub(super) set_state: unsafe extern "C" fn(Handle, Handle) -> c_int,
    pub(super) free_state: unsafe extern "C" fn(Handle, *mut Handle) -> c_int,
}

#[derive(Clone, Copy)]
pub(super) enum Api {
    V2(Fmi2Api),
    V3(Fmi3Api),
}
