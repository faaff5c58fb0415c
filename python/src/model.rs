//! `Model` (the operator `W = H + C`, (4) and (6)) and `Compensator` (its
//! inverse `W⁻¹`, (21)).

use std::path::PathBuf;

use numpy::{PyArray1, PyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use mfcbeam::io::{read_model, write_json};
use mfcbeam::operators::compensator::{self, CompensatorSettings};
use mfcbeam::operators::model::{HysteresisCreepModel, ModelFile};
use mfcbeam::operators::nominal::nominal_model;
use mfcbeam::operators::traits::{Operator, Snapshot};

use crate::arrays::{signal, to_numpy, value_error};

/// The hysteresis and creep model W = H + C (plus an output offset): it maps
/// the balanced patch voltage u (V) to the effective voltage y that drives
/// the beam.
///
/// A Model is stateful: `simulate` continues from the current state and
/// leaves the model in the state after its last sample, so a long record can
/// be simulated in pieces. `reset()` returns to the virgin state.
///
/// Build one with `Model.from_file`, `Model.from_json` or `Model.nominal()`.
#[pyclass(module = "mfcbeam", name = "Model")]
#[derive(Clone)]
pub struct Model {
    pub inner: HysteresisCreepModel,
}

#[pymethods]
impl Model {
    /// Read a model file (JSON, with or without a state).
    ///
    /// Raises ValueError naming the file and the field if it cannot be read
    /// or does not describe a valid model.
    #[staticmethod]
    fn from_file(path: PathBuf) -> PyResult<Self> {
        let inner = read_model(&path).map_err(value_error)?;
        Ok(Self { inner })
    }

    /// A model from the text of a model file (JSON).
    ///
    /// Raises ValueError naming the field if the text is not a valid model.
    #[staticmethod]
    fn from_json(text: &str) -> PyResult<Self> {
        let file: ModelFile = mfcbeam::io::parse_json(text)
            .map_err(|e| value_error(format!("malformed JSON: {e}")))?;
        let inner = HysteresisCreepModel::from_file(&file).map_err(value_error)?;
        Ok(Self { inner })
    }

    /// The paper's nominal model (12 plays, 12 log(t)-creep operators with 5
    /// eigenvalues, sample time 0.2 ms), virgin.
    #[staticmethod]
    fn nominal() -> Self {
        Self {
            inner: nominal_model(),
        }
    }

    /// y = W[u] for the input u (V, one sample per sample time), from the
    /// current state; returns a float64 array of the same length.
    ///
    /// A non-finite sample is taken as the previous input held, so it never
    /// enters the state.
    fn simulate<'py>(
        &mut self,
        py: Python<'py>,
        u: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let u = signal("u", u)?;
        let inner = &mut self.inner;
        let y = py.detach(move || inner.run(&u));
        Ok(to_numpy(py, y))
    }

    /// Return to the virgin state (every play and creep state 0).
    fn reset(&mut self) {
        self.inner.reset();
    }

    /// The sample time T_s (s).
    #[getter]
    fn sample_time(&self) -> f64 {
        self.inner.sample_time()
    }

    /// The constant output offset (unit of y).
    #[getter]
    fn offset(&self) -> f64 {
        self.inner.offset()
    }

    /// The superposition operator S after H + C as (thresholds, weights), or
    /// None (S the identity: the paper's symmetric model).
    #[getter]
    fn superposition(&self) -> Option<(Vec<f64>, Vec<f64>)> {
        self.inner
            .superposition()
            .map(|s| (s.thresholds().to_vec(), s.weights().to_vec()))
    }

    /// The dead time d (samples): y_k = G[S[H + C]]_{max(k−d, 0)} + offset.
    #[getter]
    fn delay(&self) -> usize {
        self.inner.delay()
    }

    /// The linear dynamics G after S as a dict ("low_pass": cut-off Hz or
    /// None, "resonance": (frequency Hz, damping) or None, "delay_fraction":
    /// samples), or None.
    #[getter]
    fn dynamics<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        let Some(g) = self.inner.dynamics() else {
            return Ok(None);
        };
        let p = g.parameters();
        let d = PyDict::new(py);
        d.set_item("low_pass", p.low_pass)?;
        d.set_item("resonance", p.resonance.map(|r| (r.frequency, r.damping)))?;
        d.set_item("delay_fraction", p.delay_fraction)?;
        Ok(Some(d))
    }

    /// The current state: a dict with "hysteresis" (the play states, one per
    /// threshold), "creep" (one row of eigenvalue states per creep
    /// threshold, or None without creep) and "delay" (the d values waiting
    /// in the dead time, oldest first, or None).
    #[getter]
    fn state<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let s = self.inner.state();
        let d = PyDict::new(py);
        d.set_item("hysteresis", to_numpy(py, s.hysteresis))?;
        match s.creep {
            Some(rows) => d.set_item(
                "creep",
                PyArray2::from_vec2(py, &rows).map_err(value_error)?,
            )?,
            None => d.set_item("creep", py.None())?,
        }
        d.set_item("delay", s.delay.map(|x| to_numpy(py, x)))?;
        d.set_item("dynamics", s.dynamics.map(|x| to_numpy(py, x)))?;
        Ok(d)
    }

    /// The model file (JSON) of this model with its current state;
    /// `Model.from_json` reads it back bit for bit.
    fn to_json(&self) -> PyResult<String> {
        serde_json::to_string_pretty(&self.inner.to_file()).map_err(value_error)
    }

    /// Write the model file with the current state (atomically: a failure
    /// leaves no partial file).
    fn to_file(&self, path: PathBuf) -> PyResult<()> {
        write_json(&path, &self.inner.to_file()).map_err(value_error)
    }

    /// A copy with its own state.
    fn copy(&self) -> Self {
        self.clone()
    }

    fn __copy__(&self) -> Self {
        self.clone()
    }

    fn __deepcopy__(&self, _memo: &Bound<'_, PyAny>) -> Self {
        self.clone()
    }

    fn __repr__(&self) -> String {
        let creep = match self.inner.creep() {
            Some(c) => format!(
                "{} creep operators x {} eigenvalues",
                c.thresholds().len(),
                c.eigenvalues().len()
            ),
            None => "no creep".to_string(),
        };
        format!(
            "Model({} plays, {creep}, sample_time={:?}, offset={:?})",
            self.inner.hysteresis().thresholds().len(),
            self.inner.sample_time(),
            self.inner.offset()
        )
    }
}

/// The compensator W⁻¹ of a model (21): the voltage u that makes the model
/// produce the target y_d, by the analytic inverse of the hysteresis and the
/// creep predicted one sample ahead, clipped to `limits`.
///
/// It starts from the model's current state (matched states) and keeps its
/// own state between calls; `reset()` returns it to the virgin state.
/// `limits=None` means no saturation.
#[pyclass(module = "mfcbeam", name = "Compensator")]
#[derive(Clone)]
pub struct Compensator {
    inner: compensator::Compensator<f64, mfcbeam::operators::heap::Heap>,
}

#[pymethods]
impl Compensator {
    #[new]
    #[pyo3(
        signature = (model, limits = Some((-1000.0, 1000.0))),
        text_signature = "(model, limits=(-1000.0, 1000.0))"
    )]
    fn new(model: &Model, limits: Option<(f64, f64)>) -> PyResult<Self> {
        let settings = match limits {
            None => CompensatorSettings::unlimited(),
            Some((lo, hi)) if lo.is_infinite() && hi.is_infinite() => {
                return Err(PyValueError::new_err(
                    "limits: no limits at all is limits=None",
                ))
            }
            Some((lo, hi)) => CompensatorSettings::with_limits(lo, hi),
        };
        let inner = model.inner.compensator(settings).map_err(value_error)?;
        Ok(Self { inner })
    }

    /// Compensate the targets y_d (unit of the model's output), from the
    /// current state. Returns three arrays of the same length: u (float64,
    /// V), saturated (bool: u was clipped to a limit) and fault (bool: the
    /// target was not finite, so the previous u is held).
    ///
    /// With a dead time d (`delay`) the compensator inverts the memory part:
    /// y_d[k] is the target for sample k + d, and a stream continues across
    /// calls. `preview=True` treats y_d as a whole planned signal and shifts
    /// it by d (the last d samples hold the last target), as the command
    /// line's `compensate` does: then W[u] = y_d from sample d on.
    #[allow(clippy::type_complexity)]
    #[pyo3(signature = (y_d, *, preview = false))]
    fn compensate<'py>(
        &mut self,
        py: Python<'py>,
        y_d: &Bound<'py, PyAny>,
        preview: bool,
    ) -> PyResult<(
        Bound<'py, PyArray1<f64>>,
        Bound<'py, PyArray1<bool>>,
        Bound<'py, PyArray1<bool>>,
    )> {
        let mut y_d = signal("y_d", y_d)?;
        if preview {
            let given = y_d.clone();
            mfcbeam::realtime::preview_into(&given, self.inner.delay(), &mut y_d)
                .map_err(value_error)?;
        }
        let inner = &mut self.inner;
        let (u, saturated, fault) = py
            .detach(move || {
                let n = y_d.len();
                let (mut u, mut saturated, mut fault) =
                    (vec![0.0; n], vec![false; n], vec![false; n]);
                inner
                    .compensate_into(&y_d, &mut u, &mut saturated, &mut fault)
                    .map(|_| (u, saturated, fault))
            })
            .map_err(value_error)?;
        Ok((
            to_numpy(py, u),
            to_numpy(py, saturated),
            to_numpy(py, fault),
        ))
    }

    /// Return to the virgin state (forward plays, inverse plays and creep).
    fn reset(&mut self) {
        self.inner.reset();
    }

    /// The model's dead time d (samples): the target given for sample k is
    /// the one wanted at k + d (see `compensate`).
    #[getter]
    fn delay(&self) -> usize {
        self.inner.delay()
    }

    /// The saturation limits (lower, upper) in V; infinite without limits.
    #[getter]
    fn limits(&self) -> (f64, f64) {
        let s = self.inner.settings();
        (s.lower_limit, s.upper_limit)
    }

    /// A copy with its own state.
    fn copy(&self) -> Self {
        self.clone()
    }

    fn __copy__(&self) -> Self {
        self.clone()
    }

    fn __deepcopy__(&self, _memo: &Bound<'_, PyAny>) -> Self {
        self.clone()
    }

    fn __repr__(&self) -> String {
        let (lo, hi) = self.limits();
        format!("Compensator(limits=({lo:?}, {hi:?}))")
    }
}
