//! 64-byte blocks of lanes — 8 `f64` or 16 `f32`, one cache line — and their
//! arithmetic on each instruction set: the compensator bank's unit of work.
//!
//! Every operation is lane by lane in the order the portable code writes
//! it, with `min(a, b) = a < b ? a : b` and `max(a, b) = a > b ? a : b` as
//! the hardware's `min` and `max` are defined, and no fused multiply-add,
//! so the portable, AVX2 and AVX-512 blocks compute the same bits.

use core::marker::PhantomData;
use core::mem::size_of;

use crate::realtime::real::Real;

/// Lanes of `T` in one block (8 `f64`, 16 `f32`).
#[inline(always)]
pub(crate) const fn lanes<T>() -> usize {
    64 / size_of::<T>()
}

#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn is_f64<T>() -> bool {
    size_of::<T>() == 8
}

/// One cache line: a row of a block's lanes. A vector of rows is 64-byte
/// aligned, so every block load is one line.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[repr(C, align(64))]
pub(crate) struct Row([u64; 8]);

impl Row {
    /// The row's lanes as `T` (all zero bits: `+0.0`).
    #[inline(always)]
    pub(crate) fn lanes<T: Real>(&self) -> &[T] {
        // SAFETY: `T` is `f32` or `f64` (`Real` is sealed): every bit
        // pattern is a value, 64 bytes hold `lanes::<T>()` of them, and the
        // row's alignment (64) exceeds theirs.
        unsafe { core::slice::from_raw_parts(self.0.as_ptr() as *const T, lanes::<T>()) }
    }

    #[inline(always)]
    pub(crate) fn lanes_mut<T: Real>(&mut self) -> &mut [T] {
        // SAFETY: as in `lanes`, and the borrow is unique.
        unsafe { core::slice::from_raw_parts_mut(self.0.as_mut_ptr() as *mut T, lanes::<T>()) }
    }

    /// The row as sixteen 32-bit words.
    #[inline(always)]
    fn halves(&self) -> &[u32; 16] {
        // SAFETY: 64 bytes, aligned beyond `u32`'s; every bit pattern is a
        // `u32`.
        unsafe { &*(self.0.as_ptr() as *const [u32; 16]) }
    }

    #[inline(always)]
    fn halves_mut(&mut self) -> &mut [u32; 16] {
        // SAFETY: as in `halves`, and the borrow is unique.
        unsafe { &mut *(self.0.as_mut_ptr() as *mut [u32; 16]) }
    }
}

/// The arithmetic of one block of `T` on an instruction set. `unsafe`
/// because an implementation may need CPU features: only
/// [`Kernels`](super::Kernels) values prove them, and the bank calls these
/// only within a step compiled for them.
pub(crate) trait Block<T: Real>: Copy {
    /// One flag per lane.
    type Mask: Copy;
    /// Whether the bank's creep pass updates two thresholds at a time
    /// instead of four (the same bits): where sixteen registers are all a
    /// set has, four thresholds' bounds and rows do not fit in them.
    const PAIRED_CREEP: bool = false;
    /// Whether the bank's creep pass runs on each half of the block in
    /// turn ([`Block::Lo`], then [`Block::Hi`]; the same bits: every
    /// operation is lane by lane), where a block takes two registers.
    const CREEP_IN_HALVES: bool = false;
    /// The block's first half where [`Block::CREEP_IN_HALVES`] (its loads
    /// and stores the first half of a row); otherwise the block. A half
    /// needs no CPU feature its block does not ([`Ops::halves`] relies on
    /// it).
    type Lo: Block<T>;
    /// The second half, as [`Block::Lo`].
    type Hi: Block<T>;
    /// The first half of the block's lanes ([`Block::Lo`]).
    unsafe fn lo(self) -> Self::Lo;
    /// The second half ([`Block::Hi`]).
    unsafe fn hi(self) -> Self::Hi;
    /// The lanes of `row`.
    unsafe fn load(row: &Row) -> Self;
    /// The first lanes of `values` (at least a block's worth; unaligned).
    unsafe fn load_values(values: &[T]) -> Self;
    /// All of `values` (at most a block's worth; unaligned) in the first
    /// lanes, zero in the others: a bank's last, partial block. Through a
    /// padded row by default; the vector sets load it masked (copied into
    /// a row, the vector load waited on the copy's narrower stores).
    unsafe fn load_first(values: &[T]) -> Self {
        let mut row = Row::default();
        row.lanes_mut()[..values.len()].copy_from_slice(values);
        // SAFETY: the caller's, forwarded.
        unsafe { Self::load(&row) }
    }
    unsafe fn store(self, row: &mut Row);
    unsafe fn splat(x: T) -> Self;
    unsafe fn add(self, b: Self) -> Self;
    unsafe fn sub(self, b: Self) -> Self;
    /// `a < b ? a : b` per lane.
    unsafe fn min(self, b: Self) -> Self;
    /// `a > b ? a : b` per lane.
    unsafe fn max(self, b: Self) -> Self;
    unsafe fn mul(self, b: Self) -> Self;
    /// `self · a + b` per lane, rounded as [`Real::fused_mul_add`] rounds.
    unsafe fn mul_add(self, a: Self, b: Self) -> Self;
    /// `b − self · a` per lane, rounded as `(−self).fused_mul_add(a, b)`.
    unsafe fn neg_mul_add(self, a: Self, b: Self) -> Self;
    /// `a < b` per lane (false on NaN).
    unsafe fn lt(self, b: Self) -> Self::Mask;
    /// `a > b` per lane (false on NaN).
    unsafe fn gt(self, b: Self) -> Self::Mask;
    /// Not a finite number, per lane.
    unsafe fn non_finite(self) -> Self::Mask;
    /// `m ? a : b` per lane.
    unsafe fn select(m: Self::Mask, a: Self, b: Self) -> Self;
    unsafe fn or(a: Self::Mask, b: Self::Mask) -> Self::Mask;
    /// `a && !b` per lane.
    unsafe fn and_not(a: Self::Mask, b: Self::Mask) -> Self::Mask;
    /// Lane `l`'s flag as bit `l`.
    unsafe fn bits(m: Self::Mask) -> u32;

    /// Lane `l` as the record `l` at `out`: the value, then `a`'s and
    /// `b`'s flags of the lane as one byte each (0 or 1), zeros to twice
    /// the value's size (`#[repr(C)] (T, bool, bool)` with its padding
    /// zeroed). Returns whether it did: `false` from sets without such a
    /// store, for the caller to write the records one by one.
    ///
    /// # Safety
    /// `out` is valid for writing `lanes::<T>()` records of `2 ×
    /// size_of::<T>()` bytes, aligned for `T`.
    #[inline(always)]
    unsafe fn store_flagged(self, a: Self::Mask, b: Self::Mask, out: *mut T) -> bool {
        let _ = (a, b, out);
        false
    }

    /// `m ? row : self` per lane, stored to `row` and returned: `row`
    /// updated where `m` is false. A method of its own so that a set can
    /// keep the compiler from making it a masked store (see `Avx2`'s).
    #[inline(always)]
    unsafe fn store_except(self, m: Self::Mask, row: &mut Row) -> Self {
        // SAFETY: the caller's, forwarded.
        unsafe {
            let v = Self::select(m, Self::load(row), self);
            v.store(row);
            v
        }
    }

    /// `max(min(x, upper), lower)`: the play (20), as `play::clamp`.
    #[inline(always)]
    unsafe fn clamp(self, lower: Self, upper: Self) -> Self {
        // SAFETY: the caller's, forwarded.
        unsafe { self.min(upper).max(lower) }
    }

    /// `a + b` where `one` is `1` in every lane: the same bits as
    /// [`Block::add`], computed where a set has it as the fused `b · one +
    /// a` (exact product, one rounding: the rounded sum), which runs on the
    /// multiplier's pipes and leaves the adder's to the rest. `one` comes
    /// from the caller so that the compiler, not seeing a constant 1, keeps
    /// the fused form.
    #[inline(always)]
    unsafe fn add_on_multiplier(self, b: Self, one: Self) -> Self {
        let _ = one;
        // SAFETY: the caller's, forwarded.
        unsafe { self.add(b) }
    }

    /// `a − b` as [`Block::add_on_multiplier`] computes `a + b`: the bits
    /// of [`Block::sub`], computed where a set has it as the fused
    /// `−(b · one) + a` (exact product, one rounding: the rounded
    /// difference) on the multiplier's pipes.
    #[inline(always)]
    unsafe fn sub_on_multiplier(self, b: Self, one: Self) -> Self {
        let _ = one;
        // SAFETY: the caller's, forwarded.
        unsafe { self.sub(b) }
    }
}

/// The items of a block type without halves: [`Block::Lo`] and
/// [`Block::Hi`] are the block itself.
macro_rules! whole_block_halves {
    () => {
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
    };
}
#[cfg(target_arch = "x86_64")]
pub(crate) use whole_block_halves;

/// Operation `$name` of the block type `$b`, one register (its `f64` form
/// first, its `f32` form second), compiled for `$feature`: `$pd` on the
/// `f64` form or `$ps` on the `f32` form.
#[cfg(all(feature = "std", target_arch = "x86_64"))]
macro_rules! one_register_op {
    ($b:ident, $feature:literal, $name:ident, $pd:ident, $ps:ident) => {
        #[target_feature(enable = $feature)]
        #[inline]
        unsafe fn $name(self, b: Self) -> Self {
            if is_f64::<T>() {
                $b($pd(self.0, b.0), self.1)
            } else {
                $b(self.0, $ps(self.1, b.1))
            }
        }
    };
}
#[cfg(all(feature = "std", target_arch = "x86_64"))]
pub(crate) use one_register_op;

/// [`one_register_op`] of three operands.
#[cfg(all(feature = "std", target_arch = "x86_64"))]
macro_rules! one_register_op3 {
    ($b:ident, $feature:literal, $name:ident, $pd:ident, $ps:ident) => {
        #[target_feature(enable = $feature)]
        #[inline]
        unsafe fn $name(self, a: Self, b: Self) -> Self {
            if is_f64::<T>() {
                $b($pd(self.0, a.0, b.0), self.1)
            } else {
                $b(self.0, $ps(self.1, a.1, b.1))
            }
        }
    };
}
#[cfg(all(feature = "std", target_arch = "x86_64"))]
pub(crate) use one_register_op3;

/// Lanes one by one in a [`Row`]: any CPU. Every operation is a loop over
/// the lanes without branches (a mask is a row of lanes all ones or all
/// zeros, as wide as `T`'s, and a select is bitwise), so that the compiler
/// makes each loop vector instructions where the target has them (NEON on
/// 64-bit ARM, SSE2 on x86-64).
///
/// `FUSED`: an x86-64 build without FMA on a CPU with it, where a fused
/// multiply-add is the instruction on 128-bit registers ([`fused_sse`]).
/// Otherwise it is `Real::fused_mul_add` on each lane: the instruction
/// where the build has one (64-bit ARM), else the C library's `fma`.
pub(crate) struct Portable<T, const FUSED: bool = false>(Row, PhantomData<T>);

impl<T, const FUSED: bool> Clone for Portable<T, FUSED> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<T, const FUSED: bool> Copy for Portable<T, FUSED> {}

/// A portable block's flags: each lane all ones (true) or all zeros, in
/// lanes as wide as the block's.
#[derive(Clone, Copy)]
pub(crate) struct PortableMask(Row);

impl PortableMask {
    /// Lane `l` from `flag(l)`, `T`'s lanes wide.
    #[inline(always)]
    fn from_flags<T>(flag: impl Fn(usize) -> bool) -> Self {
        let mut m = Row::default();
        if size_of::<T>() == 8 {
            for (l, w) in m.0.iter_mut().enumerate() {
                *w = if flag(l) { !0 } else { 0 };
            }
        } else {
            for (l, w) in m.halves_mut().iter_mut().enumerate() {
                *w = if flag(l) { !0 } else { 0 };
            }
        }
        PortableMask(m)
    }

    /// `f` on each 64-bit word: a lane's flag is all its bits, so any
    /// bitwise operation is one on the words, whatever the lanes' width.
    #[inline(always)]
    fn words(a: Row, b: Row, f: impl Fn(u64, u64) -> u64) -> Row {
        Row(core::array::from_fn(|w| f(a.0[w], b.0[w])))
    }
}

impl<T: Real, const FUSED: bool> Portable<T, FUSED> {
    #[inline(always)]
    fn map2(self, b: Self, f: impl Fn(T, T) -> T) -> Self {
        let mut out = Row::default();
        let (x, y) = (self.0.lanes::<T>(), b.0.lanes::<T>());
        for (l, o) in out.lanes_mut::<T>().iter_mut().enumerate() {
            *o = f(x[l], y[l]);
        }
        Portable(out, PhantomData)
    }

    #[inline(always)]
    fn map3(self, a: Self, b: Self, f: impl Fn(T, T, T) -> T) -> Self {
        let mut out = Row::default();
        let (x, y, z) = (self.0.lanes::<T>(), a.0.lanes::<T>(), b.0.lanes::<T>());
        for (l, o) in out.lanes_mut::<T>().iter_mut().enumerate() {
            *o = f(x[l], y[l], z[l]);
        }
        Portable(out, PhantomData)
    }

    #[inline(always)]
    fn test2(self, b: Self, f: impl Fn(T, T) -> bool) -> PortableMask {
        let (x, y) = (self.0.lanes::<T>(), b.0.lanes::<T>());
        PortableMask::from_flags::<T>(|l| f(x[l], y[l]))
    }
}

impl<T: Real, const FUSED: bool> Block<T> for Portable<T, FUSED> {
    type Mask = PortableMask;
    /// SSE2's sixteen registers hold four of a block's rows (each four
    /// registers): the creep pass's four thresholds do not fit in them.
    const PAIRED_CREEP: bool = cfg!(target_arch = "x86_64");
    whole_block_halves!();

    #[inline(always)]
    unsafe fn load(row: &Row) -> Self {
        Portable(*row, PhantomData)
    }

    #[inline(always)]
    unsafe fn load_values(values: &[T]) -> Self {
        let mut row = Row::default();
        row.lanes_mut().copy_from_slice(&values[..lanes::<T>()]);
        Portable(row, PhantomData)
    }

    #[inline(always)]
    unsafe fn store(self, row: &mut Row) {
        *row = self.0;
    }

    #[inline(always)]
    unsafe fn splat(x: T) -> Self {
        let mut row = Row::default();
        row.lanes_mut().fill(x);
        Portable(row, PhantomData)
    }

    #[inline(always)]
    unsafe fn add(self, b: Self) -> Self {
        self.map2(b, |x, y| x + y)
    }

    #[inline(always)]
    unsafe fn mul(self, b: Self) -> Self {
        self.map2(b, |x, y| x * y)
    }

    #[inline(always)]
    unsafe fn sub(self, b: Self) -> Self {
        self.map2(b, |x, y| x - y)
    }

    #[inline(always)]
    unsafe fn min(self, b: Self) -> Self {
        self.map2(b, |x, y| if x < y { x } else { y })
    }

    #[inline(always)]
    unsafe fn max(self, b: Self) -> Self {
        self.map2(b, |x, y| if x > y { x } else { y })
    }

    #[inline(always)]
    unsafe fn mul_add(self, a: Self, b: Self) -> Self {
        #[cfg(all(feature = "std", target_arch = "x86_64", not(target_feature = "fma")))]
        if FUSED {
            // SAFETY: a `FUSED` block's operations run only where the CPU
            // has FMA (`run_blocks`)
            return Portable(
                unsafe { fused_sse::lanes::<T, false>(self.0, a.0, b.0) },
                PhantomData,
            );
        }
        self.map3(a, b, |x, a, b| x.fused_mul_add(a, b))
    }

    #[inline(always)]
    unsafe fn neg_mul_add(self, a: Self, b: Self) -> Self {
        #[cfg(all(feature = "std", target_arch = "x86_64", not(target_feature = "fma")))]
        if FUSED {
            // SAFETY: as in `mul_add`
            return Portable(
                unsafe { fused_sse::lanes::<T, true>(self.0, a.0, b.0) },
                PhantomData,
            );
        }
        self.map3(a, b, |x, a, b| (-x).fused_mul_add(a, b))
    }

    #[inline(always)]
    unsafe fn lt(self, b: Self) -> PortableMask {
        self.test2(b, |x, y| x < y)
    }

    #[inline(always)]
    unsafe fn gt(self, b: Self) -> PortableMask {
        self.test2(b, |x, y| x > y)
    }

    #[inline(always)]
    unsafe fn non_finite(self) -> PortableMask {
        // `x − x` is 0 for a finite `x` and NaN for an infinite or NaN
        // one: a subtraction and a comparison, where `is_finite` tests bits
        // (a 64-bit integer comparison SSE2 lacks)
        self.test2(self, |x, _| {
            #[allow(clippy::eq_op)]
            let zero = x - x;
            zero != T::ZERO
        })
    }

    #[inline(always)]
    unsafe fn select(m: PortableMask, a: Self, b: Self) -> Self {
        Portable(
            PortableMask::words(
                PortableMask::words(m.0, a.0, |m, a| m & a),
                PortableMask::words(m.0, b.0, |m, b| !m & b),
                |x, y| x | y,
            ),
            PhantomData,
        )
    }

    #[inline(always)]
    unsafe fn or(a: PortableMask, b: PortableMask) -> PortableMask {
        PortableMask(PortableMask::words(a.0, b.0, |a, b| a | b))
    }

    #[inline(always)]
    unsafe fn and_not(a: PortableMask, b: PortableMask) -> PortableMask {
        PortableMask(PortableMask::words(a.0, b.0, |a, b| a & !b))
    }

    #[inline(always)]
    unsafe fn bits(m: PortableMask) -> u32 {
        if size_of::<T>() == 8 {
            (0..8).fold(0, |b, l| b | (((m.0 .0[l] >> 63) as u32) << l))
        } else {
            let h = m.0.halves();
            (0..16).fold(0, |b, l| b | ((h[l] >> 31) << l))
        }
    }
}

/// A portable block's fused multiply-adds on an x86-64 build without FMA,
/// on a CPU with it: the instruction on each 128-bit quarter of the row, the
/// width of the build's SSE2 vectors, so the block's other operations stay
/// in their registers around it. The instruction is written out because
/// the build cannot enable FMA in a function without also enabling AVX,
/// which would make it another kernel set. Its VEX encoding clears the
/// registers' upper halves: no penalty beside legacy SSE code. The same
/// bits as `Real::fused_mul_add`: both round once, and `−(x·a) + b` is
/// `(−x)·a + b` exactly.
#[cfg(all(feature = "std", target_arch = "x86_64", not(target_feature = "fma")))]
mod fused_sse {
    use core::arch::asm;
    use core::arch::x86_64::{
        __m128, __m128d, _mm_load_pd, _mm_load_ps, _mm_store_pd, _mm_store_ps,
    };
    use core::mem::size_of;

    use super::Row;

    /// `±x·a + b` on every lane of `T` (`−` if `NEGATE`).
    ///
    /// # Safety
    /// The CPU has FMA.
    #[inline(always)]
    pub(super) unsafe fn lanes<T, const NEGATE: bool>(x: Row, a: Row, b: Row) -> Row {
        let mut out = Row::default();
        for q in 0..4 {
            // SAFETY: a row is 64 bytes aligned to 64: quarter `q` is 16
            // bytes aligned to 16; the CPU has FMA (the caller's)
            unsafe {
                let at = |r: &Row| (r.0.as_ptr() as *const u8).add(16 * q);
                let to = (out.0.as_mut_ptr() as *mut u8).add(16 * q);
                if size_of::<T>() == 8 {
                    let (x, a) = (_mm_load_pd(at(&x) as _), _mm_load_pd(at(&a) as _));
                    let mut acc: __m128d = _mm_load_pd(at(&b) as _);
                    if NEGATE {
                        asm!("vfnmadd231pd {acc}, {x}, {a}", acc = inout(xmm_reg) acc,
                            x = in(xmm_reg) x, a = in(xmm_reg) a,
                            options(pure, nomem, nostack, preserves_flags));
                    } else {
                        asm!("vfmadd231pd {acc}, {x}, {a}", acc = inout(xmm_reg) acc,
                            x = in(xmm_reg) x, a = in(xmm_reg) a,
                            options(pure, nomem, nostack, preserves_flags));
                    }
                    _mm_store_pd(to as _, acc);
                } else {
                    let (x, a) = (_mm_load_ps(at(&x) as _), _mm_load_ps(at(&a) as _));
                    let mut acc: __m128 = _mm_load_ps(at(&b) as _);
                    if NEGATE {
                        asm!("vfnmadd231ps {acc}, {x}, {a}", acc = inout(xmm_reg) acc,
                            x = in(xmm_reg) x, a = in(xmm_reg) a,
                            options(pure, nomem, nostack, preserves_flags));
                    } else {
                        asm!("vfmadd231ps {acc}, {x}, {a}", acc = inout(xmm_reg) acc,
                            x = in(xmm_reg) x, a = in(xmm_reg) a,
                            options(pure, nomem, nostack, preserves_flags));
                    }
                    _mm_store_ps(to as _, acc);
                }
            }
        }
        out
    }
}

#[cfg(all(feature = "std", target_arch = "x86_64"))]
mod avx2;
#[cfg(all(feature = "std", target_arch = "x86_64"))]
mod avx512;
#[cfg(all(feature = "std", target_arch = "x86_64"))]
pub(crate) use avx2::Avx2;
#[cfg(all(feature = "std", target_arch = "x86_64"))]
pub(crate) use avx512::Avx512;

/// Safe access to a [`Block`]'s operations: made only by [`run_blocks`] for
/// the block type of kernels the CPU has, so its methods may call them.
#[derive(Debug)]
pub(crate) struct Ops<T, V>(core::marker::PhantomData<(T, V)>);

impl<T, V> Clone for Ops<T, V> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<T, V> Copy for Ops<T, V> {}

macro_rules! safe_ops {
    ($($name:ident($($arg:ident: $ty:ty),*) -> $out:ty;)*) => {
        $(
            #[inline(always)]
            pub(crate) fn $name(self, $($arg: $ty),*) -> $out {
                // SAFETY: `Ops<T, V>` exists only where `V`'s features are
                // present (see `run_blocks`).
                unsafe { V::$name($($arg),*) }
            }
        )*
    };
}

impl<T: Real, V: Block<T>> Ops<T, V> {
    safe_ops! {
        load(row: &Row) -> V;
        load_values(values: &[T]) -> V;
        load_first(values: &[T]) -> V;
        store(v: V, row: &mut Row) -> ();
        splat(x: T) -> V;
        add(a: V, b: V) -> V;
        sub(a: V, b: V) -> V;
        mul(a: V, b: V) -> V;
        lt(a: V, b: V) -> V::Mask;
        gt(a: V, b: V) -> V::Mask;
        non_finite(a: V) -> V::Mask;
        select(m: V::Mask, a: V, b: V) -> V;
        or(a: V::Mask, b: V::Mask) -> V::Mask;
        and_not(a: V::Mask, b: V::Mask) -> V::Mask;
        bits(m: V::Mask) -> u32;
        clamp(x: V, lower: V, upper: V) -> V;
        mul_add(x: V, a: V, b: V) -> V;
        neg_mul_add(x: V, a: V, b: V) -> V;
        add_on_multiplier(a: V, b: V, one: V) -> V;
        sub_on_multiplier(a: V, b: V, one: V) -> V;
        store_except(v: V, m: V::Mask, row: &mut Row) -> V;
        lo(v: V) -> V::Lo;
        hi(v: V) -> V::Hi;
    }

    /// The operations of `V`'s halves.
    #[inline(always)]
    pub(crate) fn halves(self) -> (Ops<T, V::Lo>, Ops<T, V::Hi>) {
        // sound: `Ops<T, V>` proves `V`'s features, and a half needs no
        // feature its block does not (`Block::Lo`)
        (
            Ops(core::marker::PhantomData),
            Ops(core::marker::PhantomData),
        )
    }

    /// `realtime::real::add_term` per lane: `w · x` for a sum's first
    /// term, fused with `acc` after it.
    #[inline(always)]
    pub(crate) fn add_term(self, acc: V, w: V, x: V, first: bool) -> V {
        if first {
            self.mul(w, x)
        } else {
            self.mul_add(w, x, acc)
        }
    }

    /// [`Block::store_flagged`] into `out`, whose records are laid out as
    /// it writes them (checked: their size and the flags' offsets).
    #[inline(always)]
    pub(crate) fn store_flagged<R>(
        self,
        v: V,
        a: V::Mask,
        b: V::Mask,
        out: &mut [R],
        flag_offsets: (usize, usize),
    ) -> bool {
        let t = size_of::<T>();
        if out.len() != lanes::<T>() || size_of::<R>() != 2 * t || flag_offsets != (t, t + 1) {
            return false;
        }
        // SAFETY: `Ops<T, V>` exists only where `V`'s features are present;
        // `out` holds a block's worth of records of the layout the store
        // writes (checked above), and `R` is aligned at least as `T`
        // (a record holds a `T` first).
        unsafe { v.store_flagged(a, b, out.as_mut_ptr() as *mut T) }
    }
}

/// Work on blocks of `T`, written once for every instruction set.
pub(crate) trait BlockWork<T: Real> {
    type Output;
    fn run<V: Block<T>>(self, ops: Ops<T, V>) -> Self::Output;
}

/// `work` on `k`'s blocks: the portable ones, or — compiled with their
/// features enabled — the AVX2 or AVX-512 ones.
#[inline(always)]
pub(crate) fn run_blocks<T: Real, W: BlockWork<T>>(k: super::Kernels, work: W) -> W::Output {
    match k {
        super::Kernels::Portable => {
            // out of line, as the vector sets are: inlined, its 4.4 KiB
            // frame (aligned, its stack probed) was set up by the bank's
            // step on every call, whichever kernel set ran
            #[inline(never)]
            fn portable<T: Real, W: BlockWork<T>, const FUSED: bool>(work: W) -> W::Output {
                work.run(Ops::<T, Portable<T, FUSED>>(core::marker::PhantomData))
            }
            // `Portable<T, true>` only where its instruction exists
            #[cfg(all(feature = "std", target_arch = "x86_64", not(target_feature = "fma")))]
            if std::arch::is_x86_feature_detected!("fma") {
                return portable::<T, W, true>(work);
            }
            portable::<T, W, false>(work)
        }
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        super::Kernels::Avx2(_) => {
            #[target_feature(enable = "avx2,fma")]
            unsafe fn avx2<T: Real, W: BlockWork<T>>(work: W) -> W::Output {
                super::count_simd_call();
                work.run(Ops::<T, Avx2>(core::marker::PhantomData))
            }
            // SAFETY: an `Avx2` proof exists only where the CPU has AVX2 and FMA.
            unsafe { avx2::<T, W>(work) }
        }
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        super::Kernels::Avx512(_) => {
            #[target_feature(enable = "avx2,fma,avx512f")]
            unsafe fn avx512<T: Real, W: BlockWork<T>>(work: W) -> W::Output {
                super::count_simd_call();
                work.run(Ops::<T, Avx512>(core::marker::PhantomData))
            }
            // SAFETY: an `Avx512` proof exists only where the CPU has
            // AVX-512F, AVX2 and FMA.
            unsafe { avx512::<T, W>(work) }
        }
    }
}

#[cfg(test)]
mod tests;
