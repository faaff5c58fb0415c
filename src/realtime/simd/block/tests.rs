//! The blocks' arithmetic against the scalar one, and their halves
//! against the whole, on every kernel set.
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

/// The edge cases both tests feed the blocks: signed zeros, ones, the
/// smallest normal and a subnormal (`f64`; `1e-45` is `f32`'s), the
/// largest values, infinities, and a few ordinary ones. No NaN: with two
/// NaN operands, `b · 1 + a` and `a + b` need not keep the same payload.
const SPECIAL: [f64; 16] = [
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

/// A seeded xorshift sequence of values in `[−1, 1)`.
fn seeded() -> impl FnMut() -> f64 {
    let mut seed = 0x2545_f491_4f6c_dd1d_u64;
    move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    }
}

/// Every pair of signed zeros, subnormals, ones, the largest values,
/// infinities, sums that cancel exactly and seeded random values: the
/// fused `b · 1 + a` gives the bits of `a + b`, and `−(b · 1) + a` those
/// of `a − b`, on every kernel set (one rounding of an exact product,
/// IEEE 754).
fn fused_addition_is_addition<T: Real>() {
    let mut random = seeded();
    let mut values: Vec<T> = SPECIAL.iter().map(|&x| T::from_f64(x)).collect();
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
/// The AVX2 block is its two halves, so there this checks that they
/// compose: each loads and stores its own half of a row and gives its
/// own lanes' bits. So the mask's bits are also checked against the
/// lanes' comparisons; the lanes' values are checked against the scalar
/// arithmetic by the test above and the bank's tests.
fn halves_are_the_block<T: Real>() {
    // the halves must carry a NaN through as the whole block does
    let special: Vec<f64> = SPECIAL.iter().copied().chain([f64::NAN]).collect();
    let mut random = seeded();
    let width = lanes::<T>();
    let n = 64 * width;
    let mut pick = |i: usize| {
        let x = if i.is_multiple_of(5) {
            special[(i / 5) % special.len()]
        } else {
            100.0 * random()
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
            // the bits against the lanes, which the comparison of whole and
            // halves cannot see where the block is made of its halves
            let lanes = (i * width..(i + 1) * width).enumerate();
            let expected = lanes
                .filter(|&(_, j)| a[j] < b[j] && c[j].is_finite())
                .fold(0u32, |m, (l, _)| m | 1 << l);
            assert_eq!(whole_bits, expected, "{k:?}, block {i}: bit l for lane l");
        }
    }
}

#[test]
fn each_half_of_a_block_gives_the_blocks_bits() {
    halves_are_the_block::<f64>();
    halves_are_the_block::<f32>();
}

/// `load_first` of each length of `values` from 0 to a block's: its rows.
struct FirstLanes<'a, T>(&'a [T]);

impl<T: Real> BlockWork<T> for FirstLanes<'_, T> {
    type Output = Vec<Row>;

    fn run<V: Block<T>>(self, o: Ops<T, V>) -> Self::Output {
        (0..=lanes::<T>())
            .map(|n| {
                // each length in a slice of its own: nothing after it to read
                let values = self.0[..n].to_vec();
                let mut row = Row::default();
                o.store(o.load_first(&values), &mut row);
                row
            })
            .collect()
    }
}

/// `load_first` gives the values' bits in the first lanes and `+0` in the
/// others, for every length up to a block's, on every kernel set: signed
/// zeros, a NaN, infinities and a subnormal among the values.
fn first_lanes_are_the_values<T: Real>() {
    let width = lanes::<T>();
    let values: Vec<T> = [-0.0, f64::NAN, f64::INFINITY, -f64::INFINITY, 1e-310]
        .into_iter()
        .chain((1..).map(|i| -0.5 * i as f64))
        .take(width)
        .map(T::from_f64)
        .collect();
    for k in Kernels::all() {
        for (n, row) in run_blocks(k, FirstLanes(&values)).into_iter().enumerate() {
            let bits: Vec<u64> = row
                .lanes::<T>()
                .iter()
                .map(|x| x.to_f64().to_bits())
                .collect();
            let expected: Vec<u64> = (0..width)
                .map(|l| values.get(l).filter(|_| l < n).copied().unwrap_or(T::ZERO))
                .map(|x| x.to_f64().to_bits())
                .collect();
            assert_eq!(bits, expected, "{k:?}, {n} values");
        }
    }
}

#[test]
fn a_partial_block_loads_its_values_and_zeros() {
    first_lanes_are_the_values::<f64>();
    first_lanes_are_the_values::<f32>();
}

/// [`all_operations`] on each block of `a`, `b`, `c` on the portable
/// block `Portable<T, FUSED>`: its rows and mask bits.
fn portable_operations<T: Real, const FUSED: bool>(
    a: &[T],
    b: &[T],
    c: &[T],
) -> Vec<([Row; 14], u32)> {
    let width = lanes::<T>();
    let row = |values: &[T]| {
        let mut r = Row::default();
        r.lanes_mut().copy_from_slice(values);
        r
    };
    let o = Ops::<T, Portable<T, FUSED>>(core::marker::PhantomData);
    (0..a.len() / width)
        .map(|i| {
            let lanes = i * width..(i + 1) * width;
            let (x, y, z) = (&a[lanes.clone()], &b[lanes.clone()], &c[lanes]);
            let mut out = [row(z); 14];
            let bits = all_operations(o, x, [&row(x), &row(y), &row(z)], &mut out);
            (out, bits)
        })
        .collect()
}

/// Each operation of a portable block, lane by lane, against the scalar
/// arithmetic it stands for (`min` and `max` as the block defines them,
/// the fused operations as `Real::fused_mul_add`), for signed zeros,
/// subnormals, infinities, NaN and seeded random values. On x86-64 both
/// forms run where the CPU has FMA: the fused instruction on 128-bit
/// registers and the per-lane `fma`; elsewhere the one the build has.
fn portable_blocks_are_the_scalar_arithmetic<T: Real>() {
    let special: Vec<f64> = SPECIAL.iter().copied().chain([f64::NAN]).collect();
    let mut random = seeded();
    let width = lanes::<T>();
    let n = 64 * width;
    let mut pick = |i: usize| {
        let x = if i.is_multiple_of(3) {
            special[(i / 3) % special.len()]
        } else {
            100.0 * random() * 10f64.powf(random() * 4.0)
        };
        T::from_f64(x)
    };
    let a: Vec<T> = (0..n).map(&mut pick).collect();
    let b: Vec<T> = (0..n).map(|i| pick(i + 1)).collect();
    let c: Vec<T> = (0..n).map(|i| pick(i + 2)).collect();
    let min = |x: T, y: T| if x < y { x } else { y };
    let max = |x: T, y: T| if x > y { x } else { y };
    let expected = |j: usize| -> [T; 14] {
        let (x, y, z) = (a[j], b[j], c[j]);
        [
            x + y,
            x - y,
            max(min(x, y), z),
            x * y,
            x.fused_mul_add(y, z),
            (-x).fused_mul_add(y, z),
            max(min(x, z), y),
            x + y,
            x - y,
            if x < y { x } else { z },
            if x > y { y } else { z },
            if !x.is_finite() || y < z { x } else { y },
            x,
            if x > z && y.is_finite() { z } else { x },
        ]
    };
    #[allow(clippy::eq_op)] // x != x: NaN
    let same = |x: T, y: T| x.to_f64().to_bits() == y.to_f64().to_bits() || (x != x && y != y);
    #[cfg_attr(not(target_arch = "x86_64"), allow(unused_mut))] // x86-64 adds one
    let mut forms = vec![("per lane", portable_operations::<T, false>(&a, &b, &c))];
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("fma") {
        forms.push(("fused", portable_operations::<T, true>(&a, &b, &c)));
    }
    for (form, blocks) in forms {
        for (i, (rows, bits)) in blocks.iter().enumerate() {
            for l in 0..width {
                let j = i * width + l;
                for (op, want) in expected(j).into_iter().enumerate() {
                    let got = rows[op].lanes::<T>()[l];
                    assert!(
                        same(got, want),
                        "{form}, operation {op} of {:?}, {:?}, {:?}: {got:?}, not {want:?}",
                        a[j],
                        b[j],
                        c[j]
                    );
                }
                let flag = a[j] < b[j] && c[j].is_finite();
                assert_eq!(bits >> l & 1 == 1, flag, "{form}, block {i}, lane {l}: bit");
            }
        }
    }
}

#[test]
fn portable_blocks_compute_the_scalar_bits() {
    portable_blocks_are_the_scalar_arithmetic::<f64>();
    portable_blocks_are_the_scalar_arithmetic::<f32>();
}
