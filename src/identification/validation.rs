//! Checking an identified model on records other than the one it was fitted
//! on: where a record's evaluation starts ([`FitStart`]: a sample, a time,
//! or where `|u|` first reaches `max|u|`), the errors per record, and the
//! dominant rate of each record's input, so that a model whose error grows
//! with the rate shows it at a glance ([`ValidationTable`]).

use std::fmt;
use std::str::FromStr;

use super::report::{check_record_signals, first_at_max, FitErrors};
use super::settings::IdentificationError;
use crate::operators::model::HysteresisCreepModel;
use crate::operators::traits::Operator;

/// Where the fit (or the evaluation of a record) starts.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum FitStart {
    /// Where `|u|` first reaches `max|u|`: from there every play's state is
    /// fixed by the input.
    #[default]
    FirstAtMax,
    /// A sample index.
    Sample(usize),
    /// A time after the first sample (s): a start transient to leave out.
    Seconds(f64),
}

impl FitStart {
    /// The first sample of a record `u` sampled at `sample_time`.
    pub fn resolve(&self, u: &[f64], sample_time: f64) -> usize {
        match *self {
            FitStart::FirstAtMax => first_at_max(u),
            FitStart::Sample(k) => k,
            FitStart::Seconds(t) => (t / sample_time).round() as usize,
        }
    }
}

impl FromStr for FitStart {
    type Err = String;

    /// `N` (a sample) or `Xs` (seconds, e.g. `0.1s`).
    fn from_str(s: &str) -> Result<Self, String> {
        let bad = || format!("'{s}' is neither a sample count nor a time like 0.1s");
        match s.strip_suffix('s') {
            Some(t) => {
                let t: f64 = t.trim().parse().map_err(|_| bad())?;
                if t.is_finite() && t >= 0.0 {
                    Ok(FitStart::Seconds(t))
                } else {
                    Err(format!("'{s}': a time must be finite and >= 0"))
                }
            }
            None => s.trim().parse().map(FitStart::Sample).map_err(|_| bad()),
        }
    }
}

/// The dominant rate of `u` (Hz): how often it crosses the middle of its
/// range upward, per second (the fundamental of a periodic excitation).
/// `None` when it never does.
pub fn dominant_rate(u: &[f64], sample_time: f64) -> Option<f64> {
    let (lo, hi) = u
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    let mid = 0.5 * (lo + hi);
    let ups: Vec<usize> = (1..u.len())
        .filter(|&k| u[k - 1] < mid && u[k] >= mid)
        .collect();
    match ups.as_slice() {
        [first, .., last] => Some((ups.len() - 1) as f64 / ((last - first) as f64 * sample_time)),
        _ => None,
    }
}

/// The errors of a model on one record.
#[derive(Debug, Clone, PartialEq)]
pub struct ValidationRow {
    /// The record's name (its file).
    pub name: String,
    /// The first sample evaluated.
    pub from: usize,
    pub errors: FitErrors,
    /// Its input's dominant rate (Hz), if it has one.
    pub rate: Option<f64>,
    /// With a zeroing segment: the constant offset estimated on it (the
    /// mean of `y − W[u]` there) and the errors from `from` with it removed.
    pub zeroed: Option<(f64, FitErrors)>,
}

impl ValidationRow {
    /// The errors that count: zeroed when a zeroing stretch was given.
    pub fn score(&self) -> FitErrors {
        self.zeroed.map_or(self.errors, |(_, z)| z)
    }
}

/// A stretch of a record on which its constant offset is estimated before
/// the rest is scored (the practice of zeroing a sensor before a run):
/// `A..B`, each a sample or a time like `1.0s`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ZeroSegment {
    pub start: FitStart,
    pub end: FitStart,
}

impl FromStr for ZeroSegment {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        let (a, b) = s
            .split_once("..")
            .ok_or_else(|| format!("'{s}' is not a segment like 1.0s..1.5s"))?;
        Ok(Self {
            start: a.parse()?,
            end: b.parse()?,
        })
    }
}

impl ZeroSegment {
    /// The samples of the segment in a record of `len` samples, or why
    /// there are none.
    pub fn resolve(&self, len: usize, sample_time: f64) -> Result<std::ops::Range<usize>, String> {
        let at = |s: FitStart| match s {
            FitStart::Seconds(t) => (t / sample_time).round() as usize,
            FitStart::Sample(k) => k,
            FitStart::FirstAtMax => 0,
        };
        let (a, b) = (at(self.start), at(self.end));
        if a >= b || b > len {
            return Err(format!(
                "samples {a}..{b} are not a non-empty stretch inside the record's {len} samples"
            ));
        }
        Ok(a..b)
    }
}

/// Errors of `model` (run from the virgin state over the whole record) on
/// the record `(u, y)` from sample `from` on.
pub fn validate_record(
    model: &HysteresisCreepModel,
    name: &str,
    u: &[f64],
    y: &[f64],
    from: usize,
) -> Result<ValidationRow, IdentificationError> {
    let mut virgin = model.clone();
    virgin.reset();
    validate_record_from_state(&virgin, name, u, y, from, None)
}

/// [`validate_record`], and the errors with the record's constant offset
/// estimated on `zero` (the mean of `y − W[u]` there) removed.
pub fn validate_record_zeroed(
    model: &HysteresisCreepModel,
    name: &str,
    u: &[f64],
    y: &[f64],
    from: usize,
    zero: std::ops::Range<usize>,
) -> Result<ValidationRow, IdentificationError> {
    let mut virgin = model.clone();
    virgin.reset();
    validate_record_from_state(&virgin, name, u, y, from, Some(zero))
}

/// The validation row of `model` run from its own state, not the virgin
/// one: a record whose starting memory was estimated
/// ([`super::initial_state`]). Zeroed on `zero` when given, as
/// [`validate_record_zeroed`].
pub fn validate_record_from_state(
    model: &HysteresisCreepModel,
    name: &str,
    u: &[f64],
    y: &[f64],
    from: usize,
    zero: Option<std::ops::Range<usize>>,
) -> Result<ValidationRow, IdentificationError> {
    check_record(name, u, y, from)?;
    if let Some(zero) = &zero {
        if zero.is_empty() || zero.end > u.len() {
            return Err(IdentificationError::InvalidSetting {
                field: "validate_zero",
                reason: format!(
                    "{name}: samples {}..{} are not inside its {} samples",
                    zero.start,
                    zero.end,
                    u.len()
                ),
            });
        }
    }
    let fit = model.clone().run(u);
    let zeroed = zero.map(|zero| {
        let offset = zero.clone().map(|k| y[k] - fit[k]).sum::<f64>() / zero.len() as f64;
        let shifted: Vec<f64> = fit.iter().map(|f| f + offset).collect();
        (offset, FitErrors::of(&shifted, y, from..u.len()))
    });
    Ok(ValidationRow {
        name: name.to_string(),
        from,
        errors: FitErrors::of(&fit, y, from..u.len()),
        rate: dominant_rate(u, model.sample_time()),
        zeroed,
    })
}

/// A record fit to validate on: `u` and `y` of one length, finite, and
/// `from` inside them.
pub fn check_record(
    name: &str,
    u: &[f64],
    y: &[f64],
    from: usize,
) -> Result<(), IdentificationError> {
    check_record_signals(u, y)?;
    if from >= u.len() {
        return Err(IdentificationError::InvalidSetting {
            field: "validate_from",
            reason: format!("{name}: sample {from} is beyond its {} samples", u.len()),
        });
    }
    Ok(())
}

/// One row per record: samples, rms and max error (absolute and % of the
/// record's output range) and the dominant rate of its input.
#[derive(Debug, Clone, PartialEq)]
pub struct ValidationTable(pub Vec<ValidationRow>);

impl fmt::Display for ValidationTable {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let zeroed = self.0.iter().any(|r| r.zeroed.is_some());
        write!(
            f,
            "validation {:<13} {:>8} {:>9} {:>13} {:>9} {:>13} {:>9}",
            "(record)", "from", "samples", "rms", "rms %", "max", "max %"
        )?;
        if zeroed {
            write!(f, " {:>13} {:>9} {:>9}", "zero offset", "rms %z", "max %z")?;
        }
        writeln!(f, "   input rate")?;
        for r in &self.0 {
            let e = &r.errors;
            let rate = r.rate.map_or("-".to_string(), |f| format!("{f:.4} Hz"));
            write!(
                f,
                "{:<24} {:>8} {:>9} {:>13.6e} {:>9.4} {:>13.6e} {:>9.4}",
                r.name,
                r.from,
                e.samples,
                e.rms,
                e.rms_percent(),
                e.max,
                e.max_percent()
            )?;
            match (&r.zeroed, zeroed) {
                (Some((o, z)), _) => write!(
                    f,
                    " {:>13.6e} {:>9.4} {:>9.4}",
                    o,
                    z.rms_percent(),
                    z.max_percent()
                )?,
                (None, true) => write!(f, " {:>13} {:>9} {:>9}", "-", "-", "-")?,
                (None, false) => {}
            }
            writeln!(f, "   {rate}")?;
        }
        if zeroed {
            writeln!(
                f,
                "(%z: with each record's constant offset estimated on the --validate-zero stretch removed)"
            )?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_start_is_a_sample_or_a_time() {
        assert_eq!("120".parse::<FitStart>(), Ok(FitStart::Sample(120)));
        assert_eq!("0.1s".parse::<FitStart>(), Ok(FitStart::Seconds(0.1)));
        assert_eq!(FitStart::Seconds(0.1).resolve(&[0.0; 10], 1e-4), 1000);
        assert!("ten".parse::<FitStart>().is_err());
        assert!("-1s".parse::<FitStart>().is_err());
    }

    #[test]
    fn the_dominant_rate_of_a_sine_is_its_frequency() {
        let ts = 1e-4;
        let u: Vec<f64> = (0..50_000)
            .map(|k| (2.0 * std::f64::consts::PI * 40.0 * k as f64 * ts).sin())
            .collect();
        let f = dominant_rate(&u, ts).unwrap();
        // crossings are found to a sample: 40 Hz within one sample per period
        assert!((f - 40.0).abs() <= 40.0 * 40.0 * ts, "{f}");
        assert_eq!(dominant_rate(&[1.0; 10], ts), None);
    }
}
