//! Naive reference implementations: the formulas of the paper written down
//! as plainly as possible, to compare any other implementation against.
//!
//! They share nothing with the fast operators of [`crate::operators`] except
//! the validation of the model file: `f64::max`/`f64::min` for the play (20),
//! sequential sums in the paper's order for (10) and (16), a nested
//! threshold-then-eigenvalue loop for the creep operators (15), (20), the
//! direct `O(n²)` sums of the transformation rules (22), and the explicit
//! compensator (21); the superposition operator as its sum of dead zones, and
//! its inverse by locating the segment of the piecewise-linear `S` that holds
//! the value (not by the inverse rules). [`BisectionCompensator`] inverts `W` numerically, the
//! way an operator without an analytic inverse (a Preisach model) must be
//! inverted; it is the peer the analytic inverse is benchmarked against.
//!
//! Every type here implements the traits of [`crate::operators::traits`], so
//! the conformance checks ([`crate::suite::conformance`]) run on them too.

use crate::error::ModelError;
use crate::operators::compensator::CompensatorSettings;
use crate::operators::model::{HysteresisCreepModel, ModelFile};

mod bisection;
mod compensator;
mod creep;
mod dynamics;
mod hysteresis;
mod model;
mod superposition;

pub use bisection::BisectionCompensator;
pub use compensator::NaiveCompensator;
pub use creep::NaiveCreep;
pub use dynamics::{NaiveDynamics, NaiveSection};
pub use hysteresis::{naive_inverse_hysteresis, NaiveHysteresis};
pub use model::NaiveModel;
pub use superposition::NaiveSuperposition;

/// The superposition operator of a (validated) model file, if any.
fn naive_superposition(file: &ModelFile) -> Option<NaiveSuperposition> {
    let s = file.superposition.as_ref()?;
    Some(NaiveSuperposition::new(
        s.thresholds.clone(),
        s.weights.clone(),
    ))
}

/// Hysteresis and creep parts of a validated model file.
fn naive_parts(file: &ModelFile) -> Result<(NaiveHysteresis, Option<NaiveCreep>), ModelError> {
    // validation (11), (12), (17), (18), admissibility, shapes: the one rule set
    HysteresisCreepModel::from_file(file)?;
    if file.hysteresis.rate_gain.is_some_and(|b| b != 0.0) {
        return Err(crate::realtime::ParameterError::Unsupported {
            field: "hysteresis.rate_gain",
            reason: "the textbook references have rate-independent thresholds",
        }
        .into());
    }
    let h = &file.hysteresis;
    let hysteresis = NaiveHysteresis {
        r: h.thresholds.clone(),
        w: h.weights.clone(),
        x: h.state
            .clone()
            .unwrap_or_else(|| vec![0.0; h.thresholds.len()]),
    };
    let creep = file.creep.as_ref().map(|c| NaiveCreep {
        r: c.thresholds.clone(),
        w: c.weights.clone(),
        a: c.eigenvalues.clone(),
        ts: file.sample_time,
        chi: c
            .state
            .clone()
            .unwrap_or_else(|| vec![vec![0.0; c.eigenvalues.len()]; c.thresholds.len()]),
    });
    Ok((hysteresis, creep))
}

/// Clip `v` to `[lower, upper]`, and whether it was clipped.
fn clip(v: f64, settings: &CompensatorSettings) -> (f64, bool) {
    if v < settings.lower_limit {
        (settings.lower_limit, true)
    } else if v > settings.upper_limit {
        (settings.upper_limit, true)
    } else {
        (v, false)
    }
}

/// The lag of a model file's dynamics (1 with a resonance).
fn lag_of(file: &ModelFile) -> usize {
    file.dynamics
        .as_ref()
        .map_or(0, |g| usize::from(g.resonance.is_some()))
}
