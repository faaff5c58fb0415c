//! The block on 256-bit (two registers) and 512-bit (one) registers.
//! Each type holds an `f64` and an `f32` form; `is_f64::<T>()` is a
//! constant, so only one is ever computed.
use core::arch::x86_64::*;

use super::{is_f64, Avx2Half, Block, Row};
use crate::realtime::real::Real;

/// A block in two 256-bit registers (AVX2).
#[derive(Clone, Copy)]
pub(crate) struct Avx2([__m256d; 2], [__m256; 2]);

macro_rules! avx2_op {
    ($name:ident, $pd:ident, $ps:ident) => {
        #[target_feature(enable = "avx2,fma")]
        #[inline]
        unsafe fn $name(self, b: Self) -> Self {
            if is_f64::<T>() {
                Avx2([$pd(self.0[0], b.0[0]), $pd(self.0[1], b.0[1])], self.1)
            } else {
                Avx2(self.0, [$ps(self.1[0], b.1[0]), $ps(self.1[1], b.1[1])])
            }
        }
    };
}

macro_rules! avx2_op3 {
    ($name:ident, $pd:ident, $ps:ident) => {
        #[target_feature(enable = "avx2,fma")]
        #[inline]
        unsafe fn $name(self, a: Self, b: Self) -> Self {
            if is_f64::<T>() {
                Avx2(
                    [
                        $pd(self.0[0], a.0[0], b.0[0]),
                        $pd(self.0[1], a.0[1], b.0[1]),
                    ],
                    self.1,
                )
            } else {
                Avx2(
                    self.0,
                    [
                        $ps(self.1[0], a.1[0], b.1[0]),
                        $ps(self.1[1], a.1[1], b.1[1]),
                    ],
                )
            }
        }
    };
}

macro_rules! avx2_cmp {
    ($name:ident, $imm:ident) => {
        #[target_feature(enable = "avx2,fma")]
        #[inline]
        unsafe fn $name(self, b: Self) -> Self {
            if is_f64::<T>() {
                Avx2(
                    [
                        _mm256_cmp_pd::<$imm>(self.0[0], b.0[0]),
                        _mm256_cmp_pd::<$imm>(self.0[1], b.0[1]),
                    ],
                    self.1,
                )
            } else {
                Avx2(
                    self.0,
                    [
                        _mm256_cmp_ps::<$imm>(self.1[0], b.1[0]),
                        _mm256_cmp_ps::<$imm>(self.1[1], b.1[1]),
                    ],
                )
            }
        }
    };
}

impl<T: Real> Block<T> for Avx2 {
    /// All ones in a lane for true.
    type Mask = Avx2;
    /// The creep pass's live values (each pair of thresholds' bounds and
    /// rows, the gains, the sums) spilled from sixteen registers where each
    /// took two; on one register each they fit. On a Zen 4, the medians of
    /// five alternations: 6 % more `f64` and 8 % more `f32` channel-steps at
    /// 64 channels, 4 % more of each at 1024.
    const CREEP_IN_HALVES: bool = true;
    type Lo = Avx2Half<0>;
    type Hi = Avx2Half<1>;

    #[inline(always)]
    unsafe fn lo(self) -> Avx2Half<0> {
        Avx2Half(self.0[0], self.1[0])
    }

    #[inline(always)]
    unsafe fn hi(self) -> Avx2Half<1> {
        Avx2Half(self.0[1], self.1[1])
    }

    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn load(row: &Row) -> Self {
        let p = row.0.as_ptr();
        // SAFETY: 64 aligned bytes.
        unsafe {
            if is_f64::<T>() {
                let p = p as *const f64;
                Avx2(
                    [_mm256_load_pd(p), _mm256_load_pd(p.add(4))],
                    [_mm256_setzero_ps(); 2],
                )
            } else {
                let p = p as *const f32;
                Avx2(
                    [_mm256_setzero_pd(); 2],
                    [_mm256_load_ps(p), _mm256_load_ps(p.add(8))],
                )
            }
        }
    }

    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn load_values(values: &[T]) -> Self {
        assert!(values.len() >= super::lanes::<T>());
        let p = values.as_ptr();
        // SAFETY: a block's worth of readable values (asserted).
        unsafe {
            if is_f64::<T>() {
                let p = p as *const f64;
                Avx2(
                    [_mm256_loadu_pd(p), _mm256_loadu_pd(p.add(4))],
                    [_mm256_setzero_ps(); 2],
                )
            } else {
                let p = p as *const f32;
                Avx2(
                    [_mm256_setzero_pd(); 2],
                    [_mm256_loadu_ps(p), _mm256_loadu_ps(p.add(8))],
                )
            }
        }
    }

    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn store(self, row: &mut Row) {
        let p = row.0.as_mut_ptr();
        // SAFETY: 64 aligned bytes, borrowed uniquely.
        unsafe {
            if is_f64::<T>() {
                let p = p as *mut f64;
                _mm256_store_pd(p, self.0[0]);
                _mm256_store_pd(p.add(4), self.0[1]);
            } else {
                let p = p as *mut f32;
                _mm256_store_ps(p, self.1[0]);
                _mm256_store_ps(p.add(8), self.1[1]);
            }
        }
    }

    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn splat(x: T) -> Self {
        Avx2(
            [_mm256_set1_pd(x.to_f64()); 2],
            [_mm256_set1_ps(x.to_f64() as f32); 2],
        )
    }

    avx2_op!(add, _mm256_add_pd, _mm256_add_ps);
    avx2_op!(sub, _mm256_sub_pd, _mm256_sub_ps);
    avx2_op!(min, _mm256_min_pd, _mm256_min_ps);
    avx2_op!(max, _mm256_max_pd, _mm256_max_ps);
    avx2_op!(mul, _mm256_mul_pd, _mm256_mul_ps);
    avx2_op3!(mul_add, _mm256_fmadd_pd, _mm256_fmadd_ps);
    avx2_op3!(neg_mul_add, _mm256_fnmadd_pd, _mm256_fnmadd_ps);
    avx2_cmp!(lt, _CMP_LT_OQ);
    avx2_cmp!(gt, _CMP_GT_OQ);

    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn non_finite(self) -> Self {
        // x − x is 0 for a finite x and NaN otherwise
        // SAFETY: AVX2 by the caller's contract.
        unsafe {
            let d = <Self as Block<T>>::sub(self, self);
            let z = Avx2([_mm256_setzero_pd(); 2], [_mm256_setzero_ps(); 2]);
            if is_f64::<T>() {
                Avx2(
                    [
                        _mm256_cmp_pd::<_CMP_NEQ_UQ>(d.0[0], z.0[0]),
                        _mm256_cmp_pd::<_CMP_NEQ_UQ>(d.0[1], z.0[1]),
                    ],
                    d.1,
                )
            } else {
                Avx2(
                    d.0,
                    [
                        _mm256_cmp_ps::<_CMP_NEQ_UQ>(d.1[0], z.1[0]),
                        _mm256_cmp_ps::<_CMP_NEQ_UQ>(d.1[1], z.1[1]),
                    ],
                )
            }
        }
    }

    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn select(m: Self, a: Self, b: Self) -> Self {
        if is_f64::<T>() {
            Avx2(
                [
                    _mm256_blendv_pd(b.0[0], a.0[0], m.0[0]),
                    _mm256_blendv_pd(b.0[1], a.0[1], m.0[1]),
                ],
                a.1,
            )
        } else {
            Avx2(
                a.0,
                [
                    _mm256_blendv_ps(b.1[0], a.1[0], m.1[0]),
                    _mm256_blendv_ps(b.1[1], a.1[1], m.1[1]),
                ],
            )
        }
    }

    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn or(a: Self, b: Self) -> Self {
        Avx2(
            [_mm256_or_pd(a.0[0], b.0[0]), _mm256_or_pd(a.0[1], b.0[1])],
            [_mm256_or_ps(a.1[0], b.1[0]), _mm256_or_ps(a.1[1], b.1[1])],
        )
    }

    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn and_not(a: Self, b: Self) -> Self {
        // andnot(x, y) is !x & y
        Avx2(
            [
                _mm256_andnot_pd(b.0[0], a.0[0]),
                _mm256_andnot_pd(b.0[1], a.0[1]),
            ],
            [
                _mm256_andnot_ps(b.1[0], a.1[0]),
                _mm256_andnot_ps(b.1[1], a.1[1]),
            ],
        )
    }

    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn bits(m: Self) -> u32 {
        if is_f64::<T>() {
            (_mm256_movemask_pd(m.0[0]) | _mm256_movemask_pd(m.0[1]) << 4) as u32
        } else {
            (_mm256_movemask_ps(m.1[0]) | _mm256_movemask_ps(m.1[1]) << 8) as u32
        }
    }

    /// The row's old lanes pass through an empty `asm!` before the
    /// select. Seeing a row's own lanes selected and stored back to it, the
    /// compiler made two masked stores (`vmaskmovpd`) of it: AMD's cores
    /// run them as microcode, which holds up the front end. Without them
    /// the bank made 3–6 % more `f64` and 8–9 % more `f32` channel-steps on
    /// a Zen 4.
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn store_except(self, m: Self, row: &mut Row) -> Self {
        // SAFETY: AVX2 by the caller's contract.
        unsafe {
            let old = <Self as Block<T>>::load(row);
            let old = if is_f64::<T>() {
                Avx2(old.0.map(|r| unseen_pd(r)), old.1)
            } else {
                Avx2(old.0, old.1.map(|r| unseen_ps(r)))
            };
            let v = <Self as Block<T>>::select(m, old, self);
            <Self as Block<T>>::store(v, row);
            v
        }
    }

    /// Each register's values and flag words (`a`'s all-ones lanes
    /// masked to 1, `b`'s to 256) interleaved by unpacks within the
    /// 128-bit halves and two half swaps, four 32-byte stores per
    /// register.
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn store_flagged(self, a: Self, b: Self, out: *mut T) -> bool {
        // SAFETY: the caller's: 128 writable bytes at `out`.
        unsafe {
            if is_f64::<T>() {
                let (one, two56) = (_mm256_set1_epi64x(1), _mm256_set1_epi64x(1 << 8));
                let p = out as *mut f64;
                for h in 0..2 {
                    let flags = _mm256_or_si256(
                        _mm256_and_si256(_mm256_castpd_si256(a.0[h]), one),
                        _mm256_and_si256(_mm256_castpd_si256(b.0[h]), two56),
                    );
                    let flags = _mm256_castsi256_pd(flags);
                    // [u0 f0 u2 f2], [u1 f1 u3 f3]
                    let lo = _mm256_unpacklo_pd(self.0[h], flags);
                    let hi = _mm256_unpackhi_pd(self.0[h], flags);
                    _mm256_storeu_pd(p.add(8 * h), _mm256_permute2f128_pd::<0x20>(lo, hi));
                    _mm256_storeu_pd(p.add(8 * h + 4), _mm256_permute2f128_pd::<0x31>(lo, hi));
                }
            } else {
                let (one, two56) = (_mm256_set1_epi32(1), _mm256_set1_epi32(1 << 8));
                let p = out as *mut f32;
                for h in 0..2 {
                    let flags = _mm256_or_si256(
                        _mm256_and_si256(_mm256_castps_si256(a.1[h]), one),
                        _mm256_and_si256(_mm256_castps_si256(b.1[h]), two56),
                    );
                    let flags = _mm256_castsi256_ps(flags);
                    // [u0 f0 u1 f1 | u4 f4 u5 f5], [u2 f2 u3 f3 | u6 f6 u7 f7]
                    let lo = _mm256_unpacklo_ps(self.1[h], flags);
                    let hi = _mm256_unpackhi_ps(self.1[h], flags);
                    _mm256_storeu_ps(p.add(16 * h), _mm256_permute2f128_ps::<0x20>(lo, hi));
                    _mm256_storeu_ps(p.add(16 * h + 8), _mm256_permute2f128_ps::<0x31>(lo, hi));
                }
            }
        }
        true
    }
}

/// `x`, through an empty `asm!` the compiler cannot see into.
#[target_feature(enable = "avx2,fma")]
#[inline]
fn unseen_pd(mut x: __m256d) -> __m256d {
    // SAFETY: an empty template; `x` stays in its register.
    unsafe {
        core::arch::asm!("/* {0} */", inout(ymm_reg) x, options(pure, nomem, nostack, preserves_flags));
    }
    x
}

/// [`unseen_pd`] of eight `f32`.
#[target_feature(enable = "avx2,fma")]
#[inline]
fn unseen_ps(mut x: __m256) -> __m256 {
    // SAFETY: as in `unseen_pd`.
    unsafe {
        core::arch::asm!("/* {0} */", inout(ymm_reg) x, options(pure, nomem, nostack, preserves_flags));
    }
    x
}

/// A block in one 512-bit register (AVX-512F); masks in mask registers.
#[derive(Clone, Copy)]
pub(crate) struct Avx512(__m512d, __m512);

macro_rules! avx512_op {
    ($name:ident, $pd:ident, $ps:ident) => {
        #[target_feature(enable = "avx2,fma,avx512f")]
        #[inline]
        unsafe fn $name(self, b: Self) -> Self {
            if is_f64::<T>() {
                Avx512($pd(self.0, b.0), self.1)
            } else {
                Avx512(self.0, $ps(self.1, b.1))
            }
        }
    };
}

macro_rules! avx512_op3 {
    ($name:ident, $pd:ident, $ps:ident) => {
        #[target_feature(enable = "avx2,fma,avx512f")]
        #[inline]
        unsafe fn $name(self, a: Self, b: Self) -> Self {
            if is_f64::<T>() {
                Avx512($pd(self.0, a.0, b.0), self.1)
            } else {
                Avx512(self.0, $ps(self.1, a.1, b.1))
            }
        }
    };
}

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

    avx512_op!(add, _mm512_add_pd, _mm512_add_ps);

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

    avx512_op!(sub, _mm512_sub_pd, _mm512_sub_ps);
    avx512_op!(min, _mm512_min_pd, _mm512_min_ps);
    avx512_op!(max, _mm512_max_pd, _mm512_max_ps);
    avx512_op!(mul, _mm512_mul_pd, _mm512_mul_ps);
    avx512_op3!(mul_add, _mm512_fmadd_pd, _mm512_fmadd_ps);
    avx512_op3!(neg_mul_add, _mm512_fnmadd_pd, _mm512_fnmadd_ps);
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
