//! Handles on the heap, configured by a model file (JSON), in `f64`.

use std::ffi::{c_char, c_int, CStr};
use std::panic::{catch_unwind, AssertUnwindSafe};

use mfcbeam_rs::operators::compensator::{Compensator, CompensatorSettings};
use mfcbeam_rs::operators::model::{HysteresisCreepModel, ModelFile};

use crate::error::{flags_of, set_flags, write_error, Failure, MFCBEAM_FLAG_INVALID_HANDLE};
use crate::run;

/// A model `W` on the heap, in `f64` (an opaque handle: made by
/// `mfcbeam_model_from_json`, released by `mfcbeam_model_free`).
pub struct MfcbeamModelHandle {
    inner: HysteresisCreepModel,
}

/// A compensator `W⁻¹` on the heap, in `f64` (an opaque handle: made by
/// `mfcbeam_compensator_from_json`, released by `mfcbeam_compensator_free`).
pub struct MfcbeamCompensatorHandle {
    inner: Compensator<f64, mfcbeam_rs::operators::heap::Heap>,
}

/// The model file at `json`, parsed (checked by whoever builds from it).
///
/// # Safety
/// `json` is NULL or a NUL-terminated string.
pub(crate) unsafe fn model_file(json: *const c_char) -> Result<ModelFile, Failure> {
    if json.is_null() {
        return Err(Failure::Null("json"));
    }
    // SAFETY: non-null and NUL-terminated by the caller's contract.
    let text = unsafe { CStr::from_ptr(json) }
        .to_str()
        .map_err(|e| Failure::Text(format!("json: not UTF-8: {e}")))?;
    mfcbeam_rs::io::parse_json(text)
        .map_err(|e| Failure::Text(format!("malformed model file JSON: {e}")))
}

/// Run a constructor; its error (or a panic, which would be a bug) goes to
/// `err` and the result is NULL.
///
/// # Safety
/// `err` is NULL or points to `err_len` writable bytes.
pub(crate) unsafe fn construct<T>(
    err: *mut c_char,
    err_len: usize,
    f: impl FnOnce() -> Result<T, Failure>,
) -> *mut T {
    let result = catch_unwind(AssertUnwindSafe(f))
        .unwrap_or_else(|_| Err(Failure::Text("internal error (please report it)".into())));
    match result {
        Ok(value) => Box::into_raw(Box::new(value)),
        Err(message) => {
            // SAFETY: forwarded from the caller.
            unsafe { write_error(err, err_len, &message) };
            std::ptr::null_mut()
        }
    }
}

/// `W` from a model file (the JSON text), starting from its `state`; NULL
/// and the reason in `err` (at most `err_len` bytes) if it is malformed or
/// inadmissible.
///
/// # Safety
/// `json` is NULL or NUL-terminated; `err` is NULL or has `err_len` bytes.
#[no_mangle]
pub unsafe extern "C" fn mfcbeam_model_from_json(
    json: *const c_char,
    err: *mut c_char,
    err_len: usize,
) -> *mut MfcbeamModelHandle {
    // SAFETY: forwarded from the caller.
    unsafe {
        construct(err, err_len, || {
            let file = model_file(json)?;
            let inner =
                HysteresisCreepModel::from_file(&file).map_err(|e| Failure::Text(e.to_string()))?;
            Ok(MfcbeamModelHandle { inner })
        })
    }
}

/// One sample `y_k = W[u]_k`; NaN for a NULL handle. Allocation-free.
///
/// # Safety
/// `model` is NULL or from `mfcbeam_model_from_json` and not yet freed.
#[no_mangle]
pub unsafe extern "C" fn mfcbeam_model_step(model: *mut MfcbeamModelHandle, u: f64) -> f64 {
    // SAFETY: NULL or a live handle, by the caller's contract.
    match unsafe { model.as_mut() } {
        Some(m) => m.inner.step(u),
        None => f64::NAN,
    }
}

/// Back to the virgin state. Nothing for NULL.
///
/// # Safety
/// As [`mfcbeam_model_step`].
#[no_mangle]
pub unsafe extern "C" fn mfcbeam_model_reset(model: *mut MfcbeamModelHandle) {
    // SAFETY: as above.
    if let Some(m) = unsafe { model.as_mut() } {
        m.inner.reset();
    }
}

/// Free a model. Nothing for NULL.
///
/// # Safety
/// `model` is NULL or from `mfcbeam_model_from_json`, freed once.
#[no_mangle]
pub unsafe extern "C" fn mfcbeam_model_free(model: *mut MfcbeamModelHandle) {
    if !model.is_null() {
        // SAFETY: created by Box::into_raw, freed once.
        drop(unsafe { Box::from_raw(model) });
    }
}

/// The compensator of a model file, matched to its `state`, with output
/// limits `lower < upper` (V; ±INFINITY for none). NULL and the reason in
/// `err` if the JSON, the model or the limits are bad.
///
/// # Safety
/// As [`mfcbeam_model_from_json`].
#[no_mangle]
pub unsafe extern "C" fn mfcbeam_compensator_from_json(
    json: *const c_char,
    lower: f64,
    upper: f64,
    err: *mut c_char,
    err_len: usize,
) -> *mut MfcbeamCompensatorHandle {
    // SAFETY: forwarded from the caller.
    unsafe {
        construct(err, err_len, || {
            let file = model_file(json)?;
            let model =
                HysteresisCreepModel::from_file(&file).map_err(|e| Failure::Text(e.to_string()))?;
            let settings = CompensatorSettings::with_limits(lower, upper);
            let inner = model
                .compensator(settings)
                .map_err(|e| Failure::Text(e.to_string()))?;
            Ok(MfcbeamCompensatorHandle { inner })
        })
    }
}

/// The voltage for `target` (21). `flags` (may be NULL) gets
/// `MFCBEAM_FLAG_SATURATED` and `MFCBEAM_FLAG_NON_FINITE_TARGET` bits; a
/// NULL handle returns NaN with `MFCBEAM_FLAG_INVALID_HANDLE`.
/// Allocation-free.
///
/// # Safety
/// `comp` is NULL or a live handle; `flags` is NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn mfcbeam_compensator_compensate(
    comp: *mut MfcbeamCompensatorHandle,
    target: f64,
    flags: *mut c_int,
) -> f64 {
    // SAFETY: by the caller's contract.
    unsafe {
        match comp.as_mut() {
            Some(c) => {
                let out = c.inner.compensate(target);
                set_flags(flags, flags_of(out.saturated, out.fault));
                out.u
            }
            None => {
                set_flags(flags, MFCBEAM_FLAG_INVALID_HANDLE);
                f64::NAN
            }
        }
    }
}

/// The voltages for `n` targets, in turn: the same values and flags as one
/// `mfcbeam_compensator_compensate` per sample, in one call and faster (the samples run
/// in one loop). `u` may be the same array as `targets`; `flags` (may be
/// NULL) gets each sample's flags. Allocation-free. 0; -1 with nothing
/// stepped for NULL arrays (`n > 0`); -1 with NaN voltages and
/// `MFCBEAM_FLAG_INVALID_HANDLE` for a NULL handle.
///
/// # Safety
/// `comp` is NULL or a live handle; `targets` and `u` NULL or valid for `n`
/// values; `flags` NULL or valid for `n` ints, apart from both.
#[no_mangle]
pub unsafe extern "C" fn mfcbeam_compensator_compensate_into(
    comp: *mut MfcbeamCompensatorHandle,
    targets: *const f64,
    u: *mut f64,
    flags: *mut c_int,
    n: usize,
) -> c_int {
    // SAFETY: forwarded from the caller.
    unsafe {
        match comp.as_mut() {
            Some(c) => run::run(&mut c.inner, targets, u, flags, n),
            None => run::refuse(u, flags, n),
        }
    }
}

/// The model's dead time `d` (samples): the compensator inverts the memory
/// part, so the target given at sample `k` is the one wanted at `k + d`
/// (a planned trajectory is known ahead). 0 for NULL.
///
/// # Safety
/// As [`mfcbeam_compensator_compensate`].
#[no_mangle]
pub unsafe extern "C" fn mfcbeam_compensator_delay(comp: *const MfcbeamCompensatorHandle) -> usize {
    // SAFETY: as above.
    unsafe { comp.as_ref() }.map_or(0, |c| c.inner.delay())
}

/// Back to the virgin state (of the model, not of the file's `state`).
/// Nothing for NULL.
///
/// # Safety
/// As [`mfcbeam_compensator_compensate`].
#[no_mangle]
pub unsafe extern "C" fn mfcbeam_compensator_reset(comp: *mut MfcbeamCompensatorHandle) {
    // SAFETY: as above.
    if let Some(c) = unsafe { comp.as_mut() } {
        c.inner.reset();
    }
}

/// Free a compensator. Nothing for NULL.
///
/// # Safety
/// `comp` is NULL or from `mfcbeam_compensator_from_json`, freed once.
#[no_mangle]
pub unsafe extern "C" fn mfcbeam_compensator_free(comp: *mut MfcbeamCompensatorHandle) {
    if !comp.is_null() {
        // SAFETY: created by Box::into_raw, freed once.
        drop(unsafe { Box::from_raw(comp) });
    }
}
