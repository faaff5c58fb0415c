//! The weights and each record's unknown initial memory fitted together
//! (`docs/MATHEMATICS.md`, "The weights and the memory together").
//!
//! The squared output error over every sample of every record,
//! `J(w, θ) = Σ_records Σ_k (ŷ_k(w, θ_r) − y_k)²`, with `w` the weights
//! (and offsets) and `θ_r` record `r`'s play, creep and `G` states within
//! their bounds, is minimised by block coordinate descent:
//!
//! - for fixed states the model is linear in the weights: the
//!   identification's regression, its operators started in the states, is
//!   the exact minimum over `w` (the constrained least squares of (25)).
//!   `G` is linear in its input and its state together, so its state adds
//!   a free response that does not depend on `w`: the regression fits the
//!   measurement less that response, `G` at rest on the first input;
//! - for fixed weights [`estimate_state`] lowers the error over each
//!   record's states from the current ones (its prior), never raising it.
//!
//! Both steps start from the point the other left, so `J` cannot rise
//! where the two minimise the same error. It is not quite the same where
//! a dead time holds the first samples (the regression starts after it)
//! or where `S` is fitted through its inverse (Kuhnen's equation error):
//! so a round is kept only if it lowers `J`, and the rounds stop at the
//! first that lowers it by less than [`InitialStateSettings::tolerance`].
//! The kept values of `J` fall monotonically and are bounded below: the
//! descent ends, at a point neither step can improve.
//!
//! The first round starts from the ordinary identification (virgin state,
//! the samples before `|u|` first reaches `max|u|` skipped); the later ones
//! fit every sample, since the states now account for the start. `G`'s
//! parameters, if any, stay as given.

use super::identify::{identify_records_with, started_in, FitRecord, Identification};
use super::initial_state::{estimate_state, StateEstimate, StateSettings};
use super::regressor::OperatorState;
use super::settings::{IdentificationError, IdentificationSettings};
use crate::operators::bank::Par;
use crate::operators::model::{HysteresisCreepModel, ModelFile};
use crate::operators::traits::Operator;

/// How [`identify_with_initial_states`] alternates.
#[derive(Debug, Clone, PartialEq)]
pub struct InitialStateSettings {
    /// Rounds at most (default 20).
    pub rounds: usize,
    /// A round that lowers the total squared error by less than this
    /// fraction of it ends the descent (default `1e-4`).
    pub tolerance: f64,
    /// Estimate the creep states as well (default true).
    pub fit_creep: bool,
    /// Descent iterations of each state estimate at most (default 100).
    pub max_iterations: usize,
}

impl Default for InitialStateSettings {
    fn default() -> Self {
        Self {
            rounds: 20,
            tolerance: 1e-4,
            fit_creep: true,
            max_iterations: 100,
        }
    }
}

impl InitialStateSettings {
    /// Checked once, before anything is fitted.
    pub fn validate(&self) -> Result<(), IdentificationError> {
        if self.rounds == 0 {
            return Err(IdentificationError::InvalidSetting {
                field: "rounds",
                reason: "must be at least 1".into(),
            });
        }
        if !(self.tolerance.is_finite() && (0.0..1.0).contains(&self.tolerance)) {
            return Err(IdentificationError::InvalidSetting {
                field: "tolerance",
                reason: format!("must be in [0, 1), not {}", self.tolerance),
            });
        }
        if self.max_iterations == 0 {
            return Err(IdentificationError::InvalidSetting {
                field: "max_iterations",
                reason: "must be at least 1".into(),
            });
        }
        Ok(())
    }
}

/// Each record's fitted initial memory and how the descent went.
#[derive(Debug, Clone)]
pub struct InitialStateFit {
    /// Each record's own model (the identification's weights and its
    /// offset) in its fitted state at its first sample.
    pub models: Vec<ModelFile>,
    /// The RMS error over every sample of every record: from the virgin
    /// state with the ordinary identification's model first, then after
    /// each round kept.
    pub rms: Vec<f64>,
    /// Rounds run (the last one not kept when it did not lower the error).
    pub rounds: usize,
    /// Per record, the plays whose memory the record never wipes out
    /// (their states rest on the record's level alone).
    pub unwiped: Vec<Vec<usize>>,
}

/// One model fitted to `records` together with each record's initial play
/// and creep states (module docs): [`identify_records`](super::identify_records)
/// with the memory as an unknown. The model is returned in the virgin state,
/// as a compensator starts; each record's state is in the second value.
/// `settings.fit_from` and the records' own are used in the first round
/// only. `par`: the records' state estimates side by side (the result does
/// not depend on it).
pub fn identify_with_initial_states(
    records: &[FitRecord<'_>],
    sample_time: f64,
    settings: &IdentificationSettings,
    state: &InitialStateSettings,
    par: Par,
) -> Result<(Identification, InitialStateFit), IdentificationError> {
    state.validate()?;
    let (mut id, fits) = identify_records_with(records, sample_time, settings, None, None)?;
    // the held-out end (one record only) stays out of the states and `J`
    let used = |r: &FitRecord<'_>| r.y.len().saturating_sub(settings.holdout);
    let samples: usize = records.iter().map(used).sum();
    let rms = |j: f64| (j / samples as f64).sqrt();
    // `J` of fits against measurements
    let total = |fits: &[Vec<f64>], measured: &[Vec<f64>]| -> f64 {
        measured
            .iter()
            .zip(fits)
            .map(|(y, f)| {
                let n = y.len().saturating_sub(settings.holdout);
                f[..n]
                    .iter()
                    .zip(&y[..n])
                    .map(|(a, b)| (a - b) * (a - b))
                    .sum::<f64>()
            })
            .sum()
    };
    let measured: Vec<Vec<f64>> = records.iter().map(|r| r.y.to_vec()).collect();
    let mut cost = total(&fits, &measured);
    let mut history = vec![rms(cost)];
    // every sample fitted once the states stand for the start
    let settings_whole = IdentificationSettings {
        fit_from: Some(0),
        ..settings.clone()
    };
    // the offset a state estimate may move: a record's own
    let own_offset = settings.fit_offset && (records.len() == 1 || settings.offset_per_record);
    let estimate_settings = |r: &FitRecord<'_>| StateSettings {
        until: Some(used(r)),
        fit_offset: own_offset,
        fit_creep: state.fit_creep,
        fit_dynamics: true,
        max_iterations: state.max_iterations,
    };
    let mut states: Option<Vec<RecordState>> = None;
    let mut unwiped = vec![Vec::new(); records.len()];
    let mut rounds = 0;
    while rounds < state.rounds {
        rounds += 1;
        // the records' estimates are independent: side by side with `par`
        let indices: Vec<usize> = (0..records.len()).collect();
        let estimates = par.map(&indices, |&index| {
            let r = &records[index];
            let current = started(&id.record_models[index], states.as_ref().map(|s| &s[index]))?;
            let estimate = estimate_state(&current, r.u, r.y, &estimate_settings(r))
                .map_err(|e| super::plan::in_record(e, index, records.len()))?;
            Ok::<_, IdentificationError>((RecordState::of(&estimate, r.u)?, estimate.unwiped))
        });
        let mut next = Vec::with_capacity(records.len());
        let mut next_unwiped = Vec::with_capacity(records.len());
        for estimate in estimates {
            let (s, unwiped) = estimate?;
            next.push(s);
            next_unwiped.push(unwiped);
        }
        // `G`'s part of the start is the free response of its state: the
        // regression fits what is left of each measurement
        let next_measured: Vec<Vec<f64>> = records
            .iter()
            .zip(&next)
            .map(|(r, s)| r.y.iter().zip(&s.free).map(|(y, f)| y - f).collect())
            .collect();
        let whole: Vec<FitRecord<'_>> = records
            .iter()
            .zip(&next_measured)
            .map(|(r, y)| FitRecord {
                u: r.u,
                y,
                fit_from: Some(0),
            })
            .collect();
        let operators: Vec<OperatorState> = next.iter().map(|s| s.operators.clone()).collect();
        let (next_id, fits) =
            identify_records_with(&whole, sample_time, &settings_whole, None, Some(&operators))?;
        let next_cost = total(&fits, &next_measured);
        // kept only if lower (a NaN never is)
        if next_cost.partial_cmp(&cost) != Some(std::cmp::Ordering::Less) {
            break;
        }
        let small = next_cost > cost * (1.0 - state.tolerance);
        (id, cost, states, unwiped) = (next_id, next_cost, Some(next), next_unwiped);
        history.push(rms(cost));
        if small {
            break;
        }
    }
    let models = id
        .record_models
        .iter()
        .enumerate()
        .map(|(index, m)| started(m, states.as_ref().map(|s| &s[index])))
        .collect::<Result<Vec<_>, _>>()?;
    Ok((
        id,
        InitialStateFit {
            models,
            rms: history,
            rounds,
            unwiped,
        },
    ))
}

/// A record's fitted memory: its operators' state, `G`'s, and the free
/// response of `G`'s state over the record (what it adds to the output of
/// `G` started at rest on its first input; zero without `G`).
#[derive(Debug, Clone)]
struct RecordState {
    operators: OperatorState,
    dynamics: Option<Vec<f64>>,
    free: Vec<f64>,
}

impl RecordState {
    fn of(estimate: &StateEstimate, u: &[f64]) -> Result<Self, IdentificationError> {
        let operators = operator_state(estimate)?;
        let dynamics = estimate
            .model
            .dynamics
            .as_ref()
            .and_then(|g| g.state.clone());
        let free = match dynamics {
            Some(_) => {
                // G is linear: the difference of the two starts is the
                // free response of the state, whatever the input
                let mut at_rest = estimate.model.clone();
                if let Some(g) = &mut at_rest.dynamics {
                    g.state = None;
                }
                let with = HysteresisCreepModel::from_file(&estimate.model)?.run(u);
                let without = HysteresisCreepModel::from_file(&at_rest)?.run(u);
                with.iter().zip(&without).map(|(a, b)| a - b).collect()
            }
            None => vec![0.0; u.len()],
        };
        Ok(Self {
            operators,
            dynamics,
            free,
        })
    }
}

/// `model` with the operators and `G` in `state` (as it is without one).
fn started(
    model: &HysteresisCreepModel,
    state: Option<&RecordState>,
) -> Result<ModelFile, IdentificationError> {
    let mut file = started_in(model.clone(), state.map(|s| &s.operators))?.to_file();
    if let (Some(g), Some(s)) = (&mut file.dynamics, state.and_then(|s| s.dynamics.as_ref())) {
        g.state = Some(s.clone());
    }
    HysteresisCreepModel::from_file(&file)?;
    Ok(file)
}

/// The operators' state of an estimate, checked: finite, one value per
/// play and one per creep threshold and eigenvalue of its model.
fn operator_state(estimate: &StateEstimate) -> Result<OperatorState, IdentificationError> {
    let file = &estimate.model;
    // the file checked as a model is (lengths and finiteness of its state)
    HysteresisCreepModel::from_file(file)?;
    let plays = file
        .hysteresis
        .state
        .clone()
        .unwrap_or_else(|| vec![0.0; file.hysteresis.thresholds.len()]);
    let creep = match file.creep_state_flat()? {
        Some(c) => c,
        None => vec![
            0.0;
            file.creep
                .as_ref()
                .map_or(0, |c| c.thresholds.len() * c.eigenvalues.len())
        ],
    };
    Ok(OperatorState { plays, creep })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_out_of_range_are_named() {
        for (s, field) in [
            (
                InitialStateSettings {
                    rounds: 0,
                    ..Default::default()
                },
                "rounds",
            ),
            (
                InitialStateSettings {
                    tolerance: f64::NAN,
                    ..Default::default()
                },
                "tolerance",
            ),
            (
                InitialStateSettings {
                    tolerance: 1.0,
                    ..Default::default()
                },
                "tolerance",
            ),
            (
                InitialStateSettings {
                    max_iterations: 0,
                    ..Default::default()
                },
                "max_iterations",
            ),
        ] {
            match s.validate() {
                Err(IdentificationError::InvalidSetting { field: f, .. }) => assert_eq!(f, field),
                other => panic!("{field}: {other:?}"),
            }
        }
        assert!(InitialStateSettings::default().validate().is_ok());
    }
}
