//! The kernels on 8-lane registers: the AVX-512 set's `f64` creep pass
//! (`__m512d`, with `__m256d` halves) and both sets' `f32` (`__m256`, with
//! `__m128` halves), written once over [`Eight`]. `H⁻¹`'s plays and the
//! creep pass in blocks of eight, then a block of four and a scalar tail
//! (the AVX-512 set's `H⁻¹` in blocks of four only, `hysteresis_eight`'s
//! `HALVES`: see `Avx512Step`); each sum of four partial sums ended in a
//! butterfly.
use core::arch::x86_64::*;

use super::four::all_lanes_sum;
use super::{array_straddles, debug_assert_placed, read_each, straddles_page, write_each};
use crate::realtime::creep_pass::{advance_tail, LANES};
use crate::realtime::hysteresis::{reduce, step_tail};
use crate::realtime::real::Real;

/// [`all_lanes_sum`] of four `f32` lanes: `(a₀ + a₂) + (a₁ + a₃)` in
/// lane 0, the same pairs swapped in the others.
#[target_feature(enable = "avx2,fma")]
#[inline]
fn all_lanes_sum_f32(a: __m128) -> __m128 {
    // [a₂, a₃, a₀, a₁] added, then each lane and its neighbour
    let t = _mm_add_ps(a, _mm_permute_ps::<0b01_00_11_10>(a));
    _mm_add_ps(t, _mm_permute_ps::<0b10_11_00_01>(t))
}

/// Lane 0 of `h` in all eight lanes of a 512-bit register.
#[target_feature(enable = "avx2,fma,avx512f")]
#[inline]
fn broadcast_low_f64(h: __m256d) -> __m512d {
    _mm512_broadcastsd_pd(_mm256_castpd256_pd128(h))
}

/// [`hysteresis_step_eight`], as [`hysteresis_four`](super::four::hysteresis_four);
/// `HALVES`: every block of four on the 4-lane halves, none on 8 lanes
/// (`H⁻¹` of the AVX-512 set's `f32` step, see `Avx512Step`).
#[inline(always)]
pub(super) unsafe fn hysteresis_eight<E: Eight, const HALVES: bool>(
    state: &mut [E::T],
    saved: &mut [E::T],
    thresholds: &[E::T],
    weights: &[E::T],
    t: E::T,
    c: E::Half,
) -> E::Half {
    // SAFETY (both): the caller's.
    if array_straddles(state) || array_straddles(saved) {
        unsafe { hysteresis_step_eight::<E, true, HALVES>(state, saved, thresholds, weights, t, c) }
    } else {
        unsafe {
            hysteresis_step_eight::<E, false, HALVES>(state, saved, thresholds, weights, t, c)
        }
    }
}

/// [`creep_advance_eight`], as [`creep_four`](super::four::creep_four).
#[inline(always)]
pub(super) unsafe fn creep_eight<E: Eight>(
    chi: &mut [E::T],
    thresholds: &[E::T],
    gains: &[E::T],
    weights: &[E::T],
    v: E::Half,
) -> E::Half {
    debug_assert_placed(chi, thresholds.len());
    // SAFETY: the caller's.
    unsafe { creep_advance_eight::<E>(chi, thresholds, gains, weights, v) }
}

/// Eight lanes in one register and their four-lane halves: `f64` on
/// AVX-512F (`__m512d`, `__m256d`), `f32` on AVX2 (`__m256`, `__m128`).
/// The 8-lane kernels below are written once over it.
pub(super) trait Eight: Copy {
    type T: Real;
    type Half: Copy;
    unsafe fn splat(x: Self::T) -> Self;
    unsafe fn load(p: *const Self::T) -> Self;
    unsafe fn store(self, p: *mut Self::T);
    unsafe fn add(self, b: Self) -> Self;
    unsafe fn sub(self, b: Self) -> Self;
    /// `a < b ? a : b`, and `a > b ? a : b` for `max`.
    unsafe fn min(self, b: Self) -> Self;
    unsafe fn max(self, b: Self) -> Self;
    /// `self · a + b` and `b − self · a`, rounded once.
    unsafe fn mul_add(self, a: Self, b: Self) -> Self;
    unsafe fn neg_mul_add(self, a: Self, b: Self) -> Self;
    /// Lanes 0–3 and 4–7.
    unsafe fn halves(self) -> (Self::Half, Self::Half);
    unsafe fn half_splat(x: Self::T) -> Self::Half;
    unsafe fn half_zero() -> Self::Half;
    unsafe fn half_load(p: *const Self::T) -> Self::Half;
    unsafe fn half_store(h: Self::Half, p: *mut Self::T);
    unsafe fn half_add(a: Self::Half, b: Self::Half) -> Self::Half;
    unsafe fn half_sub(a: Self::Half, b: Self::Half) -> Self::Half;
    unsafe fn half_min(a: Self::Half, b: Self::Half) -> Self::Half;
    unsafe fn half_max(a: Self::Half, b: Self::Half) -> Self::Half;
    unsafe fn half_mul(a: Self::Half, b: Self::Half) -> Self::Half;
    unsafe fn half_mul_add(a: Self::Half, b: Self::Half, c: Self::Half) -> Self::Half;
    unsafe fn half_neg_mul_add(a: Self::Half, b: Self::Half, c: Self::Half) -> Self::Half;
    /// Lane 0 of `h`, the value a half holds in every lane.
    unsafe fn half_first(h: Self::Half) -> Self::T;
    /// Lane 0 of `h` in all eight lanes.
    unsafe fn splat_half(h: Self::Half) -> Self;
    /// `hysteresis::reduce` of `h`'s four lanes, in every lane: a
    /// butterfly (see [`all_lanes_sum`]).
    unsafe fn half_every_lane_sum(h: Self::Half) -> Self::Half;

    /// `real::add_term` on a half: `w · x` for a sum's first term,
    /// fused with `acc` after it.
    #[inline(always)]
    unsafe fn half_add_term(
        acc: Self::Half,
        w: Self::Half,
        x: Self::Half,
        first: bool,
    ) -> Self::Half {
        // SAFETY (both): the caller's features.
        if first {
            unsafe { Self::half_mul(w, x) }
        } else {
            unsafe { Self::half_mul_add(w, x, acc) }
        }
    }

    /// [`Eight::load`], one value at a time where the eight straddle a
    /// page (see [`super`]'s note).
    #[inline(always)]
    unsafe fn load_unsplit<const SPLIT: bool>(p: *const Self::T) -> Self {
        // SAFETY: the caller's `p..p + 8` is readable.
        unsafe {
            if SPLIT && straddles_page(p, 8 * size_of::<Self::T>()) {
                Self::load(read_each::<Self::T, 8>(p).as_ptr())
            } else {
                Self::load(p)
            }
        }
    }
    /// [`Eight::store`], one value at a time where the eight straddle
    /// a page.
    #[inline(always)]
    unsafe fn store_unsplit<const SPLIT: bool>(self, p: *mut Self::T) {
        // SAFETY: the caller's `p..p + 8` is writable.
        unsafe {
            if SPLIT && straddles_page(p, 8 * size_of::<Self::T>()) {
                let mut a = [Self::T::ZERO; 8];
                self.store(a.as_mut_ptr());
                write_each(p, &a);
            } else {
                self.store(p);
            }
        }
    }
    /// [`Eight::half_load`], one value at a time where the four
    /// straddle a page.
    #[inline(always)]
    unsafe fn half_load_unsplit<const SPLIT: bool>(p: *const Self::T) -> Self::Half {
        // SAFETY: the caller's `p..p + 4` is readable.
        unsafe {
            if SPLIT && straddles_page(p, 4 * size_of::<Self::T>()) {
                Self::half_load(read_each::<Self::T, 4>(p).as_ptr())
            } else {
                Self::half_load(p)
            }
        }
    }
    /// [`Eight::half_store`], one value at a time where the four
    /// straddle a page.
    #[inline(always)]
    unsafe fn half_store_unsplit<const SPLIT: bool>(h: Self::Half, p: *mut Self::T) {
        // SAFETY: the caller's `p..p + 4` is writable.
        unsafe {
            if SPLIT && straddles_page(p, 4 * size_of::<Self::T>()) {
                let mut a = [Self::T::ZERO; 4];
                Self::half_store(h, a.as_mut_ptr());
                write_each(p, &a);
            } else {
                Self::half_store(h, p);
            }
        }
    }
}

macro_rules! eight {
    ($name:ident, $feature:literal, $t:ty, $v:ty, $h:ty,
     [$set1:ident, $loadu:ident, $storeu:ident, $add:ident, $sub:ident, $min:ident, $max:ident, $fma:ident, $fnma:ident],
     [$hset1:ident, $hzero:ident, $hloadu:ident, $hstoreu:ident, $hadd:ident, $hsub:ident, $hmin:ident, $hmax:ident, $hmul:ident, $hfma:ident, $hfnma:ident],
     $lo:expr, $hi:expr, $first:expr, $splat_half:expr, $every_lane_sum:expr) => {
        #[derive(Clone, Copy)]
        pub(super) struct $name($v);

        impl Eight for $name {
            type T = $t;
            type Half = $h;
            #[target_feature(enable = $feature)]
            #[inline]
            unsafe fn splat(x: $t) -> Self {
                $name($set1(x))
            }
            #[target_feature(enable = $feature)]
            #[inline]
            unsafe fn load(p: *const $t) -> Self {
                $name(unsafe { $loadu(p) })
            }
            #[target_feature(enable = $feature)]
            #[inline]
            unsafe fn store(self, p: *mut $t) {
                unsafe { $storeu(p, self.0) }
            }
            #[target_feature(enable = $feature)]
            #[inline]
            unsafe fn add(self, b: Self) -> Self {
                $name($add(self.0, b.0))
            }
            #[target_feature(enable = $feature)]
            #[inline]
            unsafe fn sub(self, b: Self) -> Self {
                $name($sub(self.0, b.0))
            }
            #[target_feature(enable = $feature)]
            #[inline]
            unsafe fn min(self, b: Self) -> Self {
                $name($min(self.0, b.0))
            }
            #[target_feature(enable = $feature)]
            #[inline]
            unsafe fn max(self, b: Self) -> Self {
                $name($max(self.0, b.0))
            }
            #[target_feature(enable = $feature)]
            #[inline]
            unsafe fn mul_add(self, a: Self, b: Self) -> Self {
                $name($fma(self.0, a.0, b.0))
            }
            #[target_feature(enable = $feature)]
            #[inline]
            unsafe fn neg_mul_add(self, a: Self, b: Self) -> Self {
                $name($fnma(self.0, a.0, b.0))
            }
            #[target_feature(enable = $feature)]
            #[inline]
            unsafe fn halves(self) -> ($h, $h) {
                ($lo(self.0), $hi(self.0))
            }
            #[target_feature(enable = $feature)]
            #[inline]
            unsafe fn half_splat(x: $t) -> $h {
                $hset1(x)
            }
            #[target_feature(enable = $feature)]
            #[inline]
            unsafe fn half_zero() -> $h {
                $hzero()
            }
            #[target_feature(enable = $feature)]
            #[inline]
            unsafe fn half_load(p: *const $t) -> $h {
                unsafe { $hloadu(p) }
            }
            #[target_feature(enable = $feature)]
            #[inline]
            unsafe fn half_store(h: $h, p: *mut $t) {
                unsafe { $hstoreu(p, h) }
            }
            #[target_feature(enable = $feature)]
            #[inline]
            unsafe fn half_add(a: $h, b: $h) -> $h {
                $hadd(a, b)
            }
            #[target_feature(enable = $feature)]
            #[inline]
            unsafe fn half_sub(a: $h, b: $h) -> $h {
                $hsub(a, b)
            }
            #[target_feature(enable = $feature)]
            #[inline]
            unsafe fn half_min(a: $h, b: $h) -> $h {
                $hmin(a, b)
            }
            #[target_feature(enable = $feature)]
            #[inline]
            unsafe fn half_max(a: $h, b: $h) -> $h {
                $hmax(a, b)
            }
            #[target_feature(enable = $feature)]
            #[inline]
            unsafe fn half_mul(a: $h, b: $h) -> $h {
                $hmul(a, b)
            }
            #[target_feature(enable = $feature)]
            #[inline]
            unsafe fn half_mul_add(a: $h, b: $h, c: $h) -> $h {
                $hfma(a, b, c)
            }
            #[target_feature(enable = $feature)]
            #[inline]
            unsafe fn half_neg_mul_add(a: $h, b: $h, c: $h) -> $h {
                $hfnma(a, b, c)
            }
            #[target_feature(enable = $feature)]
            #[inline]
            unsafe fn half_first(h: $h) -> $t {
                $first(h)
            }
            #[target_feature(enable = $feature)]
            #[inline]
            unsafe fn splat_half(h: $h) -> Self {
                $name($splat_half(h))
            }
            #[target_feature(enable = $feature)]
            #[inline]
            unsafe fn half_every_lane_sum(h: $h) -> $h {
                $every_lane_sum(h)
            }
        }
    };
}

eight!(
    F64x8,
    "avx2,fma,avx512f",
    f64,
    __m512d,
    __m256d,
    [
        _mm512_set1_pd,
        _mm512_loadu_pd,
        _mm512_storeu_pd,
        _mm512_add_pd,
        _mm512_sub_pd,
        _mm512_min_pd,
        _mm512_max_pd,
        _mm512_fmadd_pd,
        _mm512_fnmadd_pd
    ],
    [
        _mm256_set1_pd,
        _mm256_setzero_pd,
        _mm256_loadu_pd,
        _mm256_storeu_pd,
        _mm256_add_pd,
        _mm256_sub_pd,
        _mm256_min_pd,
        _mm256_max_pd,
        _mm256_mul_pd,
        _mm256_fmadd_pd,
        _mm256_fnmadd_pd
    ],
    _mm512_castpd512_pd256,
    _mm512_extractf64x4_pd::<1>,
    _mm256_cvtsd_f64,
    broadcast_low_f64,
    all_lanes_sum
);
eight!(
    F32x8,
    "avx2,fma",
    f32,
    __m256,
    __m128,
    [
        _mm256_set1_ps,
        _mm256_loadu_ps,
        _mm256_storeu_ps,
        _mm256_add_ps,
        _mm256_sub_ps,
        _mm256_min_ps,
        _mm256_max_ps,
        _mm256_fmadd_ps,
        _mm256_fnmadd_ps
    ],
    [
        _mm_set1_ps,
        _mm_setzero_ps,
        _mm_loadu_ps,
        _mm_storeu_ps,
        _mm_add_ps,
        _mm_sub_ps,
        _mm_min_ps,
        _mm_max_ps,
        _mm_mul_ps,
        _mm_fmadd_ps,
        _mm_fnmadd_ps
    ],
    _mm256_castps256_ps128,
    _mm256_extractf128_ps::<1>,
    _mm_cvtss_f32,
    _mm256_broadcastss_ps,
    all_lanes_sum_f32
);

/// `hysteresis::step` in 8-lane blocks: the products of lanes 0–3 and
/// then of lanes 4–7 added into the four partial sums, as the portable
/// blocks of four add them; then 4-lane blocks (one; every one with
/// `HALVES`) and the rest one by one. `c4` holds `c` in every lane, and
/// so does the result.
#[inline(always)]
unsafe fn hysteresis_step_eight<E: Eight, const SPLIT: bool, const HALVES: bool>(
    state: &mut [E::T],
    saved: &mut [E::T],
    thresholds: &[E::T],
    weights: &[E::T],
    t: E::T,
    c4: E::Half,
) -> E::Half {
    let n = state.len();
    assert!(thresholds.len() == n && weights.len() == n && saved.len() == n);
    let full4 = n - n % 4;
    let full8 = if HALVES { 0 } else { n - n % 8 };
    // SAFETY (all): the features are the caller's; every block ends at
    // or before n in all three slices.
    unsafe {
        let (t8, t4) = (E::splat(t), E::half_splat(t));
        let c8 = E::splat_half(c4);
        let mut acc = E::half_zero();
        for i0 in (0..full8).step_by(8) {
            let at = state.as_mut_ptr().add(i0);
            let r = E::load(thresholds.as_ptr().add(i0));
            let x = E::load_unsplit::<SPLIT>(at);
            x.store_unsplit::<SPLIT>(saved.as_mut_ptr().add(i0));
            let x = x.min(t8.add(r).sub(c8)).max(t8.sub(r).sub(c8));
            x.store_unsplit::<SPLIT>(at);
            // lanes 0–3, then 4–7, into the four partial sums (from
            // the first product, `real::add_term`)
            let (lo, hi) = x.halves();
            acc = E::half_add_term(acc, E::half_load(weights.as_ptr().add(i0)), lo, i0 == 0);
            acc = E::half_mul_add(E::half_load(weights.as_ptr().add(i0 + 4)), hi, acc);
        }
        for i0 in (full8..full4).step_by(4) {
            let at = state.as_mut_ptr().add(i0);
            let r = E::half_load(thresholds.as_ptr().add(i0));
            let x = E::half_load_unsplit::<SPLIT>(at);
            E::half_store_unsplit::<SPLIT>(x, saved.as_mut_ptr().add(i0));
            let x = E::half_min(x, E::half_sub(E::half_add(t4, r), c4));
            let x = E::half_max(x, E::half_sub(E::half_sub(t4, r), c4));
            E::half_store_unsplit::<SPLIT>(x, at);
            let w = E::half_load(weights.as_ptr().add(i0));
            acc = E::half_add_term(acc, w, x, i0 == 0);
        }
        if full4 == n {
            return E::half_every_lane_sum(acc);
        }
        let mut lanes = [E::T::ZERO; 4];
        E::half_store(acc, lanes.as_mut_ptr());
        let c = E::half_first(c4);
        step_tail::<E::T, true>(state, saved, thresholds, weights, t, c, full4, &mut lanes);
        E::half_splat(reduce(lanes))
    }
}

/// `creep_pass::advance` in 8-lane blocks of thresholds, each block's
/// weighted rows added as two blocks of four; then a 4-lane block and
/// the rest as the portable tail. `v4` holds a finite `v` in every
/// lane, and the result is in every lane.
#[inline(always)]
unsafe fn creep_advance_eight<E: Eight>(
    chi: &mut [E::T],
    thresholds: &[E::T],
    gains: &[E::T],
    weights: &[E::T],
    v4: E::Half,
) -> E::Half {
    let n = thresholds.len();
    assert!(weights.len() == n && chi.len() == n * gains.len());
    let (full8, full4) = (n - n % 8, n - n % LANES);
    let p = chi.as_mut_ptr();
    // SAFETY (all): the features are the caller's; every block ends at
    // or before n in its row of `chi` (n·m) and in the parameter slices.
    unsafe {
        let v8 = E::splat_half(v4);
        let mut acc = E::half_zero();
        for i0 in (0..full8).step_by(8) {
            let r = E::load(thresholds.as_ptr().add(i0));
            let (lower, upper) = (v8.sub(r), v8.add(r));
            macro_rules! update {
                ($at:expr, $g:expr) => {{
                    let (at, g) = ($at, $g);
                    let x = E::load(at);
                    let c = x.min(upper).max(lower);
                    let g = E::splat(g);
                    let x = g.mul_add(c, g.neg_mul_add(x, x));
                    x.store(at);
                    x
                }};
            }
            let mut at = p.add(i0);
            let mut rows = update!(at, gains[0]);
            for &g in &gains[1..] {
                at = at.add(n);
                rows = rows.add(update!(at, g));
            }
            let (lo, hi) = rows.halves();
            acc = E::half_add_term(acc, E::half_load(weights.as_ptr().add(i0)), lo, i0 == 0);
            acc = E::half_mul_add(E::half_load(weights.as_ptr().add(i0 + 4)), hi, acc);
        }
        if full4 > full8 {
            let r = E::half_load(thresholds.as_ptr().add(full8));
            let (lower, upper) = (E::half_sub(v4, r), E::half_add(v4, r));
            macro_rules! update {
                ($at:expr, $g:expr) => {{
                    let (at, g) = ($at, $g);
                    let x = E::half_load(at);
                    let c = E::half_max(E::half_min(x, upper), lower);
                    let g = E::half_splat(g);
                    let x = E::half_mul_add(g, c, E::half_neg_mul_add(g, x, x));
                    E::half_store(x, at);
                    x
                }};
            }
            let mut at = p.add(full8);
            let mut rows = update!(at, gains[0]);
            for &g in &gains[1..] {
                at = at.add(n);
                rows = E::half_add(rows, update!(at, g));
            }
            let w = E::half_load(weights.as_ptr().add(full8));
            acc = E::half_add_term(acc, w, rows, full8 == 0);
        }
        if full4 == n {
            return E::half_every_lane_sum(acc);
        }
        let mut lanes = [E::T::ZERO; LANES];
        E::half_store(acc, lanes.as_mut_ptr());
        let v = E::half_first(v4);
        advance_tail(chi, thresholds, gains, weights, v, full4, &mut lanes);
        E::half_splat(reduce(lanes))
    }
}
