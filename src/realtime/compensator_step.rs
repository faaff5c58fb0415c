//! One compensator step (21) written for its dependency chain, portable;
//! [`crate::realtime::simd`] runs the same arithmetic on vector registers.
//!
//! A step is a chain: the creep output `C_k` depends on `u_{k−1}`, the
//! plays of `H⁻¹` on `C_k`, `u_k` on the plays, and `C_{k+1}` on `u_k`.
//! Everything else (the target, `S⁻¹`, `G⁻¹`, the creep state update, the
//! saturation test) runs beside it. Three choices keep the chain short:
//!
//! * **The creep output is a running sum.** `C_{k+1} = C_k + Δ_k` with
//!   `Δ_k = Σ_e q_e d_e`, `q_e = (w_i/m) g_j` and the dead zone
//!   `d_e = clamp(χ_e − u_k, −r_i, r_i) − (χ_e − u_k)` (14) of element
//!   `e = j n + i`; the update `χ_e ← χ_e + g_j d_e` (20) is off the chain.
//!   Every [`RESUM`] steps the output is summed again from `χ`, in the
//!   order the model sums it, so the running sum never drifts further
//!   than [`RESUM`] steps' rounding (bound in `docs/MATHEMATICS.md` §4.4).
//! * **The bounds of the plays are formed early.** With `C_k = B + Δ`
//!   (`B` the output before the last increment), the play bounds
//!   `y ∓ r'_i` are `(Z ∓ r'_i) − Δ` with `Z = S⁻¹[G⁻¹[ς_k − offset]] − B`:
//!   one subtraction after `Δ`.
//! * **Every sum is a tree.** [`canonical_sum`]: products in groups of four
//!   lanes, `A = 4` accumulators,
//!   then halving, then the four lanes as `(l₀ + l₂) + (l₁ + l₃)`, which a
//!   vector register computes with two shuffles and leaves in every lane.
//!   Groups are padded to a whole number of sixteen lanes, so that 4-, 8- and
//!   16-lane registers all compute the same sums: the bits do not depend
//!   on the instruction set.
//!
//! The saturation test is a branch, off the chain: the creep runs on the
//! unclipped `v`, and a clipped sample (rare) is redone by the caller.

use crate::realtime::creep::creep_gain;
use crate::realtime::creep_pass;
use crate::realtime::error::ParameterError;
use crate::realtime::hysteresis::reduce;
use crate::realtime::parameters::CreepParameters;
use crate::realtime::play::clamp;
use crate::realtime::real::Real;
use crate::realtime::storage::{Buffer, Storage};

/// Accumulators of the plays' sum.
pub(crate) const PLAY_ACCUMULATORS: usize = 4;
/// Accumulators of the creep increment's sum.
pub(crate) const CREEP_ACCUMULATORS: usize = 4;
/// Steps between two sums of the creep output from its state.
pub const RESUM: u32 = 64;

/// Groups of four lanes for a sum of `len` products: padded to a whole
/// number of sixteen lanes, the padding contributing `+0`.
#[inline(always)]
pub(crate) fn padded_groups(len: usize) -> usize {
    4 * len.div_ceil(16)
}

/// `a + b` lane by lane.
#[inline(always)]
pub(crate) fn add4<T: Real>(a: [T; 4], b: [T; 4]) -> [T; 4] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2], a[3] + b[3]]
}

/// The sum of products in the canonical order: group `g` (lanes `4g..4g+4`)
/// goes to accumulator `g mod A` (the first group of each accumulator is
/// its value, an accumulator without a group is `+0`), the accumulators are
/// added by halving (`a` and `a + h`, `h = A/2, …, 1`) and the four lanes
/// [`reduce`]d. Groups are pushed in order, `0, 1, …` (a struct, not a
/// closure: a closure may be left out of line, one call per group).
pub(crate) struct CanonicalSum<T, const A: usize> {
    acc: [[T; 4]; A],
}

impl<T: Real, const A: usize> CanonicalSum<T, A> {
    #[inline(always)]
    pub(crate) fn new() -> Self {
        Self {
            acc: [[T::ZERO; 4]; A],
        }
    }

    /// The products of group `g`, the groups pushed in order.
    #[inline(always)]
    pub(crate) fn push(&mut self, g: usize, p: [T; 4]) {
        let a = g % A;
        self.acc[a] = if g < A { p } else { add4(self.acc[a], p) };
    }

    #[inline(always)]
    pub(crate) fn finish(mut self) -> T {
        let mut h = A / 2;
        while h >= 1 {
            for a in 0..h {
                self.acc[a] = add4(self.acc[a], self.acc[a + h]);
            }
            h /= 2;
        }
        reduce(self.acc[0])
    }
}

/// The creep of a compensator as its step runs it: the parameters per
/// elementary operator (flat, `e = j n + i`, as `χ` is stored) and the
/// running output `base + delta`.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct RunningCreep<T: Real, S: Storage> {
    /// `r_i`, `−r_i`, `g_j` and `q_e = (w_i/m) g_j` of element `e`.
    pub r: S::Creep<T>,
    pub minus_r: S::Creep<T>,
    pub gain: S::Creep<T>,
    pub q: S::Creep<T>,
    /// The output before the last increment, the last increment, and the
    /// steps since the output was last summed from the state.
    pub base: T,
    pub delta: T,
    pub steps: u32,
}

impl<T: Real, S: Storage> RunningCreep<T, S> {
    /// The flat parameters of checked creep `parameters`, output zero.
    pub(crate) fn new(
        parameters: &CreepParameters<'_>,
        sample_time: f64,
    ) -> Result<Self, ParameterError> {
        let n = parameters.thresholds.len();
        let m = parameters.eigenvalues.len();
        let len = n.saturating_mul(m);
        let field = "creep";
        let mut c = Self {
            r: S::Creep::zeroed(field, len)?,
            minus_r: S::Creep::zeroed(field, len)?,
            gain: S::Creep::zeroed(field, len)?,
            q: S::Creep::zeroed(field, len)?,
            base: T::ZERO,
            delta: T::ZERO,
            steps: 0,
        };
        for (j, &a) in parameters.eigenvalues.iter().enumerate() {
            let g = creep_gain(a, sample_time);
            for i in 0..n {
                let e = j * n + i;
                let r = T::from_f64(parameters.thresholds[i]);
                c.r[e] = r;
                c.minus_r[e] = -r;
                c.gain[e] = T::from_f64(g);
                c.q[e] = T::from_f64(parameters.weights[i] / m as f64 * g);
            }
        }
        Ok(c)
    }

    /// The creep output `C_k` (off the chain: the step uses `base` and
    /// `delta` apart).
    #[inline(always)]
    pub(crate) fn output(&self) -> T {
        self.base + self.delta
    }

    /// The output summed from the state `chi` (weights `w_i/m`), as the
    /// model sums it.
    pub(crate) fn resum(&mut self, chi: &[T], scaled_weights: &[T]) {
        self.base = creep_pass::output(chi, scaled_weights);
        self.delta = T::ZERO;
        self.steps = 0;
    }

    /// After a step with increment `delta`: `C_{k+1} = C_k + Δ_k`, summed
    /// again from the state every [`RESUM`] steps.
    #[inline(always)]
    pub(crate) fn advance(&mut self, delta: T, chi: &[T], scaled_weights: &[T]) {
        self.base += self.delta;
        self.delta = delta;
        self.steps += 1;
        if self.steps >= RESUM {
            self.resum_cold(chi, scaled_weights);
        }
    }

    #[cold]
    #[inline(never)]
    fn resum_cold(&mut self, chi: &[T], scaled_weights: &[T]) {
        self.resum(chi, scaled_weights);
    }
}

/// What one step reads and writes: `H⁻¹`'s thresholds, weights and plays,
/// and the creep (flat parameters and `χ`), if any.
pub(crate) struct StepParts<'a, T> {
    pub inv_r: &'a [T],
    pub inv_w: &'a [T],
    pub inv_x: &'a mut [T],
    pub creep: Option<CreepParts<'a, T>>,
}

/// The creep's flat parameters and state for one step.
pub(crate) struct CreepParts<'a, T> {
    pub r: &'a [T],
    pub minus_r: &'a [T],
    pub gain: &'a [T],
    pub q: &'a [T],
    pub chi: &'a mut [T],
}

/// The plays of `H⁻¹` clamped into `[lower(r'_i), upper(r'_i)]` into
/// `next`, and `v = Σ w'_i x'_i` in the canonical order.
#[inline(always)]
pub(crate) fn plays<T: Real>(
    inv_r: &[T],
    inv_w: &[T],
    x: &[T],
    next: &mut [T],
    bounds: impl Fn(T) -> (T, T),
) -> T {
    let n = x.len();
    let (inv_r, inv_w, next) = (&inv_r[..n], &inv_w[..n], &mut next[..n]);
    let mut sum = CanonicalSum::<T, PLAY_ACCUMULATORS>::new();
    let whole = n / 4;
    for g in 0..whole {
        let e = 4 * g;
        let r: &[T; 4] = inv_r[e..e + 4].try_into().unwrap();
        let w: &[T; 4] = inv_w[e..e + 4].try_into().unwrap();
        let x: &[T; 4] = x[e..e + 4].try_into().unwrap();
        let next: &mut [T; 4] = (&mut next[e..e + 4]).try_into().unwrap();
        let b = r.map(&bounds);
        let x: [T; 4] = core::array::from_fn(|l| clamp(x[l], b[l].0, b[l].1));
        *next = x;
        sum.push(g, core::array::from_fn(|l| w[l] * x[l]));
    }
    for g in whole..padded_groups(n) {
        let mut p = [T::ZERO; 4];
        for (l, p) in p.iter_mut().enumerate() {
            let e = 4 * g + l;
            if e < n {
                let (lower, upper) = bounds(inv_r[e]);
                next[e] = clamp(x[e], lower, upper);
                *p = inv_w[e] * next[e];
            }
        }
        sum.push(g, p);
    }
    sum.finish()
}

/// The bounds of a play of threshold `r` in a step: `(Z − r) − Δ` and
/// `(Z + r) − Δ`.
#[inline(always)]
pub(crate) fn folded_bounds<T: Real>(z: T, delta: T, r: T) -> (T, T) {
    ((z - r) - delta, (z + r) - delta)
}

/// `Δ = Σ_e q_e d_e` for the input `v` (finite), in the canonical order,
/// with every `χ_e` advanced (20).
#[inline(always)]
pub(crate) fn creep_increment<T: Real>(c: &mut CreepParts<'_, T>, v: T) -> T {
    let len = c.chi.len();
    let (r, minus_r) = (&c.r[..len], &c.minus_r[..len]);
    let (gain, q, chi) = (&c.gain[..len], &c.q[..len], &mut *c.chi);
    let mut sum = CanonicalSum::<T, CREEP_ACCUMULATORS>::new();
    let whole = len / 4;
    for g in 0..whole {
        let e = 4 * g;
        let x: &mut [T; 4] = (&mut chi[e..e + 4]).try_into().unwrap();
        let r: &[T; 4] = r[e..e + 4].try_into().unwrap();
        let minus_r: &[T; 4] = minus_r[e..e + 4].try_into().unwrap();
        let gain: &[T; 4] = gain[e..e + 4].try_into().unwrap();
        let q: &[T; 4] = q[e..e + 4].try_into().unwrap();
        // one operation over the four lanes at a time: the form the
        // compiler turns into vector instructions
        let z = x.map(|x| x - v);
        let c: [T; 4] = core::array::from_fn(|l| clamp(z[l], minus_r[l], r[l]));
        let d: [T; 4] = core::array::from_fn(|l| c[l] - z[l]);
        let gd: [T; 4] = core::array::from_fn(|l| gain[l] * d[l]);
        for l in 0..4 {
            x[l] += gd[l];
        }
        sum.push(g, core::array::from_fn(|l| q[l] * d[l]));
    }
    for g in whole..padded_groups(len) {
        let mut p = [T::ZERO; 4];
        for (l, p) in p.iter_mut().enumerate() {
            let e = 4 * g + l;
            if e < len {
                let z = chi[e] - v;
                let d = clamp(z, minus_r[e], r[e]) - z;
                chi[e] += gain[e] * d;
                *p = q[e] * d;
            }
        }
        sum.push(g, p);
    }
    sum.finish()
}

/// One step on the portable kernels: the plays (into `scratch`, then
/// `inv_x`) and `v`; if `lower ≤ v ≤ upper`, the plays kept, the creep
/// advanced with `v` and `Ok((v, Δ))`, else nothing changed and `Err(v)`.
#[inline(always)]
pub(crate) fn step<T: Real>(
    parts: StepParts<'_, T>,
    scratch: &mut [T],
    z: T,
    delta: T,
    lower: T,
    upper: T,
) -> Result<(T, T), T> {
    let v = plays(parts.inv_r, parts.inv_w, parts.inv_x, scratch, |r| {
        folded_bounds(z, delta, r)
    });
    if !(v >= lower && v <= upper) {
        return Err(v);
    }
    parts.inv_x.copy_from_slice(scratch);
    let d = match parts.creep {
        Some(mut c) => creep_increment(&mut c, v),
        None => T::ZERO,
    };
    Ok((v, d))
}
