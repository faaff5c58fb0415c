//! 64-byte blocks of lanes — 8 `f64` or 16 `f32`, one cache line — and their
//! arithmetic on each instruction set: the compensator bank's unit of work.
//!
//! Every operation is lane by lane in the order the portable code writes
//! it, with `min(a, b) = a < b ? a : b` and `max(a, b) = a > b ? a : b` as
//! the hardware's `min` and `max` are defined, and no fused multiply-add,
//! so the portable, AVX2 and AVX-512 blocks compute the same bits.

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

/// Lanes in an array, one by one: any CPU.
#[derive(Clone, Copy)]
pub(crate) struct Portable<T>([T; 16]);

// the lanes are indexed in step across three arrays
#[allow(clippy::needless_range_loop)]
impl<T: Real> Portable<T> {
    #[inline(always)]
    fn map2(self, b: Self, f: impl Fn(T, T) -> T) -> Self {
        let mut out = self.0;
        for l in 0..lanes::<T>() {
            out[l] = f(self.0[l], b.0[l]);
        }
        Portable(out)
    }

    #[inline(always)]
    fn map3(self, a: Self, b: Self, f: impl Fn(T, T, T) -> T) -> Self {
        let mut out = self.0;
        for l in 0..lanes::<T>() {
            out[l] = f(self.0[l], a.0[l], b.0[l]);
        }
        Portable(out)
    }

    #[inline(always)]
    fn test2(self, b: Self, f: impl Fn(T, T) -> bool) -> [bool; 16] {
        let mut out = [false; 16];
        for l in 0..lanes::<T>() {
            out[l] = f(self.0[l], b.0[l]);
        }
        out
    }
}

impl<T: Real> Block<T> for Portable<T> {
    type Mask = [bool; 16];
    whole_block_halves!();

    #[inline(always)]
    unsafe fn load(row: &Row) -> Self {
        let mut a = [T::ZERO; 16];
        a[..lanes::<T>()].copy_from_slice(row.lanes());
        Portable(a)
    }

    #[inline(always)]
    unsafe fn load_values(values: &[T]) -> Self {
        let mut a = [T::ZERO; 16];
        a[..lanes::<T>()].copy_from_slice(&values[..lanes::<T>()]);
        Portable(a)
    }

    #[inline(always)]
    unsafe fn store(self, row: &mut Row) {
        row.lanes_mut().copy_from_slice(&self.0[..lanes::<T>()]);
    }

    #[inline(always)]
    unsafe fn splat(x: T) -> Self {
        Portable([x; 16])
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
        if std::arch::is_x86_feature_detected!("fma") {
            // SAFETY: the CPU has FMA (checked just above)
            return unsafe { fused_lanes::<T, false>(self, a, b) };
        }
        self.map3(a, b, |x, a, b| x.fused_mul_add(a, b))
    }

    #[inline(always)]
    unsafe fn neg_mul_add(self, a: Self, b: Self) -> Self {
        #[cfg(all(feature = "std", target_arch = "x86_64", not(target_feature = "fma")))]
        if std::arch::is_x86_feature_detected!("fma") {
            // SAFETY: the CPU has FMA (checked just above)
            return unsafe { fused_lanes::<T, true>(self, a, b) };
        }
        self.map3(a, b, |x, a, b| (-x).fused_mul_add(a, b))
    }

    #[inline(always)]
    unsafe fn lt(self, b: Self) -> [bool; 16] {
        self.test2(b, |x, y| x < y)
    }

    #[inline(always)]
    unsafe fn gt(self, b: Self) -> [bool; 16] {
        self.test2(b, |x, y| x > y)
    }

    #[inline(always)]
    unsafe fn non_finite(self) -> [bool; 16] {
        self.test2(self, |x, _| !x.is_finite())
    }

    #[inline(always)]
    unsafe fn select(m: [bool; 16], a: Self, b: Self) -> Self {
        let mut out = b.0;
        for l in 0..lanes::<T>() {
            if m[l] {
                out[l] = a.0[l];
            }
        }
        Portable(out)
    }

    #[inline(always)]
    unsafe fn or(a: [bool; 16], b: [bool; 16]) -> [bool; 16] {
        core::array::from_fn(|l| a[l] | b[l])
    }

    #[inline(always)]
    unsafe fn and_not(a: [bool; 16], b: [bool; 16]) -> [bool; 16] {
        core::array::from_fn(|l| a[l] & !b[l])
    }

    #[inline(always)]
    unsafe fn bits(m: [bool; 16]) -> u32 {
        (0..16).fold(0, |b, l| b | (u32::from(m[l]) << l))
    }
}

/// A portable block's fused operation, `±x·a + b` on every lane, where an
/// x86-64 build without FMA runs on a CPU with it: the lanes in one
/// function compiled with FMA (the compiler's vector instructions), not a
/// call to an `fma` routine for each lane. The same bits: both round once.
///
/// # Safety
/// The CPU has FMA.
#[cfg(all(feature = "std", target_arch = "x86_64", not(target_feature = "fma")))]
#[target_feature(enable = "fma")]
#[inline(never)]
unsafe fn fused_lanes<T: Real, const NEGATE: bool>(
    x: Portable<T>,
    a: Portable<T>,
    b: Portable<T>,
) -> Portable<T> {
    x.map3(a, b, |x, a, b| {
        if NEGATE {
            (-x).fused_mul_add(a, b)
        } else {
            x.fused_mul_add(a, b)
        }
    })
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
            fn portable<T: Real, W: BlockWork<T>>(work: W) -> W::Output {
                work.run(Ops::<T, Portable<T>>(core::marker::PhantomData))
            }
            portable::<T, W>(work)
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
