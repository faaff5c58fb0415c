//! Choosing the rate gain `β` of rate-dependent play thresholds
//! `r_i + β|u_k − u_{k−1}|/T_s` (docs/MATHEMATICS.md §4.3).
//!
//! For a fixed `β` the plays' outputs are known from the input, so the
//! model is linear in its weights and one identification fits them (with
//! `β > 0`, non-negative hysteresis weights: the class whose steps stay
//! invertible). `β` itself enters through the clamps, so it is searched
//! as the dead time is: each candidate is a whole fit, scored by the
//! [`SearchCriterion`] (the validation records, else the held-out
//! samples, else the fitted records). The candidates are `g = β/T_s` on
//! the grid `0, 0.05, …, 0.5`, then a golden-section search on the two grid
//! steps around the best, down to `g` steps of 0.0025. The score need not
//! be unimodal in `g`; the grid is what guards against a distant minimum,
//! so a minimum narrower than a grid step can be missed. The search stops
//! at `g = 1/2` although the model takes any `g < 1`: above it the exact
//! inverse of a jumping target overshoots by more at every reversal
//! (docs/MATHEMATICS.md §4.3), and the model is there to be inverted.

use std::fmt;
use std::str::FromStr;

use super::delay::{Record, SearchCriterion};
use super::identify::{identify_records, FitRecord, Identification};
use super::report::FitErrors;
use super::settings::{IdentificationError, IdentificationSettings};

/// How the rate gain is chosen.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RateGainSetting {
    /// A known `β` (s).
    Fixed(f64),
    /// The best by [`search_rate_gain`].
    Auto,
}

impl Default for RateGainSetting {
    fn default() -> Self {
        RateGainSetting::Fixed(0.0)
    }
}

impl FromStr for RateGainSetting {
    type Err = String;

    /// `β` in seconds, or `auto`.
    fn from_str(s: &str) -> Result<Self, String> {
        match s.trim() {
            "auto" => Ok(RateGainSetting::Auto),
            t => match t.parse::<f64>() {
                Ok(b) if b.is_finite() && b >= 0.0 => Ok(RateGainSetting::Fixed(b)),
                _ => Err(format!(
                    "'{s}' is neither a rate gain in seconds (at least 0) nor 'auto'"
                )),
            },
        }
    }
}

/// The `g = β/T_s` of the grid, before the refinement.
const GRID: [f64; 11] = [0.0, 0.05, 0.1, 0.15, 0.2, 0.25, 0.3, 0.35, 0.4, 0.45, 0.5];
/// The largest `g` tried: the compensator's inverse stays bounded.
const MAX_GAIN: f64 = 0.5;
/// The refinement stops when its bracket is this narrow (in `g`).
const RESOLUTION: f64 = 0.0025;

/// The errors of the model fitted with one rate gain.
#[derive(Debug, Clone, PartialEq)]
pub struct RateGainRow {
    /// `β` (s).
    pub rate_gain: f64,
    /// On the first fitted record's fitted samples.
    pub fit: FitErrors,
    /// On the held-out samples, if any.
    pub holdout: Option<FitErrors>,
    /// On each validation record, in the order given.
    pub validations: Vec<FitErrors>,
    /// The value the choice minimises.
    pub score: f64,
}

/// Every rate gain tried (in increasing `β`) and the one kept.
#[derive(Debug, Clone, PartialEq)]
pub struct RateGainSearch {
    /// `β` (s).
    pub chosen: f64,
    pub sample_time: f64,
    pub criterion: SearchCriterion,
    pub rows: Vec<RateGainRow>,
    /// The validation records' names (the columns of `rows[i].validations`).
    pub names: Vec<String>,
}

/// Fit the rate gains of the module docs to the records `fitted` at once
/// ([`identify_records`]) and keep the best by the [`SearchCriterion`];
/// `settings.rate_gain` is ignored. Without validation records and
/// held-out samples the criterion is the fitted records' pooled rms.
pub fn search_rate_gain(
    fitted: &[FitRecord<'_>],
    sample_time: f64,
    settings: &IdentificationSettings,
    records: &[Record<'_>],
) -> Result<(Identification, RateGainSearch), IdentificationError> {
    let criterion = SearchCriterion::of(records, settings.holdout > 0);
    let mut rows: Vec<RateGainRow> = Vec::new();
    let mut best: Option<(f64, Identification)> = None;
    let mut fit = |g: f64| -> Result<f64, IdentificationError> {
        if let Some(row) = rows.iter().find(|r| r.rate_gain == g * sample_time) {
            return Ok(row.score);
        }
        let s = IdentificationSettings {
            rate_gain: g * sample_time,
            ..settings.clone()
        };
        let id = identify_records(fitted, sample_time, &s)?;
        let validations = records
            .iter()
            .map(|r| r.errors(&id.model))
            .collect::<Result<Vec<_>, _>>()?;
        let score = criterion.score(&id.report, &validations, id.report.fit.rms);
        rows.push(RateGainRow {
            rate_gain: s.rate_gain,
            fit: id.report.fit,
            holdout: id.report.holdout,
            validations,
            score,
        });
        // the smallest β among equal scores: candidates come in increasing
        // β on the grid, and a refined one must do better
        if best.as_ref().is_none_or(|(b, _)| score < *b) {
            best = Some((score, id));
        }
        Ok(score)
    };
    let mut grid_best = (f64::INFINITY, 0.0);
    for g in GRID {
        let score = fit(g)?;
        if score < grid_best.0 {
            grid_best = (score, g);
        }
    }
    // golden section on the bracket around the best grid point
    let step = GRID[1] - GRID[0];
    let (mut a, mut b) = (
        (grid_best.1 - step).max(0.0),
        (grid_best.1 + step).min(MAX_GAIN),
    );
    let phi = 0.5 * (5f64.sqrt() - 1.0);
    let (mut c, mut d) = (b - phi * (b - a), a + phi * (b - a));
    let (mut fc, mut fd) = (fit(c)?, fit(d)?);
    while b - a > RESOLUTION {
        if fc <= fd {
            (b, d, fd) = (d, c, fc);
            c = b - phi * (b - a);
            fc = fit(c)?;
        } else {
            (a, c, fc) = (c, d, fd);
            d = a + phi * (b - a);
            fd = fit(d)?;
        }
    }
    let (_, id) = best.expect("the grid fitted at least one gain");
    rows.sort_by(|x, y| x.rate_gain.total_cmp(&y.rate_gain));
    let search = RateGainSearch {
        chosen: id.model.rate_gain().map_or(0.0, |r| r.rate_gain()),
        sample_time,
        criterion,
        rows,
        names: records.iter().map(|r| r.name.to_string()).collect(),
    };
    Ok((id, search))
}

impl fmt::Display for RateGainSearch {
    /// One row per rate gain: rms in % of each record's output range.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "rate gain β (s)   β/T_s   fit rms %")?;
        let holdout = self.rows.first().is_some_and(|r| r.holdout.is_some());
        SearchCriterion::write_header(f, holdout, &self.names)?;
        for r in &self.rows {
            let mark = if r.rate_gain == self.chosen { '*' } else { ' ' };
            write!(
                f,
                "{mark} {:>14.4e} {:>7.4} {:>11.4}",
                r.rate_gain,
                r.rate_gain / self.sample_time,
                r.fit.rms_percent()
            )?;
            SearchCriterion::write_errors(f, r.holdout.as_ref(), &r.validations, &self.names)?;
        }
        let by = self.criterion.describe(
            "the fitted records' rms (no validation records, nothing held out: validate on a faster record)",
        );
        writeln!(f, "rate gain chosen     {:e} s, by {by}", self.chosen)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_rate_gain_setting_is_seconds_or_auto() {
        assert_eq!(
            "2e-5".parse::<RateGainSetting>(),
            Ok(RateGainSetting::Fixed(2e-5))
        );
        assert_eq!("auto".parse::<RateGainSetting>(), Ok(RateGainSetting::Auto));
        for bad in ["-1e-5", "nan", "inf", "fast"] {
            assert!(bad.parse::<RateGainSetting>().is_err(), "{bad}");
        }
    }
}
