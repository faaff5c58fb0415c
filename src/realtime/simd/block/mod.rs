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
        self.map3(a, b, |x, a, b| x.fused_mul_add(a, b))
    }

    #[inline(always)]
    unsafe fn neg_mul_add(self, a: Self, b: Self) -> Self {
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

#[cfg(all(feature = "std", target_arch = "x86_64"))]
pub(crate) use x86::{Avx2, Avx512};

#[cfg(all(feature = "std", target_arch = "x86_64"))]
mod half;
#[cfg(all(feature = "std", target_arch = "x86_64"))]
mod x86;
#[cfg(all(feature = "std", target_arch = "x86_64"))]
pub(crate) use half::Avx2Half;

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
mod tests {
    use super::*;
    use crate::realtime::simd::Kernels;

    /// `add_on_multiplier`, `add`, `sub_on_multiplier` and `sub` of every
    /// pair of `values`, lane by lane.
    struct AddBoth<'a, T>(&'a [T], &'a [T]);

    impl<T: Real> BlockWork<T> for AddBoth<'_, T> {
        type Output = [Vec<T>; 4];

        fn run<V: Block<T>>(self, o: Ops<T, V>) -> Self::Output {
            let one = o.splat(core::hint::black_box(T::ONE));
            let mut out: [Vec<T>; 4] = Default::default();
            let width = lanes::<T>();
            for (a, b) in self.0.chunks_exact(width).zip(self.1.chunks_exact(width)) {
                let (a, b) = (o.load_values(a), o.load_values(b));
                let mut row = Row::default();
                let results = [
                    o.add_on_multiplier(a, b, one),
                    o.add(a, b),
                    o.sub_on_multiplier(a, b, one),
                    o.sub(a, b),
                ];
                for (r, v) in results.into_iter().zip(&mut out) {
                    o.store(r, &mut row);
                    v.extend_from_slice(row.lanes::<T>());
                }
            }
            out
        }
    }

    /// Every pair of signed zeros, subnormals, ones, the largest values,
    /// infinities, sums that cancel exactly and seeded random values: the
    /// fused `b · 1 + a` gives the bits of `a + b`, and `−(b · 1) + a` those
    /// of `a − b`, on every kernel set (one rounding of an exact product,
    /// IEEE 754).
    fn fused_addition_is_addition<T: Real>() {
        let special = [
            0.0,
            -0.0,
            1.0,
            -1.0,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
            1e-310,
            -1e-310,
            f64::MAX,
            -f64::MAX,
            f64::INFINITY,
            -f64::INFINITY,
            0.1,
            -0.1,
            3.0e38,
            1.0e-45,
        ];
        let mut seed = 0x2545_f491_4f6c_dd1d_u64;
        let mut random = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        let mut values: Vec<T> = special.iter().map(|&x| T::from_f64(x)).collect();
        for _ in 0..200 {
            let x = random() * 10f64.powf(random() * 30.0);
            values.push(T::from_f64(x));
            values.push(T::from_f64(-x)); // exact cancellation: a + (−a)
        }
        let (mut a, mut b) = (Vec::new(), Vec::new());
        for &x in &values {
            for &y in &values {
                a.push(x);
                b.push(y);
            }
        }
        let width = lanes::<T>();
        while a.len() % width != 0 {
            a.push(T::ZERO);
            b.push(T::ZERO);
        }
        for k in Kernels::all() {
            let [fused, added, fused_sub, subtracted] = run_blocks(k, AddBoth(&a, &b));
            let bits = |x: T| x.to_f64().to_bits();
            #[allow(clippy::eq_op)] // x != x: NaN
            let nan = |x: T| x != x;
            // the scalar result is the reference; ∞ − ∞ is a NaN on every
            // path, its payload not compared
            let same = |f: T, s: T, exact: T| {
                if nan(exact) {
                    nan(f) && nan(s)
                } else {
                    bits(f) == bits(exact) && bits(s) == bits(exact)
                }
            };
            for i in 0..a.len() {
                let (f, s) = (fused[i], added[i]);
                assert!(
                    same(f, s, a[i] + b[i]),
                    "{k:?}: {:?} + {:?}: fused {f:?}, added {s:?}",
                    a[i],
                    b[i]
                );
                let (f, s) = (fused_sub[i], subtracted[i]);
                assert!(
                    same(f, s, a[i] - b[i]),
                    "{k:?}: {:?} − {:?}: fused {f:?}, subtracted {s:?}",
                    a[i],
                    b[i]
                );
            }
        }
    }

    #[test]
    fn fused_addition_and_subtraction_give_their_bits_on_every_kernel_set() {
        fused_addition_is_addition::<f64>();
        fused_addition_is_addition::<f32>();
    }

    /// Every operation of a block on rows `a`, `b`, `c` (lanes of values):
    /// the result rows and the masks' bits, computed on the whole block
    /// and, where `V` has halves, on its halves (each writing its half of
    /// the rows; where it has none, the block twice).
    struct Halves<'a, T>(&'a [T], &'a [T], &'a [T]);

    /// Each operation of [`Halves`] on one block type, `values` being the
    /// first row's lanes in a slice (for `load_values`): its rows and bits.
    #[inline(always)]
    fn all_operations<T: Real, W: Block<T>>(
        o: Ops<T, W>,
        values: &[T],
        rows: [&Row; 3],
        out: &mut [Row; 14],
    ) -> u32 {
        let (a, b, c) = (o.load(rows[0]), o.load(rows[1]), o.load(rows[2]));
        let one = o.splat(T::ONE);
        let results = [
            o.add(a, b),
            o.sub(a, b),
            o.clamp(a, c, b),
            o.mul(a, b),
            o.mul_add(a, b, c),
            o.neg_mul_add(a, b, c),
            o.clamp(a, b, c),
            o.add_on_multiplier(a, b, one),
            o.sub_on_multiplier(a, b, one),
            o.select(o.lt(a, b), a, c),
            o.select(o.gt(a, b), b, c),
            o.select(o.or(o.non_finite(a), o.lt(b, c)), a, b),
            o.load_values(values),
        ];
        for (v, row) in results.into_iter().zip(out.iter_mut()) {
            o.store(v, row);
        }
        // `store_except` into the last row, which starts as `c`
        o.store_except(a, o.and_not(o.gt(a, c), o.non_finite(b)), &mut out[13]);
        o.bits(o.and_not(o.lt(a, b), o.non_finite(c)))
    }

    impl<T: Real> BlockWork<T> for Halves<'_, T> {
        /// Per block: the whole's rows and bits, the halves' rows and bits.
        type Output = Vec<(([Row; 14], u32), ([Row; 14], u32))>;

        fn run<V: Block<T>>(self, o: Ops<T, V>) -> Self::Output {
            let width = lanes::<T>();
            let row = |values: &[T]| {
                let mut r = Row::default();
                r.lanes_mut().copy_from_slice(values);
                r
            };
            let blocks = self.0.chunks_exact(width).zip(self.1.chunks_exact(width));
            blocks
                .zip(self.2.chunks_exact(width))
                .map(|((a, b), c)| {
                    let rows = [&row(a), &row(b), &row(c)];
                    let mut whole = [row(c); 14];
                    let whole_bits = all_operations(o, a, rows, &mut whole);
                    let mut halves = [row(c); 14];
                    let (lo, hi) = o.halves();
                    let bits = all_operations(lo, a, rows, &mut halves)
                        | all_operations(hi, a, rows, &mut halves);
                    ((whole, whole_bits), (halves, bits))
                })
                .collect()
        }
    }

    /// Each operation on a block's halves in turn gives its bits on the
    /// whole block, for signed zeros, infinities, NaN and seeded random
    /// values, on every kernel set (the AVX2 creep pass runs on halves).
    fn halves_are_the_block<T: Real>() {
        let special = [
            0.0,
            -0.0,
            1.0,
            -1.0,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            1e-310,
        ];
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut random = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 200.0 - 100.0
        };
        let n = 64 * lanes::<T>();
        let mut pick = |i: usize| {
            let x = if i.is_multiple_of(5) {
                special[(i / 5) % special.len()]
            } else {
                random()
            };
            T::from_f64(x)
        };
        let a: Vec<T> = (0..n).map(&mut pick).collect();
        let b: Vec<T> = (0..n).map(|i| pick(i + 1)).collect();
        let c: Vec<T> = (0..n).map(|i| pick(i + 3)).collect();
        for k in Kernels::all() {
            for (i, ((whole, whole_bits), (halves, bits))) in
                run_blocks(k, Halves(&a, &b, &c)).into_iter().enumerate()
            {
                assert_eq!(whole, halves, "{k:?}, block {i}: rows");
                assert_eq!(whole_bits, bits, "{k:?}, block {i}: mask bits");
            }
        }
    }

    #[test]
    fn each_half_of_a_block_gives_the_blocks_bits() {
        halves_are_the_block::<f64>();
        halves_are_the_block::<f32>();
    }
}
