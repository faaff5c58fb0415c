//! The step timer: `lfence; rdtsc` on x86-64 (the time-stamp counter,
//! constant-rate on every CPU that runs this), elsewhere the monotonic
//! clock in nanoseconds. Ticks become nanoseconds by a rate calibrated
//! against the monotonic clock; the cost of an empty bracket is measured
//! and stated, not subtracted, so every latency is an upper bound.

use std::time::{Duration, Instant};

/// The counter now.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub fn ticks() -> u64 {
    use std::arch::x86_64::{_mm_lfence, _rdtsc};
    // SAFETY: lfence and rdtsc exist on every x86-64 CPU; the fences keep
    // the step's instructions inside the bracket
    unsafe {
        _mm_lfence();
        let t = _rdtsc();
        _mm_lfence();
        t
    }
}

/// The counter now (nanoseconds since the first call).
#[cfg(not(target_arch = "x86_64"))]
#[inline(always)]
pub fn ticks() -> u64 {
    use std::sync::OnceLock;
    static START: OnceLock<Instant> = OnceLock::new();
    START.get_or_init(Instant::now).elapsed().as_nanos() as u64
}

/// What the timer is, for the report.
pub fn timer_name() -> &'static str {
    if cfg!(target_arch = "x86_64") {
        "lfence+rdtsc"
    } else {
        "the monotonic clock"
    }
}

/// Nanoseconds per tick, against the monotonic clock over `span`.
pub fn calibrate(span: Duration) -> f64 {
    let (t0, c0) = (Instant::now(), ticks());
    while t0.elapsed() < span {}
    let (dt, dc) = (t0.elapsed(), ticks().wrapping_sub(c0));
    if dc == 0 {
        1.0
    } else {
        dt.as_nanos() as f64 / dc as f64
    }
}

/// The ticks of `n` empty brackets (the timer's own cost per step).
pub fn empty_brackets(n: usize) -> Vec<u64> {
    (0..n)
        .map(|_| {
            let t0 = ticks();
            ticks().wrapping_sub(t0)
        })
        .collect()
}
