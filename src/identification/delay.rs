//! Choosing the dead time `d` of an identified model.
//!
//! A delay of one sample on a slow record looks almost like hysteresis: the
//! fit on the record itself barely tells `d = 0` from `d = 1` (the lag is
//! absorbed by the plays' widths), but the error of the wrong one grows
//! with the rate. So every `d` in `0..=max` is fitted ([`identify`](fn@super::identify) with
//! `settings.delay = d`) and the one kept is the best on what the fit did
//! not see: the validation records when there are any (their pooled rms),
//! else the held-out samples, else the fitted record's own rms over the
//! samples every candidate fits ([`SearchCriterion`]).

use std::fmt;
use std::str::FromStr;

use super::identify::{identify_records, FitRecord, Identification};
use super::report::FitErrors;
use super::settings::{IdentificationError, IdentificationSettings};
use super::validation::validate_record;
use crate::operators::traits::Operator;

/// The largest dead time `auto` tries unless told (samples).
pub const DEFAULT_MAX_DELAY: usize = 10;

/// How the dead time is chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DelaySetting {
    /// A known dead time (samples).
    Fixed(usize),
    /// The best of `0..=max` ([`search_delay`]).
    Auto,
}

impl Default for DelaySetting {
    fn default() -> Self {
        DelaySetting::Fixed(0)
    }
}

impl FromStr for DelaySetting {
    type Err = String;

    /// `N` (samples) or `auto`.
    fn from_str(s: &str) -> Result<Self, String> {
        match s.trim() {
            "auto" => Ok(DelaySetting::Auto),
            t => t
                .parse()
                .map(DelaySetting::Fixed)
                .map_err(|_| format!("'{s}' is neither a sample count nor 'auto'")),
        }
    }
}

/// A record to validate on: its name, input and output, the first sample
/// evaluated, and where its constant offset is estimated first (`None`:
/// scored as it is).
#[derive(Debug, Clone)]
pub struct Record<'a> {
    pub name: &'a str,
    pub u: &'a [f64],
    pub y: &'a [f64],
    pub from: usize,
    pub zero: Option<std::ops::Range<usize>>,
}

impl Record<'_> {
    /// The errors of `model` on the record: zeroed on `zero` when given.
    pub fn errors(
        &self,
        model: &crate::operators::model::HysteresisCreepModel,
    ) -> Result<FitErrors, IdentificationError> {
        Ok(self.row(model)?.score())
    }

    /// The validation row of `model` on the record.
    pub fn row(
        &self,
        model: &crate::operators::model::HysteresisCreepModel,
    ) -> Result<super::ValidationRow, IdentificationError> {
        match &self.zero {
            Some(z) => super::validate_record_zeroed(
                model,
                self.name,
                self.u,
                self.y,
                self.from,
                z.clone(),
            ),
            None => validate_record(model, self.name, self.u, self.y, self.from),
        }
    }
}

/// Pooled rms of `model` over validation records (zeroed where they say).
pub fn validation_rms(
    model: &crate::operators::model::HysteresisCreepModel,
    records: &[Record<'_>],
) -> Result<f64, IdentificationError> {
    let errors = records
        .iter()
        .map(|r| r.errors(model))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(pooled_rms(&errors))
}

/// What a search (the dead time, the rate gain) chose by.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SearchCriterion {
    /// The pooled rms over the validation records.
    Validation,
    /// The rms on the held-out samples.
    Holdout,
    /// The fitted record's rms on the samples every candidate fits.
    Fit,
}

impl SearchCriterion {
    /// The validation records' when there are any, else the held-out
    /// samples' (`holdout`: there are some), else the fit's.
    pub(super) fn of(records: &[Record<'_>], holdout: bool) -> Self {
        if !records.is_empty() {
            SearchCriterion::Validation
        } else if holdout {
            SearchCriterion::Holdout
        } else {
            SearchCriterion::Fit
        }
    }

    /// The value a search minimises for a candidate with this `report`,
    /// errors on the validation records, and rms on its fitted samples
    /// (`fit_rms`; with several records, their pooled rms instead).
    pub(super) fn score(
        self,
        report: &super::FitReport,
        validations: &[FitErrors],
        fit_rms: f64,
    ) -> f64 {
        match self {
            SearchCriterion::Validation => pooled_rms(validations),
            SearchCriterion::Holdout => report.holdout.map_or(f64::INFINITY, |h| h.rms),
            SearchCriterion::Fit if report.records.len() > 1 => {
                let errors: Vec<FitErrors> = report.records.iter().map(|r| r.fit).collect();
                pooled_rms(&errors)
            }
            SearchCriterion::Fit => fit_rms,
        }
    }

    /// The rest of a search table's header: the held-out and validation
    /// columns.
    pub(super) fn write_header(
        f: &mut fmt::Formatter<'_>,
        holdout: bool,
        names: &[String],
    ) -> fmt::Result {
        if holdout {
            write!(f, "  held-out rms %")?;
        }
        for n in names {
            write!(f, "  {n} rms %")?;
        }
        writeln!(f)
    }

    /// The rest of a search table's row: its held-out and validation
    /// errors.
    pub(super) fn write_errors(
        f: &mut fmt::Formatter<'_>,
        holdout: Option<&FitErrors>,
        validations: &[FitErrors],
        names: &[String],
    ) -> fmt::Result {
        if let Some(h) = holdout {
            write!(f, " {:>15.4}", h.rms_percent())?;
        }
        for (v, n) in validations.iter().zip(names) {
            write!(f, " {:>w$.4}", v.rms_percent(), w = n.len() + 7)?;
        }
        writeln!(f)
    }

    /// What chose, as a table's last line says it; `fit`: the words for
    /// the fit's own criterion.
    pub(super) fn describe(self, fit: &'static str) -> &'static str {
        match self {
            SearchCriterion::Validation => "the validation records' pooled rms",
            SearchCriterion::Holdout => "the held-out samples' rms",
            SearchCriterion::Fit => fit,
        }
    }
}

/// The errors of the model fitted with one dead time.
#[derive(Debug, Clone, PartialEq)]
pub struct DelayRow {
    pub delay: usize,
    /// On the fitted record, over the samples every candidate fits.
    pub fit: FitErrors,
    /// On the held-out samples, if any.
    pub holdout: Option<FitErrors>,
    /// On each validation record, in the order given.
    pub validations: Vec<FitErrors>,
    /// The value the choice minimises.
    pub score: f64,
}

/// Every dead time tried and the one kept.
#[derive(Debug, Clone, PartialEq)]
pub struct DelaySearch {
    pub chosen: usize,
    pub criterion: SearchCriterion,
    pub rows: Vec<DelayRow>,
    /// The validation records' names (the columns of `rows[i].validations`).
    pub names: Vec<String>,
}

/// Fit every dead time `0..=max_delay` and keep the best (module docs);
/// `settings.delay` is ignored. The errors of every candidate on every
/// record are in the returned [`DelaySearch`].
pub fn search_delay(
    u: &[f64],
    y: &[f64],
    sample_time: f64,
    settings: &IdentificationSettings,
    max_delay: usize,
    records: &[Record<'_>],
) -> Result<(Identification, DelaySearch), IdentificationError> {
    let fitted = [FitRecord {
        u,
        y,
        fit_from: settings.fit_from,
    }];
    search_delay_records(&fitted, sample_time, settings, max_delay, records)
}

/// [`search_delay`] for a model fitted to several records at once
/// ([`identify_records`]); without validation records and held-out
/// samples the criterion is the pooled rms of every fitted record (the
/// first record's over the samples every candidate fits).
pub fn search_delay_records(
    fitted: &[FitRecord<'_>],
    sample_time: f64,
    settings: &IdentificationSettings,
    max_delay: usize,
    records: &[Record<'_>],
) -> Result<(Identification, DelaySearch), IdentificationError> {
    let (u, y) = (fitted[0].u, fitted[0].y);
    crate::realtime::limits::check(
        "max_delay",
        crate::realtime::limits::MAX_DELAY_SEARCH,
        max_delay,
    )
    .map_err(|e| IdentificationError::InvalidSetting {
        field: "max_delay",
        reason: e.reason(),
    })?;
    let mut fits = Vec::with_capacity(max_delay + 1);
    for d in 0..=max_delay {
        let s = IdentificationSettings {
            delay: d,
            ..settings.clone()
        };
        let id = identify_records(fitted, sample_time, &s)?;
        let mut validations = Vec::with_capacity(records.len());
        for r in records {
            validations.push(r.errors(&id.model)?);
        }
        fits.push((id, validations));
    }
    // the samples every candidate fits: a larger d starts its fit later
    let start = fits.iter().map(|f| f.0.report.fitted.start).max();
    let end = fits.iter().map(|f| f.0.report.fitted.end).min();
    let common = start.unwrap_or(0)..end.unwrap_or(0).max(start.unwrap_or(0));
    let criterion = SearchCriterion::of(records, fits[0].0.report.holdout.is_some());
    // each candidate run again here rather than kept from its fit: memory
    // for one run, not one per candidate
    let rows: Vec<DelayRow> = fits
        .iter()
        .map(|(id, validations)| {
            let run = id.model.clone().run(u);
            let fit = FitErrors::of(&run, y, common.clone());
            let score = criterion.score(&id.report, validations, fit.rms);
            DelayRow {
                delay: id.report.delay,
                fit,
                holdout: id.report.holdout,
                validations: validations.clone(),
                score,
            }
        })
        .collect();
    // the smallest d among equal scores
    let best = (0..rows.len())
        .min_by(|&a, &b| rows[a].score.total_cmp(&rows[b].score).then(a.cmp(&b)))
        .unwrap_or(0);
    let search = DelaySearch {
        chosen: rows[best].delay,
        criterion,
        rows,
        names: records.iter().map(|r| r.name.to_string()).collect(),
    };
    let id = fits.swap_remove(best).0;
    Ok((id, search))
}

/// The rms over all samples of several records.
fn pooled_rms(errors: &[FitErrors]) -> f64 {
    let (sq, n) = errors.iter().fold((0.0, 0usize), |(sq, n), e| {
        (sq + e.rms * e.rms * e.samples as f64, n + e.samples)
    });
    (sq / n.max(1) as f64).sqrt()
}

impl fmt::Display for DelaySearch {
    /// One row per dead time: rms in % of each record's output range.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "dead time (samples)   fit rms %")?;
        let holdout = self.rows.first().is_some_and(|r| r.holdout.is_some());
        SearchCriterion::write_header(f, holdout, &self.names)?;
        for r in &self.rows {
            let mark = if r.delay == self.chosen { '*' } else { ' ' };
            write!(f, "{mark} {:>18} {:>11.4}", r.delay, r.fit.rms_percent())?;
            SearchCriterion::write_errors(f, r.holdout.as_ref(), &r.validations, &self.names)?;
        }
        let by = self.criterion.describe(
            "the fitted record's rms (no validation records, nothing held out: a dead time shows at high rates; validate on a faster record)",
        );
        writeln!(f, "dead time chosen     {} samples, by {by}", self.chosen)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_delay_setting_is_a_count_or_auto() {
        assert_eq!("3".parse::<DelaySetting>(), Ok(DelaySetting::Fixed(3)));
        assert_eq!("auto".parse::<DelaySetting>(), Ok(DelaySetting::Auto));
        assert!("-1".parse::<DelaySetting>().is_err());
        assert!("1.5".parse::<DelaySetting>().is_err());
    }

    #[test]
    fn pooled_rms_weighs_by_samples() {
        let e = |rms, samples| FitErrors {
            samples,
            rms,
            max: rms,
            output_range: 1.0,
        };
        // (1² · 3 + 3² · 1) / 4 = 3
        let p = pooled_rms(&[e(1.0, 3), e(3.0, 1)]);
        assert!((p - 3f64.sqrt()).abs() <= 4.0 * f64::EPSILON, "{p}");
    }
}
