//! Heap storage for the core's operators: [`Heap`] keeps every list in a
//! `Vec` sized at run time, so the orders have no compile-time limit.

use core::ops::{Deref, DerefMut};

use crate::realtime::storage::SLACK;
use crate::realtime::{Buffer, ParameterError, Real, Storage};

/// Storage in vectors on the heap (`std`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Heap;

impl Storage for Heap {
    type Plays<T: Real> = Vec<T>;
    type Creep<T: Real> = Vec<T>;
    type CreepState<T: Real> = PaddedVec<T>;
    type Superposition<T: Real> = Vec<T>;
    type Delay<T: Real> = Vec<T>;
}

/// The longest list any heap buffer holds: every kind's own limit is
/// checked with its parameters ([`crate::realtime::limits`]); this is the last guard
/// for a caller that skipped them.
const LONGEST: usize = crate::realtime::limits::MAX_DELAY;

impl<T: Real> Buffer<T> for Vec<T> {
    fn zeroed(field: &'static str, len: usize) -> Result<Self, ParameterError> {
        crate::realtime::limits::check(field, LONGEST, len)?;
        // fallible: an allocation that fails is an error, not an abort
        let mut v = Vec::new();
        v.try_reserve_exact(len)
            .map_err(|_| ParameterError::ExceedsLimit {
                field,
                limit: LONGEST,
                found: len,
            })?;
        v.resize(len, T::ZERO);
        Ok(v)
    }
}

/// A vector with [`SLACK`] values beyond those asked for: the creep
/// state's heap buffer ([`Storage::CreepState`]).
#[derive(Debug, Clone, PartialEq)]
pub struct PaddedVec<T>(Vec<T>);

impl<T: Real> Buffer<T> for PaddedVec<T> {
    fn zeroed(field: &'static str, len: usize) -> Result<Self, ParameterError> {
        // checked for the length asked, so that an error names it
        crate::realtime::limits::check(field, LONGEST, len)?;
        Vec::zeroed(field, len + SLACK).map(PaddedVec)
    }
}

impl<T> Deref for PaddedVec<T> {
    type Target = [T];
    #[inline(always)]
    fn deref(&self) -> &[T] {
        &self.0
    }
}

impl<T> DerefMut for PaddedVec<T> {
    #[inline(always)]
    fn deref_mut(&mut self) -> &mut [T] {
        &mut self.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The heap's creep-state buffer asked for `len` values holds
    /// `len + SLACK` zeros, all of them writable (as the inline one does,
    /// `realtime::storage`'s test), and is refused past the longest.
    #[test]
    fn a_padded_vec_holds_the_slack_too() {
        for len in 0..=6 {
            let mut b = PaddedVec::<f64>::zeroed("creep", len).unwrap();
            assert_eq!(b.len(), len + SLACK);
            assert!(b.iter().all(|&x| x == 0.0));
            for (i, x) in b.iter_mut().enumerate() {
                *x = i as f64;
            }
            assert_eq!(b[len + SLACK - 1], (len + SLACK - 1) as f64);
        }
        assert!(PaddedVec::<f64>::zeroed("creep", LONGEST + 1).is_err());
    }
}
