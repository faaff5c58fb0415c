//! The `f64` kernels on 4-lane registers (the AVX2 set's): `H⁻¹`'s plays
//! and the creep pass in blocks of four, each sum ended in a butterfly
//! that leaves it in every lane.
use core::arch::x86_64::*;

use super::{array_straddles, debug_assert_placed, read_each, straddles_page, write_each};
use crate::realtime::creep_pass::{advance_tail, LANES};
use crate::realtime::hysteresis::{reduce, step_tail};

/// `hysteresis::reduce` of `a`'s four lanes, in every lane: a butterfly.
/// Lane 0 adds `(a₀ + a₂) + (a₁ + a₃)` as `reduce` does; the other
/// lanes add the same pairs with their operands swapped, which leaves
/// an IEEE sum as it is. The swap of the halves is `vperm2f128`,
/// written out: LLVM emits `_mm256_permute2f128_pd(a, a, 1)` as
/// `vpermpd`, a cycle slower on some cores.
#[target_feature(enable = "avx2,fma")]
#[inline]
pub(super) fn all_lanes_sum(a: __m256d) -> __m256d {
    let swapped: __m256d;
    // SAFETY: AVX is enabled here; the instruction reads and writes
    // registers only.
    unsafe {
        core::arch::asm!(
            "vperm2f128 {swapped}, {a}, {a}, 1",
            a = in(ymm_reg) a,
            swapped = lateout(ymm_reg) swapped,
            options(pure, nomem, nostack, preserves_flags)
        );
    }
    // [a₀ + a₂, a₁ + a₃, a₂ + a₀, a₃ + a₁], then each lane and its
    // neighbour
    let t = _mm256_add_pd(a, swapped);
    _mm256_add_pd(t, _mm256_permute_pd::<0b0101>(t))
}

/// `real::add_term` on four lanes: `w · x` for a sum's first term,
/// fused with `acc` after it (callers compiled with AVX2).
#[inline(always)]
unsafe fn add_term4(acc: __m256d, w: __m256d, x: __m256d, first: bool) -> __m256d {
    // SAFETY (both): the caller's AVX2 and FMA.
    if first {
        unsafe { _mm256_mul_pd(w, x) }
    } else {
        unsafe { _mm256_fmadd_pd(w, x, acc) }
    }
}

/// The blocks of `hysteresis::step_saving` for `f64` on 4-lane
/// registers (callers compiled with AVX2); `cc` holds `c` in every
/// lane, `t − c` is finite, and the result is in every lane.
#[inline(always)]
unsafe fn hysteresis_step_four<const SPLIT: bool>(
    state: &mut [f64],
    saved: &mut [f64],
    thresholds: &[f64],
    weights: &[f64],
    t: f64,
    cc: __m256d,
) -> __m256d {
    let n = state.len();
    assert!(thresholds.len() == n && weights.len() == n && saved.len() == n);
    let full = n - n % 4;
    // SAFETY: the caller's AVX2.
    let (tt, mut acc) = unsafe { (_mm256_set1_pd(t), _mm256_setzero_pd()) };
    for i0 in (0..full).step_by(4) {
        // SAFETY: i0 + 4 ≤ n for all three slices.
        unsafe {
            let at = state.as_mut_ptr().add(i0);
            let r = _mm256_loadu_pd(thresholds.as_ptr().add(i0));
            let x = load4_unsplit::<SPLIT>(at);
            store4_unsplit::<SPLIT>(saved.as_mut_ptr().add(i0), x);
            // (t ± r) − c: `t + r` and `t − r` wait only for `t`
            let upper = _mm256_sub_pd(_mm256_add_pd(tt, r), cc);
            let lower = _mm256_sub_pd(_mm256_sub_pd(tt, r), cc);
            let x = _mm256_max_pd(_mm256_min_pd(x, upper), lower);
            store4_unsplit::<SPLIT>(at, x);
            let w = _mm256_loadu_pd(weights.as_ptr().add(i0));
            acc = add_term4(acc, w, x, i0 == 0);
        }
    }
    // SAFETY (all three): the caller's AVX2.
    if full == n {
        return unsafe { all_lanes_sum(acc) };
    }
    let mut lanes = [0.0f64; 4];
    unsafe { _mm256_storeu_pd(lanes.as_mut_ptr(), acc) };
    let c = unsafe { _mm256_cvtsd_f64(cc) };
    step_tail::<f64, true>(state, saved, thresholds, weights, t, c, full, &mut lanes);
    unsafe { _mm256_set1_pd(reduce(lanes)) }
}

/// The blocks of `creep_pass::advance` for `f64` on 4-lane registers
/// (callers compiled with AVX2); `vv` holds a finite `v` in every lane,
/// and the result is in every lane.
#[inline(always)]
unsafe fn creep_advance_four(
    chi: &mut [f64],
    thresholds: &[f64],
    gains: &[f64],
    weights: &[f64],
    vv: __m256d,
) -> __m256d {
    let n = thresholds.len();
    let m = gains.len();
    assert!(weights.len() == n && chi.len() == n * m);
    let full = n - n % LANES;
    // SAFETY: the caller's AVX2.
    let mut acc = unsafe { _mm256_setzero_pd() };
    let p = chi.as_mut_ptr();
    for i0 in (0..full).step_by(LANES) {
        // SAFETY (all pointer accesses): i0 + 4 ≤ n and j < m, so every
        // block lies inside `chi` (n·m) and the parameter slices (n).
        unsafe {
            let r = _mm256_loadu_pd(thresholds.as_ptr().add(i0));
            let lower = _mm256_sub_pd(vv, r);
            let upper = _mm256_add_pd(vv, r);
            macro_rules! update {
                ($at:expr, $g:expr) => {{
                    let (at, g) = ($at, $g);
                    let x = _mm256_loadu_pd(at);
                    let c = _mm256_max_pd(_mm256_min_pd(x, upper), lower);
                    // `creep_pass::update`: g c + (x − g x)
                    let g = _mm256_set1_pd(g);
                    let x = _mm256_fmadd_pd(g, c, _mm256_fnmadd_pd(g, x, x));
                    _mm256_storeu_pd(at, x);
                    x
                }};
            }
            // from the first row, not from zero (see `creep_pass::advance`);
            // row `j` of the block lies `n` values after row `j − 1`
            let mut at = p.add(i0);
            let mut rows = update!(at, gains[0]);
            for &g in &gains[1..] {
                at = at.add(n);
                rows = _mm256_add_pd(rows, update!(at, g));
            }
            let w = _mm256_loadu_pd(weights.as_ptr().add(i0));
            acc = add_term4(acc, w, rows, i0 == 0);
        }
    }
    // SAFETY (all three): the caller's AVX2.
    if full == n {
        return unsafe { all_lanes_sum(acc) };
    }
    let mut lanes = [0.0f64; LANES];
    unsafe { _mm256_storeu_pd(lanes.as_mut_ptr(), acc) };
    let v = unsafe { _mm256_cvtsd_f64(vv) };
    advance_tail(chi, thresholds, gains, weights, v, full, &mut lanes);
    unsafe { _mm256_set1_pd(reduce(lanes)) }
}

/// [`hysteresis_step_four`], its states checked for straddles only if
/// an array can straddle.
#[inline(always)]
pub(super) unsafe fn hysteresis_four(
    state: &mut [f64],
    saved: &mut [f64],
    thresholds: &[f64],
    weights: &[f64],
    t: f64,
    c: __m256d,
) -> __m256d {
    // SAFETY (both): the caller's.
    if array_straddles(state) || array_straddles(saved) {
        unsafe { hysteresis_step_four::<true>(state, saved, thresholds, weights, t, c) }
    } else {
        unsafe { hysteresis_step_four::<false>(state, saved, thresholds, weights, t, c) }
    }
}

/// [`creep_advance_four`] on a placed `χ` (checked with debug
/// assertions).
#[inline(always)]
pub(super) unsafe fn creep_four(
    chi: &mut [f64],
    thresholds: &[f64],
    gains: &[f64],
    weights: &[f64],
    v: __m256d,
) -> __m256d {
    debug_assert_placed(chi, thresholds.len());
    // SAFETY: the caller's.
    unsafe { creep_advance_four(chi, thresholds, gains, weights, v) }
}

/// `_mm256_loadu_pd`, one value at a time where the four straddle a
/// page (see [`super`]'s note).
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn load4_unsplit<const SPLIT: bool>(p: *const f64) -> __m256d {
    // SAFETY: the caller's `p..p + 4` is readable.
    unsafe {
        if SPLIT && straddles_page(p, 32) {
            _mm256_loadu_pd(read_each::<f64, 4>(p).as_ptr())
        } else {
            _mm256_loadu_pd(p)
        }
    }
}

/// `_mm256_storeu_pd`, one value at a time where the four straddle a
/// page.
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn store4_unsplit<const SPLIT: bool>(p: *mut f64, x: __m256d) {
    // SAFETY: the caller's `p..p + 4` is writable.
    unsafe {
        if SPLIT && straddles_page(p, 32) {
            let mut a = [0.0f64; 4];
            _mm256_storeu_pd(a.as_mut_ptr(), x);
            write_each(p, &a);
        } else {
            _mm256_storeu_pd(p, x);
        }
    }
}
