//! The number type of the real-time core: `f32` or `f64`.
//!
//! One implementation of every operator is written against [`Real`] and
//! instantiated twice. Parameters are validated and transformed (the inverse
//! rules (22), the creep gains `1 − e^{−aT_s}`) in `f64` and rounded once to
//! `T`; only the per-sample steps run in `T`.

use core::fmt::Debug;
use core::ops::{Add, AddAssign, Div, Mul, Neg, Sub, SubAssign};

mod sealed {
    pub trait Sealed {}
    impl Sealed for f32 {}
    impl Sealed for f64 {}
}

/// `f32` or `f64` (sealed: the rounding analysis of the conformance
/// tolerances assumes IEEE 754 binary32 or binary64).
pub trait Real:
    Copy
    + Default
    + Debug
    + PartialOrd
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + AddAssign
    + SubAssign
    + Send
    + Sync
    + sealed::Sealed
    + 'static
{
    const ZERO: Self;
    const ONE: Self;
    /// Machine epsilon: the spacing of the numbers just above 1.
    const EPSILON: Self;
    const INFINITY: Self;
    const NEG_INFINITY: Self;
    /// Name as in C and Rust (`"f32"`, `"f64"`).
    const NAME: &'static str;

    /// Round an `f64` to the nearest `Self`.
    fn from_f64(x: f64) -> Self;
    /// Exact widening (or identity) to `f64`.
    fn to_f64(self) -> f64;
    fn is_finite(self) -> bool;
    /// The least `Self` greater than `self`.
    fn next_up(self) -> Self;
    /// The greatest `Self` less than `self`.
    fn next_down(self) -> Self;
    /// `self · a + b` rounded once, on every CPU: an FMA instruction where
    /// the code is compiled for one, else the C library's `fma` (on
    /// windows-gnu, whose `fma` rounds twice, the instruction where the CPU
    /// has one and the `libm` crate's otherwise). Only with
    /// `std`: stable Rust reaches no fused operation without it (the
    /// Cortex-M4's `vfma.f32` included). The creep update (20) and the
    /// steps' weighted sums are written with it (`creep_pass::update`,
    /// `add_product`).
    #[cfg(feature = "std")]
    fn fused_mul_add(self, a: Self, b: Self) -> Self;

    /// `x` rounded to a `Self` not below it (a lower limit stays a bound).
    fn from_f64_up(x: f64) -> Self {
        let y = Self::from_f64(x);
        if y.to_f64() < x {
            y.next_up()
        } else {
            y
        }
    }

    /// `x` rounded to a `Self` not above it (an upper limit stays a bound).
    fn from_f64_down(x: f64) -> Self {
        let y = Self::from_f64(x);
        if y.to_f64() > x {
            y.next_down()
        } else {
            y
        }
    }
}

/// `acc + w · x`: the product fused with the sum with `std`
/// ([`Real::fused_mul_add`]), rounded first without. Every weighted sum of
/// a step (the plays' `Σ w_i x_i`, the creep's `Σ (w_i/m) Σ_j χ_ij`) adds
/// its terms this way, in every copy, so that the copies keep one set of
/// bits; fused, a term costs one operation instead of two.
#[inline(always)]
pub(crate) fn add_product<T: Real>(acc: T, w: T, x: T) -> T {
    #[cfg(feature = "std")]
    return w.fused_mul_add(x, acc);
    #[cfg(not(feature = "std"))]
    return acc + w * x;
}

/// A partial sum's next weighted term: its first term (`first`) is the
/// product `w · x` alone, each later one [`add_product`]. Every partial
/// sum of a step starts so, in every copy. From its first product rather
/// than from `+0`, a sum starts with a multiply instead of a fused
/// multiply-add (a cycle shorter on common cores, at the head of the step's
/// two sums on its chain). The values are the same; only the sign of a
/// zero can differ: the product's sign, where `+0 + w·x` made every zero
/// `+0`.
#[inline(always)]
pub(crate) fn add_term<T: Real>(acc: T, w: T, x: T, first: bool) -> T {
    if first {
        w * x
    } else {
        add_product(acc, w, x)
    }
}

macro_rules! real {
    ($t:ident) => {
        impl Real for $t {
            const ZERO: Self = 0.0;
            const ONE: Self = 1.0;
            const EPSILON: Self = $t::EPSILON;
            const INFINITY: Self = $t::INFINITY;
            const NEG_INFINITY: Self = $t::NEG_INFINITY;
            const NAME: &'static str = stringify!($t);

            #[inline(always)]
            fn from_f64(x: f64) -> Self {
                x as $t
            }

            #[inline(always)]
            fn to_f64(self) -> f64 {
                self as f64
            }

            #[inline(always)]
            fn is_finite(self) -> bool {
                $t::is_finite(self)
            }

            fn next_up(self) -> Self {
                $t::next_up(self)
            }

            fn next_down(self) -> Self {
                $t::next_down(self)
            }

            #[cfg(feature = "std")]
            #[inline(always)]
            fn fused_mul_add(self, a: Self, b: Self) -> Self {
                fused::$t(self, a, b)
            }
        }
    };
}

real!(f32);
real!(f64);

/// The fused multiply-add of each type. Where no FMA instruction is
/// compiled in, `mul_add` is a call to the C library's `fma`. glibc's,
/// macOS's and the hardware's round once, and so have the same bits; the
/// `fma` and `fmaf` of mingw-w64 before version 11 (Debian 12's, which
/// Rust's windows-gnu target links) round twice (mingw-w64 bug 848). There
/// the operation is the instruction where the CPU has one and the `libm`
/// crate's (rounded once, in Rust) where it does not.
#[cfg(feature = "std")]
mod fused {
    #[cfg(not(all(windows, target_env = "gnu", target_arch = "x86_64")))]
    #[inline(always)]
    pub(super) fn f64(x: f64, a: f64, b: f64) -> f64 {
        x.mul_add(a, b)
    }

    #[cfg(not(all(windows, target_env = "gnu", target_arch = "x86_64")))]
    #[inline(always)]
    pub(super) fn f32(x: f32, a: f32, b: f32) -> f32 {
        x.mul_add(a, b)
    }

    #[cfg(all(windows, target_env = "gnu", target_arch = "x86_64"))]
    #[inline(always)]
    pub(super) fn f64(x: f64, a: f64, b: f64) -> f64 {
        if cfg!(target_feature = "fma") || std::arch::is_x86_feature_detected!("fma") {
            // SAFETY: the CPU has FMA
            unsafe { instruction_f64(x, a, b) }
        } else {
            libm::fma(x, a, b)
        }
    }

    #[cfg(all(windows, target_env = "gnu", target_arch = "x86_64"))]
    #[inline(always)]
    pub(super) fn f32(x: f32, a: f32, b: f32) -> f32 {
        if cfg!(target_feature = "fma") || std::arch::is_x86_feature_detected!("fma") {
            // SAFETY: the CPU has FMA
            unsafe { instruction_f32(x, a, b) }
        } else {
            libm::fmaf(x, a, b)
        }
    }

    /// Compiled with FMA, `mul_add` is the instruction.
    #[cfg(all(windows, target_env = "gnu", target_arch = "x86_64"))]
    #[target_feature(enable = "fma")]
    #[inline]
    unsafe fn instruction_f64(x: f64, a: f64, b: f64) -> f64 {
        x.mul_add(a, b)
    }

    #[cfg(all(windows, target_env = "gnu", target_arch = "x86_64"))]
    #[target_feature(enable = "fma")]
    #[inline]
    unsafe fn instruction_f32(x: f32, a: f32, b: f32) -> f32 {
        x.mul_add(a, b)
    }
}

#[cfg(all(test, feature = "std"))]
mod tests {
    use super::Real;

    /// `x·a + b` whose exact value lies just above a rounding midpoint that
    /// a first rounding to 64 bits (x87's extended format, as mingw-w64's
    /// `fma` computes) lands on exactly: rounded once it goes up, twice it
    /// goes to even, down.
    #[test]
    fn the_fused_multiply_add_rounds_once() {
        // (1 + 2⁻³⁵)² − (2⁻³⁴ − 2⁻⁵³) = 1 + 2⁻⁵³ + 2⁻⁷⁰
        let x = 1.0 + 2f64.powi(-35);
        let b = -(2f64.powi(-34) - 2f64.powi(-53));
        assert_eq!(x.fused_mul_add(x, b), 1.0 + 2f64.powi(-52));
        // in f32, fused rather than rounded after the product:
        // (1 + 2⁻¹³)² − (2⁻¹² − 2⁻²⁴) = 1 + 2⁻²⁴ + 2⁻²⁶ goes up; the
        // product rounded first (1 + 2⁻¹²) leaves the midpoint 1 + 2⁻²⁴
        let y = 1.0f32 + 2f32.powi(-13);
        let c = -(2f32.powi(-12) - 2f32.powi(-24));
        assert_eq!(y.fused_mul_add(y, c), 1.0 + 2f32.powi(-23));
    }
}
