//! NumPy arrays in and out, and errors as `ValueError`.

use numpy::{PyArray1, PyArrayDyn, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// `ValueError` carrying an error's one-line text.
pub fn value_error(e: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(e.to_string().replace(['\n', '\r'], " "))
}

/// A one-dimensional float64 copy of anything `numpy.asarray` takes (an
/// array of any dtype, a list, a tuple). It is copied so that the
/// computation can run without the GIL while other threads keep the array.
/// Errors name the argument.
pub fn signal(name: &str, obj: &Bound<'_, PyAny>) -> PyResult<Vec<f64>> {
    let py = obj.py();
    let np = py.import("numpy")?;
    let kwargs = PyDict::new(py);
    kwargs.set_item("dtype", "float64")?;
    let array = np
        .call_method("asarray", (obj,), Some(&kwargs))
        .map_err(|e| PyValueError::new_err(format!("{name}: {}", e.value(py))))?;
    let array = array
        .cast::<PyArrayDyn<f64>>()
        .map_err(|_| PyValueError::new_err(format!("{name}: not convertible to float64")))?;
    if array.ndim() != 1 {
        return Err(PyValueError::new_err(format!(
            "{name}: expected a one-dimensional array, found shape {}",
            shape_text(array.shape())
        )));
    }
    Ok(array.readonly().as_array().iter().copied().collect())
}

/// An optional [`signal`].
pub fn optional_signal(name: &str, obj: Option<&Bound<'_, PyAny>>) -> PyResult<Option<Vec<f64>>> {
    obj.map(|o| signal(name, o)).transpose()
}

/// A float64 NumPy array that takes over `v` without copying.
pub fn to_numpy<'py, T: numpy::Element>(py: Python<'py>, v: Vec<T>) -> Bound<'py, PyArray1<T>> {
    PyArray1::from_vec(py, v)
}

/// A shape as Python writes it: `()`, `(3,)`, `(2, 2)`.
fn shape_text(shape: &[usize]) -> String {
    match shape {
        [n] => format!("({n},)"),
        _ => {
            let dims: Vec<String> = shape.iter().map(usize::to_string).collect();
            format!("({})", dims.join(", "))
        }
    }
}

/// A count argument as `usize`, or `ValueError` naming it: a negative or
/// huge Python int is a bad value, not an `OverflowError`, and a count
/// above its limit is refused by the library before anything is
/// allocated.
pub fn count(name: &str, obj: &Bound<'_, PyAny>) -> PyResult<usize> {
    let bad = || {
        PyValueError::new_err(format!(
            "{name}: must be a whole number >= 0, found {}",
            obj.repr().map_or_else(|_| "?".into(), |r| r.to_string())
        ))
    };
    if obj.is_instance_of::<pyo3::types::PyBool>() {
        return Err(bad());
    }
    obj.extract::<usize>().map_err(|_| bad())
}

/// The extractors of the count arguments, one per name (`from_py_with`
/// takes a function of the object alone); `optional` ones take `None` too.
macro_rules! counts {
    ($($name:ident),*; optional: $($opt:ident),*) => {
        pub mod counts {
            use pyo3::prelude::*;
            $(
                pub fn $name(obj: &Bound<'_, PyAny>) -> PyResult<usize> {
                    super::count(stringify!($name), obj)
                }
            )*
            pub mod optional {
                use pyo3::prelude::*;
                $(
                    pub fn $opt(obj: &Bound<'_, PyAny>) -> PyResult<Option<usize>> {
                        if obj.is_none() {
                            Ok(None)
                        } else {
                            super::super::count(stringify!($opt), obj).map(Some)
                        }
                    }
                )*
            }
        }
    };
}

counts!(
    elements,
    hysteresis_operators,
    creep_operators,
    creep_eigenvalues,
    superposition,
    max_delay;
    optional: fit_from, validate_from
);
