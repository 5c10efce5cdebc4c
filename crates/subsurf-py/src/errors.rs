//! The one place where core errors become Python exceptions.
//!
//! `subsurf_core::Error` → `subsurf.ParameterError`, a subclass of `ValueError`, whose message
//! names the field and the allowed range.

use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

create_exception!(
    subsurf,
    ParameterError,
    PyValueError,
    "An input outside its allowed range; the message names the field and the range."
);

/// Convert a core error into a Python exception.
pub fn to_py(e: subsurf_core::Error) -> PyErr {
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

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("ParameterError", m.py().get_type::<ParameterError>())?;
    Ok(())
}
