//! The block on 256-bit registers (AVX2): two halves, each one register
//! ([`Avx2Half`]), every operation done on each. The bank's creep pass runs
//! on the halves one after the other ([`Block::CREEP_IN_HALVES`]). Each
//! half holds an `f64` and an `f32` form; `is_f64::<T>()` is a constant,
//! so only one is ever computed.
use core::arch::x86_64::*;

use super::{is_f64, lanes, Block, Row};
use crate::realtime::real::Real;

/// Half `H` of a block in one 256-bit register: lanes 0–3 (`f64`) or 0–7
/// (`f32`) for `H = 0`, the rest for `H = 1`. It loads and stores its half
/// of a row.
#[derive(Clone, Copy)]
pub(crate) struct Avx2Half<const H: usize>(__m256d, __m256);

/// The mask of a register's first `k` `f64` lanes: the 32 bytes from
/// element `4 − k`.
const FIRST_OF_64: [i64; 8] = [-1, -1, -1, -1, 0, 0, 0, 0];
/// The mask of a register's first `k` `f32` lanes: the 32 bytes from
/// element `8 − k`.
const FIRST_OF_32: [i32; 16] = [-1, -1, -1, -1, -1, -1, -1, -1, 0, 0, 0, 0, 0, 0, 0, 0];

impl<const H: usize> Avx2Half<H> {
    /// The offset of the half in a row, in bytes.
    const OFFSET: usize = 32 * H;
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
    /// All ones in a lane for true.
    type Mask = Self;
    /// Halves in pairs: four thresholds at a time spill on sixteen
    /// registers.
    const PAIRED_CREEP: bool = true;
    super::whole_block_halves!();

    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn load(row: &Row) -> Self {
        // SAFETY: 32 aligned bytes at `OFFSET` in a 64-byte row.
        unsafe {
            let p = row.0.as_ptr().cast::<u8>().add(Self::OFFSET);
            if is_f64::<T>() {
                Avx2Half(_mm256_load_pd(p.cast()), _mm256_setzero_ps())
            } else {
                Avx2Half(_mm256_setzero_pd(), _mm256_load_ps(p.cast()))
            }
        }
    }

    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn load_first(values: &[T]) -> Self {
        assert!(values.len() <= lanes::<T>());
        // this half's lanes of `values`: a mask of the first `k` of its own
        let half = lanes::<T>() / 2;
        let k = values.len().saturating_sub(H * half).min(half);
        if k == 0 {
            // SAFETY: no memory read.
            return unsafe { Block::<T>::splat(T::ZERO) };
        }
        // SAFETY: lane `H * half` is in `values` (k > 0); of the lanes from
        // it the masked load reads the first `k`, which are too.
        unsafe {
            let p = values.as_ptr().add(H * half);
            if is_f64::<T>() {
                let mask = _mm256_loadu_si256(FIRST_OF_64[4 - k..].as_ptr().cast());
                Avx2Half(_mm256_maskload_pd(p.cast(), mask), _mm256_setzero_ps())
            } else {
                let mask = _mm256_loadu_si256(FIRST_OF_32[8 - k..].as_ptr().cast());
                Avx2Half(_mm256_setzero_pd(), _mm256_maskload_ps(p.cast(), mask))
            }
        }
    }

    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn load_values(values: &[T]) -> Self {
        assert!(values.len() >= lanes::<T>());
        // SAFETY: a block's worth of readable values (asserted).
        unsafe {
            let p = values.as_ptr().cast::<u8>().add(Self::OFFSET);
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
        // SAFETY: 32 aligned bytes at `OFFSET`, borrowed uniquely.
        unsafe {
            let p = row.0.as_mut_ptr().cast::<u8>().add(Self::OFFSET);
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

    super::one_register_op!(Avx2Half, "avx2,fma", add, _mm256_add_pd, _mm256_add_ps);
    super::one_register_op!(Avx2Half, "avx2,fma", sub, _mm256_sub_pd, _mm256_sub_ps);
    super::one_register_op!(Avx2Half, "avx2,fma", min, _mm256_min_pd, _mm256_min_ps);
    super::one_register_op!(Avx2Half, "avx2,fma", max, _mm256_max_pd, _mm256_max_ps);
    super::one_register_op!(Avx2Half, "avx2,fma", mul, _mm256_mul_pd, _mm256_mul_ps);
    super::one_register_op3!(
        Avx2Half,
        "avx2,fma",
        mul_add,
        _mm256_fmadd_pd,
        _mm256_fmadd_ps
    );
    super::one_register_op3!(
        Avx2Half,
        "avx2,fma",
        neg_mul_add,
        _mm256_fnmadd_pd,
        _mm256_fnmadd_ps
    );
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
        // andnot(x, y) is !x & y
        Avx2Half(_mm256_andnot_pd(b.0, a.0), _mm256_andnot_ps(b.1, a.1))
    }

    /// The half's lanes as the block's bits: shifted by the lanes before it.
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn bits(m: Self) -> u32 {
        if is_f64::<T>() {
            (_mm256_movemask_pd(m.0) as u32) << (4 * H)
        } else {
            (_mm256_movemask_ps(m.1) as u32) << (8 * H)
        }
    }

    /// The row's old lanes pass through an empty `asm!` before the
    /// select. Seeing a row's own lanes selected and stored back to it, the
    /// compiler made masked stores (`vmaskmovpd`) of them, which some
    /// cores run as microcode, holding up the front end
    /// (`benches/kernel_choice/no_masked_stores.sh` checks they stay out).
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn store_except(self, m: Self, row: &mut Row) -> Self {
        // SAFETY: AVX2 by the caller's contract.
        unsafe {
            let old = <Self as Block<T>>::load(row);
            let old = if is_f64::<T>() {
                Avx2Half(unseen_pd(old.0), old.1)
            } else {
                Avx2Half(old.0, unseen_ps(old.1))
            };
            let v = <Self as Block<T>>::select(m, old, self);
            <Self as Block<T>>::store(v, row);
            v
        }
    }

    /// The records of the half's lanes only (records `H · n/2 ..`, `n` the
    /// block's lanes, at `out`): its values and flag words (`a`'s all-ones
    /// lanes masked to 1, `b`'s to 256) interleaved by unpacks within the
    /// 128-bit halves and two half swaps, two 32-byte stores.
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn store_flagged(self, a: Self, b: Self, out: *mut T) -> bool {
        // SAFETY: the caller's: a block's records (128 bytes) writable at
        // `out`, of which this half writes its 64.
        unsafe {
            if is_f64::<T>() {
                let (one, two56) = (_mm256_set1_epi64x(1), _mm256_set1_epi64x(1 << 8));
                let p = (out as *mut f64).add(8 * H);
                let flags = _mm256_or_si256(
                    _mm256_and_si256(_mm256_castpd_si256(a.0), one),
                    _mm256_and_si256(_mm256_castpd_si256(b.0), two56),
                );
                let flags = _mm256_castsi256_pd(flags);
                // [u0 f0 u2 f2], [u1 f1 u3 f3]
                let lo = _mm256_unpacklo_pd(self.0, flags);
                let hi = _mm256_unpackhi_pd(self.0, flags);
                _mm256_storeu_pd(p, _mm256_permute2f128_pd::<0x20>(lo, hi));
                _mm256_storeu_pd(p.add(4), _mm256_permute2f128_pd::<0x31>(lo, hi));
            } else {
                let (one, two56) = (_mm256_set1_epi32(1), _mm256_set1_epi32(1 << 8));
                let p = (out as *mut f32).add(16 * H);
                let flags = _mm256_or_si256(
                    _mm256_and_si256(_mm256_castps_si256(a.1), one),
                    _mm256_and_si256(_mm256_castps_si256(b.1), two56),
                );
                let flags = _mm256_castsi256_ps(flags);
                // [u0 f0 u1 f1 | u4 f4 u5 f5], [u2 f2 u3 f3 | u6 f6 u7 f7]
                let lo = _mm256_unpacklo_ps(self.1, flags);
                let hi = _mm256_unpackhi_ps(self.1, flags);
                _mm256_storeu_ps(p, _mm256_permute2f128_ps::<0x20>(lo, hi));
                _mm256_storeu_ps(p.add(8), _mm256_permute2f128_ps::<0x31>(lo, hi));
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

/// A block in two 256-bit registers (AVX2): its two halves.
#[derive(Clone, Copy)]
pub(crate) struct Avx2(Avx2Half<0>, Avx2Half<1>);

/// Operation `$name` of [`Avx2`], taking blocks `$arg…`: the half's
/// operation on each half.
macro_rules! on_both_halves {
    ($name:ident($($arg:ident),*)) => {
        #[target_feature(enable = "avx2,fma")]
        #[inline]
        unsafe fn $name($($arg: Self),*) -> Self {
            // SAFETY: AVX2 by the caller's contract.
            unsafe {
                Avx2(
                    <Avx2Half<0> as Block<T>>::$name($($arg.0),*),
                    <Avx2Half<1> as Block<T>>::$name($($arg.1),*),
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
    /// took two; on one register each they fit.
    const CREEP_IN_HALVES: bool = true;
    type Lo = Avx2Half<0>;
    type Hi = Avx2Half<1>;

    #[inline(always)]
    unsafe fn lo(self) -> Avx2Half<0> {
        self.0
    }

    #[inline(always)]
    unsafe fn hi(self) -> Avx2Half<1> {
        self.1
    }

    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn load(row: &Row) -> Self {
        // SAFETY: the caller's, forwarded.
        unsafe { Avx2(Block::<T>::load(row), Block::<T>::load(row)) }
    }

    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn load_first(values: &[T]) -> Self {
        // SAFETY: the caller's, forwarded.
        unsafe {
            Avx2(
                Block::<T>::load_first(values),
                Block::<T>::load_first(values),
            )
        }
    }

    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn load_values(values: &[T]) -> Self {
        // SAFETY: the caller's, forwarded.
        unsafe {
            Avx2(
                Block::<T>::load_values(values),
                Block::<T>::load_values(values),
            )
        }
    }

    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn store(self, row: &mut Row) {
        // SAFETY: the caller's, forwarded.
        unsafe {
            Block::<T>::store(self.0, row);
            Block::<T>::store(self.1, row);
        }
    }

    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn splat(x: T) -> Self {
        // SAFETY: the caller's, forwarded.
        unsafe { Avx2(Block::<T>::splat(x), Block::<T>::splat(x)) }
    }

    on_both_halves!(add(self, b));
    on_both_halves!(sub(self, b));
    on_both_halves!(min(self, b));
    on_both_halves!(max(self, b));
    on_both_halves!(mul(self, b));
    on_both_halves!(mul_add(self, a, b));
    on_both_halves!(neg_mul_add(self, a, b));
    on_both_halves!(lt(self, b));
    on_both_halves!(gt(self, b));
    on_both_halves!(non_finite(self));
    on_both_halves!(select(m, a, b));
    on_both_halves!(or(a, b));
    on_both_halves!(and_not(a, b));

    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn bits(m: Self) -> u32 {
        // SAFETY: the caller's, forwarded.
        unsafe { <Avx2Half<0> as Block<T>>::bits(m.0) | <Avx2Half<1> as Block<T>>::bits(m.1) }
    }

    /// Each half's (which keeps the compiler from making masked stores).
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn store_except(self, m: Self, row: &mut Row) -> Self {
        // SAFETY: the caller's, forwarded.
        unsafe {
            Avx2(
                Block::<T>::store_except(self.0, m.0, row),
                Block::<T>::store_except(self.1, m.1, row),
            )
        }
    }

    /// Each half's records, four 32-byte stores.
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn store_flagged(self, a: Self, b: Self, out: *mut T) -> bool {
        // SAFETY: the caller's, forwarded: each half writes its records.
        unsafe {
            Block::<T>::store_flagged(self.0, a.0, b.0, out)
                && Block::<T>::store_flagged(self.1, a.1, b.1, out)
        }
    }
}
