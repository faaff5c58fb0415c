//! Flags of a compensator step, and why a constructor failed, written into
//! the caller's buffer without allocating.

use core::ffi::c_char;
use core::fmt;

use mfcbeam_rs::realtime::ParameterError;

/// `flags` bit 0: the voltage was clipped to a limit.
pub const MFCBEAM_FLAG_SATURATED: i32 = 1;
/// `flags` bit 1: the target was not a finite number; the last voltage is held.
pub const MFCBEAM_FLAG_NON_FINITE_TARGET: i32 = 2;
/// `flags` bit 2: the handle was `NULL` or not initialised; nothing was done.
pub const MFCBEAM_FLAG_INVALID_HANDLE: i32 = 4;

/// Why a constructor failed.
#[derive(Debug)]
pub(crate) enum Failure {
    Null(&'static str),
    NullArray {
        field: &'static str,
        len: usize,
    },
    Parameter(ParameterError),
    #[cfg(feature = "std")]
    Text(String),
}

impl fmt::Display for Failure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Failure::Null(what) => write!(f, "{what}: NULL pointer"),
            Failure::NullArray { field, len } => {
                write!(f, "{field}: NULL pointer for {len} values")
            }
            Failure::Parameter(e) => e.fmt(f),
            #[cfg(feature = "std")]
            Failure::Text(s) => f.write_str(s),
        }
    }
}

impl From<ParameterError> for Failure {
    fn from(e: ParameterError) -> Self {
        Failure::Parameter(e)
    }
}

/// Formats into a C buffer, truncating on a character boundary and leaving
/// room for the terminating NUL.
struct Buffer<'a> {
    bytes: &'a mut [u8],
    len: usize,
}

impl fmt::Write for Buffer<'_> {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        let room = self.bytes.len() - 1 - self.len;
        let mut n = s.len().min(room);
        while !s.is_char_boundary(n) {
            n -= 1;
        }
        self.bytes[self.len..self.len + n].copy_from_slice(&s.as_bytes()[..n]);
        self.len += n;
        Ok(())
    }
}

/// Write `message` into `err` (at most `err_len` bytes with the terminating
/// NUL). Nothing if `err` is NULL.
///
/// # Safety
/// `err` is NULL or points to `err_len` writable bytes.
pub(crate) unsafe fn write_error(err: *mut c_char, err_len: usize, message: &dyn fmt::Display) {
    if err.is_null() || err_len == 0 {
        return;
    }
    // SAFETY: the caller guarantees err_len writable bytes.
    let bytes = unsafe { core::slice::from_raw_parts_mut(err.cast::<u8>(), err_len) };
    let mut buffer = Buffer { bytes, len: 0 };
    let _ = fmt::write(&mut buffer, format_args!("{message}"));
    let end = buffer.len;
    buffer.bytes[end] = 0;
    // one line: a line break inside the message (a field name read from the
    // file may hold one) becomes a space
    for b in &mut buffer.bytes[..end] {
        if *b == b'\n' || *b == b'\r' {
            *b = b' ';
        }
    }
}

/// The flags word of a compensator step.
pub(crate) fn flags_of(saturated: bool, fault: bool) -> i32 {
    (if saturated { MFCBEAM_FLAG_SATURATED } else { 0 })
        | (if fault {
            MFCBEAM_FLAG_NON_FINITE_TARGET
        } else {
            0
        })
}

/// Store `value` through `flags` unless it is NULL.
///
/// # Safety
/// `flags` is NULL or points to a writable `int`.
pub(crate) unsafe fn set_flags(flags: *mut i32, value: i32) {
    if !flags.is_null() {
        // SAFETY: checked non-null; the caller guarantees it is writable.
        unsafe { *flags = value };
    }
}
