//! Heap storage for the core's operators: [`Heap`] keeps every list in a
//! `Vec` sized at run time, so the orders have no compile-time limit.

use crate::realtime::{Buffer, ParameterError, Real, Storage};

/// Storage in vectors on the heap (`std`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Heap;

impl Storage for Heap {
    type Plays<T: Real> = Vec<T>;
    type Creep<T: Real> = Vec<T>;
    type Superposition<T: Real> = Vec<T>;
    type Delay<T: Real> = Vec<T>;
}

impl<T: Real> Buffer<T> for Vec<T> {
    fn zeroed(_field: &'static str, len: usize) -> Result<Self, ParameterError> {
        Ok(vec![T::ZERO; len])
    }
}
