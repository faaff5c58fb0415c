//! What a run of the loop is scored by (`docs/MATHEMATICS.md` §11.4): the
//! tracking error `e_k = y_k − y_d,k` of the true tip (not the measurement)
//! during the transition `[t₀, t₀ + T)` and after it, the residual
//! vibration, the peak patch voltage, the time in saturation, the held
//! samples and the controller's compute time per step.

use super::LoopTrace;

/// The scores of one run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scores {
    /// rms and max `|e|` during the transition (m).
    pub during_rms: f64,
    pub during_max: f64,
    /// rms and max `|e|` after the transition, to the end (m).
    pub after_rms: f64,
    pub after_max: f64,
    /// max `|e|` over the whole run (m): Fig. 14's tracking error.
    pub max_error: f64,
    /// max `|e|` over the last [`RESIDUAL_WINDOW`] seconds (m).
    pub residual: f64,
    /// Highest patch voltage `max(u_fs, u_bs)` (V).
    pub peak_voltage: f64,
    /// Time the compensator's output was clipped (s).
    pub saturated_time: f64,
    /// Samples whose controller answer was held.
    pub held: usize,
    /// Mean and max wall-clock time of a controller step (s).
    pub compute_mean: f64,
    pub compute_max: f64,
}

/// The residual vibration is measured over the last this many seconds.
pub const RESIDUAL_WINDOW: f64 = 0.2;

/// Score `trace` for the transition `[start, end)` (s).
pub fn score(trace: &LoopTrace, start: f64, end: f64) -> Scores {
    let n = trace.t.len();
    let error = |k: usize| trace.tip[k] - trace.reference[k];
    let stats = |ks: &mut dyn Iterator<Item = usize>| {
        let (mut sum, mut max, mut count) = (0.0, 0.0f64, 0usize);
        for k in ks {
            let e = error(k);
            sum += e * e;
            max = max.max(e.abs());
            count += 1;
        }
        ((sum / count.max(1) as f64).sqrt(), max)
    };
    let t = &trace.t;
    let (during_rms, during_max) = stats(&mut (0..n).filter(|&k| t[k] >= start && t[k] < end));
    let (after_rms, after_max) = stats(&mut (0..n).filter(|&k| t[k] >= end));
    let (_, max_error) = stats(&mut (0..n));
    let last = t.last().copied().unwrap_or(0.0);
    let (_, residual) = stats(&mut (0..n).filter(|&k| t[k] > last - RESIDUAL_WINDOW));
    let ts = if n > 1 { t[1] - t[0] } else { 0.0 };
    let max = |v: &[f64]| v.iter().fold(f64::NEG_INFINITY, |m, x| m.max(*x));
    Scores {
        during_rms,
        during_max,
        after_rms,
        after_max,
        max_error,
        residual,
        peak_voltage: max(&trace.u_fs).max(max(&trace.u_bs)),
        saturated_time: trace.saturated.iter().filter(|s| **s).count() as f64 * ts,
        held: trace.held.iter().filter(|h| **h).count(),
        compute_mean: trace.compute_time.iter().sum::<f64>() / n.max(1) as f64,
        compute_max: max(&trace.compute_time).max(0.0),
    }
}
