//! Where an operator keeps its numbers: the storage parameter `S` of
//! [`Hysteresis`](super::Hysteresis), [`Creep`](super::Creep),
//! [`Model`](super::Model) and [`Compensator`](super::Compensator).
//!
//! One type per concept, with its storage as a parameter (as nalgebra makes
//! storage a parameter of one `Matrix`): the mathematics and the per-sample
//! kernels are written once and run on either
//!
//! * [`Inline<PLAYS, CREEP, SUPERPOSITION, DELAY>`]: arrays of a capacity
//!   fixed at compile time inside the object (at most `PLAYS` plays, at
//!   most `CREEP` elementary creep operators, at most `SUPERPOSITION` terms
//!   of the superposition operator, 9 unless given: four dead zones per
//!   side, and at most `DELAY` samples of dead time, 16 unless given); no
//!   allocator, for `no_std` firmware and C storage;
//! * `Heap` (with the `std` feature, in `crate::operators`): vectors sized
//!   at run time.
//!
//! The orders are chosen at run time in both; an inline object refuses
//! orders above its capacity with [`ParameterError::ExceedsCapacity`].

use core::fmt::Debug;
use core::ops::{Deref, DerefMut};

use crate::realtime::error::ParameterError;
pub use crate::realtime::placement::SLACK;
use crate::realtime::real::Real;

/// A storage class: the buffer types for play-sized and creep-sized lists.
pub trait Storage: Sized + Copy + Debug + PartialEq + 'static {
    /// Room for one value per play (thresholds, weights, states of `H`).
    type Plays<T: Real>: Buffer<T>;
    /// Room for one value per elementary creep operator (and the shorter
    /// lists of `C`: thresholds, weights, eigenvalues).
    type Creep<T: Real>: Buffer<T>;
    /// Room for the creep state `χ`: [`Buffer::zeroed`]`(field, len)` holds
    /// `len` values and [`SLACK`] more (a slice of `len + SLACK`), for the
    /// operator to start `χ` where no register's worth straddles a page
    /// (`crate::realtime::placement`).
    type CreepState<T: Real>: Buffer<T>;
    /// Room for one value per term of the superposition operator `S`.
    type Superposition<T: Real>: Buffer<T>;
    /// Room for one value per sample of dead time.
    type Delay<T: Real>: Buffer<T>;
}

/// A list of `len` values, zero-initialised, seen as a slice of exactly
/// that length.
pub trait Buffer<T: Real>: Clone + Debug + PartialEq + Deref<Target = [T]> + DerefMut {
    /// `len` zeros, or [`ParameterError::ExceedsCapacity`] naming `field`.
    fn zeroed(field: &'static str, len: usize) -> Result<Self, ParameterError>;

    /// The first `K` values, for a step compiled for `K` of them: a slice
    /// of length `K`. Ask only when the buffer holds at least `K`: one
    /// holding fewer panics, except an inline buffer with room for `K`,
    /// which takes them from its array without reading its length (so
    /// that the compiler sees a constant and no check) and would give the
    /// unused zeros after those in use.
    #[inline(always)]
    fn prefix<const K: usize>(&self) -> &[T] {
        &self[..K]
    }

    /// [`Buffer::prefix`], mutable.
    #[inline(always)]
    fn prefix_mut<const K: usize>(&mut self) -> &mut [T] {
        &mut self[..K]
    }
}

/// Inline storage: at most `PLAYS` plays, `CREEP` elementary creep
/// operators, `SUPERPOSITION` terms of `S` (thresholds including the zero
/// one) and `DELAY` samples of dead time, in arrays inside the object.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Inline<
    const PLAYS: usize,
    const CREEP: usize,
    const SUPERPOSITION: usize = 9,
    const DELAY: usize = 16,
>;

impl<const PLAYS: usize, const CREEP: usize, const SUPERPOSITION: usize, const DELAY: usize> Storage
    for Inline<PLAYS, CREEP, SUPERPOSITION, DELAY>
{
    type Plays<T: Real> = InlineBuffer<T, PLAYS>;
    type Creep<T: Real> = InlineBuffer<T, CREEP>;
    type CreepState<T: Real> = PaddedBuffer<T, CREEP>;
    type Superposition<T: Real> = InlineBuffer<T, SUPERPOSITION>;
    type Delay<T: Real> = InlineBuffer<T, DELAY>;
}

/// Up to `N` values in an array, `len` of them in use.
#[derive(Debug, Clone, Copy)]
pub struct InlineBuffer<T, const N: usize> {
    len: usize,
    data: [T; N],
}

impl<T: Real, const N: usize> Buffer<T> for InlineBuffer<T, N> {
    fn zeroed(field: &'static str, len: usize) -> Result<Self, ParameterError> {
        crate::realtime::checks::check_capacity(field, N, len)?;
        Ok(Self {
            len,
            data: [T::ZERO; N],
        })
    }

    // with `N ≥ K` known when compiled: no length read, no check
    #[inline(always)]
    fn prefix<const K: usize>(&self) -> &[T] {
        &self.data[..K]
    }

    #[inline(always)]
    fn prefix_mut<const K: usize>(&mut self) -> &mut [T] {
        &mut self.data[..K]
    }
}

impl<T, const N: usize> Deref for InlineBuffer<T, N> {
    type Target = [T];
    #[inline(always)]
    fn deref(&self) -> &[T] {
        // the slice lets the kernels see the orders, not the capacity;
        // `len ≤ N` by construction, and `min` tells the compiler so (a
        // conditional move instead of a bounds check per access)
        &self.data[..self.len.min(N)]
    }
}

impl<T, const N: usize> DerefMut for InlineBuffer<T, N> {
    #[inline(always)]
    fn deref_mut(&mut self) -> &mut [T] {
        &mut self.data[..self.len.min(N)]
    }
}

/// Equal when the values in use are (the unused tail does not count).
impl<T: PartialEq, const N: usize> PartialEq for InlineBuffer<T, N> {
    fn eq(&self, other: &Self) -> bool {
        self[..] == other[..]
    }
}

/// Up to `N` values in use and [`SLACK`] more, in one array: the creep
/// state's inline buffer ([`Storage::CreepState`]), seen as a slice of the
/// `len + SLACK` values from its start.
#[derive(Debug, Clone, Copy)]
pub struct PaddedBuffer<T, const N: usize> {
    len: usize,
    values: Padded<T, N>,
}

/// `N` values, then [`SLACK`]: one array of `N + SLACK` (`repr(C)` puts
/// `slack` right after `data`, with no padding between arrays of one type).
#[derive(Debug, Clone, Copy)]
#[repr(C)]
struct Padded<T, const N: usize> {
    data: [T; N],
    slack: [T; SLACK],
}

impl<T, const N: usize> PaddedBuffer<T, N> {
    /// All `N + SLACK` values.
    #[inline(always)]
    fn all(&self) -> &[T] {
        // SAFETY: `Padded` is `N + SLACK` values of `T` in a row (above),
        // read through a pointer to all of it.
        unsafe { core::slice::from_raw_parts((&raw const self.values).cast::<T>(), N + SLACK) }
    }

    /// All `N + SLACK` values, mutable.
    #[inline(always)]
    fn all_mut(&mut self) -> &mut [T] {
        // SAFETY: as in `all`, through the one mutable reference.
        unsafe { core::slice::from_raw_parts_mut((&raw mut self.values).cast::<T>(), N + SLACK) }
    }
}

impl<T: Real, const N: usize> Buffer<T> for PaddedBuffer<T, N> {
    fn zeroed(field: &'static str, len: usize) -> Result<Self, ParameterError> {
        crate::realtime::checks::check_capacity(field, N, len)?;
        Ok(Self {
            len: len + SLACK,
            values: Padded {
                data: [T::ZERO; N],
                slack: [T::ZERO; SLACK],
            },
        })
    }

    // the array's length known when compiled, as for `InlineBuffer`
    #[inline(always)]
    fn prefix<const K: usize>(&self) -> &[T] {
        &self.all()[..K]
    }

    #[inline(always)]
    fn prefix_mut<const K: usize>(&mut self) -> &mut [T] {
        &mut self.all_mut()[..K]
    }
}

impl<T, const N: usize> Deref for PaddedBuffer<T, N> {
    type Target = [T];
    #[inline(always)]
    fn deref(&self) -> &[T] {
        &self.all()[..self.len.min(N + SLACK)]
    }
}

impl<T, const N: usize> DerefMut for PaddedBuffer<T, N> {
    #[inline(always)]
    fn deref_mut(&mut self) -> &mut [T] {
        let len = self.len.min(N + SLACK);
        &mut self.all_mut()[..len]
    }
}

/// Equal when the values in use and the slack are.
impl<T: PartialEq, const N: usize> PartialEq for PaddedBuffer<T, N> {
    fn eq(&self, other: &Self) -> bool {
        self[..] == other[..]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `prefix::<K>` is the first `K` values in use whenever the buffer
    /// holds at least `K` (an inline one reads them from its array).
    /// Holding fewer, an inline buffer with room for `K` gives those it
    /// holds and then its unused zeros; any other panics. For inline
    /// buffers with room for `K` and without, heap buffers, and lengths
    /// below, at and above `K`.
    #[test]
    fn a_prefix_is_the_first_values_in_use() {
        fn check<B: Buffer<f64> + std::panic::UnwindSafe>(len: usize, room: Option<usize>) {
            let mut b = B::zeroed("test", len).unwrap();
            for (i, x) in b.iter_mut().enumerate() {
                *x = i as f64 + 1.0;
            }
            let held: std::vec::Vec<f64> = b.to_vec();
            if len < 4 && room.is_none_or(|n| n < 4) {
                let taken = std::panic::catch_unwind(move || b.prefix::<4>().len());
                assert!(taken.is_err(), "len {len}: no panic");
                return;
            }
            let prefix = b.prefix::<4>().to_vec();
            assert_eq!(prefix.len(), 4);
            if len >= 4 {
                assert_eq!(prefix, held[..4], "len {len}");
            } else {
                assert_eq!(prefix[..len], held[..], "len {len}");
                assert!(prefix[len..] == [0.0; 4][len..], "len {len}");
            }
            assert_eq!(b.prefix_mut::<4>(), &prefix[..]);
            if len > 0 {
                b.prefix_mut::<4>()[0] = -1.0;
                assert_eq!(b[0], -1.0);
            }
        }
        for len in 0..=6 {
            check::<InlineBuffer<f64, 6>>(len, Some(6));
            check::<std::vec::Vec<f64>>(len, None);
        }
        for len in 0..=3 {
            check::<InlineBuffer<f64, 3>>(len, Some(3));
        }
    }

    /// A creep-state buffer asked for `len` values holds `len + SLACK`
    /// zeros, all of them writable, inline up to its capacity (and refused
    /// beyond it, naming the capacity in values in use); its prefix
    /// reaches into the slack (the heap's buffer: `operators::heap`).
    #[test]
    fn a_creep_state_buffer_holds_the_slack_too() {
        fn check<B: Buffer<f64>>(len: usize) {
            let mut b = B::zeroed("creep", len).unwrap();
            assert_eq!(b.len(), len + SLACK);
            assert!(b.iter().all(|&x| x == 0.0));
            for (i, x) in b.iter_mut().enumerate() {
                *x = i as f64;
            }
            assert_eq!(b[len + SLACK - 1], (len + SLACK - 1) as f64);
        }
        for len in 0..=6 {
            check::<PaddedBuffer<f64, 6>>(len);
        }
        let e = PaddedBuffer::<f64, 6>::zeroed("creep", 7).unwrap_err();
        assert!(matches!(
            e,
            ParameterError::ExceedsCapacity {
                capacity: 6,
                found: 7,
                ..
            }
        ));
        let mut b = PaddedBuffer::<f64, 6>::zeroed("creep", 2).unwrap();
        b.prefix_mut::<{ 6 + SLACK }>()[6 + SLACK - 1] = 5.0;
        assert_eq!(b.prefix::<{ 6 + SLACK }>()[6 + SLACK - 1], 5.0);
    }
}
