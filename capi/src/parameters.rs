//! Model parameters as C arrays.

use mfcbeam_rs::realtime::{
    CreepParameters, DynamicsParameters, HysteresisParameters, ModelParameters, Resonance,
    SuperpositionParameters,
};

use crate::error::Failure;

/// The model `W = S[H + C] + offset`: hysteresis thresholds
/// `0 = r_0 < … < r_n` and weights with positive partial sums
/// (`hysteresis_len` each); creep thresholds and weights (`creep_len` each;
/// 0 for no creep) and `eigenvalue_count` eigenvalues `a_j > 0` (1/s); the
/// sample time (s) and an output offset (V); the superposition operator's
/// thresholds (increasing, one of them 0) and weights (`superposition_len`
/// each; 0 for none, `S` the identity); the dead time `delay` in whole
/// samples (`y_k = S[H + C]_{max(k−d, 0)} + offset`; at most
/// `MFCBEAM_MAX_DELAY` in caller-owned model storage). The arrays are read
/// during `*_init` only. Then the linear dynamics `G` after `S`
/// (`y = G[S[H + C]]`): a first-order low-pass of cut-off
/// `low_pass_frequency` (Hz) and a resonance of natural frequency
/// `resonance_frequency` (Hz, below the Nyquist frequency) and damping ratio
/// `resonance_damping` (`0 < ζ < 1`; the resonance brings one sample of lag,
/// which the compensator's preview covers: `mfcbeam_*_delay` reports it),
/// and a delay of `delay_fraction` of a sample (`|τ| < 0.5`); a frequency
/// or fraction of 0 means that part is absent. The `S` fields, `delay` and the dynamics come last, so an
/// initializer that stops after `offset` leaves them zero: no `S`, no dead
/// time, no dynamics.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct MfcbeamParameters {
    pub sample_time: f64,
    pub hysteresis_thresholds: *const f64,
    pub hysteresis_weights: *const f64,
    pub hysteresis_len: usize,
    pub creep_thresholds: *const f64,
    pub creep_weights: *const f64,
    pub creep_len: usize,
    pub creep_eigenvalues: *const f64,
    pub eigenvalue_count: usize,
    pub offset: f64,
    pub superposition_thresholds: *const f64,
    pub superposition_weights: *const f64,
    pub superposition_len: usize,
    pub delay: usize,
    pub low_pass_frequency: f64,
    pub resonance_frequency: f64,
    pub resonance_damping: f64,
    pub delay_fraction: f64,
}

/// `len` values at `ptr`, refusing a NULL pointer with a non-zero length.
///
/// # Safety
/// `ptr` is NULL or points to `len` readable `f64`.
unsafe fn slice<'a>(
    ptr: *const f64,
    len: usize,
    field: &'static str,
) -> Result<&'a [f64], Failure> {
    if len == 0 {
        return Ok(&[]);
    }
    if ptr.is_null() {
        return Err(Failure::NullArray { field, len });
    }
    // SAFETY: non-null, and the caller guarantees len readable values.
    Ok(unsafe { core::slice::from_raw_parts(ptr, len) })
}

impl MfcbeamParameters {
    /// The parameters as the real-time core takes them (not yet validated).
    ///
    /// # Safety
    /// Every pointer is NULL or points to its length's readable values.
    pub(crate) unsafe fn model(&self) -> Result<ModelParameters<'_>, Failure> {
        // SAFETY: forwarded from the caller.
        unsafe {
            let hysteresis = HysteresisParameters {
                thresholds: slice(
                    self.hysteresis_thresholds,
                    self.hysteresis_len,
                    "hysteresis_thresholds",
                )?,
                weights: slice(
                    self.hysteresis_weights,
                    self.hysteresis_len,
                    "hysteresis_weights",
                )?,
            };
            let creep = if self.creep_len == 0 {
                None
            } else {
                Some(CreepParameters {
                    thresholds: slice(self.creep_thresholds, self.creep_len, "creep_thresholds")?,
                    weights: slice(self.creep_weights, self.creep_len, "creep_weights")?,
                    eigenvalues: slice(
                        self.creep_eigenvalues,
                        self.eigenvalue_count,
                        "creep_eigenvalues",
                    )?,
                })
            };
            let superposition = if self.superposition_len == 0 {
                None
            } else {
                let len = self.superposition_len;
                Some(SuperpositionParameters {
                    thresholds: slice(
                        self.superposition_thresholds,
                        len,
                        "superposition_thresholds",
                    )?,
                    weights: slice(self.superposition_weights, len, "superposition_weights")?,
                })
            };
            let dynamics = DynamicsParameters {
                low_pass: (self.low_pass_frequency != 0.0).then_some(self.low_pass_frequency),
                resonance: (self.resonance_frequency != 0.0).then_some(Resonance {
                    frequency: self.resonance_frequency,
                    damping: self.resonance_damping,
                }),
                delay_fraction: self.delay_fraction,
            };
            Ok(ModelParameters {
                sample_time: self.sample_time,
                hysteresis,
                creep,
                superposition,
                dynamics: (!dynamics.is_identity()).then_some(dynamics),
                delay: self.delay,
                offset: self.offset,
                rate_gain: 0.0,
            })
        }
    }
}
