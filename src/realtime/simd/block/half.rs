//! Half a 256-bit block: one of its two registers (AVX2), for the creep
//! pass, whose live values then fit in sixteen registers.
use core::arch::x86_64::*;

use super::{is_f64, Block, Row};
use crate::realtime::real::Real;

/// Half `H` (0: lanes 0–3 `f64` or 0–7 `f32`, 1: the rest) of a block in
/// one 256-bit register.
#[derive(Clone, Copy)]
pub(crate) struct Avx2Half<const H: usize>(pub(super) __m256d, pub(super) __m256);

macro_rules! half_op {
    ($name:ident, $pd:ident, $ps:ident) => {
        #[target_feature(enable = "avx2,fma")]
        #[inline]
        unsafe fn $name(self, b: Self) -> Self {
            if is_f64::<T>() {
                Avx2Half($pd(self.0, b.0), self.1)
            } else {
                Avx2Half(self.0, $ps(self.1, b.1))
            }
        }
    };
}

macro_rules! half_op3 {
    ($name:ident, $pd:ident, $ps:ident) => {
        #[target_feature(enable = "avx2,fma")]
        #[inline]
        unsafe fn $name(self, a: Self, b: Self) -> Self {
            if is_f64::<T>() {
                Avx2Half($pd(self.0, a.0, b.0), self.1)
            } else {
                Avx2Half(self.0, $ps(self.1, a.1, b.1))
            }
        }
    };
}

macro_rules! half_cmp {
    ($name:ident, $imm:ident) => {
        #[target_feature(enable = "avx2,fma")]
        #[inline]
        unsafe fn $name(self, b: Self) -> Self {
            if is_f64::<T>() {
                Avx2Half(_mm256_cmp_pd::<$imm>(self.0, b.0), self.1)
            } else {
                Avx2Half(self.0, _mm256_cmp_ps::<$imm>(self.1, b.1))
            }
        }
    };
}

impl<T: Real, const H: usize> Block<T> for Avx2Half<H> {
    type Mask = Self;
    /// On a Zen 4, 64 channels, halves four thresholds at a time made 4 %
    /// fewer `f64` channel-steps than the whole blocks' paired pass, and
    /// halves in pairs 6 % more.
    const PAIRED_CREEP: bool = true;
    type Lo = Self;
    type Hi = Self;

    #[inline(always)]
    unsafe fn lo(self) -> Self {
        self
    }

    #[inline(always)]
    unsafe fn hi(self) -> Self {
        self
    }

    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn load(row: &Row) -> Self {
        // SAFETY: 32 aligned bytes at 32 H in a 64-byte row.
        unsafe {
            let p = row.0.as_ptr().cast::<u8>().add(32 * H);
            if is_f64::<T>() {
                Avx2Half(_mm256_load_pd(p.cast()), _mm256_setzero_ps())
            } else {
                Avx2Half(_mm256_setzero_pd(), _mm256_load_ps(p.cast()))
            }
        }
    }

    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn load_values(values: &[T]) -> Self {
        assert!(values.len() >= super::lanes::<T>());
        // SAFETY: a block's worth of readable values (asserted).
        unsafe {
            let p = values.as_ptr().cast::<u8>().add(32 * H);
            if is_f64::<T>() {
                Avx2Half(_mm256_loadu_pd(p.cast()), _mm256_setzero_ps())
            } else {
                Avx2Half(_mm256_setzero_pd(), _mm256_loadu_ps(p.cast()))
            }
        }
    }

    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn store(self, row: &mut Row) {
        // SAFETY: 32 aligned bytes at 32 H, borrowed uniquely.
        unsafe {
            let p = row.0.as_mut_ptr().cast::<u8>().add(32 * H);
            if is_f64::<T>() {
                _mm256_store_pd(p.cast(), self.0);
            } else {
                _mm256_store_ps(p.cast(), self.1);
            }
        }
    }

    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn splat(x: T) -> Self {
        Avx2Half(
            _mm256_set1_pd(x.to_f64()),
            _mm256_set1_ps(x.to_f64() as f32),
        )
    }

    half_op!(add, _mm256_add_pd, _mm256_add_ps);
    half_op!(sub, _mm256_sub_pd, _mm256_sub_ps);
    half_op!(min, _mm256_min_pd, _mm256_min_ps);
    half_op!(max, _mm256_max_pd, _mm256_max_ps);
    half_op!(mul, _mm256_mul_pd, _mm256_mul_ps);
    half_op3!(mul_add, _mm256_fmadd_pd, _mm256_fmadd_ps);
    half_op3!(neg_mul_add, _mm256_fnmadd_pd, _mm256_fnmadd_ps);
    half_cmp!(lt, _CMP_LT_OQ);
    half_cmp!(gt, _CMP_GT_OQ);

    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn non_finite(self) -> Self {
        // x − x is 0 for a finite x and NaN otherwise
        if is_f64::<T>() {
            let d = _mm256_sub_pd(self.0, self.0);
            Avx2Half(_mm256_cmp_pd::<_CMP_NEQ_UQ>(d, _mm256_setzero_pd()), self.1)
        } else {
            let d = _mm256_sub_ps(self.1, self.1);
            Avx2Half(self.0, _mm256_cmp_ps::<_CMP_NEQ_UQ>(d, _mm256_setzero_ps()))
        }
    }

    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn select(m: Self, a: Self, b: Self) -> Self {
        if is_f64::<T>() {
            Avx2Half(_mm256_blendv_pd(b.0, a.0, m.0), a.1)
        } else {
            Avx2Half(a.0, _mm256_blendv_ps(b.1, a.1, m.1))
        }
    }

    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn or(a: Self, b: Self) -> Self {
        Avx2Half(_mm256_or_pd(a.0, b.0), _mm256_or_ps(a.1, b.1))
    }

    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn and_not(a: Self, b: Self) -> Self {
        Avx2Half(_mm256_andnot_pd(b.0, a.0), _mm256_andnot_ps(b.1, a.1))
    }

    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn bits(m: Self) -> u32 {
        // the lanes of half H of the block
        if is_f64::<T>() {
            (_mm256_movemask_pd(m.0) as u32) << (4 * H)
        } else {
            (_mm256_movemask_ps(m.1) as u32) << (8 * H)
        }
    }
}
