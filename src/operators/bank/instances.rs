//! The bank's steps for `f32` and `f64`, compiled in this crate.
//!
//! The steps are generic in the sample type, so each crate that steps a
//! bank compiles every kernel set of them again, each test binary that
//! uses the bank among them. Where rustc shares generic instances
//! between crates (`opt-level` 0, 1, `s` and `z`: the `shared_generics`
//! cfg set by `build.rs`), the instances below, kept by `#[used]`, are
//! linked instead. Optimized builds do not share them and compile their
//! own as before, so there the cfg is off and nothing is added; nor in
//! the crate's own unit tests, which no other crate links.

use crate::realtime::compensator::Compensated;
use crate::realtime::error::ParameterError;
use crate::realtime::real::Real;
#[cfg(feature = "internals")]
use crate::realtime::simd::Kernels;

use super::{CompensatorBank, Par};

type Step<T> =
    fn(&mut CompensatorBank<T>, &[T], &mut [Compensated<T>]) -> Result<(), ParameterError>;
type StepOn<T, P> =
    fn(&mut CompensatorBank<T>, P, &[T], &mut [Compensated<T>]) -> Result<(), ParameterError>;

/// Every public step of a bank of `T`: one sample, one sample on a
/// threading, and a run of frames.
const fn steps<T: Real>() -> (Step<T>, StepOn<T, Par>, Step<T>) {
    (
        CompensatorBank::<T>::compensate,
        CompensatorBank::<T>::compensate_on,
        CompensatorBank::<T>::compensate_frames,
    )
}

#[used]
static STEPS_F32: (Step<f32>, StepOn<f32, Par>, Step<f32>) = steps();
#[used]
static STEPS_F64: (Step<f64>, StepOn<f64, Par>, Step<f64>) = steps();

/// The step on a chosen kernel set, which the tests run on each.
#[cfg(feature = "internals")]
#[used]
static STEPS_USING: (StepOn<f32, Kernels>, StepOn<f64, Kernels>) = (
    CompensatorBank::<f32>::compensate_using,
    CompensatorBank::<f64>::compensate_using,
);
