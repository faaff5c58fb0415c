//! Instruction sets: the one place they are chosen and the one place
//! `unsafe` is written.
//!
//! The kernels are written once, generic and `#[inline(always)]`. A caller
//! picks [`Kernels`] once per call (a whole `compensate`, a whole signal, a
//! bank step) with [`Kernels::detect`]: with `std` on x86-64 the step is then
//! compiled again with AVX2, or AVX-512F, enabled (`Kernels::run`). One
//! compensator step's vector work — `H⁻¹`, the clip and the creep pass — is
//! one such function (`compensator_step`), its borrows of the
//! compensator's arrays in registers; a run of steps is another
//! (`compensator_run`), its loop inside, the creep's output carried from
//! one sample to the next in a register. Its `f64` blocks run on explicit
//! 256-bit registers (the creep pass's on 8-lane 512-bit ones with
//! AVX-512F where the CPU runs them at full width:
//! [`Kernels::for_single_step`]), its `f32` ones on 8-lane registers; the
//! plays and creep pass of the forward model likewise; the bank's 64-byte
//! blocks (`block`: 8 `f64` or 16 `f32` lanes, one cache line) on two
//! 256-bit registers or one 512-bit register. A
//! multiply and an add are fused only where every copy fuses them (with
//! `std`: the creep update's two operations, `creep_pass::update`, and each
//! weighted term with its partial sum, `real::add_product`; Rust never
//! contracts the others), `min` and `max` are written as the hardware
//! defines them and the sums run in a fixed order, so every copy computes
//! the same bits: `verification/bank.rs`
//! checks that for each kernel set the CPU has ([`Kernels::all`]), and that
//! the explicit kernels did run where it has them ([`simd_kernel_calls`]).
//! Without `std` (firmware) there is one copy, for the target's own
//! features.

// the bank's blocks: the bank is part of the `std` layer
#[cfg(feature = "std")]
pub(crate) mod block;
#[cfg(feature = "std")]
mod cpu;

#[cfg(feature = "std")]
pub use cpu::cpu_description;
#[cfg(all(feature = "std", target_arch = "x86_64"))]
pub use cpu::f64_step_on_512;

#[cfg(all(feature = "std", target_arch = "x86_64"))]
use core::any::TypeId;

use crate::realtime::real::Real;

/// The kernels a step runs: the portable ones, or (x86-64 with `std`, the
/// CPU having them) the AVX2 (with FMA) or the AVX-512 ones. Only [`Kernels::detect`]
/// and [`Kernels::all`] make the vector values, so holding one proves the
/// CPU has its features.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kernels {
    Portable,
    #[cfg(all(feature = "std", target_arch = "x86_64"))]
    Avx2(Avx2),
    /// AVX-512F (with AVX2 and FMA, which every such CPU has).
    #[cfg(all(feature = "std", target_arch = "x86_64"))]
    Avx512(Avx512),
}

/// The proof that this CPU has AVX2 and FMA (private constructor).
#[cfg(all(feature = "std", target_arch = "x86_64"))]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Avx2(());

/// The proof that this CPU has AVX-512F, AVX2 and FMA (private constructor).
#[cfg(all(feature = "std", target_arch = "x86_64"))]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Avx512(());

impl Kernels {
    /// The best kernels this CPU runs (a cached feature test).
    #[inline]
    pub fn detect() -> Self {
        // one relaxed load on every call after the first (a step calls it)
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        {
            use core::sync::atomic::{AtomicU8, Ordering};
            static BEST: AtomicU8 = AtomicU8::new(0);
            if let Some(best) = Self::from_code(BEST.load(Ordering::Relaxed)) {
                return best;
            }
            let best = Self::all().last().unwrap_or(Kernels::Portable);
            BEST.store(best.code(), Ordering::Relaxed);
            best
        }
        #[cfg(not(all(feature = "std", target_arch = "x86_64")))]
        Kernels::Portable
    }

    /// Every kernel set this CPU runs, the portable one first and the best
    /// last: what the bit-for-bit tests compare.
    #[cfg_attr(not(feature = "internals"), allow(dead_code))]
    pub fn all() -> impl Iterator<Item = Kernels> {
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        let (avx2, avx512) = {
            // the creep update is fused (`Real::fused_mul_add`): no AVX2
            // set without FMA (every AVX2 CPU so far has both)
            let avx2 =
                std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma");
            (
                avx2.then_some(Kernels::Avx2(Avx2(()))),
                (avx2 && std::is_x86_feature_detected!("avx512f"))
                    .then_some(Kernels::Avx512(Avx512(()))),
            )
        };
        #[cfg(not(all(feature = "std", target_arch = "x86_64")))]
        let (avx2, avx512): (Option<Kernels>, Option<Kernels>) = (None, None);
        [Some(Kernels::Portable), avx2, avx512]
            .into_iter()
            .flatten()
    }

    /// The set's name: `portable`, `avx2` or `avx512`.
    #[cfg_attr(not(feature = "internals"), allow(dead_code))]
    pub fn name(self) -> &'static str {
        if self.is_avx512() {
            "avx512"
        } else if self.is_avx2() {
            "avx2"
        } else {
            "portable"
        }
    }

    /// Whether these kernels have AVX2 (the AVX2 or the AVX-512 ones).
    #[cfg_attr(not(feature = "internals"), allow(dead_code))]
    pub fn is_avx2(self) -> bool {
        self != Kernels::Portable
    }

    /// Whether these are the AVX-512 kernels.
    pub fn is_avx512(self) -> bool {
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        return matches!(self, Kernels::Avx512(_));
        #[cfg(not(all(feature = "std", target_arch = "x86_64")))]
        false
    }

    /// `f(self)`, compiled with the kernels' features enabled.
    #[inline(always)]
    pub(crate) fn run<R>(self, f: impl FnOnce(Self) -> R) -> R {
        match self {
            #[cfg(all(feature = "std", target_arch = "x86_64"))]
            Kernels::Avx2(_) => {
                #[target_feature(enable = "avx2,fma")]
                unsafe fn with_avx2<R>(k: Kernels, f: impl FnOnce(Kernels) -> R) -> R {
                    f(k)
                }
                // SAFETY: an `Avx2` value exists only where the CPU has AVX2 and FMA.
                unsafe { with_avx2(self, f) }
            }
            #[cfg(all(feature = "std", target_arch = "x86_64"))]
            Kernels::Avx512(_) => {
                #[target_feature(enable = "avx2,fma,avx512f")]
                unsafe fn with_avx512<R>(k: Kernels, f: impl FnOnce(Kernels) -> R) -> R {
                    f(k)
                }
                // SAFETY: an `Avx512` value exists only where the CPU has
                // AVX-512F, AVX2 and FMA.
                unsafe { with_avx512(self, f) }
            }
            Kernels::Portable => f(self),
        }
    }

    /// `detect().for_single_step::<T>()`, kept after the first call: one
    /// load per step (a compensator step calls it).
    #[inline]
    // `T` decides only where there are vector kernels to choose from
    #[cfg_attr(
        not(all(feature = "std", target_arch = "x86_64")),
        allow(clippy::extra_unused_type_parameters)
    )]
    pub fn detect_single_step<T: Real>() -> Self {
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        {
            use core::sync::atomic::{AtomicU8, Ordering};
            // the choice depends on `T` only through whether it is `f64`
            static F64: AtomicU8 = AtomicU8::new(0);
            static OTHER: AtomicU8 = AtomicU8::new(0);
            let kept = if TypeId::of::<T>() == TypeId::of::<f64>() {
                &F64
            } else {
                &OTHER
            };
            if let Some(k) = Self::from_code(kept.load(Ordering::Relaxed)) {
                return k;
            }
            let k = Self::detect().for_single_step::<T>();
            kept.store(k.code(), Ordering::Relaxed);
            k
        }
        #[cfg(not(all(feature = "std", target_arch = "x86_64")))]
        Kernels::Portable
    }

    /// The set as a nonzero byte, for a cached choice.
    #[cfg(all(feature = "std", target_arch = "x86_64"))]
    fn code(self) -> u8 {
        match self {
            Kernels::Portable => 1,
            Kernels::Avx2(_) => 2,
            Kernels::Avx512(_) => 3,
        }
    }

    /// The set [`Kernels::code`] gave (only ever for a set this CPU runs);
    /// `None` for 0, not chosen yet.
    #[cfg(all(feature = "std", target_arch = "x86_64"))]
    #[inline(always)]
    fn from_code(code: u8) -> Option<Self> {
        match code {
            1 => Some(Kernels::Portable),
            2 => Some(Kernels::Avx2(Avx2(()))),
            3 => Some(Kernels::Avx512(Avx512(()))),
            _ => None,
        }
    }

    /// The set one compensator step in `T` runs fastest on, of these:
    /// `self`, except `f64` on AVX-512 where its chain is shorter on the
    /// AVX2 set's blocks of four ([`f64_step_on_512`]). The same bits
    /// either way.
    #[inline]
    #[cfg_attr(not(feature = "internals"), allow(dead_code))]
    #[cfg_attr(
        not(all(feature = "std", target_arch = "x86_64")),
        allow(clippy::extra_unused_type_parameters)
    )]
    pub fn for_single_step<T: Real>(self) -> Self {
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        if self.is_avx512() && TypeId::of::<T>() == TypeId::of::<f64>() && !f64_step_on_512() {
            return Kernels::Avx2(Avx2(()));
        }
        self
    }

    /// The AVX2 proof, for the AVX2 and the AVX-512 kernels.
    #[cfg(all(feature = "std", target_arch = "x86_64"))]
    #[inline(always)]
    fn avx2(self) -> Option<Avx2> {
        match self {
            Kernels::Avx2(a) => Some(a),
            Kernels::Avx512(_) => Some(Avx2(())),
            Kernels::Portable => None,
        }
    }
}

#[cfg(all(feature = "std", target_arch = "x86_64", debug_assertions))]
std::thread_local! {
    static SIMD_CALLS: core::cell::Cell<usize> = const { core::cell::Cell::new(0) };
}

/// How many explicit vector kernel calls (AVX2 or AVX-512) this thread has
/// made (counted in builds with debug assertions, as the tests run; always
/// 0 otherwise).
#[cfg(feature = "internals")]
pub fn simd_kernel_calls() -> usize {
    #[cfg(all(feature = "std", target_arch = "x86_64", debug_assertions))]
    return SIMD_CALLS.with(|c| c.get());
    #[cfg(not(all(feature = "std", target_arch = "x86_64", debug_assertions)))]
    0
}

#[cfg(all(feature = "std", target_arch = "x86_64"))]
#[inline(always)]
pub(crate) fn count_simd_call() {
    #[cfg(debug_assertions)]
    SIMD_CALLS.with(|c| c.set(c.get() + 1));
}

/// `x` as a slice of `U` when `T` is `U`.
#[cfg(all(feature = "std", target_arch = "x86_64"))]
#[inline(always)]
fn cast<T: Real, U: Real>(x: &[T]) -> Option<&[U]> {
    // SAFETY: T is U when the TypeIds agree: the same type, the same layout.
    (TypeId::of::<T>() == TypeId::of::<U>()).then(|| unsafe { &*(x as *const [T] as *const [U]) })
}

/// `x` as a slice of `U` when `T` is `U`, mutably.
#[cfg(all(feature = "std", target_arch = "x86_64"))]
#[inline(always)]
fn cast_mut<T: Real, U: Real>(x: &mut [T]) -> Option<&mut [U]> {
    // SAFETY: as in `cast`.
    (TypeId::of::<T>() == TypeId::of::<U>()).then(|| unsafe { &mut *(x as *mut [T] as *mut [U]) })
}

/// One step of the creep pass ([`crate::realtime::creep_pass::advance`]) on `k`'s
/// kernels (those of a compensator step: [`StepKernels::creep`]).
#[inline(always)]
pub(crate) fn creep_advance<T: Real>(
    k: Kernels,
    chi: &mut [T],
    thresholds: &[T],
    gains: &[T],
    weights: &[T],
    v: T,
    last_input: &mut T,
) -> T {
    #[cfg(all(feature = "std", target_arch = "x86_64"))]
    if k.avx2().is_some() {
        let held = if v.is_finite() { v } else { *last_input };
        *last_input = held;
        // SAFETY: `k` proves AVX2, and AVX-512F where it is `Avx512`.
        return unsafe {
            if k.is_avx512() {
                x86::creep_avx512(chi, thresholds, gains, weights, held)
            } else {
                x86::creep_avx2(chi, thresholds, gains, weights, held)
            }
        };
    }
    let _ = k;
    crate::realtime::creep_pass::advance(chi, thresholds, gains, weights, v, last_input)
}

/// What one compensator step reads and writes: the plays of `H⁻¹` with
/// room for their copy, and the creep pass's parts if the model has creep.
pub(crate) struct StepParts<'a, T> {
    pub inv_state: &'a mut [T],
    pub saved: &'a mut [T],
    pub inv_thresholds: &'a [T],
    pub inv_weights: &'a [T],
    pub creep: Option<CreepParts<'a, T>>,
}

/// The creep operator's part of a step: its state, parameters, the last
/// finite input and the output the step writes.
pub(crate) struct CreepParts<'a, T> {
    pub chi: &'a mut [T],
    pub thresholds: &'a [T],
    pub gains: &'a [T],
    pub weights: &'a [T],
    pub last_input: &'a mut T,
    pub output: &'a mut T,
}

/// Where a step's parts come from: the compensator lends them inside the
/// kernel's function, so that the borrows are registers, not a record of
/// slices written to the stack for a call.
pub(crate) trait StepSource<T: Real> {
    fn step_parts(&mut self) -> StepParts<'_, T>;
    /// The parts of a source with the paper's layout, each sliced to its
    /// length there, a constant the compiler sees; where the storage has
    /// room for them, without reading the lengths
    /// ([`Buffer::prefix`](crate::realtime::storage::Buffer::prefix)).
    /// Asked only when [`StepSource::paper_layout`] says so.
    #[cfg_attr(not(all(feature = "std", target_arch = "x86_64")), allow(dead_code))]
    fn paper_parts(&mut self) -> StepParts<'_, T>;
    /// Whether the parts have the paper's layout ([`PAPER_PLAYS`] plays,
    /// [`PAPER_CREEP`] creep thresholds × eigenvalues), fixed when the
    /// source was made. (Only the vector steps have a form for it.)
    #[cfg_attr(not(all(feature = "std", target_arch = "x86_64")), allow(dead_code))]
    fn paper_layout(&self) -> bool;
}

/// The paper's layout — 12 plays, 12 creep thresholds × 5 eigenvalues, the
/// identification's default — for which the step (and the bank's block
/// step) is compiled with every slice's length a constant (its loops
/// unrolled, every offset known).
pub(crate) const PAPER_PLAYS: usize = crate::realtime::nominal::PLAYS;
/// The creep thresholds and eigenvalues of the paper's layout.
pub(crate) const PAPER_CREEP: (usize, usize) = (
    crate::realtime::nominal::CREEP_WEIGHTS.len(),
    crate::realtime::nominal::CREEP_EIGENVALUES.len(),
);

/// The two kernels of a compensator step on one instruction set, and how
/// a value on the step's chain goes from one to the next:
/// [`StepKernels::Lanes`]. On the vector sets it is the value and the
/// value in every lane of a 4-lane register (for `f32` a 128-bit one):
/// the kernels end their sums in a butterfly that leaves the sum in every
/// lane, so the creep's output and `H⁻¹`'s output reach the next kernel's
/// 4-lane blocks without a broadcast (its 8-lane blocks take one from that
/// register).
/// `v` and `t − c` are finite.
trait StepKernels<T: Real> {
    /// A value of `T` on the chain (on the portable set, the value).
    type Lanes: Copy;
    /// `x` as [`StepKernels::Lanes`].
    unsafe fn splat(x: T) -> Self::Lanes;
    /// `*x` as [`StepKernels::Lanes`], read by the broadcast itself: where
    /// `*x` was just stored (the creep's output of the step before), the
    /// store goes to the vector register in one forwarded load, without a
    /// scalar load and a broadcast after it on the chain.
    unsafe fn splat_from(x: &T) -> Self::Lanes;
    /// The value of `x`.
    unsafe fn first(x: Self::Lanes) -> T;
    /// The plays' step (`hysteresis::step_saving`) with the input `t − c`,
    /// the states before it saved.
    unsafe fn inverse_plays(
        state: &mut [T],
        saved: &mut [T],
        r: &[T],
        w: &[T],
        t: T,
        c: Self::Lanes,
    ) -> Self::Lanes;
    /// The creep pass ([`creep_advance`]'s blocks).
    unsafe fn creep(chi: &mut [T], r: &[T], g: &[T], w: &[T], v: Self::Lanes) -> Self::Lanes;
}

/// The portable kernels.
struct PortableStep;

impl<T: Real> StepKernels<T> for PortableStep {
    type Lanes = T;
    #[inline(always)]
    unsafe fn splat(x: T) -> T {
        x
    }
    #[inline(always)]
    unsafe fn splat_from(x: &T) -> T {
        *x
    }
    #[inline(always)]
    unsafe fn first(x: T) -> T {
        x
    }
    #[inline(always)]
    unsafe fn inverse_plays(state: &mut [T], saved: &mut [T], r: &[T], w: &[T], t: T, c: T) -> T {
        crate::realtime::hysteresis::step_saving::<T, true>(state, saved, r, w, t, c)
    }
    #[inline(always)]
    unsafe fn creep(chi: &mut [T], r: &[T], g: &[T], w: &[T], v: T) -> T {
        let mut held = v;
        crate::realtime::creep_pass::advance(chi, r, g, w, v, &mut held)
    }
}

/// `H⁻¹[y]` of `y = t − creep` clipped to `[lower, upper]` (a non-finite
/// `y` replaced by the zero-threshold play's state, so that it never enters
/// the plays; their states before the step saved), then the creep pass
/// with the voltage applied (a non-finite one replaced by the last finite
/// input): one compensator step once the target `t` (less the offset, or
/// `S⁻¹` of it) and the creep's output `creep` are known (`None`: the
/// output the creep operator holds, read from it here). `y` is given as
/// its two terms so that the creep's output, the end of the step's
/// dependency chain, enters each play's bounds last
/// (`hysteresis::step_saving`). Returns the voltage,
/// whether it was clipped, and the creep's new output as `K::Lanes` (zero
/// without creep),
/// which the step also writes. `PAPER`: the source has the paper's layout
/// ([`StepSource::paper_parts`]).
#[inline(always)]
unsafe fn step_body<T: Real, K: StepKernels<T>, C: StepSource<T>, const PAPER: bool>(
    c: &mut C,
    t: T,
    creep: Option<K::Lanes>,
    lower: T,
    upper: T,
) -> (T, bool, K::Lanes) {
    let p = if PAPER {
        c.paper_parts()
    } else {
        c.step_parts()
    };
    assert!(p.saved.len() == p.inv_state.len());
    // SAFETY (every `K` call): the caller's: `K`'s features are present.
    let creep = match (creep, &p.creep) {
        (Some(lanes), _) => lanes,
        (None, Some(cp)) => unsafe { K::splat_from(&*cp.output) },
        (None, None) => unsafe { K::splat(T::ZERO) },
    };
    // a predicted branch, so the test's subtraction stays off the chain
    // (with the length known, a select would put a test and a blend on it)
    let (t, creep) = if (t - unsafe { K::first(creep) }).is_finite() {
        (t, creep)
    } else {
        (first_play(p.inv_state), unsafe { K::splat(T::ZERO) })
    };
    let v_lanes = unsafe {
        K::inverse_plays(
            p.inv_state,
            p.saved,
            p.inv_thresholds,
            p.inv_weights,
            t,
            creep,
        )
    };
    let v = unsafe { K::first(v_lanes) };
    // within the limits: a predicted branch, off the chain (selects put
    // the clip's `min`, compare and blend on it)
    let (u, u_lanes, saturated) = if v >= lower && v <= upper {
        (v, v_lanes, false)
    } else {
        let (u, saturated) = clip(v, lower, upper);
        (u, unsafe { K::splat(u) }, saturated)
    };
    let mut creep_output = unsafe { K::splat(T::ZERO) };
    if let Some(cp) = p.creep {
        let held = if u.is_finite() {
            u_lanes
        } else {
            unsafe { K::splat(*cp.last_input) }
        };
        *cp.last_input = unsafe { K::first(held) };
        creep_output = unsafe { K::creep(cp.chi, cp.thresholds, cp.gains, cp.weights, held) };
        *cp.output = unsafe { K::first(creep_output) };
    }
    (u, saturated, creep_output)
}

/// The zero-threshold play's state: the input that leaves the plays as
/// they are, for a non-finite one.
#[cold]
#[inline(never)]
fn first_play<T: Real>(state: &[T]) -> T {
    state[0]
}

/// `v` clipped to `[lower, upper]` and whether it was (a NaN passes
/// unclipped, as the comparisons say).
#[cold]
#[inline(never)]
fn clip<T: Real>(v: T, lower: T, upper: T) -> (T, bool) {
    if v < lower {
        (lower, true)
    } else if v > upper {
        (upper, true)
    } else {
        (v, false)
    }
}

/// `x86::f::<T, C, PAPER>(args)` with `PAPER` whether `c` has the paper's
/// layout (a const parameter: the step is compiled once for each).
#[cfg(all(feature = "std", target_arch = "x86_64"))]
macro_rules! by_layout {
    ($c:ident, $f:ident, $($arg:expr),*) => {
        if $c.paper_layout() {
            x86::$f::<T, C, true>($($arg),*)
        } else {
            x86::$f::<T, C, false>($($arg),*)
        }
    };
}

/// [`step_body`] on `k`'s kernels, compiled as one function with their
/// features: one call per step, the parts in registers (split into a call
/// per kernel, the step wrote some 40 values to the stack per sample). The
/// creep's output enters as the creep operator of `c` holds it, read inside
/// the kernels' function by the broadcast that needs it
/// ([`StepKernels::splat_from`]).
#[inline(always)]
pub(crate) fn compensator_step<T: Real, C: StepSource<T>>(
    k: Kernels,
    c: &mut C,
    t: T,
    lower: T,
    upper: T,
) -> (T, bool) {
    match k {
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        // SAFETY: an `Avx512` value exists only where the CPU has AVX-512F,
        // AVX2 and FMA.
        Kernels::Avx512(_) => unsafe { by_layout!(c, step_avx512, c, t, lower, upper) },
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        // SAFETY: an `Avx2` value exists only where the CPU has AVX2 and FMA.
        Kernels::Avx2(_) => unsafe { by_layout!(c, step_avx2, c, t, lower, upper) },
        // SAFETY: the portable kernels need no feature.
        Kernels::Portable => step_portable(c, t, lower, upper),
    }
}

/// What a run of steps needs besides one step's parts
/// ([`compensator_run`]): the common case's input to the step, what follows
/// a step, and the general path for the rest.
pub(crate) trait RunSource<T: Real>: StepSource<T> {
    /// The clip's limits, `(lower, upper)`.
    fn limits(&self) -> (T, T);
    /// The target less the offset where the sample is the common case (a
    /// finite target, no `G`, no `S`); `None` where it is not. The input of
    /// `H⁻¹` is this less the creep's output.
    fn common_target(&self, target: T) -> Option<T>;
    /// The creep's output as the state holds it (zero without creep).
    fn creep_output(&self) -> T;
    /// After a common step to `u`: the re-seat if it was clipped, and `u`
    /// kept.
    fn after_step(&mut self, u: T, saturated: bool);
    /// A sample outside the common case, on the kernels `k`: the voltage,
    /// whether it was clipped, whether it was a fault.
    fn general_step(&mut self, k: Kernels, target: T) -> (T, bool, bool);
}

/// Where a run writes, one entry per target: the voltage, whether it was
/// clipped, whether it was a fault (the slices as long as the targets; the
/// caller checks).
pub(crate) struct RunOutputs<'a, T> {
    pub(crate) u: &'a mut [T],
    pub(crate) saturated: &'a mut [bool],
    pub(crate) fault: &'a mut [bool],
}

/// Every target of `targets` through [`step_body`] in turn, in one loop
/// within the kernels' function. The creep's output goes from one sample to
/// the next in a register (the state is written too), not stored and
/// loaded again on the dependency chain; the loop's constants (the
/// parameters' addresses, the limits) stay in registers, as a hand-written
/// loop over a step keeps them. The same operations, so the same bits, as
/// one call per sample. Returns how many samples were clipped and how many
/// were faults.
#[inline(always)]
unsafe fn run_body<T: Real, K: StepKernels<T>, C: RunSource<T>, const PAPER: bool>(
    k: Kernels,
    c: &mut C,
    targets: &[T],
    out: RunOutputs<'_, T>,
) -> (usize, usize) {
    let (lower, upper) = c.limits();
    let (mut clipped, mut faults) = (0, 0);
    // SAFETY (every `K` call): the caller's: `K`'s features are present.
    let mut creep_output = unsafe { K::splat(c.creep_output()) };
    let outputs = out
        .u
        .iter_mut()
        .zip(out.saturated.iter_mut())
        .zip(out.fault.iter_mut());
    for (&target, ((u, saturated), fault)) in targets.iter().zip(outputs) {
        let (v, s, f) = match c.common_target(target) {
            Some(y) => {
                let (v, s, next) =
                    unsafe { step_body::<T, K, C, PAPER>(c, y, Some(creep_output), lower, upper) };
                creep_output = next;
                c.after_step(v, s);
                (v, s, false)
            }
            None => {
                let out = c.general_step(k, target);
                creep_output = unsafe { K::splat(c.creep_output()) };
                out
            }
        };
        (*u, *saturated, *fault) = (v, s, f);
        clipped += usize::from(s);
        faults += usize::from(f);
    }
    (clipped, faults)
}

/// [`run_body`] on `k`'s kernels, compiled as one function with their
/// features.
pub(crate) fn compensator_run<T: Real, C: RunSource<T>>(
    k: Kernels,
    c: &mut C,
    targets: &[T],
    out: RunOutputs<'_, T>,
) -> (usize, usize) {
    match k {
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        // SAFETY: an `Avx512` value exists only where the CPU has AVX-512F,
        // AVX2 and FMA.
        Kernels::Avx512(_) => unsafe { by_layout!(c, run_avx512, k, c, targets, out) },
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        // SAFETY: an `Avx2` value exists only where the CPU has AVX2 and FMA.
        Kernels::Avx2(_) => unsafe { by_layout!(c, run_avx2, k, c, targets, out) },
        // SAFETY: the portable kernels need no feature.
        Kernels::Portable => unsafe { run_body::<T, PortableStep, C, false>(k, c, targets, out) },
    }
}

/// [`step_body`] on the portable kernels: out of line where vector
/// kernels exist, so that its scalar loops take no registers or stack in
/// the callers of the vector steps (their frames a quarter the size).
#[cfg_attr(all(feature = "std", target_arch = "x86_64"), inline(never))]
#[cfg_attr(not(all(feature = "std", target_arch = "x86_64")), inline(always))]
fn step_portable<T: Real, C: StepSource<T>>(c: &mut C, t: T, lower: T, upper: T) -> (T, bool) {
    // SAFETY: the portable kernels need no feature.
    let (u, saturated, _) =
        unsafe { step_body::<T, PortableStep, C, false>(c, t, None, lower, upper) };
    (u, saturated)
}

#[cfg(all(feature = "std", target_arch = "x86_64"))]
mod x86;

#[cfg(all(test, feature = "std", target_arch = "x86_64", target_os = "linux"))]
mod tests {
    /// The vendor and family read by CPUID are the ones Linux reports: the
    /// rule of [`super::f64_step_on_512`] (AMD family 26 and later) asks
    /// the CPU it runs on.
    #[test]
    fn f64_step_on_512_reads_the_vendor_and_family_linux_reports() {
        let info = std::fs::read_to_string("/proc/cpuinfo").unwrap();
        let field = |name: &str| {
            info.lines()
                .find(|l| l.split(':').next().map(str::trim) == Some(name))
                .and_then(|l| l.split_once(':'))
                .map(|(_, v)| v.trim().to_string())
                .unwrap()
        };
        let family: u32 = field("cpu family").parse().unwrap();
        let amd = field("vendor_id") == "AuthenticAMD";
        assert_eq!(super::cpu::vendor_is_amd_and_family(), (amd, family));
        assert_eq!(super::f64_step_on_512(), amd && family >= 26);
    }
}
