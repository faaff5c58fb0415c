//! `mfcbeam._mfcbeam`: the Python bindings of mfcbeam.
//!
//! Whole NumPy arrays go in and out; the per-sample loops run in Rust with
//! the GIL released. Every bad argument or file raises `ValueError` with the
//! one-line message the command line prints (without its `mfcbeam: error:`
//! prefix), naming the file, field or sample. The Python-facing docs are
//! these doc comments and the stubs in `mfcbeam/_mfcbeam.pyi`.

use pyo3::prelude::*;

mod arrays;
mod beam;
mod identify;
mod model;
mod state;

/// Prandtl–Ishlinskii hysteresis and creep operators, their analytic inverse
/// (the compensator), identification from measurements, the MFC-driven
/// cantilever and flatness-based feedforward (Schröck, Meurer, Kugi 2011).
#[pymodule]
fn _mfcbeam(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<model::Model>()?;
    m.add_class::<model::Compensator>()?;
    m.add_class::<beam::Beam>()?;
    m.add_function(wrap_pyfunction!(identify::identify, m)?)?;
    m.add_function(wrap_pyfunction!(state::estimate_state, m)?)?;
    m.add_function(wrap_pyfunction!(beam::feedforward, m)?)?;
    Ok(())
}
