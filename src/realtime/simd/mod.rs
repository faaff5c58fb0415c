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
//! 256-bit registers (8-lane 512-bit ones with AVX-512F where the CPU runs
//! them at full width: [`Kernels::for_single_step`]), its `f32` ones on
//! 8-lane registers; the plays and creep pass of the forward model likewise;
//! the bank's 64-byte blocks (`block`: 8 `f64` or 16 `f32` lanes, one
//! cache line) on two 256-bit registers or one 512-bit register. A
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
    /// `self`, except `f64` on AVX-512 where the CPU splits 512-bit
    /// operations ([`full_width_512`]): there the AVX2 set's blocks of
    /// four. The same bits either way.
    #[inline]
    pub fn for_single_step<T: Real>(self) -> Self {
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        if self.is_avx512() && TypeId::of::<T>() == TypeId::of::<f64>() && !full_width_512() {
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

/// Whether this CPU executes a 512-bit operation at full width. AMD's
/// Zen 4 (family 25 with AVX-512F) splits each into two 256-bit halves:
/// there one compensator step's `f64` blocks of four (the AVX2 kernels)
/// are faster than blocks of eight (the same bits either way; measured in
/// the guide's performance chapter), while the bank's 8-lane blocks still
/// pay. Every other CPU with AVX-512F is taken to run it at full width.
#[cfg(all(feature = "std", target_arch = "x86_64"))]
#[inline]
pub fn full_width_512() -> bool {
    use core::sync::atomic::{AtomicU8, Ordering};
    static FULL: AtomicU8 = AtomicU8::new(0);
    match FULL.load(Ordering::Relaxed) {
        1 => return false,
        2 => return true,
        _ => {}
    }
    // SAFETY: CPUID exists on every x86-64 CPU (a safe function in newer
    // Rust, unsafe in the MSRV's)
    #[allow(unused_unsafe)]
    let (vendor, signature) = unsafe {
        let v = core::arch::x86_64::__cpuid(0);
        ([v.ebx, v.edx, v.ecx], core::arch::x86_64::__cpuid(1).eax)
    };
    // "AuthenticAMD" as CPUID returns it, four bytes a register
    let amd = vendor == [0x6874_7541, 0x6974_6e65, 0x444d_4163];
    // the family as CPUID gives it: base plus extended where the base is 15
    let base = (signature >> 8) & 0xf;
    let family = if base == 0xf {
        base + ((signature >> 20) & 0xff)
    } else {
        base
    };
    let full = !(amd && family == 25);
    FULL.store(if full { 2 } else { 1 }, Ordering::Relaxed);
    full
}

/// The CPU as a performance figure must name it: vendor, family, model,
/// model name (from `/proc/cpuinfo` on Linux) and the vector features the
/// kernels use.
#[cfg(feature = "std")]
pub fn cpu_description() -> std::string::String {
    use std::string::String;
    let info = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let field = |name: &str| -> String {
        info.lines()
            .find(|l| l.split(':').next().map(str::trim) == Some(name))
            .and_then(|l| l.split_once(':'))
            .map(|(_, v)| v.trim().into())
            .unwrap_or_else(|| "?".into())
    };
    #[allow(unused_mut)]
    let mut features: std::vec::Vec<&str> = std::vec::Vec::new();
    #[cfg(target_arch = "x86_64")]
    {
        for (name, has) in [
            ("avx2", std::is_x86_feature_detected!("avx2")),
            ("fma", std::is_x86_feature_detected!("fma")),
            ("avx512f", std::is_x86_feature_detected!("avx512f")),
        ] {
            if has {
                features.push(name);
            }
        }
    }
    std::format!(
        "{} ({}, family {}, model {}), {} logical CPUs, features [{}]",
        field("model name"),
        field("vendor_id"),
        field("cpu family"),
        field("model"),
        std::thread::available_parallelism().map_or(0, |n| n.get()),
        features.join(", ")
    )
}

#[cfg(all(feature = "std", target_arch = "x86_64", debug_assertions))]
std::thread_local! {
    static SIMD_CALLS: core::cell::Cell<usize> = const { core::cell::Cell::new(0) };
}

/// How many explicit vector kernel calls (AVX2 or AVX-512) this thread has
/// made (counted in builds with debug assertions, as the tests run; always
/// 0 otherwise).
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
/// [`StepKernels::Lanes`]. On the vector sets it is the value and, for
/// `f64`, the value in every lane of a 4-lane register: the `f64` kernels
/// end their sums in a butterfly that leaves the sum in every lane, so the
/// creep's output and `H⁻¹`'s output reach the next kernel's 4-lane blocks
/// without a broadcast (its 8-lane blocks take one from that register).
/// `v` and `t − c` are finite.
trait StepKernels<T: Real> {
    /// A value of `T` on the chain (on the portable set, the value).
    type Lanes: Copy;
    /// `x` as [`StepKernels::Lanes`].
    unsafe fn splat(x: T) -> Self::Lanes;
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
/// `S⁻¹` of it) and the creep's output `creep` are known. `y` is given as
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
    creep: K::Lanes,
    lower: T,
    upper: T,
) -> (T, bool, K::Lanes) {
    let p = if PAPER {
        c.paper_parts()
    } else {
        c.step_parts()
    };
    assert!(p.saved.len() == p.inv_state.len());
    // a predicted branch, so the test's subtraction stays off the chain
    // (with the length known, a select would put a test and a blend on it)
    // SAFETY (every `K` call): the caller's: `K`'s features are present.
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
/// per kernel, the step wrote some 40 values to the stack per sample).
#[inline(always)]
pub(crate) fn compensator_step<T: Real, C: StepSource<T>>(
    k: Kernels,
    c: &mut C,
    t: T,
    creep: T,
    lower: T,
    upper: T,
) -> (T, bool) {
    match k {
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        // SAFETY: an `Avx512` value exists only where the CPU has AVX-512F,
        // AVX2 and FMA.
        Kernels::Avx512(_) => unsafe { by_layout!(c, step_avx512, c, t, creep, lower, upper) },
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        // SAFETY: an `Avx2` value exists only where the CPU has AVX2 and FMA.
        Kernels::Avx2(_) => unsafe { by_layout!(c, step_avx2, c, t, creep, lower, upper) },
        // SAFETY: the portable kernels need no feature.
        Kernels::Portable => step_portable(c, t, creep, lower, upper),
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
                    unsafe { step_body::<T, K, C, PAPER>(c, y, creep_output, lower, upper) };
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
/// the callers of the vector steps (on a Zen 4 the caller's frame went
/// from 0x228 to 0x58 bytes).
#[cfg_attr(all(feature = "std", target_arch = "x86_64"), inline(never))]
#[cfg_attr(not(all(feature = "std", target_arch = "x86_64")), inline(always))]
fn step_portable<T: Real, C: StepSource<T>>(
    c: &mut C,
    t: T,
    creep: T,
    lower: T,
    upper: T,
) -> (T, bool) {
    // SAFETY: the portable kernels need no feature.
    let (u, saturated, _) =
        unsafe { step_body::<T, PortableStep, C, false>(c, t, creep, lower, upper) };
    (u, saturated)
}

#[cfg(all(feature = "std", target_arch = "x86_64"))]
mod x86 {
    //! The AVX2 kernels. Each does the operations of its portable kernel in
    //! the same order: `vminpd(x, hi)` is `if x < hi { x } else { hi }` and
    //! `vmaxpd(t, lo)` is `if t > lo { t } else { lo }`, as `play` and
    //! `clamp` are written, so the bits are the same.
    //!
    //! The plays' states and their saved copy, which a step loads and
    //! stores again, go through `*_unsplit`: a register's worth that would
    //! straddle a 4 KiB page is moved one value at a time. On a Zen 5 a
    //! step whose creep row straddled a page, at an offset that matched
    //! stack slots the step had just written, took 13–21 % longer (a
    //! compensator on the stack, in 6 of 256 stack offsets), and the
    //! plays' arrays are kept from the same. Whether an array can straddle
    //! at all is asked once per array and step (`SPLIT`): most never do,
    //! and their accesses carry no test. The creep state needs neither:
    //! the operator places it so that no register's worth straddles a page
    //! (`crate::realtime::placement`; on a Zen 4 the per-access tests had
    //! cost more than the split).
    //!
    //! The kernels end each sum of four partial sums in a butterfly
    //! ([`all_lanes_sum`], and its `f32` twin in the 8-lane kernels): the
    //! same bits as `hysteresis::reduce`, in every lane. On a Zen 4 a run
    //! of the AVX2 set took 0.976–0.982 of the strongest C's loop with it,
    //! 0.993–0.996 with the scalar sum and a broadcast; the AVX-512 set's
    //! `f64` step went from 27.2–27.3 to 26.9–27.0 ns (a broadcast fewer
    //! between the two kernels). Zen 1's instruction tables list `vperm2f128` as
    //! eight micro-operations (its latency 3, as on later cores); that CPU
    //! was not measured with it.
    use core::arch::x86_64::*;

    use core::any::TypeId;

    use crate::realtime::creep_pass::{advance_tail, LANES};
    use crate::realtime::hysteresis::{reduce, step_tail};
    use crate::realtime::real::Real;

    /// `hysteresis::reduce` of `a`'s four lanes, in every lane: a butterfly.
    /// Lane 0 adds `(a₀ + a₂) + (a₁ + a₃)` as `reduce` does; the other
    /// lanes add the same pairs with their operands swapped, which leaves
    /// an IEEE sum as it is. The swap of the halves is `vperm2f128`,
    /// written out: LLVM emits `_mm256_permute2f128_pd(a, a, 1)` as
    /// `vpermpd`, a cycle slower on a Zen 4 (4 against 3).
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    fn all_lanes_sum(a: __m256d) -> __m256d {
        let swapped: __m256d;
        // SAFETY: AVX is enabled here; the instruction reads and writes
        // registers only.
        unsafe {
            core::arch::asm!(
                "vperm2f128 {swapped}, {a}, {a}, 1",
                a = in(ymm_reg) a,
                swapped = lateout(ymm_reg) swapped,
                options(pure, nomem, nostack, preserves_flags)
            );
        }
        // [a₀ + a₂, a₁ + a₃, a₂ + a₀, a₃ + a₁], then each lane and its
        // neighbour
        let t = _mm256_add_pd(a, swapped);
        _mm256_add_pd(t, _mm256_permute_pd::<0b0101>(t))
    }

    /// [`all_lanes_sum`] of four `f32` lanes: `(a₀ + a₂) + (a₁ + a₃)` in
    /// lane 0, the same pairs swapped in the others.
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    fn all_lanes_sum_f32(a: __m128) -> __m128 {
        // [a₂, a₃, a₀, a₁] added, then each lane and its neighbour
        let t = _mm_add_ps(a, _mm_permute_ps::<0b01_00_11_10>(a));
        _mm_add_ps(t, _mm_permute_ps::<0b10_11_00_01>(t))
    }

    /// Lane 0 of `h` in all eight lanes of a 512-bit register.
    #[target_feature(enable = "avx2,fma,avx512f")]
    #[inline]
    fn broadcast_low_f64(h: __m256d) -> __m512d {
        _mm512_broadcastsd_pd(_mm256_castpd256_pd128(h))
    }

    /// `real::add_term` on four lanes: `w · x` for a sum's first term,
    /// fused with `acc` after it (callers compiled with AVX2).
    #[inline(always)]
    unsafe fn add_term4(acc: __m256d, w: __m256d, x: __m256d, first: bool) -> __m256d {
        // SAFETY (both): the caller's AVX2 and FMA.
        if first {
            unsafe { _mm256_mul_pd(w, x) }
        } else {
            unsafe { _mm256_fmadd_pd(w, x, acc) }
        }
    }

    /// The blocks of `hysteresis::step_saving` for `f64` on 4-lane
    /// registers (callers compiled with AVX2); `cc` holds `c` in every
    /// lane, `t − c` is finite, and the result is in every lane.
    #[inline(always)]
    unsafe fn hysteresis_step_four<const SPLIT: bool>(
        state: &mut [f64],
        saved: &mut [f64],
        thresholds: &[f64],
        weights: &[f64],
        t: f64,
        cc: __m256d,
    ) -> __m256d {
        let n = state.len();
        assert!(thresholds.len() == n && weights.len() == n && saved.len() == n);
        let full = n - n % 4;
        // SAFETY: the caller's AVX2.
        let (tt, mut acc) = unsafe { (_mm256_set1_pd(t), _mm256_setzero_pd()) };
        for i0 in (0..full).step_by(4) {
            // SAFETY: i0 + 4 ≤ n for all three slices.
            unsafe {
                let at = state.as_mut_ptr().add(i0);
                let r = _mm256_loadu_pd(thresholds.as_ptr().add(i0));
                let x = load4_unsplit::<SPLIT>(at);
                store4_unsplit::<SPLIT>(saved.as_mut_ptr().add(i0), x);
                // (t ± r) − c: `t + r` and `t − r` wait only for `t`
                let upper = _mm256_sub_pd(_mm256_add_pd(tt, r), cc);
                let lower = _mm256_sub_pd(_mm256_sub_pd(tt, r), cc);
                let x = _mm256_max_pd(_mm256_min_pd(x, upper), lower);
                store4_unsplit::<SPLIT>(at, x);
                let w = _mm256_loadu_pd(weights.as_ptr().add(i0));
                acc = add_term4(acc, w, x, i0 == 0);
            }
        }
        // SAFETY (all three): the caller's AVX2.
        if full == n {
            return unsafe { all_lanes_sum(acc) };
        }
        let mut lanes = [0.0f64; 4];
        unsafe { _mm256_storeu_pd(lanes.as_mut_ptr(), acc) };
        let c = unsafe { _mm256_cvtsd_f64(cc) };
        step_tail::<f64, true>(state, saved, thresholds, weights, t, c, full, &mut lanes);
        unsafe { _mm256_set1_pd(reduce(lanes)) }
    }

    /// The blocks of `creep_pass::advance` for `f64` on 4-lane registers
    /// (callers compiled with AVX2); `vv` holds a finite `v` in every lane,
    /// and the result is in every lane.
    #[inline(always)]
    unsafe fn creep_advance_four(
        chi: &mut [f64],
        thresholds: &[f64],
        gains: &[f64],
        weights: &[f64],
        vv: __m256d,
    ) -> __m256d {
        let n = thresholds.len();
        let m = gains.len();
        assert!(weights.len() == n && chi.len() == n * m);
        let full = n - n % LANES;
        // SAFETY: the caller's AVX2.
        let mut acc = unsafe { _mm256_setzero_pd() };
        let p = chi.as_mut_ptr();
        for i0 in (0..full).step_by(LANES) {
            // SAFETY (all pointer accesses): i0 + 4 ≤ n and j < m, so every
            // block lies inside `chi` (n·m) and the parameter slices (n).
            unsafe {
                let r = _mm256_loadu_pd(thresholds.as_ptr().add(i0));
                let lower = _mm256_sub_pd(vv, r);
                let upper = _mm256_add_pd(vv, r);
                macro_rules! update {
                    ($at:expr, $g:expr) => {{
                        let (at, g) = ($at, $g);
                        let x = _mm256_loadu_pd(at);
                        let c = _mm256_max_pd(_mm256_min_pd(x, upper), lower);
                        // `creep_pass::update`: g c + (x − g x)
                        let g = _mm256_set1_pd(g);
                        let x = _mm256_fmadd_pd(g, c, _mm256_fnmadd_pd(g, x, x));
                        _mm256_storeu_pd(at, x);
                        x
                    }};
                }
                // from the first row, not from zero (see `creep_pass::advance`);
                // row `j` of the block lies `n` values after row `j − 1`
                let mut at = p.add(i0);
                let mut rows = update!(at, gains[0]);
                for &g in &gains[1..] {
                    at = at.add(n);
                    rows = _mm256_add_pd(rows, update!(at, g));
                }
                let w = _mm256_loadu_pd(weights.as_ptr().add(i0));
                acc = add_term4(acc, w, rows, i0 == 0);
            }
        }
        // SAFETY (all three): the caller's AVX2.
        if full == n {
            return unsafe { all_lanes_sum(acc) };
        }
        let mut lanes = [0.0f64; LANES];
        unsafe { _mm256_storeu_pd(lanes.as_mut_ptr(), acc) };
        let v = unsafe { _mm256_cvtsd_f64(vv) };
        advance_tail(chi, thresholds, gains, weights, v, full, &mut lanes);
        unsafe { _mm256_set1_pd(reduce(lanes)) }
    }

    /// Whether `bytes` bytes from `p` straddle a 4 KiB page.
    #[inline(always)]
    fn straddles_page<T>(p: *const T, bytes: usize) -> bool {
        (p as usize & 4095) > 4096 - bytes
    }

    /// Whether the array `x` straddles a 4 KiB page. Only then can a
    /// register's worth of it, so the kernels check each one (`SPLIT`)
    /// only then: once per array and step instead of once per access.
    #[inline(always)]
    fn array_straddles<T>(x: &[T]) -> bool {
        (x.as_ptr() as usize & 4095) + size_of_val(x) > 4096
    }

    /// [`hysteresis_step_four`], its states checked for straddles only if
    /// an array can straddle.
    #[inline(always)]
    unsafe fn hysteresis_four(
        state: &mut [f64],
        saved: &mut [f64],
        thresholds: &[f64],
        weights: &[f64],
        t: f64,
        c: __m256d,
    ) -> __m256d {
        // SAFETY (both): the caller's.
        if array_straddles(state) || array_straddles(saved) {
            unsafe { hysteresis_step_four::<true>(state, saved, thresholds, weights, t, c) }
        } else {
            unsafe { hysteresis_step_four::<false>(state, saved, thresholds, weights, t, c) }
        }
    }

    /// [`creep_advance_four`] on a placed `χ` (checked with debug
    /// assertions).
    #[inline(always)]
    unsafe fn creep_four(
        chi: &mut [f64],
        thresholds: &[f64],
        gains: &[f64],
        weights: &[f64],
        v: __m256d,
    ) -> __m256d {
        debug_assert_placed(chi, thresholds.len());
        // SAFETY: the caller's.
        unsafe { creep_advance_four(chi, thresholds, gains, weights, v) }
    }

    /// [`hysteresis_step_eight`], as [`hysteresis_four`].
    #[inline(always)]
    unsafe fn hysteresis_eight<E: Eight>(
        state: &mut [E::T],
        saved: &mut [E::T],
        thresholds: &[E::T],
        weights: &[E::T],
        t: E::T,
        c: E::Half,
    ) -> E::Half {
        // SAFETY (both): the caller's.
        if array_straddles(state) || array_straddles(saved) {
            unsafe { hysteresis_step_eight::<E, true>(state, saved, thresholds, weights, t, c) }
        } else {
            unsafe { hysteresis_step_eight::<E, false>(state, saved, thresholds, weights, t, c) }
        }
    }

    /// [`creep_advance_eight`], as [`creep_four`].
    #[inline(always)]
    unsafe fn creep_eight<E: Eight>(
        chi: &mut [E::T],
        thresholds: &[E::T],
        gains: &[E::T],
        weights: &[E::T],
        v: E::Half,
    ) -> E::Half {
        debug_assert_placed(chi, thresholds.len());
        // SAFETY: the caller's.
        unsafe { creep_advance_eight::<E>(chi, thresholds, gains, weights, v) }
    }

    /// With debug assertions: no register of `χ` (rows of `n`) straddles
    /// the first page boundary in it.
    #[inline(always)]
    fn debug_assert_placed<T>(chi: &[T], n: usize) {
        debug_assert!(
            !crate::realtime::placement::cuts_a_register(
                chi.as_ptr() as usize,
                size_of::<T>(),
                n,
                chi.len()
            ),
            "χ not placed"
        );
    }

    /// `N` values at `p` read one by one (volatile, so that they are not
    /// merged into the one wide access this avoids) into an array.
    #[inline(always)]
    unsafe fn read_each<T: Real, const N: usize>(p: *const T) -> [T; N] {
        // SAFETY: the caller's `p..p + N` is readable.
        core::array::from_fn(|l| unsafe { core::ptr::read_volatile(p.add(l)) })
    }

    /// `values` written one by one to `p` (volatile, as in [`read_each`]).
    #[inline(always)]
    unsafe fn write_each<T: Real, const N: usize>(p: *mut T, values: &[T; N]) {
        for (l, &x) in values.iter().enumerate() {
            // SAFETY: the caller's `p..p + N` is writable.
            unsafe { core::ptr::write_volatile(p.add(l), x) };
        }
    }

    /// `_mm256_loadu_pd`, one value at a time where the four straddle a
    /// page (see the module's note).
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn load4_unsplit<const SPLIT: bool>(p: *const f64) -> __m256d {
        // SAFETY: the caller's `p..p + 4` is readable.
        unsafe {
            if SPLIT && straddles_page(p, 32) {
                _mm256_loadu_pd(read_each::<f64, 4>(p).as_ptr())
            } else {
                _mm256_loadu_pd(p)
            }
        }
    }

    /// `_mm256_storeu_pd`, one value at a time where the four straddle a
    /// page.
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn store4_unsplit<const SPLIT: bool>(p: *mut f64, x: __m256d) {
        // SAFETY: the caller's `p..p + 4` is writable.
        unsafe {
            if SPLIT && straddles_page(p, 32) {
                let mut a = [0.0f64; 4];
                _mm256_storeu_pd(a.as_mut_ptr(), x);
                write_each(p, &a);
            } else {
                _mm256_storeu_pd(p, x);
            }
        }
    }

    /// Eight lanes in one register and their four-lane halves: `f64` on
    /// AVX-512F (`__m512d`, `__m256d`), `f32` on AVX2 (`__m256`, `__m128`).
    /// The 8-lane kernels below are written once over it.
    trait Eight: Copy {
        type T: Real;
        type Half: Copy;
        unsafe fn splat(x: Self::T) -> Self;
        unsafe fn load(p: *const Self::T) -> Self;
        unsafe fn store(self, p: *mut Self::T);
        unsafe fn add(self, b: Self) -> Self;
        unsafe fn sub(self, b: Self) -> Self;
        /// `a < b ? a : b`, and `a > b ? a : b` for `max`.
        unsafe fn min(self, b: Self) -> Self;
        unsafe fn max(self, b: Self) -> Self;
        /// `self · a + b` and `b − self · a`, rounded once.
        unsafe fn mul_add(self, a: Self, b: Self) -> Self;
        unsafe fn neg_mul_add(self, a: Self, b: Self) -> Self;
        /// Lanes 0–3 and 4–7.
        unsafe fn halves(self) -> (Self::Half, Self::Half);
        unsafe fn half_splat(x: Self::T) -> Self::Half;
        unsafe fn half_zero() -> Self::Half;
        unsafe fn half_load(p: *const Self::T) -> Self::Half;
        unsafe fn half_store(h: Self::Half, p: *mut Self::T);
        unsafe fn half_add(a: Self::Half, b: Self::Half) -> Self::Half;
        unsafe fn half_sub(a: Self::Half, b: Self::Half) -> Self::Half;
        unsafe fn half_min(a: Self::Half, b: Self::Half) -> Self::Half;
        unsafe fn half_max(a: Self::Half, b: Self::Half) -> Self::Half;
        unsafe fn half_mul(a: Self::Half, b: Self::Half) -> Self::Half;
        unsafe fn half_mul_add(a: Self::Half, b: Self::Half, c: Self::Half) -> Self::Half;
        unsafe fn half_neg_mul_add(a: Self::Half, b: Self::Half, c: Self::Half) -> Self::Half;
        /// Lane 0 of `h`, the value a half holds in every lane.
        unsafe fn half_first(h: Self::Half) -> Self::T;
        /// Lane 0 of `h` in all eight lanes.
        unsafe fn splat_half(h: Self::Half) -> Self;
        /// `hysteresis::reduce` of `h`'s four lanes, in every lane: a
        /// butterfly (see [`all_lanes_sum`]).
        unsafe fn half_every_lane_sum(h: Self::Half) -> Self::Half;

        /// `real::add_term` on a half: `w · x` for a sum's first term,
        /// fused with `acc` after it.
        #[inline(always)]
        unsafe fn half_add_term(
            acc: Self::Half,
            w: Self::Half,
            x: Self::Half,
            first: bool,
        ) -> Self::Half {
            // SAFETY (both): the caller's features.
            if first {
                unsafe { Self::half_mul(w, x) }
            } else {
                unsafe { Self::half_mul_add(w, x, acc) }
            }
        }

        /// [`Eight::load`], one value at a time where the eight straddle a
        /// page (see the module's note).
        #[inline(always)]
        unsafe fn load_unsplit<const SPLIT: bool>(p: *const Self::T) -> Self {
            // SAFETY: the caller's `p..p + 8` is readable.
            unsafe {
                if SPLIT && straddles_page(p, 8 * size_of::<Self::T>()) {
                    Self::load(read_each::<Self::T, 8>(p).as_ptr())
                } else {
                    Self::load(p)
                }
            }
        }
        /// [`Eight::store`], one value at a time where the eight straddle
        /// a page.
        #[inline(always)]
        unsafe fn store_unsplit<const SPLIT: bool>(self, p: *mut Self::T) {
            // SAFETY: the caller's `p..p + 8` is writable.
            unsafe {
                if SPLIT && straddles_page(p, 8 * size_of::<Self::T>()) {
                    let mut a = [Self::T::ZERO; 8];
                    self.store(a.as_mut_ptr());
                    write_each(p, &a);
                } else {
                    self.store(p);
                }
            }
        }
        /// [`Eight::half_load`], one value at a time where the four
        /// straddle a page.
        #[inline(always)]
        unsafe fn half_load_unsplit<const SPLIT: bool>(p: *const Self::T) -> Self::Half {
            // SAFETY: the caller's `p..p + 4` is readable.
            unsafe {
                if SPLIT && straddles_page(p, 4 * size_of::<Self::T>()) {
                    Self::half_load(read_each::<Self::T, 4>(p).as_ptr())
                } else {
                    Self::half_load(p)
                }
            }
        }
        /// [`Eight::half_store`], one value at a time where the four
        /// straddle a page.
        #[inline(always)]
        unsafe fn half_store_unsplit<const SPLIT: bool>(h: Self::Half, p: *mut Self::T) {
            // SAFETY: the caller's `p..p + 4` is writable.
            unsafe {
                if SPLIT && straddles_page(p, 4 * size_of::<Self::T>()) {
                    let mut a = [Self::T::ZERO; 4];
                    Self::half_store(h, a.as_mut_ptr());
                    write_each(p, &a);
                } else {
                    Self::half_store(h, p);
                }
            }
        }
    }

    macro_rules! eight {
        ($name:ident, $feature:literal, $t:ty, $v:ty, $h:ty,
         [$set1:ident, $loadu:ident, $storeu:ident, $add:ident, $sub:ident, $min:ident, $max:ident, $fma:ident, $fnma:ident],
         [$hset1:ident, $hzero:ident, $hloadu:ident, $hstoreu:ident, $hadd:ident, $hsub:ident, $hmin:ident, $hmax:ident, $hmul:ident, $hfma:ident, $hfnma:ident],
         $lo:expr, $hi:expr, $first:expr, $splat_half:expr, $every_lane_sum:expr) => {
            #[derive(Clone, Copy)]
            struct $name($v);

            impl Eight for $name {
                type T = $t;
                type Half = $h;
                #[target_feature(enable = $feature)]
                #[inline]
                unsafe fn splat(x: $t) -> Self {
                    $name($set1(x))
                }
                #[target_feature(enable = $feature)]
                #[inline]
                unsafe fn load(p: *const $t) -> Self {
                    $name(unsafe { $loadu(p) })
                }
                #[target_feature(enable = $feature)]
                #[inline]
                unsafe fn store(self, p: *mut $t) {
                    unsafe { $storeu(p, self.0) }
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
                unsafe fn mul_add(self, a: Self, b: Self) -> Self {
                    $name($fma(self.0, a.0, b.0))
                }
                #[target_feature(enable = $feature)]
                #[inline]
                unsafe fn neg_mul_add(self, a: Self, b: Self) -> Self {
                    $name($fnma(self.0, a.0, b.0))
                }
                #[target_feature(enable = $feature)]
                #[inline]
                unsafe fn halves(self) -> ($h, $h) {
                    ($lo(self.0), $hi(self.0))
                }
                #[target_feature(enable = $feature)]
                #[inline]
                unsafe fn half_splat(x: $t) -> $h {
                    $hset1(x)
                }
                #[target_feature(enable = $feature)]
                #[inline]
                unsafe fn half_zero() -> $h {
                    $hzero()
                }
                #[target_feature(enable = $feature)]
                #[inline]
                unsafe fn half_load(p: *const $t) -> $h {
                    unsafe { $hloadu(p) }
                }
                #[target_feature(enable = $feature)]
                #[inline]
                unsafe fn half_store(h: $h, p: *mut $t) {
                    unsafe { $hstoreu(p, h) }
                }
                #[target_feature(enable = $feature)]
                #[inline]
                unsafe fn half_add(a: $h, b: $h) -> $h {
                    $hadd(a, b)
                }
                #[target_feature(enable = $feature)]
                #[inline]
                unsafe fn half_sub(a: $h, b: $h) -> $h {
                    $hsub(a, b)
                }
                #[target_feature(enable = $feature)]
                #[inline]
                unsafe fn half_min(a: $h, b: $h) -> $h {
                    $hmin(a, b)
                }
                #[target_feature(enable = $feature)]
                #[inline]
                unsafe fn half_max(a: $h, b: $h) -> $h {
                    $hmax(a, b)
                }
                #[target_feature(enable = $feature)]
                #[inline]
                unsafe fn half_mul(a: $h, b: $h) -> $h {
                    $hmul(a, b)
                }
                #[target_feature(enable = $feature)]
                #[inline]
                unsafe fn half_mul_add(a: $h, b: $h, c: $h) -> $h {
                    $hfma(a, b, c)
                }
                #[target_feature(enable = $feature)]
                #[inline]
                unsafe fn half_neg_mul_add(a: $h, b: $h, c: $h) -> $h {
                    $hfnma(a, b, c)
                }
                #[target_feature(enable = $feature)]
                #[inline]
                unsafe fn half_first(h: $h) -> $t {
                    $first(h)
                }
                #[target_feature(enable = $feature)]
                #[inline]
                unsafe fn splat_half(h: $h) -> Self {
                    $name($splat_half(h))
                }
                #[target_feature(enable = $feature)]
                #[inline]
                unsafe fn half_every_lane_sum(h: $h) -> $h {
                    $every_lane_sum(h)
                }
            }
        };
    }

    eight!(
        F64x8,
        "avx2,fma,avx512f",
        f64,
        __m512d,
        __m256d,
        [
            _mm512_set1_pd,
            _mm512_loadu_pd,
            _mm512_storeu_pd,
            _mm512_add_pd,
            _mm512_sub_pd,
            _mm512_min_pd,
            _mm512_max_pd,
            _mm512_fmadd_pd,
            _mm512_fnmadd_pd
        ],
        [
            _mm256_set1_pd,
            _mm256_setzero_pd,
            _mm256_loadu_pd,
            _mm256_storeu_pd,
            _mm256_add_pd,
            _mm256_sub_pd,
            _mm256_min_pd,
            _mm256_max_pd,
            _mm256_mul_pd,
            _mm256_fmadd_pd,
            _mm256_fnmadd_pd
        ],
        _mm512_castpd512_pd256,
        _mm512_extractf64x4_pd::<1>,
        _mm256_cvtsd_f64,
        broadcast_low_f64,
        all_lanes_sum
    );
    eight!(
        F32x8,
        "avx2,fma",
        f32,
        __m256,
        __m128,
        [
            _mm256_set1_ps,
            _mm256_loadu_ps,
            _mm256_storeu_ps,
            _mm256_add_ps,
            _mm256_sub_ps,
            _mm256_min_ps,
            _mm256_max_ps,
            _mm256_fmadd_ps,
            _mm256_fnmadd_ps
        ],
        [
            _mm_set1_ps,
            _mm_setzero_ps,
            _mm_loadu_ps,
            _mm_storeu_ps,
            _mm_add_ps,
            _mm_sub_ps,
            _mm_min_ps,
            _mm_max_ps,
            _mm_mul_ps,
            _mm_fmadd_ps,
            _mm_fnmadd_ps
        ],
        _mm256_castps256_ps128,
        _mm256_extractf128_ps::<1>,
        _mm_cvtss_f32,
        _mm256_broadcastss_ps,
        all_lanes_sum_f32
    );

    /// `hysteresis::step` in 8-lane blocks: the products of lanes 0–3 and
    /// then of lanes 4–7 added into the four partial sums, as the portable
    /// blocks of four add them; then a 4-lane block and the rest one by one.
    /// `c4` holds `c` in every lane, and so does the result.
    #[inline(always)]
    unsafe fn hysteresis_step_eight<E: Eight, const SPLIT: bool>(
        state: &mut [E::T],
        saved: &mut [E::T],
        thresholds: &[E::T],
        weights: &[E::T],
        t: E::T,
        c4: E::Half,
    ) -> E::Half {
        let n = state.len();
        assert!(thresholds.len() == n && weights.len() == n && saved.len() == n);
        let (full8, full4) = (n - n % 8, n - n % 4);
        // SAFETY (all): the features are the caller's; every block ends at
        // or before n in all three slices.
        unsafe {
            let (t8, t4) = (E::splat(t), E::half_splat(t));
            let c8 = E::splat_half(c4);
            let mut acc = E::half_zero();
            for i0 in (0..full8).step_by(8) {
                let at = state.as_mut_ptr().add(i0);
                let r = E::load(thresholds.as_ptr().add(i0));
                let x = E::load_unsplit::<SPLIT>(at);
                x.store_unsplit::<SPLIT>(saved.as_mut_ptr().add(i0));
                let x = x.min(t8.add(r).sub(c8)).max(t8.sub(r).sub(c8));
                x.store_unsplit::<SPLIT>(at);
                // lanes 0–3, then 4–7, into the four partial sums (from
                // the first product, `real::add_term`)
                let (lo, hi) = x.halves();
                acc = E::half_add_term(acc, E::half_load(weights.as_ptr().add(i0)), lo, i0 == 0);
                acc = E::half_mul_add(E::half_load(weights.as_ptr().add(i0 + 4)), hi, acc);
            }
            if full4 > full8 {
                let at = state.as_mut_ptr().add(full8);
                let r = E::half_load(thresholds.as_ptr().add(full8));
                let x = E::half_load_unsplit::<SPLIT>(at);
                E::half_store_unsplit::<SPLIT>(x, saved.as_mut_ptr().add(full8));
                let x = E::half_min(x, E::half_sub(E::half_add(t4, r), c4));
                let x = E::half_max(x, E::half_sub(E::half_sub(t4, r), c4));
                E::half_store_unsplit::<SPLIT>(x, at);
                let w = E::half_load(weights.as_ptr().add(full8));
                acc = E::half_add_term(acc, w, x, full8 == 0);
            }
            if full4 == n {
                return E::half_every_lane_sum(acc);
            }
            let mut lanes = [E::T::ZERO; 4];
            E::half_store(acc, lanes.as_mut_ptr());
            let c = E::half_first(c4);
            step_tail::<E::T, true>(state, saved, thresholds, weights, t, c, full4, &mut lanes);
            E::half_splat(reduce(lanes))
        }
    }

    /// `creep_pass::advance` in 8-lane blocks of thresholds, each block's
    /// weighted rows added as two blocks of four; then a 4-lane block and
    /// the rest as the portable tail. `v4` holds a finite `v` in every
    /// lane, and the result is in every lane.
    #[inline(always)]
    unsafe fn creep_advance_eight<E: Eight>(
        chi: &mut [E::T],
        thresholds: &[E::T],
        gains: &[E::T],
        weights: &[E::T],
        v4: E::Half,
    ) -> E::Half {
        let n = thresholds.len();
        assert!(weights.len() == n && chi.len() == n * gains.len());
        let (full8, full4) = (n - n % 8, n - n % LANES);
        let p = chi.as_mut_ptr();
        // SAFETY (all): the features are the caller's; every block ends at
        // or before n in its row of `chi` (n·m) and in the parameter slices.
        unsafe {
            let v8 = E::splat_half(v4);
            let mut acc = E::half_zero();
            for i0 in (0..full8).step_by(8) {
                let r = E::load(thresholds.as_ptr().add(i0));
                let (lower, upper) = (v8.sub(r), v8.add(r));
                macro_rules! update {
                    ($at:expr, $g:expr) => {{
                        let (at, g) = ($at, $g);
                        let x = E::load(at);
                        let c = x.min(upper).max(lower);
                        let g = E::splat(g);
                        let x = g.mul_add(c, g.neg_mul_add(x, x));
                        x.store(at);
                        x
                    }};
                }
                let mut at = p.add(i0);
                let mut rows = update!(at, gains[0]);
                for &g in &gains[1..] {
                    at = at.add(n);
                    rows = rows.add(update!(at, g));
                }
                let (lo, hi) = rows.halves();
                acc = E::half_add_term(acc, E::half_load(weights.as_ptr().add(i0)), lo, i0 == 0);
                acc = E::half_mul_add(E::half_load(weights.as_ptr().add(i0 + 4)), hi, acc);
            }
            if full4 > full8 {
                let r = E::half_load(thresholds.as_ptr().add(full8));
                let (lower, upper) = (E::half_sub(v4, r), E::half_add(v4, r));
                macro_rules! update {
                    ($at:expr, $g:expr) => {{
                        let (at, g) = ($at, $g);
                        let x = E::half_load(at);
                        let c = E::half_max(E::half_min(x, upper), lower);
                        let g = E::half_splat(g);
                        let x = E::half_mul_add(g, c, E::half_neg_mul_add(g, x, x));
                        E::half_store(x, at);
                        x
                    }};
                }
                let mut at = p.add(full8);
                let mut rows = update!(at, gains[0]);
                for &g in &gains[1..] {
                    at = at.add(n);
                    rows = E::half_add(rows, update!(at, g));
                }
                let w = E::half_load(weights.as_ptr().add(full8));
                acc = E::half_add_term(acc, w, rows, full8 == 0);
            }
            if full4 == n {
                return E::half_every_lane_sum(acc);
            }
            let mut lanes = [E::T::ZERO; LANES];
            E::half_store(acc, lanes.as_mut_ptr());
            let v = E::half_first(v4);
            advance_tail(chi, thresholds, gains, weights, v, full4, &mut lanes);
            E::half_splat(reduce(lanes))
        }
    }

    /// The step's kernels of the AVX2 set: `f64` on 4-lane registers,
    /// `f32` on 8-lane ones.
    struct Avx2Step;
    /// The step's kernels of the AVX-512 set: `f64` on 8-lane registers,
    /// `f32` on the AVX2 8-lane ones.
    struct Avx512Step;

    /// A value on a vector set's chain (its `Lanes`): the value, and for
    /// `f64` the value in every lane of a 4-lane register, which the `f64`
    /// kernels take and give (the `f32` kernels read the value; a register
    /// no kernel reads is not computed).
    #[derive(Clone, Copy)]
    pub(super) struct OnChain<T> {
        every_lane: __m256d,
        value: T,
    }

    macro_rules! step_kernels {
        ($set:ident, $hysteresis_f64:expr, $creep_f64:expr) => {
            impl<T: Real> super::StepKernels<T> for $set {
                type Lanes = OnChain<T>;

                #[inline(always)]
                unsafe fn splat(x: T) -> OnChain<T> {
                    // SAFETY (both): the caller's features.
                    let every_lane = if TypeId::of::<T>() == TypeId::of::<f64>() {
                        unsafe { _mm256_set1_pd(x.to_f64()) }
                    } else {
                        unsafe { _mm256_setzero_pd() }
                    };
                    OnChain {
                        every_lane,
                        value: x,
                    }
                }

                #[inline(always)]
                unsafe fn first(x: OnChain<T>) -> T {
                    x.value
                }

                #[inline(always)]
                unsafe fn inverse_plays(
                    state: &mut [T],
                    saved: &mut [T],
                    r: &[T],
                    w: &[T],
                    t: T,
                    c: OnChain<T>,
                ) -> OnChain<T> {
                    use super::{cast, cast_mut, count_simd_call};
                    count_simd_call();
                    // SAFETY (all): the caller's features.
                    if let (Some(x), Some(s), Some(r), Some(w)) =
                        (cast_mut(state), cast_mut(saved), cast(r), cast(w))
                    {
                        let v = unsafe { $hysteresis_f64(x, s, r, w, t.to_f64(), c.every_lane) };
                        return unsafe { on_chain(v) };
                    }
                    if let (Some(x), Some(s), Some(r), Some(w)) =
                        (cast_mut(state), cast_mut(saved), cast(r), cast(w))
                    {
                        let (t, c) = (t.to_f64() as f32, c.value.to_f64() as f32);
                        let y = unsafe { hysteresis_eight::<F32x8>(x, s, r, w, t, _mm_set1_ps(c)) };
                        return unsafe { Self::splat(T::from_f64(f64::from(_mm_cvtss_f32(y)))) };
                    }
                    unreachable!("Real is f32 or f64")
                }

                #[inline(always)]
                unsafe fn creep(
                    chi: &mut [T],
                    r: &[T],
                    g: &[T],
                    w: &[T],
                    v: OnChain<T>,
                ) -> OnChain<T> {
                    use super::{cast, cast_mut, count_simd_call};
                    count_simd_call();
                    // SAFETY (all): the caller's features.
                    if let (Some(chi), Some(r), Some(g), Some(w)) =
                        (cast_mut(chi), cast(r), cast(g), cast(w))
                    {
                        return unsafe { on_chain($creep_f64(chi, r, g, w, v.every_lane)) };
                    }
                    if let (Some(chi), Some(r), Some(g), Some(w)) =
                        (cast_mut(chi), cast(r), cast(g), cast(w))
                    {
                        let v = v.value.to_f64() as f32;
                        let y = unsafe { creep_eight::<F32x8>(chi, r, g, w, _mm_set1_ps(v)) };
                        return unsafe { Self::splat(T::from_f64(f64::from(_mm_cvtss_f32(y)))) };
                    }
                    unreachable!("Real is f32 or f64")
                }
            }
        };
    }
    /// An `f64` in every lane of `v` as a `T` on the chain (`T` is `f64`).
    #[inline(always)]
    unsafe fn on_chain<T: Real>(v: __m256d) -> OnChain<T> {
        OnChain {
            every_lane: v,
            // SAFETY: the caller's AVX.
            value: T::from_f64(unsafe { _mm256_cvtsd_f64(v) }),
        }
    }

    step_kernels!(Avx2Step, hysteresis_four, creep_four);
    step_kernels!(Avx512Step, hysteresis_eight::<F64x8>, creep_eight::<F64x8>);

    /// The creep pass alone on the AVX2 kernels (the forward model's, a
    /// held compensator sample's).
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    pub(super) unsafe fn creep_avx2<T: Real>(chi: &mut [T], r: &[T], g: &[T], w: &[T], v: T) -> T {
        type K = Avx2Step;
        // SAFETY: the features are enabled here.
        unsafe {
            let v = <K as super::StepKernels<T>>::splat(v);
            <K as super::StepKernels<T>>::first(<K as super::StepKernels<T>>::creep(
                chi, r, g, w, v,
            ))
        }
    }

    /// The creep pass alone on the AVX-512 kernels.
    #[target_feature(enable = "avx2,fma,avx512f")]
    #[inline]
    pub(super) unsafe fn creep_avx512<T: Real>(
        chi: &mut [T],
        r: &[T],
        g: &[T],
        w: &[T],
        v: T,
    ) -> T {
        type K = Avx512Step;
        // SAFETY: the features are enabled here.
        unsafe {
            let v = <K as super::StepKernels<T>>::splat(v);
            <K as super::StepKernels<T>>::first(<K as super::StepKernels<T>>::creep(
                chi, r, g, w, v,
            ))
        }
    }

    /// A kernel set's two functions compiled with its features:
    /// [`super::step_body`] (one step) and [`super::run_body`] (a run).
    macro_rules! step_and_run {
        ($set:ident, $features:literal, $step:ident, $run:ident) => {
            /// [`super::step_body`] on the set's kernels, one function.
            #[target_feature(enable = $features)]
            #[inline(never)]
            pub(super) unsafe fn $step<T: Real, C: super::StepSource<T>, const PAPER: bool>(
                c: &mut C,
                t: T,
                creep: T,
                lower: T,
                upper: T,
            ) -> (T, bool) {
                // SAFETY: the features are enabled here.
                let (u, saturated, _) = unsafe {
                    let creep = <$set as super::StepKernels<T>>::splat(creep);
                    super::step_body::<T, $set, C, PAPER>(c, t, creep, lower, upper)
                };
                (u, saturated)
            }

            /// [`super::run_body`] on the set's kernels, one function.
            #[target_feature(enable = $features)]
            #[inline(never)]
            pub(super) unsafe fn $run<T: Real, C: super::RunSource<T>, const PAPER: bool>(
                k: super::Kernels,
                c: &mut C,
                targets: &[T],
                out: super::RunOutputs<'_, T>,
            ) -> (usize, usize) {
                // SAFETY: the features are enabled here.
                unsafe { super::run_body::<T, $set, C, PAPER>(k, c, targets, out) }
            }
        };
    }
    step_and_run!(Avx2Step, "avx2,fma", step_avx2, run_avx2);
    step_and_run!(Avx512Step, "avx2,fma,avx512f", step_avx512, run_avx512);
}

#[cfg(all(test, feature = "std", target_arch = "x86_64", target_os = "linux"))]
mod tests {
    /// The vendor and family read by CPUID are the ones Linux reports: the
    /// rule of [`super::full_width_512`] (AMD family 25 splits 512-bit
    /// operations) asks the CPU it runs on.
    #[test]
    fn full_width_512_reads_the_vendor_and_family_linux_reports() {
        let info = std::fs::read_to_string("/proc/cpuinfo").unwrap();
        let field = |name: &str| {
            info.lines()
                .find(|l| l.split(':').next().map(str::trim) == Some(name))
                .and_then(|l| l.split_once(':'))
                .map(|(_, v)| v.trim().to_string())
                .unwrap()
        };
        let split = field("vendor_id") == "AuthenticAMD" && field("cpu family") == "25";
        assert_eq!(super::full_width_512(), !split);
    }
}
