//! Instruction sets: the one place they are chosen and the one place
//! `unsafe` is written.
//!
//! The kernels are written once, generic and `#[inline(always)]`. A caller
//! picks [`Kernels`] once per call (a whole `compensate`, a whole signal, a
//! bank step) with [`Kernels::detect`]: with `std` on x86-64 the step is then
//! compiled again with AVX2, or AVX-512F, enabled ([`Kernels::run`]). The
//! single compensator's `f64` blocks of `H⁻¹`, the plays and the creep pass
//! run on explicit 256-bit registers, its `f32` ones on 8-lane registers;
//! the bank's 64-byte blocks ([`block`]: 8 `f64` or 16 `f32` lanes, one
//! cache line) on two 256-bit registers or one 512-bit register. No copy
//! fuses a multiply and an add (Rust never contracts them), `min` and `max`
//! are written as the hardware defines them and the sums run in a fixed
//! order, so every copy computes the same bits: `verification/bank.rs`
//! checks that for each kernel set the CPU has ([`Kernels::all`]), and that
//! the explicit kernels did run where it has them ([`simd_kernel_calls`]).
//! Without `std` (firmware) there is one copy, for the target's own
//! features.

// the bank's blocks: the bank is part of the `std` layer
#[cfg(feature = "std")]
pub(crate) mod block;

#[cfg(all(feature = "std", target_arch = "x86_64"))]
use core::any::TypeId;

use crate::realtime::real::Real;

/// The kernels a step runs: the portable ones, or (x86-64 with `std`, the
/// CPU having them) the AVX2 or the AVX-512 ones. Only [`Kernels::detect`]
/// and [`Kernels::all`] make the vector values, so holding one proves the
/// CPU has its features.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kernels {
    Portable,
    #[cfg(all(feature = "std", target_arch = "x86_64"))]
    Avx2(Avx2),
    /// AVX-512F (with AVX2, which every such CPU has).
    #[cfg(all(feature = "std", target_arch = "x86_64"))]
    Avx512(Avx512),
}

/// The proof that this CPU has AVX2 (private constructor).
#[cfg(all(feature = "std", target_arch = "x86_64"))]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Avx2(());

/// The proof that this CPU has AVX-512F and AVX2 (private constructor).
#[cfg(all(feature = "std", target_arch = "x86_64"))]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Avx512(());

impl Kernels {
    /// The best kernels this CPU runs (a cached feature test).
    #[inline]
    pub fn detect() -> Self {
        let mut best = Kernels::Portable;
        for k in Self::all() {
            best = k;
        }
        best
    }

    /// Every kernel set this CPU runs, the portable one first and the best
    /// last: what the bit-for-bit tests compare.
    pub fn all() -> impl Iterator<Item = Kernels> {
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        let (avx2, avx512) = {
            let avx2 = std::is_x86_feature_detected!("avx2");
            (
                avx2.then_some(Kernels::Avx2(Avx2(()))),
                (avx2 && std::is_x86_feature_detected!("avx512f"))
                    .then_some(Kernels::Avx512(Avx512(()))),
            )
        };
        #[cfg(not(all(feature = "std", target_arch = "x86_64")))]
        let (avx2, avx512): (Option<Kernels>, Option<Kernels>) = (None, None);
        [Some(Kernels::Portable), avx2, avx512]
            .into_iter()
            .flatten()
    }

    /// Whether these kernels have AVX2 (the AVX2 or the AVX-512 ones).
    pub fn is_avx2(self) -> bool {
        self != Kernels::Portable
    }

    /// Whether these are the AVX-512 kernels.
    pub fn is_avx512(self) -> bool {
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        return matches!(self, Kernels::Avx512(_));
        #[cfg(not(all(feature = "std", target_arch = "x86_64")))]
        false
    }

    /// `f(self)`, compiled with the kernels' features enabled.
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
            #[cfg(all(feature = "std", target_arch = "x86_64"))]
            Kernels::Avx512(_) => {
                #[target_feature(enable = "avx2,avx512f")]
                unsafe fn with_avx512<R>(k: Kernels, f: impl FnOnce(Kernels) -> R) -> R {
                    f(k)
                }
                // SAFETY: an `Avx512` value exists only where the CPU has
                // AVX-512F and AVX2.
                unsafe { with_avx512(self, f) }
            }
            Kernels::Portable => f(self),
        }
    }

    /// The AVX2 proof, for the AVX2 and the AVX-512 kernels.
    #[cfg(all(feature = "std", target_arch = "x86_64"))]
    #[inline(always)]
    fn avx2(self) -> Option<Avx2> {
        match self {
            Kernels::Avx2(a) => Some(a),
            Kernels::Avx512(_) => Some(Avx2(())),
            Kernels::Portable => None,
        }
    }
}

#[cfg(all(feature = "std", target_arch = "x86_64", debug_assertions))]
std::thread_local! {
    static SIMD_CALLS: core::cell::Cell<usize> = const { core::cell::Cell::new(0) };
}

/// How many explicit vector kernel calls (AVX2 or AVX-512) this thread has
/// made (counted in builds with debug assertions, as the tests run; always
/// 0 otherwise).
pub fn simd_kernel_calls() -> usize {
    #[cfg(all(feature = "std", target_arch = "x86_64", debug_assertions))]
    return SIMD_CALLS.with(|c| c.get());
    #[cfg(not(all(feature = "std", target_arch = "x86_64", debug_assertions)))]
    0
}

#[cfg(all(feature = "std", target_arch = "x86_64"))]
#[inline(always)]
pub(crate) fn count_simd_call() {
    #[cfg(debug_assertions)]
    SIMD_CALLS.with(|c| c.set(c.get() + 1));
}

/// `x` as a slice of `U` when `T` is `U`.
#[cfg(all(feature = "std", target_arch = "x86_64"))]
#[inline(always)]
fn cast<T: Real, U: Real>(x: &[T]) -> Option<&[U]> {
    // SAFETY: T is U when the TypeIds agree: the same type, the same layout.
    (TypeId::of::<T>() == TypeId::of::<U>()).then(|| unsafe { &*(x as *const [T] as *const [U]) })
}

/// `x` as a slice of `U` when `T` is `U`, mutably.
#[cfg(all(feature = "std", target_arch = "x86_64"))]
#[inline(always)]
fn cast_mut<T: Real, U: Real>(x: &mut [T]) -> Option<&mut [U]> {
    // SAFETY: as in `cast`.
    (TypeId::of::<T>() == TypeId::of::<U>()).then(|| unsafe { &mut *(x as *mut [T] as *mut [U]) })
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
    if k.avx2().is_some() {
        let v = if v.is_finite() { v } else { state[0] };
        if let (Some(x), Some(r), Some(w)) = (cast_mut(state), cast(thresholds), cast(weights)) {
            count_simd_call();
            // SAFETY: `k` proves AVX2, and AVX-512F where it is `Avx512`.
            let y = unsafe {
                if k.is_avx512() {
                    x86::hysteresis_step_f64_avx512(x, r, w, v.to_f64())
                } else {
                    x86::hysteresis_step(x, r, w, v.to_f64())
                }
            };
            return T::from_f64(y);
        }
        if let (Some(x), Some(r), Some(w)) = (cast_mut(state), cast(thresholds), cast(weights)) {
            count_simd_call();
            // SAFETY: `k` proves AVX2.
            let y = unsafe { x86::hysteresis_step_f32(x, r, w, v.to_f64() as f32) };
            return T::from_f64(f64::from(y));
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
    if k.avx2().is_some() {
        let held = if v.is_finite() { v } else { *last_input };
        if let (Some(chi), Some(r), Some(g), Some(w)) =
            (cast_mut(chi), cast(thresholds), cast(gains), cast(weights))
        {
            *last_input = held;
            count_simd_call();
            // SAFETY: `k` proves AVX2, and AVX-512F where it is `Avx512`.
            let y = unsafe {
                if k.is_avx512() {
                    x86::creep_advance_f64_avx512(chi, r, g, w, held.to_f64())
                } else {
                    x86::creep_advance(chi, r, g, w, held.to_f64())
                }
            };
            return T::from_f64(y);
        }
        if let (Some(chi), Some(r), Some(g), Some(w)) =
            (cast_mut(chi), cast(thresholds), cast(gains), cast(weights))
        {
            *last_input = held;
            count_simd_call();
            // SAFETY: `k` proves AVX2.
            let y = unsafe { x86::creep_advance_f32(chi, r, g, w, held.to_f64() as f32) };
            return T::from_f64(f64::from(y));
        }
    }
    let _ = k;
    crate::realtime::creep::advance(chi, thresholds, gains, weights, v, last_input)
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

    /// `hysteresis::step` for `f64` in 8-lane blocks (AVX-512F): the
    /// products of lanes 0–3 and then of lanes 4–7 into the four partial
    /// sums, as the portable blocks of four add them; a 4-lane block and
    /// the rest as in [`hysteresis_step`].
    #[target_feature(enable = "avx2,avx512f")]
    #[inline(never)]
    pub(super) unsafe fn hysteresis_step_f64_avx512(
        state: &mut [f64],
        thresholds: &[f64],
        weights: &[f64],
        v: f64,
    ) -> f64 {
        let n = state.len();
        assert!(thresholds.len() == n && weights.len() == n);
        let (full8, full4) = (n - n % 8, n - n % 4);
        let (v8, v4) = (_mm512_set1_pd(v), _mm256_set1_pd(v));
        let mut acc = _mm256_setzero_pd();
        // SAFETY (all pointer accesses): every block ends at or before n.
        unsafe {
            for i0 in (0..full8).step_by(8) {
                let at = state.as_mut_ptr().add(i0);
                let r = _mm512_loadu_pd(thresholds.as_ptr().add(i0));
                let x = _mm512_loadu_pd(at);
                let x = _mm512_max_pd(_mm512_min_pd(x, _mm512_add_pd(v8, r)), _mm512_sub_pd(v8, r));
                _mm512_storeu_pd(at, x);
                let p = _mm512_mul_pd(_mm512_loadu_pd(weights.as_ptr().add(i0)), x);
                acc = _mm256_add_pd(acc, _mm512_castpd512_pd256(p));
                acc = _mm256_add_pd(acc, _mm512_extractf64x4_pd::<1>(p));
            }
            if full4 > full8 {
                let at = state.as_mut_ptr().add(full8);
                let r = _mm256_loadu_pd(thresholds.as_ptr().add(full8));
                let x = _mm256_loadu_pd(at);
                let x = _mm256_max_pd(_mm256_min_pd(x, _mm256_add_pd(v4, r)), _mm256_sub_pd(v4, r));
                _mm256_storeu_pd(at, x);
                acc = _mm256_add_pd(
                    acc,
                    _mm256_mul_pd(_mm256_loadu_pd(weights.as_ptr().add(full8)), x),
                );
            }
        }
        let mut lanes = [0.0f64; 4];
        // SAFETY: four lanes into four f64.
        unsafe { _mm256_storeu_pd(lanes.as_mut_ptr(), acc) };
        for i in full4..n {
            state[i] = play(v, thresholds[i], state[i]);
            lanes[i - full4] += weights[i] * state[i];
        }
        reduce(lanes)
    }

    /// `hysteresis::step` for `f32` in 8-lane blocks (AVX2), summed as
    /// [`hysteresis_step_f64_avx512`] sums, then a 4-lane block and the rest.
    #[target_feature(enable = "avx2")]
    #[inline(never)]
    pub(super) unsafe fn hysteresis_step_f32(
        state: &mut [f32],
        thresholds: &[f32],
        weights: &[f32],
        v: f32,
    ) -> f32 {
        let n = state.len();
        assert!(thresholds.len() == n && weights.len() == n);
        let (full8, full4) = (n - n % 8, n - n % 4);
        let (v8, v4) = (_mm256_set1_ps(v), _mm_set1_ps(v));
        let mut acc = _mm_setzero_ps();
        // SAFETY (all pointer accesses): every block ends at or before n.
        unsafe {
            for i0 in (0..full8).step_by(8) {
                let at = state.as_mut_ptr().add(i0);
                let r = _mm256_loadu_ps(thresholds.as_ptr().add(i0));
                let x = _mm256_loadu_ps(at);
                let x = _mm256_max_ps(_mm256_min_ps(x, _mm256_add_ps(v8, r)), _mm256_sub_ps(v8, r));
                _mm256_storeu_ps(at, x);
                let p = _mm256_mul_ps(_mm256_loadu_ps(weights.as_ptr().add(i0)), x);
                acc = _mm_add_ps(acc, _mm256_castps256_ps128(p));
                acc = _mm_add_ps(acc, _mm256_extractf128_ps::<1>(p));
            }
            if full4 > full8 {
                let at = state.as_mut_ptr().add(full8);
                let r = _mm_loadu_ps(thresholds.as_ptr().add(full8));
                let x = _mm_loadu_ps(at);
                let x = _mm_max_ps(_mm_min_ps(x, _mm_add_ps(v4, r)), _mm_sub_ps(v4, r));
                _mm_storeu_ps(at, x);
                acc = _mm_add_ps(
                    acc,
                    _mm_mul_ps(_mm_loadu_ps(weights.as_ptr().add(full8)), x),
                );
            }
        }
        let mut lanes = [0.0f32; 4];
        // SAFETY: four lanes into four f32.
        unsafe { _mm_storeu_ps(lanes.as_mut_ptr(), acc) };
        for i in full4..n {
            state[i] = play(v, thresholds[i], state[i]);
            lanes[i - full4] += weights[i] * state[i];
        }
        reduce(lanes)
    }

    /// `creep::advance` for `f64` in 8-lane blocks of thresholds (AVX-512F),
    /// each block's weighted rows added as two blocks of four; then a
    /// 4-lane block and the rest as the portable tail.
    #[target_feature(enable = "avx2,avx512f")]
    #[inline(never)]
    pub(super) unsafe fn creep_advance_f64_avx512(
        chi: &mut [f64],
        thresholds: &[f64],
        gains: &[f64],
        weights: &[f64],
        v: f64,
    ) -> f64 {
        let n = thresholds.len();
        assert!(weights.len() == n && chi.len() == n * gains.len());
        let (full8, full4) = (n - n % 8, n - n % LANES);
        let (v8, v4) = (_mm512_set1_pd(v), _mm256_set1_pd(v));
        let mut acc = _mm256_setzero_pd();
        let p = chi.as_mut_ptr();
        // SAFETY (all pointer accesses): every block ends at or before n in
        // its row of `chi` (n·m) and in the parameter slices (n).
        unsafe {
            for i0 in (0..full8).step_by(8) {
                let r = _mm512_loadu_pd(thresholds.as_ptr().add(i0));
                let (lower, upper) = (_mm512_sub_pd(v8, r), _mm512_add_pd(v8, r));
                let mut rows = _mm512_setzero_pd();
                for (j, &g) in gains.iter().enumerate() {
                    let at = p.add(j * n + i0);
                    let x = _mm512_loadu_pd(at);
                    let c = _mm512_max_pd(_mm512_min_pd(x, upper), lower);
                    let x = _mm512_add_pd(x, _mm512_mul_pd(_mm512_set1_pd(g), _mm512_sub_pd(c, x)));
                    _mm512_storeu_pd(at, x);
                    rows = _mm512_add_pd(rows, x);
                }
                let s = _mm512_mul_pd(_mm512_loadu_pd(weights.as_ptr().add(i0)), rows);
                acc = _mm256_add_pd(acc, _mm512_castpd512_pd256(s));
                acc = _mm256_add_pd(acc, _mm512_extractf64x4_pd::<1>(s));
            }
            if full4 > full8 {
                let r = _mm256_loadu_pd(thresholds.as_ptr().add(full8));
                let (lower, upper) = (_mm256_sub_pd(v4, r), _mm256_add_pd(v4, r));
                let mut rows = _mm256_setzero_pd();
                for (j, &g) in gains.iter().enumerate() {
                    let at = p.add(j * n + full8);
                    let x = _mm256_loadu_pd(at);
                    let c = _mm256_max_pd(_mm256_min_pd(x, upper), lower);
                    let x = _mm256_add_pd(x, _mm256_mul_pd(_mm256_set1_pd(g), _mm256_sub_pd(c, x)));
                    _mm256_storeu_pd(at, x);
                    rows = _mm256_add_pd(rows, x);
                }
                let w = _mm256_loadu_pd(weights.as_ptr().add(full8));
                acc = _mm256_add_pd(acc, _mm256_mul_pd(w, rows));
            }
        }
        let mut lanes = [0.0f64; LANES];
        // SAFETY: four lanes into four f64.
        unsafe { _mm256_storeu_pd(lanes.as_mut_ptr(), acc) };
        advance_tail(chi, thresholds, gains, weights, v, full4, &mut lanes);
        reduce(lanes)
    }

    /// `creep::advance` for `f32` in 8-lane blocks of thresholds (AVX2),
    /// summed as [`creep_advance_f64_avx512`] sums; then a 4-lane block and
    /// the rest as the portable tail.
    #[target_feature(enable = "avx2")]
    #[inline(never)]
    pub(super) unsafe fn creep_advance_f32(
        chi: &mut [f32],
        thresholds: &[f32],
        gains: &[f32],
        weights: &[f32],
        v: f32,
    ) -> f32 {
        let n = thresholds.len();
        assert!(weights.len() == n && chi.len() == n * gains.len());
        let (full8, full4) = (n - n % 8, n - n % LANES);
        let (v8, v4) = (_mm256_set1_ps(v), _mm_set1_ps(v));
        let mut acc = _mm_setzero_ps();
        let p = chi.as_mut_ptr();
        // SAFETY (all pointer accesses): as in `creep_advance_f64_avx512`.
        unsafe {
            for i0 in (0..full8).step_by(8) {
                let r = _mm256_loadu_ps(thresholds.as_ptr().add(i0));
                let (lower, upper) = (_mm256_sub_ps(v8, r), _mm256_add_ps(v8, r));
                let mut rows = _mm256_setzero_ps();
                for (j, &g) in gains.iter().enumerate() {
                    let at = p.add(j * n + i0);
                    let x = _mm256_loadu_ps(at);
                    let c = _mm256_max_ps(_mm256_min_ps(x, upper), lower);
                    let x = _mm256_add_ps(x, _mm256_mul_ps(_mm256_set1_ps(g), _mm256_sub_ps(c, x)));
                    _mm256_storeu_ps(at, x);
                    rows = _mm256_add_ps(rows, x);
                }
                let s = _mm256_mul_ps(_mm256_loadu_ps(weights.as_ptr().add(i0)), rows);
                acc = _mm_add_ps(acc, _mm256_castps256_ps128(s));
                acc = _mm_add_ps(acc, _mm256_extractf128_ps::<1>(s));
            }
            if full4 > full8 {
                let r = _mm_loadu_ps(thresholds.as_ptr().add(full8));
                let (lower, upper) = (_mm_sub_ps(v4, r), _mm_add_ps(v4, r));
                let mut rows = _mm_setzero_ps();
                for (j, &g) in gains.iter().enumerate() {
                    let at = p.add(j * n + full8);
                    let x = _mm_loadu_ps(at);
                    let c = _mm_max_ps(_mm_min_ps(x, upper), lower);
                    let x = _mm_add_ps(x, _mm_mul_ps(_mm_set1_ps(g), _mm_sub_ps(c, x)));
                    _mm_storeu_ps(at, x);
                    rows = _mm_add_ps(rows, x);
                }
                let w = _mm_loadu_ps(weights.as_ptr().add(full8));
                acc = _mm_add_ps(acc, _mm_mul_ps(w, rows));
            }
        }
        let mut lanes = [0.0f32; LANES];
        // SAFETY: four lanes into four f32.
        unsafe { _mm_storeu_ps(lanes.as_mut_ptr(), acc) };
        advance_tail(chi, thresholds, gains, weights, v, full4, &mut lanes);
        reduce(lanes)
    }
}
