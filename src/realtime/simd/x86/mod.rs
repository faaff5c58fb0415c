//! The compensator step's AVX2 and AVX-512 kernels (`step_avx2`,
//! `run_avx2`, `step_avx512`, `run_avx512`, and the creep pass alone for
//! the forward model). Each does the operations of its portable kernel in
//! the same order: `vminpd(x, hi)` is `if x < hi { x } else { hi }` and
//! `vmaxpd(t, lo)` is `if t > lo { t } else { lo }`, as `play` and
//! `clamp` are written, so the bits are the same.
//!
//! The plays' states and their saved copy, which a step loads and
//! stores again, go through `*_unsplit`: a register's worth that would
//! straddle a 4 KiB page is moved one value at a time: a step whose
//! creep row straddled a page, at an offset that matched stack slots the
//! step had just written, took up to a fifth longer, and the plays'
//! arrays are kept from the same. Whether an array can straddle
//! at all is asked once per array and step (`SPLIT`): most never do,
//! and their accesses carry no test. The creep state needs neither:
//! the operator places it so that no register's worth straddles a page
//! (`crate::realtime::placement`; per-access tests had cost more than
//! the split).
//!
//! The kernels end each sum of four partial sums in a butterfly
//! ([`four::all_lanes_sum`], and its `f32` twin in the 8-lane kernels): the
//! same bits as `hysteresis::reduce`, in every lane, a broadcast fewer
//! on the chain than a scalar sum.
//!
//! [`four`] holds the `f64` kernels on 4-lane registers (the AVX2 set's),
//! [`eight`] the 8-lane ones (the AVX-512 set's `f64` creep pass, both
//! sets' `f32`);
//! this module, how a step goes through them.
mod eight;
mod four;

use core::arch::x86_64::*;

use core::any::TypeId;

use crate::realtime::real::Real;
use eight::{creep_eight, hysteresis_eight, F32x8, F64x8};
use four::{creep_four, hysteresis_four};

/// Whether `bytes` bytes from `p` straddle a 4 KiB page.
#[inline(always)]
fn straddles_page<T>(p: *const T, bytes: usize) -> bool {
    (p as usize & 4095) > 4096 - bytes
}

/// Whether the array `x` straddles a 4 KiB page. Only then can a
/// register's worth of it, so the kernels check each one (`SPLIT`)
/// only then: once per array and step instead of once per access.
#[inline(always)]
fn array_straddles<T>(x: &[T]) -> bool {
    (x.as_ptr() as usize & 4095) + size_of_val(x) > 4096
}

/// With debug assertions: no register of `χ` (rows of `n`) straddles
/// the first page boundary in it.
#[inline(always)]
fn debug_assert_placed<T>(chi: &[T], n: usize) {
    debug_assert!(
        !crate::realtime::placement::cuts_a_register(
            chi.as_ptr() as usize,
            size_of::<T>(),
            n,
            chi.len()
        ),
        "χ not placed"
    );
}

/// `N` values at `p` read one by one (volatile, so that they are not
/// merged into the one wide access this avoids) into an array.
#[inline(always)]
unsafe fn read_each<T: Real, const N: usize>(p: *const T) -> [T; N] {
    // SAFETY: the caller's `p..p + N` is readable.
    core::array::from_fn(|l| unsafe { core::ptr::read_volatile(p.add(l)) })
}

/// `values` written one by one to `p` (volatile, as in [`read_each`]).
#[inline(always)]
unsafe fn write_each<T: Real, const N: usize>(p: *mut T, values: &[T; N]) {
    for (l, &x) in values.iter().enumerate() {
        // SAFETY: the caller's `p..p + N` is writable.
        unsafe { core::ptr::write_volatile(p.add(l), x) };
    }
}

/// The step's kernels of the AVX2 set: `f64` on 4-lane registers,
/// `f32` on 8-lane ones.
struct Avx2Step;
/// The step's kernels of the AVX-512 set: `H⁻¹`'s plays on 4-lane
/// registers (for `f64` the AVX2 set's kernel, for `f32` 128-bit halves)
/// and the creep pass on 8-lane ones (512-bit for `f64`, 256-bit for
/// `f32`). The paper's twelve plays are too few for 8 lanes to pay: there
/// the step's chain waited for the creep's output to be broadcast to 8
/// lanes and for the upper half of the plays' sum to be extracted, where
/// on 4 lanes it waits for neither; the creep pass's sixty updates are
/// enough, and 8 lanes halve its operations. The same bits either way.
struct Avx512Step;

/// A value on a vector set's chain (its `Lanes`): the value, and the
/// value in every lane of a 4-lane register, which the kernels take and
/// give: for `f64` the register, for `f32` its low 128 bits as four `f32`
/// (the upper half unused).
#[derive(Clone, Copy)]
pub(super) struct OnChain<T> {
    every_lane: __m256d,
    value: T,
}

macro_rules! step_kernels {
    ($set:ident, $hysteresis_f64:expr, $creep_f64:expr, $hysteresis_f32:expr, $creep_f32:expr) => {
        impl<T: Real> super::StepKernels<T> for $set {
            type Lanes = OnChain<T>;

            #[inline(always)]
            unsafe fn splat(x: T) -> OnChain<T> {
                // SAFETY (both): the caller's features.
                let every_lane = if TypeId::of::<T>() == TypeId::of::<f64>() {
                    unsafe { _mm256_set1_pd(x.to_f64()) }
                } else {
                    unsafe { every_lane_f32(_mm_set1_ps(x.to_f64() as f32)) }
                };
                OnChain {
                    every_lane,
                    value: x,
                }
            }

            #[inline(always)]
            unsafe fn splat_from(x: &T) -> OnChain<T> {
                // SAFETY (both): the caller's features; `x` is one
                // readable `f64` or `f32`. The value is lane 0 of the
                // broadcast, so that the one load is the broadcast's.
                if let Some(x) = super::cast::<T, f64>(core::slice::from_ref(x)) {
                    return unsafe { on_chain(_mm256_broadcast_sd(&x[0])) };
                }
                if let Some(x) = super::cast::<T, f32>(core::slice::from_ref(x)) {
                    return unsafe { on_chain_f32(_mm_broadcast_ss(&x[0])) };
                }
                unreachable!("Real is f32 or f64")
            }

            #[inline(always)]
            unsafe fn first(x: OnChain<T>) -> T {
                x.value
            }

            #[inline(always)]
            unsafe fn inverse_plays(
                state: &mut [T],
                saved: &mut [T],
                r: &[T],
                w: &[T],
                t: T,
                c: OnChain<T>,
            ) -> OnChain<T> {
                use super::{cast, cast_mut, count_simd_call};
                count_simd_call();
                // SAFETY (all): the caller's features.
                if let (Some(x), Some(s), Some(r), Some(w)) =
                    (cast_mut(state), cast_mut(saved), cast(r), cast(w))
                {
                    let v = unsafe { $hysteresis_f64(x, s, r, w, t.to_f64(), c.every_lane) };
                    return unsafe { on_chain(v) };
                }
                if let (Some(x), Some(s), Some(r), Some(w)) =
                    (cast_mut(state), cast_mut(saved), cast(r), cast(w))
                {
                    let t = t.to_f64() as f32;
                    let y = unsafe { $hysteresis_f32(x, s, r, w, t, lanes_f32(c)) };
                    return unsafe { on_chain_f32(y) };
                }
                unreachable!("Real is f32 or f64")
            }

            #[inline(always)]
            unsafe fn creep(chi: &mut [T], r: &[T], g: &[T], w: &[T], v: OnChain<T>) -> OnChain<T> {
                use super::{cast, cast_mut, count_simd_call};
                count_simd_call();
                // SAFETY (all): the caller's features.
                if let (Some(chi), Some(r), Some(g), Some(w)) =
                    (cast_mut(chi), cast(r), cast(g), cast(w))
                {
                    return unsafe { on_chain($creep_f64(chi, r, g, w, v.every_lane)) };
                }
                if let (Some(chi), Some(r), Some(g), Some(w)) =
                    (cast_mut(chi), cast(r), cast(g), cast(w))
                {
                    let y = unsafe { $creep_f32(chi, r, g, w, lanes_f32(v)) };
                    return unsafe { on_chain_f32(y) };
                }
                unreachable!("Real is f32 or f64")
            }
        }
    };
}
/// An `f64` in every lane of `v` as a `T` on the chain (`T` is `f64`).
#[inline(always)]
unsafe fn on_chain<T: Real>(v: __m256d) -> OnChain<T> {
    OnChain {
        every_lane: v,
        // SAFETY: the caller's AVX.
        value: T::from_f64(unsafe { _mm256_cvtsd_f64(v) }),
    }
}

/// An `f32` in every lane of `v` as a `T` on the chain (`T` is `f32`).
#[inline(always)]
unsafe fn on_chain_f32<T: Real>(v: __m128) -> OnChain<T> {
    OnChain {
        // SAFETY (both): the caller's AVX.
        every_lane: unsafe { every_lane_f32(v) },
        value: T::from_f64(f64::from(unsafe { _mm_cvtss_f32(v) })),
    }
}

/// Four `f32` lanes as an [`OnChain`]'s register: the low 128 bits, the
/// upper half never read.
#[inline(always)]
unsafe fn every_lane_f32(v: __m128) -> __m256d {
    // SAFETY: the caller's AVX.
    unsafe { _mm256_castpd128_pd256(_mm_castps_pd(v)) }
}

/// The four `f32` lanes of an `f32` on the chain ([`on_chain_f32`]).
#[inline(always)]
unsafe fn lanes_f32<T>(x: OnChain<T>) -> __m128 {
    // SAFETY: the caller's AVX.
    unsafe { _mm_castpd_ps(_mm256_castpd256_pd128(x.every_lane)) }
}

step_kernels!(
    Avx2Step,
    hysteresis_four,
    creep_four,
    hysteresis_eight::<F32x8, false>,
    creep_eight::<F32x8>
);
step_kernels!(
    Avx512Step,
    hysteresis_four,
    creep_eight::<F64x8>,
    hysteresis_eight::<F32x8, true>,
    creep_eight::<F32x8>
);

/// A kernel set's entry points, each compiled with its features:
/// [`super::step_body`] (one step), [`super::run_body`] (a run) and the
/// creep pass alone (the forward model's, a held compensator sample's).
macro_rules! entry_points {
    ($set:ident, $features:literal, $step:ident, $run:ident, $creep:ident) => {
        /// [`super::step_body`] on the set's kernels, one function.
        #[target_feature(enable = $features)]
        #[inline(never)]
        pub(super) unsafe fn $step<T: Real, C: super::StepSource<T>, const PAPER: bool>(
            c: &mut C,
            t: T,
            lower: T,
            upper: T,
        ) -> (T, bool) {
            // SAFETY: the features are enabled here.
            let (u, saturated, _) =
                unsafe { super::step_body::<T, $set, C, PAPER>(c, t, None, lower, upper) };
            (u, saturated)
        }

        /// [`super::run_body`] on the set's kernels, one function.
        #[target_feature(enable = $features)]
        #[inline(never)]
        pub(super) unsafe fn $run<T: Real, C: super::RunSource<T>, const PAPER: bool>(
            k: super::Kernels,
            c: &mut C,
            targets: &[T],
            out: super::RunOutputs<'_, T>,
        ) -> (usize, usize) {
            // SAFETY: the features are enabled here.
            unsafe { super::run_body::<T, $set, C, PAPER>(k, c, targets, out) }
        }

        /// The creep pass alone on the set's kernels.
        #[target_feature(enable = $features)]
        #[inline]
        pub(super) unsafe fn $creep<T: Real>(chi: &mut [T], r: &[T], g: &[T], w: &[T], v: T) -> T {
            type K = $set;
            // SAFETY: the features are enabled here.
            unsafe {
                let v = <K as super::StepKernels<T>>::splat(v);
                let c = <K as super::StepKernels<T>>::creep(chi, r, g, w, v);
                <K as super::StepKernels<T>>::first(c)
            }
        }
    };
}
entry_points!(Avx2Step, "avx2,fma", step_avx2, run_avx2, creep_avx2);
entry_points!(
    Avx512Step,
    "avx2,fma,avx512f",
    step_avx512,
    run_avx512,
    creep_avx512
);
