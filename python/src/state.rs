//! `estimate_state`: the memory a record starts in, for a fixed model
//! (`mfcbeam::identification::initial_state`).

use pyo3::prelude::*;
use pyo3::types::PyDict;

use mfcbeam::identification::initial_state::{self, StateSettings};
use mfcbeam::operators::model::HysteresisCreepModel;

use crate::arrays::{signal, value_error};
use crate::model::Model;

/// Estimate the memory the record (u, y) starts in for `model`: its play
/// and creep states, the state of G and the output offset, from the samples
/// before `until` (default: all), within the bounds some history leaves.
/// The model's parameters are kept; its own memory states are where the
/// estimate starts from.
///
/// `state_at="start"` returns the model in the estimated state at the
/// record's first sample; `"end"` after the window, where a compensator
/// started up by the record goes on. `fit_offset`, `fit_creep`,
/// `fit_dynamics`: False keeps the model's offset, creep states, or G at
/// rest on its first input.
///
/// Returns (model, report): report["rms"] and report["prior_rms"] are the
/// RMS errors over the window from the estimate and from the prior,
/// report["unwiped"] the plays the window never moved (their states rest on
/// the output level alone), report["window"] its samples, report["offset"]
/// and report["iterations"]. Raises ValueError for a bad record or window.
#[pyfunction]
#[pyo3(signature = (
    model, u, y, *, until = None, state_at = "start",
    fit_offset = true, fit_creep = true, fit_dynamics = true
))]
#[allow(clippy::too_many_arguments)]
pub fn estimate_state<'py>(
    py: Python<'py>,
    model: &Model,
    u: &Bound<'py, PyAny>,
    y: &Bound<'py, PyAny>,
    until: Option<usize>,
    state_at: &str,
    fit_offset: bool,
    fit_creep: bool,
    fit_dynamics: bool,
) -> PyResult<(Model, Bound<'py, PyDict>)> {
    let at_end = match state_at {
        "start" => false,
        "end" => true,
        other => {
            return Err(value_error(format!(
                "state_at: '{other}' is neither 'start' nor 'end'"
            )))
        }
    };
    let (u, y) = (signal("u", u)?, signal("y", y)?);
    let file = model.inner.to_file();
    let settings = StateSettings {
        until,
        fit_offset,
        fit_creep,
        fit_dynamics,
        ..StateSettings::default()
    };
    let (estimate, written) = py
        .detach(|| {
            let estimate = initial_state::estimate_state(&file, &u, &y, &settings)?;
            let written = if at_end {
                estimate.model_after_window(&u)?
            } else {
                estimate.model.clone()
            };
            Ok::<_, mfcbeam::identification::IdentificationError>((estimate, written))
        })
        .map_err(value_error)?;
    let inner = HysteresisCreepModel::from_file(&written).map_err(value_error)?;
    let report = PyDict::new(py);
    report.set_item("window", estimate.window)?;
    report.set_item("rms", estimate.rms)?;
    report.set_item("prior_rms", estimate.prior_rms)?;
    report.set_item("offset", estimate.model.offset.unwrap_or(0.0))?;
    report.set_item("unwiped", estimate.unwiped)?;
    report.set_item("iterations", estimate.iterations)?;
    Ok((Model { inner }, report))
}
