//! The compensator step ([`crate::realtime::compensator_step`]) on vector
//! registers: `f64` in 4-lane AVX2 registers or 8-lane AVX-512 ones, `f32`
//! in 8-lane AVX2 registers or 16-lane AVX-512 ones. One kernel, written over [`Wide`]: a register
//! holds one or two groups of four lanes, so the canonical sums (groups to
//! accumulators, halving, the four lanes as `(l₀ + l₂) + (l₁ + l₃)`) are
//! the same additions in every width, and the bits are the portable ones.
//! The four lanes are summed by two shuffles that leave the sum in every
//! lane, so `v` and `Δ` never leave the vector registers on the chain.

use core::arch::x86_64::*;

use crate::realtime::compensator_step::{
    padded_groups, CreepParts, StepParts, CREEP_ACCUMULATORS, PLAY_ACCUMULATORS,
};
use crate::realtime::real::Real;

/// A register of one, two or four groups of four lanes.
pub(super) trait Wide: Copy {
    type T: Real;
    /// A register of four lanes.
    type Four: Copy;
    /// Groups of four lanes per register: 1, 2 or 4.
    const GROUPS: usize;
    unsafe fn splat(x: Self::T) -> Self;
    unsafe fn load(p: *const Self::T) -> Self;
    unsafe fn store(self, p: *mut Self::T);
    /// The first `k` lanes (`0 < k < 4 GROUPS`) from `p`, the others `pad`
    /// (masked: nothing beyond `p + k` is read).
    unsafe fn load_first(p: *const Self::T, k: usize, pad: Self::T) -> Self;
    /// The first `k` lanes to `p` (masked: nothing beyond `p + k` is
    /// written).
    unsafe fn store_first(self, p: *mut Self::T, k: usize);
    unsafe fn add(self, b: Self) -> Self;
    unsafe fn sub(self, b: Self) -> Self;
    unsafe fn mul(self, b: Self) -> Self;
    /// `a < b ? a : b` (and `a > b ? a : b` for `max`), as `play::clamp`.
    unsafe fn min(self, b: Self) -> Self;
    unsafe fn max(self, b: Self) -> Self;
    /// The groups added as the canonical halving adds them (one group:
    /// itself; two: lanes 0–3 plus 4–7; four: groups 0 + 2 and 1 + 3,
    /// then those two).
    unsafe fn fold(self) -> Self::Four;
    /// `(l₀ + l₂) + (l₁ + l₃)` in every lane.
    unsafe fn four_sum(x: Self::Four) -> Self::Four;
    /// Lane 0 of a four-lane register in every lane.
    unsafe fn spread(x: Self::Four) -> Self;
    /// Lane 0.
    unsafe fn first(x: Self::Four) -> Self::T;
}

macro_rules! wide {
    ($name:ident, $feature:literal, $t:ty, $v:ty, $four:ty, $groups:expr,
     [$set1:ident, $loadu:ident, $storeu:ident, $add:ident, $sub:ident, $mul:ident, $min:ident, $max:ident],
     load_first: |$lp:ident, $lk:ident, $lpad:ident| $load_first:expr,
     store_first: |$sv:ident, $sp:ident, $sk:ident| $store_first:expr,
     fold: |$fx:ident| $fold:expr, four_sum: |$sx:ident| $four_sum:expr,
     spread: |$px:ident| $spread:expr, first: |$lx:ident| $first:expr) => {
        #[derive(Clone, Copy)]
        pub(super) struct $name($v);

        impl Wide for $name {
            type T = $t;
            type Four = $four;
            const GROUPS: usize = $groups;
            #[target_feature(enable = $feature)]
            #[inline]
            unsafe fn splat(x: $t) -> Self {
                $name($set1(x))
            }
            #[target_feature(enable = $feature)]
            #[inline]
            unsafe fn load(p: *const $t) -> Self {
                // SAFETY: the caller's (a whole register inside a slice)
                $name(unsafe { $loadu(p) })
            }
            #[target_feature(enable = $feature)]
            #[inline]
            unsafe fn store(self, p: *mut $t) {
                // SAFETY: as for `load`
                unsafe { $storeu(p, self.0) }
            }
            #[target_feature(enable = $feature)]
            #[inline]
            unsafe fn load_first($lp: *const $t, $lk: usize, $lpad: $t) -> Self {
                // SAFETY: the caller's (the first k lanes lie inside a slice)
                $name(unsafe { $load_first })
            }
            #[target_feature(enable = $feature)]
            #[inline]
            unsafe fn store_first(self, $sp: *mut $t, $sk: usize) {
                let $sv = self.0;
                // SAFETY: as for `load_first`
                unsafe { $store_first }
            }
            #[target_feature(enable = $feature)]
            #[inline]
            unsafe fn add(self, b: Self) -> Self {
                $name($add(self.0, b.0))
            }
            #[target_feature(enable = $feature)]
            #[inline]
            unsafe fn sub(self, b: Self) -> Self {
                $name($sub(self.0, b.0))
            }
            #[target_feature(enable = $feature)]
            #[inline]
            unsafe fn mul(self, b: Self) -> Self {
                $name($mul(self.0, b.0))
            }
            #[target_feature(enable = $feature)]
            #[inline]
            unsafe fn min(self, b: Self) -> Self {
                $name($min(self.0, b.0))
            }
            #[target_feature(enable = $feature)]
            #[inline]
            unsafe fn max(self, b: Self) -> Self {
                $name($max(self.0, b.0))
            }
            #[target_feature(enable = $feature)]
            #[inline]
            unsafe fn fold(self) -> $four {
                let $fx = self.0;
                $fold
            }
            #[target_feature(enable = $feature)]
            #[inline]
            unsafe fn four_sum($sx: $four) -> $four {
                $four_sum
            }
            #[target_feature(enable = $feature)]
            #[inline]
            unsafe fn spread($px: $four) -> Self {
                $name($spread)
            }
            #[target_feature(enable = $feature)]
            #[inline]
            unsafe fn first($lx: $four) -> $t {
                $first
            }
        }
    };
}

wide!(
    F64x4,
    "avx2",
    f64,
    __m256d,
    __m256d,
    1,
    [
        _mm256_set1_pd,
        _mm256_loadu_pd,
        _mm256_storeu_pd,
        _mm256_add_pd,
        _mm256_sub_pd,
        _mm256_mul_pd,
        _mm256_min_pd,
        _mm256_max_pd
    ],
    load_first: |p, k, pad| {
        let mask = first_lanes_64(k);
        _mm256_blendv_pd(
            _mm256_set1_pd(pad),
            _mm256_maskload_pd(p, mask),
            _mm256_castsi256_pd(mask),
        )
    },
    store_first: |v, p, k| _mm256_maskstore_pd(p, first_lanes_64(k), v),
    fold: |x| x,
    four_sum: |x| {
        // (l0 + l2, l1 + l3, l2 + l0, l3 + l1), then each lane plus its pair
        let s = _mm256_add_pd(x, _mm256_permute2f128_pd::<1>(x, x));
        _mm256_add_pd(s, _mm256_permute_pd::<0b0101>(s))
    },
    spread: |x| x,
    first: |x| _mm256_cvtsd_f64(x)
);

wide!(
    F64x8,
    "avx2,avx512f",
    f64,
    __m512d,
    __m256d,
    2,
    [
        _mm512_set1_pd,
        _mm512_loadu_pd,
        _mm512_storeu_pd,
        _mm512_add_pd,
        _mm512_sub_pd,
        _mm512_mul_pd,
        _mm512_min_pd,
        _mm512_max_pd
    ],
    load_first: |p, k, pad| _mm512_mask_loadu_pd(_mm512_set1_pd(pad), (1u8 << k) - 1, p),
    store_first: |v, p, k| _mm512_mask_storeu_pd(p, (1u8 << k) - 1, v),
    fold: |x| _mm256_add_pd(_mm512_castpd512_pd256(x), _mm512_extractf64x4_pd::<1>(x)),
    four_sum: |x| {
        let s = _mm256_add_pd(x, _mm256_permute2f128_pd::<1>(x, x));
        _mm256_add_pd(s, _mm256_permute_pd::<0b0101>(s))
    },
    spread: |x| _mm512_broadcastsd_pd(_mm256_castpd256_pd128(x)),
    first: |x| _mm256_cvtsd_f64(x)
);

wide!(
    F32x8,
    "avx2",
    f32,
    __m256,
    __m128,
    2,
    [
        _mm256_set1_ps,
        _mm256_loadu_ps,
        _mm256_storeu_ps,
        _mm256_add_ps,
        _mm256_sub_ps,
        _mm256_mul_ps,
        _mm256_min_ps,
        _mm256_max_ps
    ],
    load_first: |p, k, pad| {
        let mask = first_lanes_32(k);
        _mm256_blendv_ps(
            _mm256_set1_ps(pad),
            _mm256_maskload_ps(p, mask),
            _mm256_castsi256_ps(mask),
        )
    },
    store_first: |v, p, k| _mm256_maskstore_ps(p, first_lanes_32(k), v),
    fold: |x| _mm_add_ps(_mm256_castps256_ps128(x), _mm256_extractf128_ps::<1>(x)),
    four_sum: |x| {
        let s = _mm_add_ps(x, _mm_permute_ps::<0b01_00_11_10>(x));
        _mm_add_ps(s, _mm_permute_ps::<0b10_11_00_01>(s))
    },
    spread: |x| _mm256_broadcastss_ps(x),
    first: |x| _mm_cvtss_f32(x)
);

wide!(
    F32x16,
    "avx2,avx512f",
    f32,
    __m512,
    __m128,
    4,
    [
        _mm512_set1_ps,
        _mm512_loadu_ps,
        _mm512_storeu_ps,
        _mm512_add_ps,
        _mm512_sub_ps,
        _mm512_mul_ps,
        _mm512_min_ps,
        _mm512_max_ps
    ],
    load_first: |p, k, pad| _mm512_mask_loadu_ps(_mm512_set1_ps(pad), ((1u32 << k) - 1) as u16, p),
    store_first: |v, p, k| _mm512_mask_storeu_ps(p, ((1u32 << k) - 1) as u16, v),
    // groups (0, 2) and (1, 3), then (0, 1): the canonical halving
    fold: |x| {
        let half = _mm256_add_ps(
            _mm512_castps512_ps256(x),
            _mm256_castpd_ps(_mm512_extractf64x4_pd::<1>(_mm512_castps_pd(x))),
        );
        _mm_add_ps(_mm256_castps256_ps128(half), _mm256_extractf128_ps::<1>(half))
    },
    four_sum: |x| {
        let s = _mm_add_ps(x, _mm_permute_ps::<0b01_00_11_10>(x));
        _mm_add_ps(s, _mm_permute_ps::<0b10_11_00_01>(s))
    },
    spread: |x| _mm512_broadcastss_ps(x),
    first: |x| _mm_cvtss_f32(x)
);

/// All bits set in the 64-bit lanes below `k`.
#[target_feature(enable = "avx2")]
#[inline]
fn first_lanes_64(k: usize) -> __m256i {
    _mm256_cmpgt_epi64(_mm256_set1_epi64x(k as i64), _mm256_setr_epi64x(0, 1, 2, 3))
}

/// All bits set in the 32-bit lanes below `k`.
#[target_feature(enable = "avx2")]
#[inline]
fn first_lanes_32(k: usize) -> __m256i {
    _mm256_cmpgt_epi32(
        _mm256_set1_epi32(k as i32),
        _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7),
    )
}

/// A register of lanes `e0..e0 + 4 GROUPS` of `x` (`e0 < x.len()`), lanes
/// at or beyond the slice's end `pad`.
#[inline(always)]
unsafe fn load_padded<V: Wide>(x: &[V::T], e0: usize, pad: V::T) -> V {
    let w = 4 * V::GROUPS;
    debug_assert!(e0 < x.len());
    // SAFETY: the lanes read lie inside the slice; features: the caller's
    unsafe {
        if e0 + w <= x.len() {
            V::load(x.as_ptr().add(e0))
        } else {
            V::load_first(x.as_ptr().add(e0), x.len() - e0, pad)
        }
    }
}

/// Store the lanes of `r` that lie inside `x` from `e0 < x.len()` on.
#[inline(always)]
unsafe fn store_inside<V: Wide>(r: V, x: &mut [V::T], e0: usize) {
    let w = 4 * V::GROUPS;
    debug_assert!(e0 < x.len());
    // SAFETY: the lanes written lie inside the slice; features: the caller's
    unsafe {
        if e0 + w <= x.len() {
            r.store(x.as_mut_ptr().add(e0))
        } else {
            r.store_first(x.as_mut_ptr().add(e0), x.len() - e0)
        }
    }
}

/// The accumulators (`A / GROUPS` registers) added by halving, the groups
/// folded and the four lanes summed: the canonical sum, in every lane.
#[inline(always)]
unsafe fn finish<V: Wide>(acc: &[V]) -> V::Four {
    let mut acc_regs = [acc[0]; 8];
    acc_regs[..acc.len()].copy_from_slice(acc);
    let mut h = acc.len() / 2;
    // SAFETY (all): features: the caller's
    unsafe {
        while h >= 1 {
            for a in 0..h {
                acc_regs[a] = acc_regs[a].add(acc_regs[a + h]);
            }
            h /= 2;
        }
        V::four_sum(acc_regs[0].fold())
    }
}

/// [`crate::realtime::compensator_step::step`] on `V`'s registers (with
/// more plays than it keeps in registers, the portable step, compiled with
/// the same features: the same bits).
#[inline(always)]
pub(super) unsafe fn step<V: Wide>(
    parts: StepParts<'_, V::T>,
    scratch: &mut [V::T],
    z: V::T,
    delta: V::T,
    lower: V::T,
    upper: V::T,
) -> Result<(V::T, V::T), V::T> {
    let n = parts.inv_x.len();
    assert!(parts.inv_r.len() == n && parts.inv_w.len() == n);
    // SAFETY (all): features: the caller's
    unsafe {
        // the registers of plays are a whole number of accumulators: 4 or
        // 2 in one run, 8 or 4 in two
        match padded_groups(n) / V::GROUPS {
            1 => step_with::<V, 1>(parts, z, delta, lower, upper),
            2 => step_with::<V, 2>(parts, z, delta, lower, upper),
            4 => step_with::<V, 4>(parts, z, delta, lower, upper),
            8 => step_with::<V, 8>(parts, z, delta, lower, upper),
            _ => crate::realtime::compensator_step::step(parts, scratch, z, delta, lower, upper),
        }
    }
}

/// [`step`] with `P` registers of plays, kept in registers throughout.
#[inline(always)]
unsafe fn step_with<V: Wide, const P: usize>(
    parts: StepParts<'_, V::T>,
    z: V::T,
    delta: V::T,
    lower: V::T,
    upper: V::T,
) -> Result<(V::T, V::T), V::T> {
    let n = parts.inv_x.len();
    let w = 4 * V::GROUPS;
    let (zero, inf) = (V::T::ZERO, V::T::INFINITY);
    // SAFETY (all): features: the caller's; every load and store lies
    // inside its slice (`load_padded`, `store_inside`).
    unsafe {
        let (zv, dv) = (V::splat(z), V::splat(delta));
        let play_acc = PLAY_ACCUMULATORS / V::GROUPS;
        let mut xs = [V::splat(zero); P];
        let mut acc = [V::splat(zero); PLAY_ACCUMULATORS];
        let (inv_r, inv_x, inv_w) = (
            parts.inv_r.as_ptr(),
            parts.inv_x.as_ptr(),
            parts.inv_w.as_ptr(),
        );
        for (q, x) in xs.iter_mut().enumerate() {
            let e0 = q * w;
            let product = if e0 + w <= n {
                let r = V::load(inv_r.add(e0));
                let upper = zv.add(r).sub(dv);
                let lower = zv.sub(r).sub(dv);
                *x = V::load(inv_x.add(e0)).min(upper).max(lower);
                V::load(inv_w.add(e0)).mul(*x)
            } else if e0 < n {
                // padding: x' = 0, r' = ∞, w' = 0, so x' stays 0 and adds +0
                let r = V::load_first(inv_r.add(e0), n - e0, inf);
                let upper = zv.add(r).sub(dv);
                let lower = zv.sub(r).sub(dv);
                *x = V::load_first(inv_x.add(e0), n - e0, zero)
                    .min(upper)
                    .max(lower);
                V::load_first(inv_w.add(e0), n - e0, zero).mul(*x)
            } else {
                V::splat(zero)
            };
            let a = q % play_acc;
            acc[a] = if q < play_acc {
                product
            } else {
                acc[a].add(product)
            };
        }
        let v4 = finish::<V>(&acc[..play_acc]);
        let v = V::first(v4);
        if !(v >= lower && v <= upper) {
            return Err(v);
        }
        for (q, &x) in xs.iter().enumerate() {
            if q * w < n {
                store_inside(x, parts.inv_x, q * w);
            }
        }
        let increment = match parts.creep {
            Some(c) => creep::<V>(c, V::spread(v4)),
            None => zero,
        };
        Ok((v, increment))
    }
}

/// [`crate::realtime::compensator_step::creep_increment`] on `V`'s
/// registers for the input `u` (in every lane).
#[inline(always)]
unsafe fn creep<V: Wide>(c: CreepParts<'_, V::T>, u: V) -> V::T {
    let len = c.chi.len();
    assert!(c.r.len() == len && c.minus_r.len() == len);
    assert!(c.gain.len() == len && c.q.len() == len);
    let w = 4 * V::GROUPS;
    // registers the canonical sum adds (whole ones, partial, then +0), and
    // the whole ones
    let registers = padded_groups(len) / V::GROUPS;
    let whole = len / w;
    let (zero, inf) = (V::T::ZERO, V::T::INFINITY);
    let (chi, r, minus_r) = (c.chi.as_mut_ptr(), c.r.as_ptr(), c.minus_r.as_ptr());
    let (gain, q) = (c.gain.as_ptr(), c.q.as_ptr());
    // SAFETY (all): features: the caller's; `at(k)` is called for whole
    // registers only (k < whole), inside every slice; the partial one is
    // read and written masked.
    unsafe {
        let p = Pointers {
            chi,
            r,
            minus_r,
            gain,
            q,
        };
        let at = |k: usize| whole_register(&p, u, k * w);
        let mut acc = [V::splat(zero); CREEP_ACCUMULATORS];
        let runs = CREEP_ACCUMULATORS / V::GROUPS;
        let mut k = 0;
        if whole >= runs {
            // the first run assigns, whole runs add: no test per register
            for (a, acc) in acc.iter_mut().enumerate().take(runs) {
                *acc = at(a);
            }
            k = runs;
            while k + runs <= whole {
                for (a, acc) in acc.iter_mut().enumerate().take(runs) {
                    *acc = acc.add(at(k + a));
                }
                k += runs;
            }
        }
        // the rest, in whole runs (`registers` is a multiple of `runs`):
        // whole registers, the partial one (padding: χ = 0, r = ∞, −r = −∞,
        // g = q = 0, so d = +0) and +0
        while k < registers {
            for (a, acc) in acc.iter_mut().enumerate().take(runs) {
                let i = k + a;
                let product = if i < whole {
                    at(i)
                } else if i * w < len {
                    let e0 = i * w;
                    let x = load_padded::<V>(c.chi, e0, zero);
                    let z = x.sub(u);
                    let r = load_padded::<V>(c.r, e0, inf);
                    let minus_r = load_padded::<V>(c.minus_r, e0, -inf);
                    let d = z.min(r).max(minus_r).sub(z);
                    let g = load_padded::<V>(c.gain, e0, zero);
                    store_inside(x.add(g.mul(d)), c.chi, e0);
                    load_padded::<V>(c.q, e0, zero).mul(d)
                } else {
                    V::splat(zero)
                };
                *acc = if k == 0 { product } else { acc.add(product) };
            }
            k += runs;
        }
        V::first(finish::<V>(&acc[..runs]))
    }
}

/// Where the creep's flat arrays start.
struct Pointers<T> {
    chi: *mut T,
    r: *const T,
    minus_r: *const T,
    gain: *const T,
    q: *const T,
}

/// The whole register of elementary creep operators from `e0`: each
/// advanced, `q d` returned. A function, not a closure: a closure body is
/// compiled without the caller's features, every vector operation a call.
#[inline(always)]
unsafe fn whole_register<V: Wide>(p: &Pointers<V::T>, u: V, e0: usize) -> V {
    // SAFETY: the caller's (a whole register inside every array; features)
    unsafe {
        let x = V::load(p.chi.add(e0));
        let z = x.sub(u);
        let d = z
            .min(V::load(p.r.add(e0)))
            .max(V::load(p.minus_r.add(e0)))
            .sub(z);
        x.add(V::load(p.gain.add(e0)).mul(d)).store(p.chi.add(e0));
        V::load(p.q.add(e0)).mul(d)
    }
}
