//! Instruction sets: the one place they are chosen and the one place
//! `unsafe` is written.
//!
//! The kernels are written once, generic and `#[inline(always)]`. A caller
//! picks [`Kernels`] once per call (a whole `compensate`, a whole signal, a
//! bank step) with [`Kernels::detect`]: with `std` on x86-64 the step is then
//! compiled a second time with AVX2 enabled ([`Kernels::run`]) and the
//! `f64` blocks of `H⁻¹`, the plays and the creep pass, and the bank's lane
//! blocks in `f64 × 4` and `f32 × 8`, run on explicit 256-bit registers.
//! Neither copy fuses a multiply and an add (Rust never contracts them) and
//! the sums run in a fixed order, so both compute the same bits:
//! `verification/bank.rs` checks that, and that the AVX kernels did run
//! where the CPU has AVX2 ([`avx2_kernel_calls`]). Without `std` (firmware)
//! there is one copy, for the target's own features.

#[cfg(all(feature = "std", target_arch = "x86_64"))]
use core::any::TypeId;

use crate::realtime::real::Real;

/// The kernels a step runs: the portable ones, or (x86-64 with `std`, the
/// CPU having it) the AVX2 ones. Only [`Kernels::detect`] makes the AVX2
/// value, so holding one proves the CPU has AVX2.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kernels {
    Portable,
    #[cfg(all(feature = "std", target_arch = "x86_64"))]
    Avx2(Avx2),
}

/// The proof that this CPU has AVX2 (private constructor).
#[cfg(all(feature = "std", target_arch = "x86_64"))]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Avx2(());

impl Kernels {
    /// The best kernels this CPU runs (a cached feature test).
    #[inline]
    pub fn detect() -> Self {
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        if std::is_x86_feature_detected!("avx2") {
            return Kernels::Avx2(Avx2(()));
        }
        Kernels::Portable
    }

    /// Whether these are the AVX2 kernels.
    pub fn is_avx2(self) -> bool {
        self != Kernels::Portable
    }

    /// `f(self)`, compiled with AVX2 enabled for the AVX2 kernels.
    #[inline(always)]
    pub(crate) fn run<R>(self, f: impl FnOnce(Self) -> R) -> R {
        match self {
            #[cfg(all(feature = "std", target_arch = "x86_64"))]
            Kernels::Avx2(_) => {
                #[target_feature(enable = "avx2")]
                unsafe fn with_avx2<R>(k: Kernels, f: impl FnOnce(Kernels) -> R) -> R {
                    f(k)
                }
                // SAFETY: an `Avx2` value exists only where the CPU has AVX2.
                unsafe { with_avx2(self, f) }
            }
            Kernels::Portable => f(self),
        }
    }
}

#[cfg(all(feature = "std", target_arch = "x86_64", debug_assertions))]
std::thread_local! {
    static AVX2_CALLS: core::cell::Cell<usize> = const { core::cell::Cell::new(0) };
}

/// How many AVX2 kernel calls this thread has made (counted in builds with
/// debug assertions, as the tests run; always 0 otherwise).
pub fn avx2_kernel_calls() -> usize {
    #[cfg(all(feature = "std", target_arch = "x86_64", debug_assertions))]
    return AVX2_CALLS.with(|c| c.get());
    #[cfg(not(all(feature = "std", target_arch = "x86_64", debug_assertions)))]
    0
}

#[cfg(all(feature = "std", target_arch = "x86_64"))]
#[inline(always)]
fn count_avx2_call() {
    #[cfg(debug_assertions)]
    AVX2_CALLS.with(|c| c.set(c.get() + 1));
}

/// `x` as `f64` when `T` is `f64` (the single-step kernels are explicit for
/// `f64` only; `f32` runs the portable ones, vectorised by the compiler).
#[cfg(all(feature = "std", target_arch = "x86_64"))]
#[inline(always)]
fn as_f64<T: Real>(x: &[T]) -> Option<&[f64]> {
    // SAFETY: T is f64 when the TypeIds agree: the same type, the same layout.
    (TypeId::of::<T>() == TypeId::of::<f64>())
        .then(|| unsafe { &*(x as *const [T] as *const [f64]) })
}

/// `x` as `f64` when `T` is `f64`, mutably.
#[cfg(all(feature = "std", target_arch = "x86_64"))]
#[inline(always)]
fn as_f64_mut<T: Real>(x: &mut [T]) -> Option<&mut [f64]> {
    // SAFETY: as in `as_f64`.
    (TypeId::of::<T>() == TypeId::of::<f64>())
        .then(|| unsafe { &mut *(x as *mut [T] as *mut [f64]) })
}

/// One step of `H` ([`crate::realtime::hysteresis::step`]) on `k`'s
/// kernels; a non-finite `v` is held out as there.
#[inline(always)]
pub(crate) fn hysteresis_step<T: Real>(
    k: Kernels,
    state: &mut [T],
    thresholds: &[T],
    weights: &[T],
    v: T,
) -> T {
    #[cfg(all(feature = "std", target_arch = "x86_64"))]
    if let Kernels::Avx2(_) = k {
        let v = if v.is_finite() { v } else { state[0] };
        if let (Some(x), Some(r), Some(w)) =
            (as_f64_mut(state), as_f64(thresholds), as_f64(weights))
        {
            count_avx2_call();
            // SAFETY: `Avx2` proves the CPU has AVX2.
            return T::from_f64(unsafe { x86::hysteresis_step(x, r, w, v.to_f64()) });
        }
    }
    let _ = k;
    crate::realtime::hysteresis::step(state, thresholds, weights, v)
}

/// One step of the creep pass ([`crate::realtime::creep::advance`]) on `k`'s
/// kernels.
#[inline(always)]
pub(crate) fn creep_advance<T: Real>(
    k: Kernels,
    chi: &mut [T],
    thresholds: &[T],
    gains: &[T],
    weights: &[T],
    v: T,
    last_input: &mut T,
) -> T {
    #[cfg(all(feature = "std", target_arch = "x86_64"))]
    if let Kernels::Avx2(_) = k {
        if let (Some(chi), Some(r), Some(g), Some(w)) = (
            as_f64_mut(chi),
            as_f64(thresholds),
            as_f64(gains),
            as_f64(weights),
        ) {
            let v = if v.is_finite() { v } else { *last_input };
            *last_input = v;
            count_avx2_call();
            // SAFETY: `Avx2` proves the CPU has AVX2.
            return T::from_f64(unsafe { x86::creep_advance(chi, r, g, w, v.to_f64()) });
        }
    }
    let _ = k;
    crate::realtime::creep::advance(chi, thresholds, gains, weights, v, last_input)
}

/// The bank's lane blocks on 256-bit registers: `Some` when `k` is AVX2 and
/// a block of `W` lanes of `T` fills one (`f64 × 4`, `f32 × 8`).
#[cfg(all(feature = "std", target_arch = "x86_64"))]
#[inline(always)]
pub(crate) fn lanes<T: Real, const W: usize>(k: Kernels) -> Option<Lanes> {
    match k {
        Kernels::Avx2(_) if W * core::mem::size_of::<T>() == 32 => Some(Lanes(())),
        _ => None,
    }
}

/// The proof that the CPU has AVX2 and a lane block is one 256-bit register.
#[cfg(all(feature = "std", target_arch = "x86_64"))]
#[derive(Clone, Copy)]
pub(crate) struct Lanes(());

#[cfg(all(feature = "std", target_arch = "x86_64"))]
impl Lanes {
    /// One inverse play per lane (the bank's `inverse_play`): `x` clamped
    /// into `[y − r, y + r]`, `sum += w x`, the old `x` kept where the lane's
    /// `mask` has its sign bit set (a fault).
    #[inline(always)]
    pub(crate) fn inverse_play<T: Real, const W: usize>(
        self,
        x: &mut [T; W],
        r: &[T; W],
        w: &[T; W],
        y: &[T; W],
        mask: &[T; W],
        sum: &mut [T; W],
    ) {
        count_avx2_call();
        // SAFETY: `Lanes` proves AVX2 and 32-byte lane arrays of f64 or f32.
        unsafe { x86::lanes::inverse_play(x, r, w, y, mask, sum) }
    }

    /// One creep row of a block of lanes (the bank's `creep_row`): for the
    /// `m` eigenvalues, `χ ← χ + g (clamp(χ, u − r, u + r) − χ)` at
    /// `chi[e0 + j·step ..]` with gains at `gains[j·ps + pb ..]`, their sum
    /// times `w` added to `acc`.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(crate) fn creep_row<T: Real, const W: usize>(
        self,
        chi: &mut [T],
        (e0, step): (usize, usize),
        gains: &[T],
        (ps, pb, m): (usize, usize, usize),
        u: &[T; W],
        r: &[T; W],
        w: &[T; W],
        acc: &mut [T; W],
    ) {
        assert!(
            e0 + (m.max(1) - 1) * step + W <= chi.len()
                && (m.max(1) - 1) * ps + pb + W <= gains.len()
        );
        count_avx2_call();
        // SAFETY: every block read lies inside chi and gains (asserted
        // above); `Lanes` proves AVX2 and 32-byte lane arrays.
        unsafe { x86::lanes::creep_row(chi, e0, step, gains, ps, pb, m, u, r, w, acc) }
    }
}

#[cfg(all(feature = "std", target_arch = "x86_64"))]
mod x86 {
    //! The AVX2 kernels. Each does the operations of its portable kernel in
    //! the same order: `vminpd(x, hi)` is `if x < hi { x } else { hi }` and
    //! `vmaxpd(t, lo)` is `if t > lo { t } else { lo }`, as `play` and
    //! `clamp` are written, so the bits are the same.
    use core::arch::x86_64::*;

    use crate::realtime::creep::{advance_tail, LANES};
    use crate::realtime::hysteresis::reduce;
    use crate::realtime::play::play;

    /// The blocks of `hysteresis::step` for `f64`; `v` is finite. Kept
    /// out of line: inlined into the AVX2 step it made the step 4–9 %
    /// slower for the same instructions (measured against the C peer).
    #[target_feature(enable = "avx2")]
    #[inline(never)]
    pub(super) unsafe fn hysteresis_step(
        state: &mut [f64],
        thresholds: &[f64],
        weights: &[f64],
        v: f64,
    ) -> f64 {
        let n = state.len();
        assert!(thresholds.len() == n && weights.len() == n);
        let full = n - n % 4;
        let vv = _mm256_set1_pd(v);
        let mut acc = _mm256_setzero_pd();
        for i0 in (0..full).step_by(4) {
            // SAFETY: i0 + 4 ≤ n for all three slices.
            unsafe {
                let at = state.as_mut_ptr().add(i0);
                let r = _mm256_loadu_pd(thresholds.as_ptr().add(i0));
                let x = _mm256_loadu_pd(at);
                let x = _mm256_max_pd(_mm256_min_pd(x, _mm256_add_pd(vv, r)), _mm256_sub_pd(vv, r));
                _mm256_storeu_pd(at, x);
                let w = _mm256_loadu_pd(weights.as_ptr().add(i0));
                acc = _mm256_add_pd(acc, _mm256_mul_pd(w, x));
            }
        }
        let mut lanes = [0.0f64; 4];
        // SAFETY: four lanes into four f64.
        unsafe { _mm256_storeu_pd(lanes.as_mut_ptr(), acc) };
        for i in full..n {
            state[i] = play(v, thresholds[i], state[i]);
            lanes[i - full] += weights[i] * state[i];
        }
        reduce(lanes)
    }

    /// The blocks of `creep::advance` for `f64`; `v` is finite.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(super) unsafe fn creep_advance(
        chi: &mut [f64],
        thresholds: &[f64],
        gains: &[f64],
        weights: &[f64],
        v: f64,
    ) -> f64 {
        let n = thresholds.len();
        let m = gains.len();
        assert!(weights.len() == n && chi.len() == n * m);
        let full = n - n % LANES;
        let vv = _mm256_set1_pd(v);
        let mut acc = _mm256_setzero_pd();
        let p = chi.as_mut_ptr();
        for i0 in (0..full).step_by(LANES) {
            // SAFETY (all pointer accesses): i0 + 4 ≤ n and j < m, so every
            // block lies inside `chi` (n·m) and the parameter slices (n).
            unsafe {
                let r = _mm256_loadu_pd(thresholds.as_ptr().add(i0));
                let lower = _mm256_sub_pd(vv, r);
                let upper = _mm256_add_pd(vv, r);
                let mut rows = _mm256_setzero_pd();
                for (j, &g) in gains.iter().enumerate() {
                    let at = p.add(j * n + i0);
                    let x = _mm256_loadu_pd(at);
                    let c = _mm256_max_pd(_mm256_min_pd(x, upper), lower);
                    let x = _mm256_add_pd(x, _mm256_mul_pd(_mm256_set1_pd(g), _mm256_sub_pd(c, x)));
                    _mm256_storeu_pd(at, x);
                    rows = _mm256_add_pd(rows, x);
                }
                let w = _mm256_loadu_pd(weights.as_ptr().add(i0));
                acc = _mm256_add_pd(acc, _mm256_mul_pd(w, rows));
            }
        }
        let mut lanes = [0.0f64; LANES];
        // SAFETY: four lanes into four f64.
        unsafe { _mm256_storeu_pd(lanes.as_mut_ptr(), acc) };
        advance_tail(chi, thresholds, gains, weights, v, full, &mut lanes);
        reduce(lanes)
    }

    pub(super) mod lanes {
        //! The bank's two inner kernels on 256-bit registers, for `f64 × 4`
        //! and `f32 × 8` (no other `T` or width reaches them: `Lanes` is made
        //! only for 32-byte lane arrays, and `T` is `f32` or `f64`).
        use core::arch::x86_64::*;
        use core::mem::size_of;

        use crate::realtime::real::Real;

        /// 32 bytes of lanes, either type.
        #[derive(Clone, Copy)]
        struct V(__m256d, __m256);

        #[inline(always)]
        fn is_f64<T>() -> bool {
            size_of::<T>() == 8
        }

        #[target_feature(enable = "avx2")]
        #[inline]
        unsafe fn load<T>(p: *const T) -> V {
            // SAFETY: the caller passes 32 readable bytes.
            unsafe {
                if is_f64::<T>() {
                    V(_mm256_loadu_pd(p as *const f64), _mm256_setzero_ps())
                } else {
                    V(_mm256_setzero_pd(), _mm256_loadu_ps(p as *const f32))
                }
            }
        }

        #[target_feature(enable = "avx2")]
        #[inline]
        unsafe fn store<T>(p: *mut T, v: V) {
            // SAFETY: the caller passes 32 writable bytes.
            unsafe {
                if is_f64::<T>() {
                    _mm256_storeu_pd(p as *mut f64, v.0)
                } else {
                    _mm256_storeu_ps(p as *mut f32, v.1)
                }
            }
        }

        macro_rules! op {
            ($name:ident, $pd:ident, $ps:ident) => {
                #[target_feature(enable = "avx2")]
                #[inline]
                fn $name<T>(a: V, b: V) -> V {
                    if is_f64::<T>() {
                        V($pd(a.0, b.0), a.1)
                    } else {
                        V(a.0, $ps(a.1, b.1))
                    }
                }
            };
        }
        op!(add, _mm256_add_pd, _mm256_add_ps);
        op!(sub, _mm256_sub_pd, _mm256_sub_ps);
        op!(mul, _mm256_mul_pd, _mm256_mul_ps);
        op!(min, _mm256_min_pd, _mm256_min_ps);
        op!(max, _mm256_max_pd, _mm256_max_ps);

        /// `a` where the lane of `mask` has its sign bit set, else `b`.
        #[target_feature(enable = "avx2")]
        #[inline]
        fn select<T>(mask: V, a: V, b: V) -> V {
            if is_f64::<T>() {
                V(_mm256_blendv_pd(b.0, a.0, mask.0), a.1)
            } else {
                V(a.0, _mm256_blendv_ps(b.1, a.1, mask.1))
            }
        }

        #[target_feature(enable = "avx2")]
        #[inline]
        pub(in crate::realtime::simd) unsafe fn inverse_play<T: Real, const W: usize>(
            x: &mut [T; W],
            r: &[T; W],
            w: &[T; W],
            y: &[T; W],
            fault: &[T; W],
            sum: &mut [T; W],
        ) {
            // SAFETY: every array is 32 bytes (the caller's contract).
            unsafe {
                let (xv, rv, yv) = (load(x.as_ptr()), load(r.as_ptr()), load(y.as_ptr()));
                let new = max::<T>(min::<T>(xv, add::<T>(yv, rv)), sub::<T>(yv, rv));
                let s = add::<T>(load(sum.as_ptr()), mul::<T>(load(w.as_ptr()), new));
                store(sum.as_mut_ptr(), s);
                store(x.as_mut_ptr(), select::<T>(load(fault.as_ptr()), xv, new));
            }
        }

        #[allow(clippy::too_many_arguments)]
        #[target_feature(enable = "avx2")]
        #[inline]
        pub(in crate::realtime::simd) unsafe fn creep_row<T: Real, const W: usize>(
            chi: &mut [T],
            e0: usize,
            step: usize,
            gains: &[T],
            ps: usize,
            pb: usize,
            m: usize,
            u: &[T; W],
            r: &[T; W],
            w: &[T; W],
            acc: &mut [T; W],
        ) {
            // SAFETY: the blocks lie inside chi and gains (the caller
            // asserted it); the lane arrays are 32 bytes.
            unsafe {
                let (uv, rv) = (load(u.as_ptr()), load(r.as_ptr()));
                let (lower, upper) = (sub::<T>(uv, rv), add::<T>(uv, rv));
                let mut rows = V(_mm256_setzero_pd(), _mm256_setzero_ps());
                let p = chi.as_mut_ptr();
                for j in 0..m {
                    let g = load(gains.as_ptr().add(j * ps + pb));
                    let at = p.add(e0 + j * step);
                    let x = load(at);
                    let c = max::<T>(min::<T>(x, upper), lower);
                    let x = add::<T>(x, mul::<T>(g, sub::<T>(c, x)));
                    store(at, x);
                    rows = add::<T>(rows, x);
                }
                let a = add::<T>(load(acc.as_ptr()), mul::<T>(load(w.as_ptr()), rows));
                store(acc.as_mut_ptr(), a);
            }
        }
    }
}
