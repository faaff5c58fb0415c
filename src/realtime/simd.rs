//! Run-time instruction-set dispatch for the per-sample kernels.
//!
//! The kernels are written once, generic and `#[inline(always)]`; with `std`
//! on x86-64 a step is compiled a second time with AVX2 enabled and chosen
//! when the CPU has it (a cached feature test: one load and a branch per
//! step). Neither copy fuses a multiply and an add (Rust never contracts
//! them) and the sums run in a fixed order, so both compute the same bits:
//! `verification/bank.rs` checks that. Without `std` (firmware) the kernels
//! are compiled once, for the target's own features.

#[cfg(all(feature = "std", target_arch = "x86_64"))]
use {crate::realtime::real::Real, core::any::TypeId};

/// Whether the steps run the AVX2 copy on this CPU.
#[inline]
pub fn avx2_in_use() -> bool {
    #[cfg(all(feature = "std", target_arch = "x86_64"))]
    {
        std::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(all(feature = "std", target_arch = "x86_64")))]
    {
        false
    }
}

/// `f()` compiled with AVX2 when the CPU has it, else as the target is.
#[inline(always)]
pub(crate) fn dispatch<R>(f: impl FnOnce() -> R) -> R {
    #[cfg(all(feature = "std", target_arch = "x86_64"))]
    if std::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU supports AVX2, checked just above.
        return unsafe { avx2(f) };
    }
    f()
}

#[cfg(all(feature = "std", target_arch = "x86_64"))]
#[target_feature(enable = "avx2")]
unsafe fn avx2<R>(f: impl FnOnce() -> R) -> R {
    f()
}

/// `x` as `f64` when `T` is `f64` (for the kernels written for `f64` only).
#[cfg(all(feature = "std", target_arch = "x86_64"))]
#[inline(always)]
pub(crate) fn as_f64<T: Real>(x: &[T]) -> Option<&[f64]> {
    // SAFETY: T is f64 when the TypeIds agree: the same type, the same layout.
    (TypeId::of::<T>() == TypeId::of::<f64>())
        .then(|| unsafe { &*(x as *const [T] as *const [f64]) })
}

/// `x` as `f64` when `T` is `f64`, mutably.
#[cfg(all(feature = "std", target_arch = "x86_64"))]
#[inline(always)]
pub(crate) fn as_f64_mut<T: Real>(x: &mut [T]) -> Option<&mut [f64]> {
    // SAFETY: as in `as_f64`.
    (TypeId::of::<T>() == TypeId::of::<f64>())
        .then(|| unsafe { &mut *(x as *mut [T] as *mut [f64]) })
}
