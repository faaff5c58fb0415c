//! Flags of a compensator step and the error buffer of the constructors.

use std::ffi::c_char;

/// `flags` bit 0: the voltage was clipped to a limit.
pub const MFCBEAM_FLAG_SATURATED: i32 = 1;
/// `flags` bit 1: the target was not a finite number; the last voltage is held.
pub const MFCBEAM_FLAG_NON_FINITE_TARGET: i32 = 2;
/// `flags` bit 2: the handle was `NULL` or not initialised; nothing was done.
pub const MFCBEAM_FLAG_INVALID_HANDLE: i32 = 4;

/// Copy `message` into `err` (at most `err_len` bytes with the terminating
/// NUL; truncated on a character boundary). Nothing if `err` is NULL.
///
/// # Safety
/// `err` is NULL or points to `err_len` writable bytes.
pub(crate) unsafe fn write_error(err: *mut c_char, err_len: usize, message: &str) {
    if err.is_null() || err_len == 0 {
        return;
    }
    let mut n = message.len().min(err_len - 1);
    while !message.is_char_boundary(n) {
        n -= 1;
    }
    // SAFETY: the caller guarantees err_len writable bytes; n < err_len.
    unsafe {
        std::ptr::copy_nonoverlapping(message.as_ptr().cast::<c_char>(), err, n);
        *err.add(n) = 0;
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
