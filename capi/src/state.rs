//! The memory a record starts in, for a fixed model: `estimate-state`
//! behind the C ABI (`mfcbeam::identification::initial_state`).

use std::ffi::{c_char, c_int, CString};
use std::panic::{catch_unwind, AssertUnwindSafe};

use mfcbeam_rs::identification::initial_state::{estimate_state, StateSettings};

use crate::error::{write_error, Failure};
use crate::heap::model_file;

/// The samples at `data` (`len` of them), or the failure naming `field`.
///
/// # Safety
/// `data` is NULL or points to `len` readable doubles.
unsafe fn samples<'a>(
    field: &'static str,
    data: *const f64,
    len: usize,
) -> Result<&'a [f64], Failure> {
    if data.is_null() {
        return Err(Failure::NullArray { field, len });
    }
    // SAFETY: non-null, `len` readable by the caller's contract.
    Ok(unsafe { std::slice::from_raw_parts(data, len) })
}

/// Estimate the memory a record starts in for the model file `model_json`:
/// its play and creep states, the state of `G` and the offset, from the
/// samples `0..until` of the record `u`, `y` (`len` samples each; `until`
/// 0: all of them), its parameters kept. Returns the model file (JSON, to be
/// released with `mfcbeam_string_free`) in the estimated state at the
/// record's first sample, or with `state_at_end` nonzero after the window:
/// where a compensator built from it goes on. NULL and the reason in `err`
/// (at most `err_len` bytes) for a bad model, a NULL array, a non-finite
/// sample or a window outside the record. Allocates; not for a control
/// loop's step.
///
/// # Safety
/// `model_json` is NULL or NUL-terminated; `u` and `y` are NULL or have
/// `len` readable doubles; `err` is NULL or has `err_len` writable bytes.
#[no_mangle]
pub unsafe extern "C" fn mfcbeam_estimate_state(
    model_json: *const c_char,
    u: *const f64,
    y: *const f64,
    len: usize,
    until: usize,
    state_at_end: c_int,
    err: *mut c_char,
    err_len: usize,
) -> *mut c_char {
    let run = || -> Result<CString, Failure> {
        // SAFETY: forwarded from the caller.
        let file = unsafe { model_file(model_json) }?;
        // SAFETY: as above.
        let (u, y) = unsafe { (samples("u", u, len)?, samples("y", y, len)?) };
        let settings = StateSettings {
            until: (until != 0).then_some(until),
            ..StateSettings::default()
        };
        let estimate =
            estimate_state(&file, u, y, &settings).map_err(|e| Failure::Text(e.to_string()))?;
        let model = if state_at_end != 0 {
            estimate
                .model_after_window(u)
                .map_err(|e| Failure::Text(e.to_string()))?
        } else {
            estimate.model
        };
        let text = serde_json::to_string(&model).map_err(|e| Failure::Text(e.to_string()))?;
        CString::new(text).map_err(|e| Failure::Text(e.to_string()))
    };
    let result = catch_unwind(AssertUnwindSafe(run))
        .unwrap_or_else(|_| Err(Failure::Text("internal error (please report it)".into())));
    match result {
        Ok(text) => text.into_raw(),
        Err(message) => {
            // SAFETY: forwarded from the caller.
            unsafe { write_error(err, err_len, &message) };
            std::ptr::null_mut()
        }
    }
}

/// Release a string this library returned. Nothing for NULL.
///
/// # Safety
/// `text` is NULL or from this library (`mfcbeam_estimate_state`), freed
/// once.
#[no_mangle]
pub unsafe extern "C" fn mfcbeam_string_free(text: *mut c_char) {
    if !text.is_null() {
        // SAFETY: made by CString::into_raw, freed once.
        drop(unsafe { CString::from_raw(text) });
    }
}
