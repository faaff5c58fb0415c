//! The block on 512-bit registers (AVX-512F): one register, masks in mask
//! registers. It holds an `f64` and an `f32` form; `is_f64::<T>()` is a
//! constant, so only one is ever computed.
use core::arch::x86_64::*;

use super::{is_f64, Block, Row};
use crate::realtime::real::Real;

/// A block in one 512-bit register (AVX-512F); masks in mask registers.
#[derive(Clone, Copy)]
pub(crate) struct Avx512(__m512d, __m512);

macro_rules! avx512_cmp {
    ($name:ident, $imm:ident) => {
        #[target_feature(enable = "avx2,fma,avx512f")]
        #[inline]
        unsafe fn $name(self, b: Self) -> u16 {
            if is_f64::<T>() {
                u16::from(_mm512_cmp_pd_mask::<$imm>(self.0, b.0))
            } else {
                _mm512_cmp_ps_mask::<$imm>(self.1, b.1)
            }
        }
    };
}

impl<T: Real> Block<T> for Avx512 {
    /// Bit `l` for lane `l`.
    type Mask = u16;
    super::whole_block_halves!();

    #[target_feature(enable = "avx2,fma,avx512f")]
    #[inline]
    unsafe fn load(row: &Row) -> Self {
        let p = row.0.as_ptr();
        // SAFETY: 64 aligned bytes.
        unsafe {
            if is_f64::<T>() {
                Avx512(_mm512_load_pd(p as *const f64), _mm512_setzero_ps())
            } else {
                Avx512(_mm512_setzero_pd(), _mm512_load_ps(p as *const f32))
            }
        }
    }

    #[target_feature(enable = "avx2,fma,avx512f")]
    #[inline]
    unsafe fn load_first(values: &[T]) -> Self {
        let n = values.len();
        assert!(n <= super::lanes::<T>());
        // lanes 0..n: the masked lanes are not read
        let mask = (1u32 << n) - 1;
        let p = values.as_ptr();
        // SAFETY: the `n` lanes read are `values`.
        unsafe {
            if is_f64::<T>() {
                let v = _mm512_maskz_loadu_pd(mask as __mmask8, p as *const f64);
                Avx512(v, _mm512_setzero_ps())
            } else {
                let v = _mm512_maskz_loadu_ps(mask as __mmask16, p as *const f32);
                Avx512(_mm512_setzero_pd(), v)
            }
        }
    }

    #[target_feature(enable = "avx2,fma,avx512f")]
    #[inline]
    unsafe fn load_values(values: &[T]) -> Self {
        assert!(values.len() >= super::lanes::<T>());
        let p = values.as_ptr();
        // SAFETY: a block's worth of readable values (asserted).
        unsafe {
            if is_f64::<T>() {
                Avx512(_mm512_loadu_pd(p as *const f64), _mm512_setzero_ps())
            } else {
                Avx512(_mm512_setzero_pd(), _mm512_loadu_ps(p as *const f32))
            }
        }
    }

    #[target_feature(enable = "avx2,fma,avx512f")]
    #[inline]
    unsafe fn store(self, row: &mut Row) {
        let p = row.0.as_mut_ptr();
        // SAFETY: 64 aligned bytes, borrowed uniquely.
        unsafe {
            if is_f64::<T>() {
                _mm512_store_pd(p as *mut f64, self.0)
            } else {
                _mm512_store_ps(p as *mut f32, self.1)
            }
        }
    }

    #[target_feature(enable = "avx2,fma,avx512f")]
    #[inline]
    unsafe fn splat(x: T) -> Self {
        Avx512(
            _mm512_set1_pd(x.to_f64()),
            _mm512_set1_ps(x.to_f64() as f32),
        )
    }

    super::one_register_op!(
        Avx512,
        "avx2,fma,avx512f",
        add,
        _mm512_add_pd,
        _mm512_add_ps
    );

    #[target_feature(enable = "avx2,fma,avx512f")]
    #[inline]
    unsafe fn add_on_multiplier(self, b: Self, one: Self) -> Self {
        if is_f64::<T>() {
            Avx512(_mm512_fmadd_pd(b.0, one.0, self.0), self.1)
        } else {
            Avx512(self.0, _mm512_fmadd_ps(b.1, one.1, self.1))
        }
    }

    #[target_feature(enable = "avx2,fma,avx512f")]
    #[inline]
    unsafe fn sub_on_multiplier(self, b: Self, one: Self) -> Self {
        if is_f64::<T>() {
            Avx512(_mm512_fnmadd_pd(b.0, one.0, self.0), self.1)
        } else {
            Avx512(self.0, _mm512_fnmadd_ps(b.1, one.1, self.1))
        }
    }

    super::one_register_op!(
        Avx512,
        "avx2,fma,avx512f",
        sub,
        _mm512_sub_pd,
        _mm512_sub_ps
    );
    super::one_register_op!(
        Avx512,
        "avx2,fma,avx512f",
        min,
        _mm512_min_pd,
        _mm512_min_ps
    );
    super::one_register_op!(
        Avx512,
        "avx2,fma,avx512f",
        max,
        _mm512_max_pd,
        _mm512_max_ps
    );
    super::one_register_op!(
        Avx512,
        "avx2,fma,avx512f",
        mul,
        _mm512_mul_pd,
        _mm512_mul_ps
    );
    super::one_register_op3!(
        Avx512,
        "avx2,fma,avx512f",
        mul_add,
        _mm512_fmadd_pd,
        _mm512_fmadd_ps
    );
    super::one_register_op3!(
        Avx512,
        "avx2,fma,avx512f",
        neg_mul_add,
        _mm512_fnmadd_pd,
        _mm512_fnmadd_ps
    );
    avx512_cmp!(lt, _CMP_LT_OQ);
    avx512_cmp!(gt, _CMP_GT_OQ);

    #[target_feature(enable = "avx2,fma,avx512f")]
    #[inline]
    unsafe fn non_finite(self) -> u16 {
        // x − x is 0 for a finite x and NaN otherwise
        if is_f64::<T>() {
            let d = _mm512_sub_pd(self.0, self.0);
            u16::from(_mm512_cmp_pd_mask::<_CMP_NEQ_UQ>(d, _mm512_setzero_pd()))
        } else {
            let d = _mm512_sub_ps(self.1, self.1);
            _mm512_cmp_ps_mask::<_CMP_NEQ_UQ>(d, _mm512_setzero_ps())
        }
    }

    #[target_feature(enable = "avx2,fma,avx512f")]
    #[inline]
    unsafe fn select(m: u16, a: Self, b: Self) -> Self {
        // mask_blend takes the second vector where the mask is set
        if is_f64::<T>() {
            Avx512(_mm512_mask_blend_pd(m as u8, b.0, a.0), a.1)
        } else {
            Avx512(a.0, _mm512_mask_blend_ps(m, b.1, a.1))
        }
    }

    #[inline(always)]
    unsafe fn or(a: u16, b: u16) -> u16 {
        a | b
    }

    #[inline(always)]
    unsafe fn and_not(a: u16, b: u16) -> u16 {
        a & !b
    }

    #[inline(always)]
    unsafe fn bits(m: u16) -> u32 {
        u32::from(m)
    }

    /// The values and a flag word per lane (`a` in its first byte, `b`
    /// in its second) interleaved by two two-source permutes, two
    /// 64-byte stores (lane by lane it was 6 % of the bank's `f64`
    /// time and 11 % of its `f32` time).
    #[target_feature(enable = "avx2,fma,avx512f")]
    #[inline]
    unsafe fn store_flagged(self, a: u16, b: u16, out: *mut T) -> bool {
        // SAFETY: the caller's: 128 writable bytes at `out`.
        unsafe {
            if is_f64::<T>() {
                let (a, b) = (a as u8, b as u8);
                let flags = _mm512_or_si512(
                    _mm512_maskz_set1_epi64(a, 1),
                    _mm512_maskz_set1_epi64(b, 1 << 8),
                );
                let flags = _mm512_castsi512_pd(flags);
                let first = _mm512_setr_epi64(0, 8, 1, 9, 2, 10, 3, 11);
                let second = _mm512_setr_epi64(4, 12, 5, 13, 6, 14, 7, 15);
                let p = out as *mut f64;
                _mm512_storeu_pd(p, _mm512_permutex2var_pd(self.0, first, flags));
                _mm512_storeu_pd(p.add(8), _mm512_permutex2var_pd(self.0, second, flags));
            } else {
                let flags = _mm512_or_si512(
                    _mm512_maskz_set1_epi32(a, 1),
                    _mm512_maskz_set1_epi32(b, 1 << 8),
                );
                let flags = _mm512_castsi512_ps(flags);
                let first =
                    _mm512_setr_epi32(0, 16, 1, 17, 2, 18, 3, 19, 4, 20, 5, 21, 6, 22, 7, 23);
                let second =
                    _mm512_setr_epi32(8, 24, 9, 25, 10, 26, 11, 27, 12, 28, 13, 29, 14, 30, 15, 31);
                let p = out as *mut f32;
                _mm512_storeu_ps(p, _mm512_permutex2var_ps(self.1, first, flags));
                _mm512_storeu_ps(p.add(16), _mm512_permutex2var_ps(self.1, second, flags));
            }
        }
        true
    }
}
