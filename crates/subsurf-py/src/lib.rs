//! `subsurf._core`: the thin PyO3 layer over `subsurf-core`.
//!
//! One file per core module; each has a `register` function adding its functions and classes
//! to the single extension module. Errors are mapped to Python in one place: the `errors` module.

use pyo3::prelude::*;

mod adaptive;
mod bssrdf;
mod diffusion;
mod errors;
mod hk;
mod mc;
mod medium;
mod optics;
mod render;
mod wait;

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    errors::register(m)?;
    optics::register(m)?;
    medium::register(m)?;
    mc::register(m)?;
    hk::register(m)?;
    diffusion::register(m)?;
    render::register(m)?;
    bssrdf::register(m)?;
    adaptive::register(m)?;
    Ok(())
}
