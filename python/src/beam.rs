//! `Beam` (the MFC-driven cantilever: Ritz or finite-element model reduced
//! to modes, exact zero-order-hold simulation) and `feedforward` (the
//! flatness-based design (26)–(28), compensated by W⁻¹ with a model).

use std::path::PathBuf;

use numpy::PyArray1;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use mfcbeam::beam::fe::DEFAULT_ELEMENTS;
use mfcbeam::beam::step_response_fit::{modal_model, simulate_response, BeamModelKind};
use mfcbeam::beam::BeamParameters;
use mfcbeam::feedforward::{compensate, design, FeedforwardSettings, FlatParametrization};
use mfcbeam::io::{read_beam, write_json};
use mfcbeam::operators::supply::Supply;

use crate::arrays::{signal, to_numpy, value_error};

// The signatures below spell the default out, so that Python shows it.
const _: () = assert!(DEFAULT_ELEMENTS == 240);
use crate::model::Model;

/// The discretization `beam_model` names: "modal" (converged finite elements
/// reduced to the beam's `basis_functions` modes) or "ritz" (the paper's).
fn kind(beam_model: &str, elements: usize) -> PyResult<BeamModelKind> {
    match beam_model {
        "modal" => Ok(BeamModelKind::Modal { elements }),
        "ritz" => Ok(BeamModelKind::Ritz),
        other => Err(PyValueError::new_err(format!(
            "beam_model: expected 'modal' or 'ritz', found '{other}'"
        ))),
    }
}

/// The parameters of the MFC-driven cantilever (a beam file, SI units).
///
/// Build one with `Beam.from_file`, `Beam.from_json` or `Beam.nominal()`.
/// Every method takes `beam_model`: "modal" (default: converged finite
/// elements, `elements` of them, reduced to the beam's `basis_functions`
/// modes) or "ritz" (the paper's Ritz model).
#[pyclass(module = "mfcbeam", name = "Beam")]
#[derive(Clone)]
pub struct Beam {
    inner: BeamParameters,
}

#[pymethods]
impl Beam {
    /// Read a beam file (JSON). Raises ValueError naming the file and field.
    #[staticmethod]
    fn from_file(path: PathBuf) -> PyResult<Self> {
        let inner = read_beam(&path).map_err(value_error)?;
        Ok(Self { inner })
    }

    /// A beam from the text of a beam file (JSON). Raises ValueError naming
    /// the field.
    #[staticmethod]
    fn from_json(text: &str) -> PyResult<Self> {
        let inner: BeamParameters = mfcbeam::io::parse_json(text)
            .map_err(|e| value_error(format!("malformed JSON: {e}")))?;
        inner.validate().map_err(value_error)?;
        Ok(Self { inner })
    }

    /// The paper's beam (reconstructed).
    #[staticmethod]
    fn nominal() -> Self {
        Self {
            inner: BeamParameters::nominal(),
        }
    }

    /// The beam file (JSON).
    fn to_json(&self) -> PyResult<String> {
        serde_json::to_string_pretty(&self.inner).map_err(value_error)
    }

    /// Write the beam file (atomically).
    fn to_file(&self, path: PathBuf) -> PyResult<()> {
        write_json(&path, &self.inner).map_err(value_error)
    }

    /// Undamped natural frequencies (Hz), modal damping ratios and the
    /// static gain (m per effective V) of the model's modes, as a dict with
    /// "frequencies_hz", "damping_ratios", "static_gain", "model", "modes".
    #[pyo3(signature = (beam_model = "modal", *, elements = 240))]
    fn modes<'py>(
        &self,
        py: Python<'py>,
        beam_model: &str,
        #[pyo3(from_py_with = crate::arrays::counts::elements)] elements: usize,
    ) -> PyResult<Bound<'py, PyDict>> {
        let k = kind(beam_model, elements)?;
        let beam = &self.inner;
        let modal = py
            .detach(move || modal_model(beam, k))
            .map_err(value_error)?;
        let d = PyDict::new(py);
        d.set_item("frequencies_hz", to_numpy(py, modal.frequencies_hz()))?;
        d.set_item("damping_ratios", to_numpy(py, modal.damping_ratios()))?;
        d.set_item("static_gain", modal.static_gain())?;
        d.set_item("model", beam_model)?;
        d.set_item("modes", modal.len())?;
        Ok(d)
    }

    /// Tip deflection y (m) for the effective voltage u (V) sampled at
    /// `sample_time` (s): exact zero-order hold, from rest in equilibrium
    /// with u[0].
    #[pyo3(signature = (u, sample_time, *, beam_model = "modal", elements = 240))]
    fn simulate<'py>(
        &self,
        py: Python<'py>,
        u: &Bound<'py, PyAny>,
        sample_time: f64,
        beam_model: &str,
        #[pyo3(from_py_with = crate::arrays::counts::elements)] elements: usize,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let u = signal("u", u)?;
        let k = kind(beam_model, elements)?;
        if !(sample_time.is_finite() && sample_time > 0.0) {
            return Err(PyValueError::new_err(format!(
                "sample_time: must be a finite number > 0, found {sample_time}"
            )));
        }
        let beam = &self.inner;
        let y = py
            .detach(move || simulate_response(beam, k, sample_time, &u))
            .map_err(value_error)?;
        Ok(to_numpy(py, y))
    }

    fn __repr__(&self) -> String {
        format!(
            "Beam(length={:?}, basis_functions={})",
            self.inner.length, self.inner.basis_functions
        )
    }
}

/// Flatness-based feedforward for a rest-to-rest move of the tip from 0 to
/// `y_final` (m) in `duration` (s) from `start` (s), with the Gevrey
/// trajectory of parameter `sigma` (28), sampled every `sample_time` (s;
/// default: the model's, else 0.2 ms) up to `end` (s).
///
/// Returns a dict of arrays: "t", "y_d" (desired tip deflection, m), "u_d"
/// (effective voltage, V). With a hysteresis and creep `model` also
/// "u" = W⁻¹[u_d] (balanced voltage, V), "u_fs" and "u_bs" (front and back
/// patch voltages of the asymmetric supply, V) and "saturated" (bool).
#[pyfunction]
#[pyo3(signature = (
    beam, model = None, *, start = 2.9, duration = 0.075, y_final = 1e-3, sigma = 1.1,
    end = 4.0, sample_time = None, beam_model = "modal", elements = 240
))]
#[allow(clippy::too_many_arguments)]
pub fn feedforward<'py>(
    py: Python<'py>,
    beam: &Beam,
    model: Option<&Model>,
    start: f64,
    duration: f64,
    y_final: f64,
    sigma: f64,
    end: f64,
    sample_time: Option<f64>,
    beam_model: &str,
    #[pyo3(from_py_with = crate::arrays::counts::elements)] elements: usize,
) -> PyResult<Bound<'py, PyDict>> {
    let k = kind(beam_model, elements)?;
    let model = model.map(|m| m.inner.clone());
    if let (Some(m), Some(ts)) = (&model, sample_time) {
        if (m.sample_time() - ts).abs() > 1e-12 * ts {
            return Err(PyValueError::new_err(format!(
                "sample_time: {ts} s differs from the model's sample time {} s",
                m.sample_time()
            )));
        }
    }
    let settings = FeedforwardSettings {
        start,
        duration,
        y_final,
        sigma,
        end,
        sample_time: sample_time
            .or(model.as_ref().map(|m| m.sample_time()))
            .unwrap_or(FeedforwardSettings::default().sample_time),
    };
    let beam = &beam.inner;
    let (ff, compensated) = py
        .detach(move || {
            let modal = modal_model(beam, k)?;
            let flat = FlatParametrization::new(&modal)?;
            let ff = design(&flat, &settings)?;
            let compensated = match &model {
                Some(m) => Some(compensate(&ff.u_d, m, &Supply::default())?),
                None => None,
            };
            Ok::<_, mfcbeam::feedforward::FeedforwardError>((ff, compensated))
        })
        .map_err(value_error)?;
    let d = PyDict::new(py);
    d.set_item("t", to_numpy(py, ff.t))?;
    d.set_item("y_d", to_numpy(py, ff.y_d))?;
    d.set_item("u_d", to_numpy(py, ff.u_d))?;
    if let Some(c) = compensated {
        d.set_item("u", to_numpy(py, c.u))?;
        d.set_item("u_fs", to_numpy(py, c.u_fs))?;
        d.set_item("u_bs", to_numpy(py, c.u_bs))?;
        d.set_item("saturated", to_numpy(py, c.saturated))?;
    }
    Ok(d)
}
