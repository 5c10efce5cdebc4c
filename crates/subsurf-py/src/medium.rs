//! Bindings of `subsurf_core::medium`: validation, derived properties and mixtures. The Python
//! `Layer` and `Stack` classes (python/subsurf/medium.py) hold plain numbers and call these.

use crate::errors::IntoPyResult;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use subsurf_core::medium::{self, Component, Layer, Stack};
use subsurf_core::optics::Phase;

/// A layer tuple as Python passes it: (n, mua, mus, lobes [(weight, g)], thickness).
pub type LayerTuple = (f64, f64, f64, Vec<(f64, f64)>, f64);

/// Build a core layer from its tuple (a single lobe is a plain HG phase function, field `g`).
pub fn layer_from_tuple(t: &LayerTuple) -> subsurf_core::Result<Layer> {
    let (n, mua, mus, lobes, d) = t;
    let phase = match lobes.as_slice() {
        [(_, g)] => Phase::hg(*g)?,
        _ => Phase::mixture(lobes)?,
    };
    Ok(Layer { n: *n, mua: *mua, mus: *mus, phase, thickness: *d })
}

/// Build and validate a core stack from Python values.
pub fn stack_from_py(layers: &[LayerTuple], n_above: f64, n_below: f64) -> subsurf_core::Result<Stack> {
    let mut out = Vec::with_capacity(layers.len());
    for (i, t) in layers.iter().enumerate() {
        out.push(layer_from_tuple(t).map_err(|e| e.within(&format!("layers[{i}].")))?);
    }
    Stack::new(out, n_above, n_below)
}

/// Validate one layer; raises ParameterError naming the field.
#[pyfunction]
#[pyo3(signature = (n, mua, mus, lobes, thickness, prefix=""))]
fn validate_layer(n: f64, mua: f64, mus: f64, lobes: Vec<(f64, f64)>, thickness: f64, prefix: &str) -> PyResult<()> {
    let l = layer_from_tuple(&(n, mua, mus, lobes, thickness)).map_err(|e| e.within(prefix)).py()?;
    l.validate(prefix).py()
}

/// Validate a whole stack; raises ParameterError naming the field.
#[pyfunction]
fn validate_stack(layers: Vec<LayerTuple>, n_above: f64, n_below: f64) -> PyResult<()> {
    stack_from_py(&layers, n_above, n_below).py().map(|_| ())
}

/// The derived properties of a layer (core `Layer` methods): g, sigma_t, albedo, mus_prime,
/// sigma_t_prime, transport_mfp, optical_thickness.
#[pyfunction]
fn layer_properties<'py>(py: Python<'py>, layer: LayerTuple) -> PyResult<Bound<'py, PyDict>> {
    let l = layer_from_tuple(&layer).py()?;
    l.validate("").py()?;
    let d = PyDict::new(py);
    d.set_item("g", l.g())?;
    d.set_item("sigma_t", l.sigma_t())?;
    d.set_item("albedo", l.albedo())?;
    d.set_item("mus_prime", l.mus_prime())?;
    d.set_item("sigma_t_prime", l.sigma_t_prime())?;
    d.set_item("transport_mfp", l.transport_mfp())?;
    d.set_item("optical_thickness", l.optical_thickness())?;
    Ok(d)
}

/// Depths of a stack's interfaces, mm: [0, d0, d0 + d1, …].
#[pyfunction]
fn stack_boundaries(layers: Vec<LayerTuple>, n_above: f64, n_below: f64) -> PyResult<Vec<f64>> {
    Ok(stack_from_py(&layers, n_above, n_below).py()?.boundaries())
}

/// Mix components (fraction, mua, mus, g) into a layer; returns (n, mua, mus, lobes, thickness).
#[pyfunction]
fn mix_components(n: f64, thickness: f64, components: Vec<(f64, f64, f64, f64)>) -> PyResult<LayerTuple> {
    let comps: Vec<Component> =
        components.into_iter().map(|(fraction, mua, mus, g)| Component { fraction, mua, mus, g }).collect();
    let l = medium::mix(n, thickness, &comps).py()?;
    let lobes = l.phase.lobes().iter().map(|lb| (lb.weight, lb.g)).collect();
    Ok((l.n, l.mua, l.mus, lobes, l.thickness))
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(validate_layer, m)?)?;
    m.add_function(wrap_pyfunction!(validate_stack, m)?)?;
    m.add_function(wrap_pyfunction!(layer_properties, m)?)?;
    m.add_function(wrap_pyfunction!(stack_boundaries, m)?)?;
    m.add_function(wrap_pyfunction!(mix_components, m)?)?;
    Ok(())
}
