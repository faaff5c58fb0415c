//! The C functions of mfcbeam's FMUs (FMI 2.0 and 3.0 Co-Simulation), a
//! thin layer over [`mfcbeam::fmi::Component`]: they check pointers,
//! convert types, log errors through the importer's callback and return
//! the status. No panic crosses the C boundary: every function runs its
//! body under [`guard`], which turns a panic into an error status with a
//! logged message and marks the instance unusable (only free and reset
//! remain).

use std::ffi::{c_char, c_void, CStr, CString};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::PathBuf;

use mfcbeam::fmi::Component;
use mfcbeam::fmi::FmuError;

pub mod fmi2;
pub mod fmi3;

/// The status codes, the same numbers in FMI 2 and 3.
pub const OK: i32 = 0;
pub const WARNING: i32 = 1;
pub const DISCARD: i32 = 2;
pub const ERROR: i32 = 3;
pub const FATAL: i32 = 4;

type Fmi2Logger =
    unsafe extern "C" fn(*mut c_void, *const c_char, i32, *const c_char, *const c_char, ...);
type Fmi3Logger = unsafe extern "C" fn(*mut c_void, i32, *const c_char, *const c_char);

/// The importer's logger.
#[derive(Clone, Copy)]
pub(crate) enum Logger {
    V2(Option<Fmi2Logger>, *mut c_void),
    V3(Option<Fmi3Logger>, *mut c_void),
}

/// One instance as the importer holds it.
pub struct Instance {
    pub(crate) component: Component,
    name: CString,
    logger: Logger,
    logging_on: bool,
    /// Strings handed out by GetString stay valid until the next call.
    pub(crate) strings: Vec<CString>,
    /// A panic happened: only free and reset are served.
    poisoned: bool,
    /// FMI 2's start time, from SetupExperiment.
    pub(crate) start_time: f64,
}

impl Instance {
    pub(crate) fn new(component: Component, name: &str, logger: Logger, logging_on: bool) -> Self {
        Self {
            component,
            name: CString::new(name.replace('\0', "")).unwrap_or_default(),
            logger,
            logging_on,
            strings: Vec::new(),
            poisoned: false,
            start_time: 0.0,
        }
    }

    /// Log a message; errors are logged whether or not logging is on.
    pub(crate) fn log(&self, status: i32, category: &str, message: &str) {
        if status < ERROR && !self.logging_on {
            return;
        }
        log_to(self.logger, &self.name, status, category, message);
    }
}

/// Send one message to a logger (`%` escaped: FMI 2's logger formats).
pub(crate) fn log_to(logger: Logger, name: &CStr, status: i32, category: &str, message: &str) {
    let category = CString::new(category.replace('\0', "")).unwrap_or_default();
    match logger {
        Logger::V2(Some(f), env) => {
            let m = CString::new(message.replace('\0', "").replace('%', "%%")).unwrap_or_default();
            // SAFETY: the importer's logger, called with its declared arguments
            unsafe { f(env, name.as_ptr(), status, category.as_ptr(), m.as_ptr()) };
        }
        Logger::V3(Some(f), env) => {
            let m = CString::new(message.replace('\0', "")).unwrap_or_default();
            // SAFETY: as above
            unsafe { f(env, status, category.as_ptr(), m.as_ptr()) };
        }
        _ => {}
    }
}

/// Reset (either version): back to the instantiated state; also clears a
/// panic's mark.
pub(crate) fn reset(ptr: *mut c_void) -> i32 {
    if ptr.is_null() {
        return ERROR;
    }
    // SAFETY: an instance Instantiate made
    let instance = unsafe { &mut *(ptr as *mut Instance) };
    instance.poisoned = false;
    guard(ptr, "Reset", |i| {
        i.component.reset()?;
        i.start_time = 0.0;
        Ok(OK)
    })
}

/// GetFMUState (either version): a new state, or the given one
/// overwritten.
pub(crate) fn get_state(ptr: *mut c_void, state: *mut *mut c_void, call: &str) -> i32 {
    guard(ptr, call, |i| {
        if state.is_null() {
            return Err(FmuError::Invalid("FMUstate is NULL".into()));
        }
        let saved = i.component.save();
        // SAFETY: `state` points to a state pointer, NULL or one we made
        unsafe {
            if (*state).is_null() {
                *state = Box::into_raw(saved).cast();
            } else {
                *(*state as *mut mfcbeam::fmi::component::State) = *saved;
            }
        }
        Ok(OK)
    })
}

/// SetFMUState (either version).
pub(crate) fn set_state(ptr: *mut c_void, state: *mut c_void, call: &str) -> i32 {
    guard(ptr, call, |i| {
        if state.is_null() {
            return Err(FmuError::Invalid("FMUstate is NULL".into()));
        }
        // SAFETY: a state GetFMUState made and not freed
        let s = unsafe { &*(state as *const mfcbeam::fmi::component::State) };
        i.component.restore(s);
        Ok(OK)
    })
}

/// FreeFMUState (either version).
pub(crate) fn free_state(ptr: *mut c_void, state: *mut *mut c_void, call: &str) -> i32 {
    guard(ptr, call, |_| {
        if state.is_null() {
            return Ok(OK);
        }
        // SAFETY: a state GetFMUState made, freed once
        unsafe {
            if !(*state).is_null() {
                drop(Box::from_raw(*state as *mut mfcbeam::fmi::component::State));
                *state = std::ptr::null_mut();
            }
        }
        Ok(OK)
    })
}

/// The text of a panic payload.
fn panic_message(p: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = p.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = p.downcast_ref::<String>() {
        s.clone()
    } else {
        "a panic".into()
    }
}

/// Run `body` on the instance behind `ptr`: a null or poisoned instance,
/// an error and a panic each become `ERROR` with a logged message.
pub(crate) fn guard(
    ptr: *mut c_void,
    call: &str,
    body: impl FnOnce(&mut Instance) -> Result<i32, FmuError>,
) -> i32 {
    if ptr.is_null() {
        return ERROR;
    }
    // SAFETY: a non-null instance pointer is one Instantiate returned
    let instance = unsafe { &mut *(ptr as *mut Instance) };
    if instance.poisoned {
        instance.log(
            ERROR,
            "logStatusError",
            &format!("{call}: the instance failed earlier (a panic); free or reset it"),
        );
        return ERROR;
    }
    match catch_unwind(AssertUnwindSafe(|| body(instance))) {
        Ok(Ok(status)) => status,
        Ok(Err(e)) => {
            instance.log(ERROR, "logStatusError", &format!("{call}: {e}"));
            ERROR
        }
        Err(p) => {
            instance.poisoned = true;
            instance.log(
                FATAL,
                "logStatusFatal",
                &format!(
                    "{call}: internal error ({}); the instance is unusable",
                    panic_message(&*p)
                ),
            );
            ERROR
        }
    }
}

/// [`guard`] around a body that may panic, for the tests of the
/// boundary (the exported functions' bodies do not panic on any input
/// found so far; this proves the guard holds if one does).
#[doc(hidden)]
pub fn guard_for_tests(ptr: *mut c_void, call: &str, body: impl FnOnce() -> i32) -> i32 {
    guard(ptr, call, |_| Ok(body()))
}

/// Like [`guard`] for calls without an instance (Instantiate): a panic
/// becomes `None`.
pub(crate) fn guard_plain<R>(body: impl FnOnce() -> Option<R>) -> Option<R> {
    catch_unwind(AssertUnwindSafe(body)).ok().flatten()
}

/// A C string argument, or an error naming it.
pub(crate) fn c_str<'a>(p: *const c_char, what: &str) -> Result<&'a str, FmuError> {
    if p.is_null() {
        return Err(FmuError::Invalid(format!("{what} is NULL")));
    }
    // SAFETY: the importer passes NUL-terminated strings
    unsafe { CStr::from_ptr(p) }
        .to_str()
        .map_err(|_| FmuError::Invalid(format!("{what} is not UTF-8")))
}

/// The folder of an FMI 2 resource location (`file:///…`, `file:/…`,
/// percent-encoded) or an FMI 3 resource path.
pub(crate) fn resource_folder(location: &str) -> PathBuf {
    let rest = match location.strip_prefix("file://") {
        // file://localhost/… and file:///…: the path starts at the first '/'
        Some(rest) => match rest.find('/') {
            Some(i) => &rest[i..],
            None => rest,
        },
        None => match location.strip_prefix("file:") {
            Some(rest) => rest,
            // a native path (FMI 3.0's resourcePath): as it is
            None => return PathBuf::from(location),
        },
    };
    let bytes = rest.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' && i + 2 < bytes.len() {
            let hex = |b: u8| (b as char).to_digit(16);
            if let (Some(h), Some(l)) = (hex(bytes[i + 1]), hex(bytes[i + 2])) {
                out.push((h * 16 + l) as u8);
                i += 3;
                continue;
            }
        }
        out.push(bytes[i]);
        i += 1;
    }
    let path = String::from_utf8_lossy(&out).into_owned();
    // file:///C:/dir: on Windows the path starts at the drive letter
    let b = path.as_bytes();
    if cfg!(windows) && b.len() >= 3 && b[0] == b'/' && b[1].is_ascii_alphabetic() && b[2] == b':' {
        return PathBuf::from(&path[1..]);
    }
    PathBuf::from(path)
}

/// The body of a setter or getter of a type this FMU has no variable of:
/// any value reference is unknown, none is fine.
pub(crate) fn no_variable(vr: *const u32, n: usize) -> Result<i32, FmuError> {
    match slice(vr, n, "vr")?.first() {
        Some(r) => Err(FmuError::UnknownVariable(*r)),
        None => Ok(OK),
    }
}

/// Slices from C arrays (empty for a null pointer with length 0).
pub(crate) fn slice<'a, T>(p: *const T, n: usize, what: &str) -> Result<&'a [T], FmuError> {
    if n == 0 {
        return Ok(&[]);
    }
    if p.is_null() {
        return Err(FmuError::Invalid(format!("{what} is NULL")));
    }
    // SAFETY: the importer passes `n` elements
    Ok(unsafe { std::slice::from_raw_parts(p, n) })
}

pub(crate) fn slice_mut<'a, T>(p: *mut T, n: usize, what: &str) -> Result<&'a mut [T], FmuError> {
    if n == 0 {
        return Ok(&mut []);
    }
    if p.is_null() {
        return Err(FmuError::Invalid(format!("{what} is NULL")));
    }
    // SAFETY: the importer passes room for `n` elements
    Ok(unsafe { std::slice::from_raw_parts_mut(p, n) })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resource_locations() {
        assert_eq!(
            resource_folder("file:///tmp/a%20b/resources"),
            PathBuf::from("/tmp/a b/resources")
        );
        assert_eq!(
            resource_folder("file:/tmp/x/resources/"),
            PathBuf::from("/tmp/x/resources/")
        );
        assert_eq!(
            resource_folder("file://localhost/tmp/x"),
            PathBuf::from("/tmp/x")
        );
        assert_eq!(resource_folder("/tmp/x/"), PathBuf::from("/tmp/x/"));
        // a native path is not decoded
        assert_eq!(resource_folder("/tmp/100%41"), PathBuf::from("/tmp/100%41"));
        assert_eq!(resource_folder("Z:/tmp/x/"), PathBuf::from("Z:/tmp/x/"));
        assert_eq!(
            resource_folder("Z:\\tmp\\x\\"),
            PathBuf::from("Z:\\tmp\\x\\")
        );
        // a stray % stays
        assert_eq!(
            resource_folder("file:///tmp/100%"),
            PathBuf::from("/tmp/100%")
        );
        // on Windows, the drive letter after file:///
        let drive = resource_folder("file:///C:/x%20y/resources");
        if cfg!(windows) {
            assert_eq!(drive, PathBuf::from("C:/x y/resources"));
        } else {
            assert_eq!(drive, PathBuf::from("/C:/x y/resources"));
        }
    }
}
