//! Compensators and models in storage the caller owns (a static, a stack
//! variable, a struct member): no allocator needed, `f32` or `f64`.
//!
//! Each storage type is a block of `uint64_t` words sized at compile time
//! for `MFCBEAM_MAX_PLAYS` plays and `MFCBEAM_MAX_CREEP` elementary creep
//! operators; `*_init` writes a checked compensator or model into it and
//! marks it initialised, a failed `*_init` marks it uninitialised, and every
//! step refuses storage not so marked (zeroed storage included).

use core::ffi::{c_char, c_int};
use core::mem::{align_of, size_of};

use mfcbeam_rs::realtime::{Compensator, CompensatorSettings, Inline, Model, Real};

use crate::error::{flags_of, set_flags, write_error, Failure, MFCBEAM_FLAG_INVALID_HANDLE};
#[cfg(feature = "std")]
use crate::heap::model_file;
use crate::parameters::MfcbeamParameters;
use crate::run;

/// Plays (hysteresis thresholds) the caller-owned storage holds.
pub const MFCBEAM_MAX_PLAYS: usize = 24;
/// Elementary creep operators (creep thresholds × eigenvalues) it holds.
pub const MFCBEAM_MAX_CREEP: usize = 144;

/// Terms of the superposition operator `S` it holds (thresholds including
/// the zero one: four dead zones per side).
pub const MFCBEAM_MAX_SUPERPOSITION: usize = 9;

/// Samples of dead time a model in caller-owned storage holds (a
/// compensator holds none: it inverts the memory part, and its caller
/// shifts the target by the delay).
pub const MFCBEAM_MAX_DELAY: usize = 16;

/// Words of `MfcbeamCompensatorStorageF32`.
pub const MFCBEAM_COMPENSATOR_F32_WORDS: usize = 587;
/// Words of `MfcbeamCompensatorStorageF64`.
pub const MFCBEAM_COMPENSATOR_F64_WORDS: usize = 1133;
/// Words of `MfcbeamModelStorageF32`.
pub const MFCBEAM_MODEL_F32_WORDS: usize = 530;
/// Words of `MfcbeamModelStorageF64`.
pub const MFCBEAM_MODEL_F64_WORDS: usize = 1025;

/// The capacity of every caller-owned object.
type Capacity =
    Inline<MFCBEAM_MAX_PLAYS, MFCBEAM_MAX_CREEP, MFCBEAM_MAX_SUPERPOSITION, MFCBEAM_MAX_DELAY>;
type CompensatorF32 = Compensator<f32, Capacity>;
type CompensatorF64 = Compensator<f64, Capacity>;
type ModelF32 = Model<f32, Capacity>;
type ModelF64 = Model<f64, Capacity>;

/// Caller-owned storage for a compensator in `f32` (declare it, statically
/// or on the stack, then `*_init` it; nothing to free).
#[repr(C)]
pub struct MfcbeamCompensatorStorageF32 {
    pub words: [u64; MFCBEAM_COMPENSATOR_F32_WORDS],
}

/// Caller-owned storage for a compensator in `f64`.
#[repr(C)]
pub struct MfcbeamCompensatorStorageF64 {
    pub words: [u64; MFCBEAM_COMPENSATOR_F64_WORDS],
}

/// Caller-owned storage for a model `W` in `f32`.
#[repr(C)]
pub struct MfcbeamModelStorageF32 {
    pub words: [u64; MFCBEAM_MODEL_F32_WORDS],
}

/// Caller-owned storage for a model `W` in `f64`.
#[repr(C)]
pub struct MfcbeamModelStorageF64 {
    pub words: [u64; MFCBEAM_MODEL_F64_WORDS],
}

/// What the storage holds: a tag, then the value.
#[repr(C)]
pub(crate) struct Slot<T> {
    tag: u64,
    value: T,
}

const INITIALISED: u64 = u64::from_le_bytes(*b"mfcbeam1");

/// Words a `Slot<T>` needs.
pub(crate) const fn words<T>() -> usize {
    size_of::<Slot<T>>().div_ceil(8)
}

const _: () = {
    assert!(words::<CompensatorF32>() <= MFCBEAM_COMPENSATOR_F32_WORDS);
    assert!(words::<CompensatorF64>() <= MFCBEAM_COMPENSATOR_F64_WORDS);
    assert!(words::<ModelF32>() <= MFCBEAM_MODEL_F32_WORDS);
    assert!(words::<ModelF64>() <= MFCBEAM_MODEL_F64_WORDS);
    assert!(align_of::<Slot<CompensatorF64>>() <= align_of::<u64>());
    assert!(align_of::<Slot<ModelF64>>() <= align_of::<u64>());
};

/// The value in initialised storage, or None.
///
/// # Safety
/// `storage` is NULL or points to storage sized for `Slot<T>`.
unsafe fn value<'a, S, T>(storage: *mut S) -> Option<&'a mut T> {
    let slot = storage.cast::<Slot<T>>();
    // SAFETY: NULL checked; sized storage by contract; the tag is a plain word.
    unsafe {
        if slot.is_null() || (*slot).tag != INITIALISED {
            None
        } else {
            Some(&mut (*slot).value)
        }
    }
}

/// Build a value into `storage`: 0 on success; -1, the reason in `err` and
/// the storage marked uninitialised otherwise.
///
/// # Safety
/// `storage` is NULL or sized for `Slot<T>`; `err` NULL or `err_len` bytes.
unsafe fn init<S, T>(
    storage: *mut S,
    err: *mut c_char,
    err_len: usize,
    make: impl FnOnce() -> Result<T, Failure>,
) -> c_int {
    // SAFETY: forwarded from the caller.
    unsafe {
        if storage.is_null() {
            write_error(err, err_len, &Failure::Null("storage"));
            return -1;
        }
        let slot = storage.cast::<Slot<T>>();
        (*slot).tag = 0;
        #[cfg(feature = "std")]
        let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(make))
            .unwrap_or_else(|_| Err(Failure::Text("internal error (please report it)".into())));
        #[cfg(not(feature = "std"))]
        let result = make();
        match result {
            Ok(value) => {
                core::ptr::addr_of_mut!((*slot).value).write(value);
                (*slot).tag = INITIALISED;
                0
            }
            Err(message) => {
                write_error(err, err_len, &message);
                -1
            }
        }
    }
}

/// # Safety
/// `parameters` is NULL or valid, its arrays as their lengths say.
unsafe fn compensator_from<T: Real>(
    parameters: *const MfcbeamParameters,
    lower: f64,
    upper: f64,
) -> Result<Compensator<T, Capacity>, Failure> {
    // SAFETY: forwarded from the caller.
    let p = unsafe { parameters.as_ref() }.ok_or(Failure::Null("parameters"))?;
    // SAFETY: forwarded from the caller.
    let model = unsafe { p.model() }?;
    Ok(Compensator::new(
        &model.validate()?,
        CompensatorSettings::with_limits(lower, upper),
    )?)
}

/// # Safety
/// As [`compensator_from`].
unsafe fn model_from<T: Real>(
    parameters: *const MfcbeamParameters,
) -> Result<Model<T, Capacity>, Failure> {
    // SAFETY: forwarded from the caller.
    let p = unsafe { parameters.as_ref() }.ok_or(Failure::Null("parameters"))?;
    // SAFETY: forwarded from the caller.
    let model = unsafe { p.model() }?;
    Ok(Model::new(&model.validate()?)?)
}

#[cfg(feature = "std")]
/// # Safety
/// `json` is NULL or NUL-terminated.
unsafe fn compensator_from_json<T: Real>(
    json: *const c_char,
    lower: f64,
    upper: f64,
) -> Result<Compensator<T, Capacity>, Failure> {
    // SAFETY: forwarded from the caller.
    let file = unsafe { model_file(json) }?;
    Compensator::from_file(&file, CompensatorSettings::with_limits(lower, upper))
        .map_err(|e| Failure::Text(e.to_string()))
}

#[cfg(feature = "std")]
/// # Safety
/// `json` is NULL or NUL-terminated.
unsafe fn model_from_json<T: Real>(json: *const c_char) -> Result<Model<T, Capacity>, Failure> {
    // SAFETY: forwarded from the caller.
    let file = unsafe { model_file(json) }?;
    Model::from_file(&file).map_err(|e| Failure::Text(e.to_string()))
}

/// One compensator step on storage.
///
/// # Safety
/// `storage` NULL or sized for the compensator; `flags` NULL or writable.
unsafe fn compensate<S, T: Real>(storage: *mut S, target: T, flags: *mut c_int) -> T {
    // SAFETY: forwarded from the caller.
    unsafe {
        match value::<S, Compensator<T, Capacity>>(storage) {
            Some(c) => {
                let out = c.compensate(target);
                set_flags(flags, flags_of(out.saturated, out.fault));
                out.u
            }
            None => {
                set_flags(flags, MFCBEAM_FLAG_INVALID_HANDLE);
                T::from_f64(f64::NAN)
            }
        }
    }
}

/// A run of steps on storage (`run::run`).
///
/// # Safety
/// `storage` NULL or sized for the compensator; the arrays as `run::run`'s.
unsafe fn compensate_into<S, T: Real>(
    storage: *mut S,
    targets: *const T,
    u: *mut T,
    flags: *mut c_int,
    n: usize,
) -> c_int {
    // SAFETY: forwarded from the caller.
    unsafe {
        match value::<S, Compensator<T, Capacity>>(storage) {
            Some(c) => run::run(c, targets, u, flags, n),
            None => run::refuse(u, flags, n),
        }
    }
}

/// A compensator of the model `parameters` (virgin state) with limits
/// `lower < upper` in `storage`, computing in `f32`. No allocation. 0, or -1
/// and the reason in `err`.
///
/// # Safety
/// `storage` NULL or an `MfcbeamCompensatorStorageF32`; `parameters` NULL or valid
/// with arrays of the lengths it states; `err` NULL or `err_len` bytes.
#[no_mangle]
pub unsafe extern "C" fn mfcbeam_compensator_f32_init(
    storage: *mut MfcbeamCompensatorStorageF32,
    parameters: *const MfcbeamParameters,
    lower: f64,
    upper: f64,
    err: *mut c_char,
    err_len: usize,
) -> c_int {
    // SAFETY: forwarded from the caller.
    unsafe {
        init(storage, err, err_len, || {
            compensator_from::<f32>(parameters, lower, upper)
        })
    }
}

/// As [`mfcbeam_compensator_f32_init`], from a model file (JSON, its
/// `state` honoured). Parsing the JSON uses the heap; the result does not.
///
/// # Safety
/// As [`mfcbeam_compensator_f32_init`]; `json` NULL or NUL-terminated.
#[cfg(feature = "std")]
#[no_mangle]
pub unsafe extern "C" fn mfcbeam_compensator_f32_init_json(
    storage: *mut MfcbeamCompensatorStorageF32,
    json: *const c_char,
    lower: f64,
    upper: f64,
    err: *mut c_char,
    err_len: usize,
) -> c_int {
    // SAFETY: forwarded from the caller.
    unsafe {
        init(storage, err, err_len, || {
            compensator_from_json::<f32>(json, lower, upper)
        })
    }
}

/// The voltage for `target`, in `f32`; flags as `mfcbeam_compensator_compensate`.
///
/// # Safety
/// `storage` NULL or an `MfcbeamCompensatorStorageF32`; `flags` NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn mfcbeam_compensator_f32_compensate(
    storage: *mut MfcbeamCompensatorStorageF32,
    target: f32,
    flags: *mut c_int,
) -> f32 {
    // SAFETY: forwarded from the caller.
    unsafe { compensate(storage, target, flags) }
}

/// The voltages for `n` targets in turn, in `f32`: the same values and
/// flags as one `mfcbeam_compensator_f32_compensate` per sample, in one call and faster
/// (the samples run in one loop). `u` may be the same array as `targets`;
/// `flags` (may be NULL) gets each sample's flags. Allocation-free. 0; -1
/// with nothing stepped for NULL arrays (`n > 0`); -1 with NaN voltages and
/// `MFCBEAM_FLAG_INVALID_HANDLE` for NULL or uninitialised storage.
///
/// # Safety
/// `storage` NULL or an `MfcbeamCompensatorStorageF32`; `targets` and `u`
/// NULL or valid for `n` values; `flags` NULL or valid for `n` ints, apart
/// from both.
#[no_mangle]
pub unsafe extern "C" fn mfcbeam_compensator_f32_compensate_into(
    storage: *mut MfcbeamCompensatorStorageF32,
    targets: *const f32,
    u: *mut f32,
    flags: *mut c_int,
    n: usize,
) -> c_int {
    // SAFETY: forwarded from the caller.
    unsafe { compensate_into(storage, targets, u, flags, n) }
}

/// The model's dead time `d` (samples): the compensator inverts the memory
/// part, so the target given at sample `k` is the one wanted at `k + d`.
/// 0 for NULL or uninitialised storage.
///
/// # Safety
/// `storage` NULL or an `MfcbeamCompensatorStorageF32`.
#[no_mangle]
pub unsafe extern "C" fn mfcbeam_compensator_f32_delay(
    storage: *mut MfcbeamCompensatorStorageF32,
) -> usize {
    // SAFETY: forwarded from the caller.
    unsafe { value::<_, CompensatorF32>(storage) }.map_or(0, |c| c.delay())
}

/// As [`mfcbeam_compensator_f32_delay`], for an `MfcbeamCompensatorStorageF64`.
///
/// # Safety
/// `storage` NULL or an `MfcbeamCompensatorStorageF64`.
#[no_mangle]
pub unsafe extern "C" fn mfcbeam_compensator_f64_delay(
    storage: *mut MfcbeamCompensatorStorageF64,
) -> usize {
    // SAFETY: forwarded from the caller.
    unsafe { value::<_, CompensatorF64>(storage) }.map_or(0, |c| c.delay())
}

/// Back to the virgin state. Nothing for NULL or uninitialised storage.
///
/// # Safety
/// `storage` NULL or an `MfcbeamCompensatorStorageF32`.
#[no_mangle]
pub unsafe extern "C" fn mfcbeam_compensator_f32_reset(storage: *mut MfcbeamCompensatorStorageF32) {
    // SAFETY: forwarded from the caller.
    if let Some(c) = unsafe { value::<_, CompensatorF32>(storage) } {
        c.reset();
    }
}

/// As [`mfcbeam_compensator_f32_init`], computing in `f64`.
///
/// # Safety
/// As [`mfcbeam_compensator_f32_init`], for an `MfcbeamCompensatorStorageF64`.
#[no_mangle]
pub unsafe extern "C" fn mfcbeam_compensator_f64_init(
    storage: *mut MfcbeamCompensatorStorageF64,
    parameters: *const MfcbeamParameters,
    lower: f64,
    upper: f64,
    err: *mut c_char,
    err_len: usize,
) -> c_int {
    // SAFETY: forwarded from the caller.
    unsafe {
        init(storage, err, err_len, || {
            compensator_from::<f64>(parameters, lower, upper)
        })
    }
}

/// As [`mfcbeam_compensator_f32_init_json`], computing in `f64`.
///
/// # Safety
/// As [`mfcbeam_compensator_f32_init_json`], for an `MfcbeamCompensatorStorageF64`.
#[cfg(feature = "std")]
#[no_mangle]
pub unsafe extern "C" fn mfcbeam_compensator_f64_init_json(
    storage: *mut MfcbeamCompensatorStorageF64,
    json: *const c_char,
    lower: f64,
    upper: f64,
    err: *mut c_char,
    err_len: usize,
) -> c_int {
    // SAFETY: forwarded from the caller.
    unsafe {
        init(storage, err, err_len, || {
            compensator_from_json::<f64>(json, lower, upper)
        })
    }
}

/// The voltage for `target`, in `f64`; flags as `mfcbeam_compensator_compensate`.
///
/// # Safety
/// `storage` NULL or an `MfcbeamCompensatorStorageF64`; `flags` NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn mfcbeam_compensator_f64_compensate(
    storage: *mut MfcbeamCompensatorStorageF64,
    target: f64,
    flags: *mut c_int,
) -> f64 {
    // SAFETY: forwarded from the caller.
    unsafe { compensate(storage, target, flags) }
}

/// The voltages for `n` targets in turn, in `f64`: the same values and
/// flags as one `mfcbeam_compensator_f64_compensate` per sample, in one call and faster
/// (the samples run in one loop). `u` may be the same array as `targets`;
/// `flags` (may be NULL) gets each sample's flags. Allocation-free. 0; -1
/// with nothing stepped for NULL arrays (`n > 0`); -1 with NaN voltages and
/// `MFCBEAM_FLAG_INVALID_HANDLE` for NULL or uninitialised storage.
///
/// # Safety
/// `storage` NULL or an `MfcbeamCompensatorStorageF64`; `targets` and `u`
/// NULL or valid for `n` values; `flags` NULL or valid for `n` ints, apart
/// from both.
#[no_mangle]
pub unsafe extern "C" fn mfcbeam_compensator_f64_compensate_into(
    storage: *mut MfcbeamCompensatorStorageF64,
    targets: *const f64,
    u: *mut f64,
    flags: *mut c_int,
    n: usize,
) -> c_int {
    // SAFETY: forwarded from the caller.
    unsafe { compensate_into(storage, targets, u, flags, n) }
}

/// Back to the virgin state. Nothing for NULL or uninitialised storage.
///
/// # Safety
/// `storage` NULL or an `MfcbeamCompensatorStorageF64`.
#[no_mangle]
pub unsafe extern "C" fn mfcbeam_compensator_f64_reset(storage: *mut MfcbeamCompensatorStorageF64) {
    // SAFETY: forwarded from the caller.
    if let Some(c) = unsafe { value::<_, CompensatorF64>(storage) } {
        c.reset();
    }
}

/// The model `W` of `parameters` (virgin state) in `storage`, in `f32`.
/// 0, or -1 and the reason in `err`.
///
/// # Safety
/// `storage` NULL or an `MfcbeamModelStorageF32`; otherwise as
/// [`mfcbeam_compensator_f32_init`].
#[no_mangle]
pub unsafe extern "C" fn mfcbeam_model_f32_init(
    storage: *mut MfcbeamModelStorageF32,
    parameters: *const MfcbeamParameters,
    err: *mut c_char,
    err_len: usize,
) -> c_int {
    // SAFETY: forwarded from the caller.
    unsafe { init(storage, err, err_len, || model_from::<f32>(parameters)) }
}

/// As [`mfcbeam_model_f32_init`], from a model file (its `state` honoured).
///
/// # Safety
/// As [`mfcbeam_model_f32_init`]; `json` NULL or NUL-terminated.
#[cfg(feature = "std")]
#[no_mangle]
pub unsafe extern "C" fn mfcbeam_model_f32_init_json(
    storage: *mut MfcbeamModelStorageF32,
    json: *const c_char,
    err: *mut c_char,
    err_len: usize,
) -> c_int {
    // SAFETY: forwarded from the caller.
    unsafe { init(storage, err, err_len, || model_from_json::<f32>(json)) }
}

/// One sample `W[u]` in `f32`; NaN for NULL or uninitialised storage.
///
/// # Safety
/// `storage` NULL or an `MfcbeamModelStorageF32`.
#[no_mangle]
pub unsafe extern "C" fn mfcbeam_model_f32_step(
    storage: *mut MfcbeamModelStorageF32,
    u: f32,
) -> f32 {
    // SAFETY: forwarded from the caller.
    match unsafe { value::<_, ModelF32>(storage) } {
        Some(m) => m.step(u),
        None => f32::NAN,
    }
}

/// As [`mfcbeam_model_f32_init`], in `f64`.
///
/// # Safety
/// As [`mfcbeam_model_f32_init`], for an `MfcbeamModelStorageF64`.
#[no_mangle]
pub unsafe extern "C" fn mfcbeam_model_f64_init(
    storage: *mut MfcbeamModelStorageF64,
    parameters: *const MfcbeamParameters,
    err: *mut c_char,
    err_len: usize,
) -> c_int {
    // SAFETY: forwarded from the caller.
    unsafe { init(storage, err, err_len, || model_from::<f64>(parameters)) }
}

/// As [`mfcbeam_model_f32_init_json`], in `f64`.
///
/// # Safety
/// As [`mfcbeam_model_f32_init_json`], for an `MfcbeamModelStorageF64`.
#[cfg(feature = "std")]
#[no_mangle]
pub unsafe extern "C" fn mfcbeam_model_f64_init_json(
    storage: *mut MfcbeamModelStorageF64,
    json: *const c_char,
    err: *mut c_char,
    err_len: usize,
) -> c_int {
    // SAFETY: forwarded from the caller.
    unsafe { init(storage, err, err_len, || model_from_json::<f64>(json)) }
}

/// One sample `W[u]` in `f64`; NaN for NULL or uninitialised storage.
///
/// # Safety
/// `storage` NULL or an `MfcbeamModelStorageF64`.
#[no_mangle]
pub unsafe extern "C" fn mfcbeam_model_f64_step(
    storage: *mut MfcbeamModelStorageF64,
    u: f64,
) -> f64 {
    // SAFETY: forwarded from the caller.
    match unsafe { value::<_, ModelF64>(storage) } {
        Some(m) => m.step(u),
        None => f64::NAN,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The storage is exactly as large as it must be on a 64-bit host (on a
    /// 32-bit target `usize` is smaller, and it is a few words too large).
    #[test]
    fn storage_words_are_exact_on_64_bit() {
        let sizes = [
            (words::<CompensatorF32>(), MFCBEAM_COMPENSATOR_F32_WORDS),
            (words::<CompensatorF64>(), MFCBEAM_COMPENSATOR_F64_WORDS),
            (words::<ModelF32>(), MFCBEAM_MODEL_F32_WORDS),
            (words::<ModelF64>(), MFCBEAM_MODEL_F64_WORDS),
        ];
        if cfg!(target_pointer_width = "64") {
            assert!(
                sizes.iter().all(|(n, d)| n == d),
                "needed vs declared: {sizes:?}"
            );
        }
    }
}
