//! A whole signal through a compensator in one call (`mfcbeam_compensator_compensate_into`,
//! `_f32_into`, `_f64_into`): `Compensator::compensate_into`, whose samples
//! run in one loop with the creep's output kept in a register, behind the
//! C ABI.
//!
//! The samples go through in chunks of [`CHUNK`], each copied to the stack
//! first. That keeps the call free of allocation (it serves the `no_std`
//! build too) and lets `u` be the same array as `targets`: the chunk is read
//! before any of it is written. A stream continues across chunks and calls,
//! so the voltages and flags are those of one per-sample call each.

use core::ffi::c_int;
use core::mem::size_of;

use mfcbeam_rs::realtime::{Compensator, Real, Storage};

use crate::error::{flags_of, set_flags, MFCBEAM_FLAG_INVALID_HANDLE};

/// Samples per chunk: 512 bytes of `f64` targets and 128 of flags on the
/// stack (a microcontroller's stack takes that), and few enough calls that
/// their cost is small (a run through the C API took about 1 % more than
/// `compensate_into` on a Zen 4, in the peers bench).
const CHUNK: usize = 64;

/// `targets[..n]` through `c` into `u[..n]`, each sample's flags into
/// `flags[..n]` when it is not NULL. 0, or -1 (nothing stepped, nothing
/// written) for NULL arrays with `n > 0` or an `n` no array can have.
///
/// # Safety
/// `targets` and `u` NULL or valid for `n` values (they may be the same
/// array); `flags` NULL or valid for `n` ints, apart from both.
pub(crate) unsafe fn run<T: Real, S: Storage>(
    c: &mut Compensator<T, S>,
    targets: *const T,
    u: *mut T,
    flags: *mut c_int,
    n: usize,
) -> c_int {
    if n == 0 {
        return 0;
    }
    if targets.is_null() || u.is_null() || n > isize::MAX as usize / size_of::<T>() {
        return -1;
    }
    let mut chunk_targets = [T::ZERO; CHUNK];
    let mut saturated = [false; CHUNK];
    let mut fault = [false; CHUNK];
    let mut start = 0;
    while start < n {
        let len = CHUNK.min(n - start);
        // SAFETY: `start + len ≤ n` values are readable at `targets`; the
        // slice ends before `u`'s is made, so an alias is never both.
        let source = unsafe { core::slice::from_raw_parts(targets.add(start), len) };
        chunk_targets[..len].copy_from_slice(source);
        // SAFETY: as above, writable at `u`.
        let out = unsafe { core::slice::from_raw_parts_mut(u.add(start), len) };
        // the lengths agree by construction, so this cannot fail
        if c.compensate_into(
            &chunk_targets[..len],
            out,
            &mut saturated[..len],
            &mut fault[..len],
        )
        .is_err()
        {
            return -1;
        }
        if !flags.is_null() {
            for i in 0..len {
                // SAFETY: `flags` is valid for `n` ints.
                unsafe { *flags.add(start + i) = flags_of(saturated[i], fault[i]) };
            }
        }
        start += len;
    }
    0
}

/// What a run on a NULL or uninitialised handle writes, as one step does
/// for each sample: NaN voltages and `MFCBEAM_FLAG_INVALID_HANDLE`. -1.
///
/// # Safety
/// `u` NULL or valid for `n` values; `flags` NULL or valid for `n` ints.
pub(crate) unsafe fn refuse<T: Real>(u: *mut T, flags: *mut c_int, n: usize) -> c_int {
    // nothing to write: no walk over an `n` that may be anything
    if (u.is_null() && flags.is_null()) || n > isize::MAX as usize / size_of::<T>() {
        return -1;
    }
    for k in 0..n {
        if !u.is_null() {
            // SAFETY: the caller's: valid for `n` values.
            unsafe { *u.add(k) = T::from_f64(f64::NAN) };
        }
        if !flags.is_null() {
            // SAFETY: the caller's: valid for `n` ints.
            unsafe { set_flags(flags.add(k), MFCBEAM_FLAG_INVALID_HANDLE) };
        }
    }
    -1
}
