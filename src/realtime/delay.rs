//! Dead time: `y_k = z_{max(k−d, 0)}` for the output `z` of the memory part
//! `S[H + C]`, `d` whole samples (an amplifier, an anti-alias filter, a
//! sensor's conversion). Before sample `d` the output is the first sample's
//! `z_0`, as if the record had started `d` samples earlier at rest on it.
//!
//! A delay cannot be inverted causally. A compensator inverts the memory
//! part only; a planned target is known ahead, so a caller shifts it by `d`
//! samples ([`preview`]): `u_k = W⁻¹[y_d]_{k+d}` makes `W[u] = y_d` from
//! sample `d` on.

use crate::realtime::checks::check_finite;
use crate::realtime::error::ParameterError;
use crate::realtime::real::Real;
use crate::realtime::storage::{Buffer, Storage};

/// A ring buffer of the last `d` values of `z`, in storage `S` (capacity
/// fixed at compile time with [`Inline`](super::Inline)).
#[derive(Debug, Clone, PartialEq)]
pub struct DelayLine<T: Real, S: Storage> {
    line: S::Delay<T>,
    /// Where the oldest value is (and the next one goes).
    head: usize,
    /// False until the first sample: then the line fills with `z_0`.
    started: bool,
}

impl<T: Real, S: Storage> DelayLine<T, S> {
    /// A line of `d` samples, not started.
    pub fn new(d: usize) -> Result<Self, ParameterError> {
        crate::realtime::limits::check("delay", crate::realtime::limits::MAX_DELAY, d)?;
        Ok(Self {
            line: S::Delay::<T>::zeroed("delay", d)?,
            head: 0,
            started: false,
        })
    }

    /// The dead time `d` in samples.
    #[inline(always)]
    pub fn len(&self) -> usize {
        self.line.len()
    }

    /// No dead time.
    #[inline(always)]
    pub fn is_empty(&self) -> bool {
        self.line.is_empty()
    }

    /// `z_{k−d}` out, `z_k` in.
    #[inline(always)]
    pub fn step(&mut self, z: T) -> T {
        let d = self.line.len();
        if d == 0 {
            return z;
        }
        if !self.started {
            self.line.fill(z);
            self.started = true;
        }
        let out = core::mem::replace(&mut self.line[self.head], z);
        self.head = if self.head + 1 == d { 0 } else { self.head + 1 };
        out
    }

    /// The values waiting in the line, oldest (the next output) first;
    /// `None` before the first sample.
    pub fn state_into(&self, out: &mut [T]) -> Option<()> {
        if !self.started || out.len() != self.len() {
            return None;
        }
        let d = self.len();
        for (i, o) in out.iter_mut().enumerate() {
            *o = self.line[(self.head + i) % d];
        }
        Some(())
    }

    /// Whether a sample has gone in (the line holds a state).
    pub fn is_started(&self) -> bool {
        self.started
    }

    /// Put `values` (oldest first) in the line, or `None`: not started.
    pub fn set_state(&mut self, values: Option<&[f64]>) -> Result<(), ParameterError> {
        let Some(values) = values else {
            self.reset();
            return Ok(());
        };
        crate::realtime::checks::check_length("delay_state", self.len(), values.len())?;
        check_finite("delay_state", values)?;
        for (l, &v) in self.line.iter_mut().zip(values) {
            *l = T::from_f64(v);
        }
        self.head = 0;
        self.started = true;
        Ok(())
    }

    /// Not started: the next sample fills the line.
    pub fn reset(&mut self) {
        self.line.fill(T::ZERO);
        self.head = 0;
        self.started = false;
    }
}

/// The target a compensator gets at sample `k` when the model has dead time
/// `d`: `targets[min(k + d, n − 1)]` (the last `d` samples hold the last
/// target), so that `W[W⁻¹[y]] = y` from sample `d` on.
#[inline]
pub fn preview<T: Copy>(targets: &[T], d: usize, k: usize) -> T {
    targets[(k + d).min(targets.len() - 1)]
}

/// `targets` previewed by `d` samples into `out` (same length): what a
/// compensator is given for a whole planned signal.
pub fn preview_into<T: Copy>(targets: &[T], d: usize, out: &mut [T]) -> Result<(), ParameterError> {
    crate::realtime::checks::check_length("preview", targets.len(), out.len())?;
    for (k, o) in out.iter_mut().enumerate() {
        *o = preview(targets, d, k);
    }
    Ok(())
}
