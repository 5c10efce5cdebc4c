//! The one place where core errors become Python exceptions.
//!
//! `subsurf_core::Error` → `subsurf.ParameterError`, a subclass of `ValueError`, whose message
//! names the field and the allowed range. Python integers that do not fit the core's integer
//! types (negative, ≥ 2⁶⁴) become the core's range error for their field too, never an
//! `OverflowError`.

use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use subsurf_core::Error;

create_exception!(
    subsurf,
    ParameterError,
    PyValueError,
    "An input outside its allowed range; the message names the field and the range."
);

/// Convert a core error into a Python exception.
pub fn to_py(e: Error) -> PyErr {
    ParameterError::new_err(e.to_string())
}

/// Extension trait: `.py()?` on a core `Result`.
pub trait IntoPyResult<T> {
    fn py(self) -> PyResult<T>;
}

impl<T> IntoPyResult<T> for subsurf_core::Result<T> {
    fn py(self) -> PyResult<T> {
        self.map_err(to_py)
    }
}

/// An integer argument as u64; a Python number outside [0, 2⁶⁴) (or not an integer) raises the
/// core's range error for `field` with `allowed`.
pub fn u64_arg(obj: &Bound<'_, PyAny>, field: &str, allowed: &'static str) -> PyResult<u64> {
    obj.extract::<u64>().map_err(|_| {
        to_py(match obj.extract::<i128>() {
            Ok(v) => Error::param_int(field, v, allowed),
            Err(_) => Error::param_count(field, obj.extract::<f64>().unwrap_or(f64::NAN), allowed),
        })
    })
}

/// A thread count (1 … 1024, `MAX_THREADS`) through [`u64_arg`].
pub fn threads_arg(t: &Bound<'_, PyAny>) -> PyResult<usize> {
    let n = u64_arg(t, "threads", subsurf_core::mc::config::THREADS_ALLOWED)?;
    Ok(usize::try_from(n).unwrap_or(usize::MAX))
}

/// A number argument as f64 (a Python int too large for a float is +∞, so the core refuses it by range).
pub fn f64_arg(obj: &Bound<'_, PyAny>, field: &str) -> PyResult<f64> {
    obj.extract::<f64>().or_else(|e| {
        if e.is_instance_of::<pyo3::exceptions::PyOverflowError>(obj.py()) {
            Ok(if obj.lt(0)? { f64::NEG_INFINITY } else { f64::INFINITY })
        } else {
            Err(to_py(Error::Invalid(format!("{field} = {} is not a number", obj.repr()?))))
        }
    })
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("ParameterError", m.py().get_type::<ParameterError>())?;
    Ok(())
}
