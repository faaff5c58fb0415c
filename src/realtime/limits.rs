//! The largest count any input may ask for.
//!
//! A count read from a file, an option or a C or Python argument — or
//! derived from them, like the samples of `duration / sample_time` — decides
//! how much memory and time a call takes. Each is checked against a limit
//! here *before* anything is allocated from it, so that a small hostile file
//! gets an error instead of an abort or hours of work. Lists that are
//! written out in a file (thresholds, weights, states, trace rows) take
//! memory in proportion to the file itself; the limits below cap what a
//! file can ask for beyond its own size. `docs/FILES.md` ("Limits") states
//! each with its reason.
//!
//! The limits are far beyond every model the paper and the identification
//! use (12 plays, 12 × 5 creep elements, 4 terms of `S` per side, a few
//! samples of dead time), and small enough that the largest model of any
//! kind takes well under a megabyte.

use crate::realtime::error::ParameterError;

/// Plays of a hysteresis operator `H` (and of its inverse): its state and
/// the per-sample work grow with it; identified models use 12 to 48.
pub const MAX_PLAYS: usize = 1024;

/// Thresholds of a creep operator `C` (elementary PI creep operators).
pub const MAX_CREEP_THRESHOLDS: usize = 1024;

/// Eigenvalues `a_j` of the log(t)-creep operators (24): five decades in the
/// paper; 64 would space them at a tenth of a decade over six decades.
pub const MAX_CREEP_EIGENVALUES: usize = 64;

/// Elementary creep states `(thresholds) × (eigenvalues)`: the product is
/// what a file of two short lists could otherwise blow up (128 kB of state
/// at this limit).
pub const MAX_CREEP_ELEMENTS: usize = 16_384;

/// Terms of a superposition operator `S` (thresholds including the zero
/// one).
pub const MAX_SUPERPOSITION_TERMS: usize = 1024;

/// Dead time in samples: one delay line holds this many values (800 kB in
/// `f64`); 20 s at the paper's 0.2 ms, 10 s at 10 kHz, far beyond any
/// amplifier, filter or sensor delay.
pub const MAX_DELAY: usize = 100_000;

/// The largest dead time `identify --delay auto` tries: every candidate is
/// a whole fit, so the search costs this many fits (40 ms at 0.2 ms).
pub const MAX_DELAY_SEARCH: usize = 200;

/// Weights an identification fits at once (plays, creep thresholds, terms of
/// `S⁻¹`): its triangular factor takes `(4096 + p)·p` doubles (18 MB at
/// this limit) and its time grows with `samples · p²`.
pub const MAX_IDENTIFIED_WEIGHTS: usize = 512;

/// Basis functions (modes) of a beam model: its state has `2n` values and the
/// Ritz assembly costs `n²` quadratures; 100 modes reach far above the
/// Nyquist frequency of any sample time used with it.
pub const MAX_BASIS_FUNCTIONS: usize = 100;

/// Finite elements of the beam: the dense `2N × 2N` matrices of its modal
/// reduction (8 MB each at this limit, about five of them) and the `O(N³)`
/// eigensolver; 240 elements are converged to 1e-6 in the first frequency.
pub const MAX_ELEMENTS: usize = 500;

/// Samples of a trace a command generates from its options (a signal, a
/// feedforward trajectory): 200 s at the paper's 0.2 ms, about 8 MB per
/// column.
pub const MAX_GENERATED_SAMPLES: usize = 1_000_000;

/// Random cases of one conformance run (each runs the candidate at least
/// once).
pub const MAX_CONFORMANCE_CASES: usize = 100_000;

/// The longest time limit (s) of one run of a conformance candidate: a day.
pub const MAX_CANDIDATE_TIMEOUT: f64 = 86_400.0;

/// `Ok` when `found ≤ limit`, else [`ParameterError::ExceedsLimit`] naming
/// `field`.
pub fn check(field: &'static str, limit: usize, found: usize) -> Result<(), ParameterError> {
    if found <= limit {
        Ok(())
    } else {
        Err(ParameterError::ExceedsLimit {
            field,
            limit,
            found,
        })
    }
}

/// The number of samples `duration / sample_time` (rounded, plus one for
/// the first sample), checked against [`MAX_GENERATED_SAMPLES`] before
/// anything is allocated; both must be finite, the sample time `> 0` and the
/// duration `≥ 0`.
pub fn generated_samples(duration: f64, sample_time: f64) -> Result<usize, ParameterError> {
    if !(sample_time.is_finite() && sample_time > 0.0) {
        return Err(ParameterError::NonPositiveSampleTime { value: sample_time });
    }
    if !duration.is_finite() {
        return Err(ParameterError::NonFiniteValue {
            field: "duration",
            value: duration,
        });
    }
    if duration < 0.0 {
        return Err(ParameterError::InvalidDuration {
            field: "duration",
            value: duration,
        });
    }
    let steps = libm::round(duration / sample_time);
    // compared as f64: the quotient may be far beyond usize, or infinite
    // (never NaN: the duration is finite, the sample time finite and > 0)
    if steps >= MAX_GENERATED_SAMPLES as f64 {
        return Err(ParameterError::ExceedsLimit {
            field: "samples (duration / sample time)",
            limit: MAX_GENERATED_SAMPLES,
            found: if steps.is_finite() && steps < usize::MAX as f64 {
                steps as usize + 1
            } else {
                usize::MAX
            },
        });
    }
    Ok(steps as usize + 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn generated_samples_are_refused_before_they_are_counted() {
        assert_eq!(generated_samples(1.0, 0.25), Ok(5));
        assert_eq!(generated_samples(0.0, 0.25), Ok(1));
        for (duration, ts) in [(1e9, 2e-4), (1.0, 1e-300), (f64::MAX, 1e-3)] {
            assert!(matches!(
                generated_samples(duration, ts),
                Err(ParameterError::ExceedsLimit { .. })
            ));
        }
        assert!(generated_samples(f64::NAN, 1.0).is_err());
        assert!(generated_samples(-1.0, 1.0).is_err());
        assert!(generated_samples(1.0, 0.0).is_err());
        assert!(generated_samples(1.0, f64::INFINITY).is_err());
    }

    #[test]
    fn check_names_the_field_and_the_limit() {
        assert!(check("delay", MAX_DELAY, MAX_DELAY).is_ok());
        let e = check("delay", MAX_DELAY, MAX_DELAY + 1).unwrap_err();
        assert_eq!(
            e.to_string(),
            "delay: 100001 exceeds the limit of 100000 (docs/FILES.md, \"Limits\")"
        );
    }
}
