//! Bindings of `subsurf_core::hk` (Hanrahan–Krueger first-order BRDF/BTDF).
//!
//! Directions come as flat, C-contiguous float64 arrays of length 3N (x, y, z per direction)
//! with `shape`, the numpy shape of the N directions; `python/subsurf/hk.py` broadcasts and
//! reshapes. The core validates every direction; an error names the element by its index in
//! `shape` (`wi[1, 2].z`).

use crate::errors::IntoPyResult;
use crate::medium::{stack_from_py, LayerTuple};
use numpy::{PyArray1, PyReadonlyArray1};
use pyo3::prelude::*;
use subsurf_core::error::unravel;
use subsurf_core::medium::Stack;
use subsurf_core::{hk, Error, Result};

type StackTuple = (Vec<LayerTuple>, f64, f64);
/// An owned 1-D float64 numpy array.
type Arr = Py<PyArray1<f64>>;

fn stack(t: StackTuple) -> PyResult<Stack> {
    stack_from_py(&t.0, t.1, t.2).py()
}

fn triples<'a>(name: &str, a: &'a PyReadonlyArray1<'_, f64>) -> PyResult<&'a [f64]> {
    let s = a.as_slice().map_err(|_| Error::Invalid(format!("{name}: expected a contiguous float64 array"))).py()?;
    if s.len() % 3 != 0 {
        return Err(Error::Invalid(format!("{name}: length {} is not a multiple of 3", s.len()))).py();
    }
    Ok(s)
}

fn at(s: &[f64], k: usize) -> [f64; 3] {
    [s[3 * k], s[3 * k + 1], s[3 * k + 2]]
}

/// `wi`, and `wo` when given, as direction triples of equal count.
fn directions<'a>(
    wi: &'a PyReadonlyArray1<'_, f64>,
    wo: Option<&'a PyReadonlyArray1<'_, f64>>,
) -> PyResult<(&'a [f64], &'a [f64])> {
    let a = triples("wi", wi)?;
    let b = match wo {
        Some(w) => triples("wo", w)?,
        None => a,
    };
    if a.len() != b.len() {
        return Err(Error::Invalid(format!(
            "wi and wo: {} and {} directions, must be equal",
            a.len() / 3,
            b.len() / 3
        )))
        .py();
    }
    Ok((a, b))
}

/// Evaluate `f` for every direction pair k without the GIL, naming a failing element by its
/// index in `shape`; `f` appends its values to the output.
fn each<F>(py: Python<'_>, n: usize, shape: &[usize], f: F) -> PyResult<Vec<f64>>
where
    F: Fn(usize, &mut Vec<f64>) -> Result<()> + Send + Sync,
{
    py.detach(|| {
        let mut out = Vec::with_capacity(n);
        for k in 0..n {
            f(k, &mut out).map_err(|e| e.at(&unravel(k, shape)))?;
        }
        Ok(out)
    })
    .py()
}

fn pairwise(
    py: Python<'_>,
    stack_t: StackTuple,
    wi: PyReadonlyArray1<'_, f64>,
    wo: PyReadonlyArray1<'_, f64>,
    shape: Vec<usize>,
    f: fn(&Stack, [f64; 3], [f64; 3]) -> Result<f64>,
) -> PyResult<Arr> {
    let s = stack(stack_t)?;
    let (a, b) = directions(&wi, Some(&wo))?;
    let out = each(py, a.len() / 3, &shape, |k, out| {
        out.push(f(&s, at(a, k), at(b, k))?);
        Ok(())
    })?;
    Ok(PyArray1::from_vec(py, out).unbind())
}

/// First-order BRDF f_r(wi, wo) in sr⁻¹ for N direction pairs (flat arrays of 3N).
#[pyfunction]
#[pyo3(signature = (stack, wi, wo, shape=vec![]))]
fn hk_brdf(
    py: Python<'_>,
    stack: StackTuple,
    wi: PyReadonlyArray1<'_, f64>,
    wo: PyReadonlyArray1<'_, f64>,
    shape: Vec<usize>,
) -> PyResult<Arr> {
    pairwise(py, stack, wi, wo, shape, hk::single_scattering_brdf)
}

/// First-order BTDF f_t(wi, wo) in sr⁻¹ for N direction pairs (flat arrays of 3N).
#[pyfunction]
#[pyo3(signature = (stack, wi, wo, shape=vec![]))]
fn hk_btdf(
    py: Python<'_>,
    stack: StackTuple,
    wi: PyReadonlyArray1<'_, f64>,
    wo: PyReadonlyArray1<'_, f64>,
    shape: Vec<usize>,
) -> PyResult<Arr> {
    pairwise(py, stack, wi, wo, shape, hk::single_scattering_btdf)
}

/// Per-layer contributions to the BRDF (`transmission=False`) or BTDF: flat array N × L.
#[pyfunction]
#[pyo3(signature = (stack, wi, wo, transmission=false, shape=vec![]))]
fn hk_layer_terms(
    py: Python<'_>,
    stack: StackTuple,
    wi: PyReadonlyArray1<'_, f64>,
    wo: PyReadonlyArray1<'_, f64>,
    transmission: bool,
    shape: Vec<usize>,
) -> PyResult<Arr> {
    let s = self::stack(stack)?;
    let (a, b) = directions(&wi, Some(&wo))?;
    let f = if transmission { hk::single_scattering_btdf_layers } else { hk::single_scattering_brdf_layers };
    let out = each(py, a.len() / 3, &shape, |k, out| {
        out.extend(f(&s, at(a, k), at(b, k))?);
        Ok(())
    })?;
    Ok(PyArray1::from_vec(py, out).unbind())
}

/// Unscattered transmittance and exit direction for N incident directions: returns
/// (T: N, wt: 3N; wt is NaN where T = 0).
#[pyfunction]
#[pyo3(signature = (stack, wi, shape=vec![]))]
fn hk_unscattered(
    py: Python<'_>,
    stack: StackTuple,
    wi: PyReadonlyArray1<'_, f64>,
    shape: Vec<usize>,
) -> PyResult<(Arr, Arr)> {
    let s = self::stack(stack)?;
    let (a, _) = directions(&wi, None)?;
    let both = each(py, a.len() / 3, &shape, |k, out| {
        let (t, d) = hk::unscattered_transmittance(&s, at(a, k))?;
        out.push(t);
        out.extend(d.unwrap_or([f64::NAN; 3]));
        Ok(())
    })?;
    let t: Vec<f64> = both.chunks(4).map(|c| c[0]).collect();
    let d: Vec<f64> = both.chunks(4).flat_map(|c| c[1..].to_vec()).collect();
    Ok((PyArray1::from_vec(py, t).unbind(), PyArray1::from_vec(py, d).unbind()))
}

/// First-order directional-hemispherical reflectance (or transmittance) for N incident
/// directions, by n_theta × n_phi quadrature.
#[pyfunction]
#[pyo3(signature = (stack, wi, n_theta, n_phi, transmission=false, shape=vec![]))]
fn hk_albedo(
    py: Python<'_>,
    stack: StackTuple,
    wi: PyReadonlyArray1<'_, f64>,
    n_theta: i128,
    n_phi: i128,
    transmission: bool,
    shape: Vec<usize>,
) -> PyResult<Arr> {
    let s = self::stack(stack)?;
    let (n_theta, n_phi) = (hk::albedo::nodes("n_theta", n_theta).py()?, hk::albedo::nodes("n_phi", n_phi).py()?);
    let (a, _) = directions(&wi, None)?;
    let f = if transmission { hk::single_scattering_transmittance } else { hk::single_scattering_reflectance };
    let out = each(py, a.len() / 3, &shape, |k, out| {
        out.push(f(&s, at(a, k), n_theta, n_phi)?);
        Ok(())
    })?;
    Ok(PyArray1::from_vec(py, out).unbind())
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(hk_brdf, m)?)?;
    m.add_function(wrap_pyfunction!(hk_btdf, m)?)?;
    m.add_function(wrap_pyfunction!(hk_layer_terms, m)?)?;
    m.add_function(wrap_pyfunction!(hk_unscattered, m)?)?;
    m.add_function(wrap_pyfunction!(hk_albedo, m)?)?;
    Ok(())
}
