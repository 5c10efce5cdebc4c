//! Bindings of `subsurf_core::hk` (Hanrahan–Krueger first-order BRDF/BTDF).
//!
//! Directions come as flat, C-contiguous float64 arrays of length 3N (x, y, z per direction);
//! `python/subsurf/hk.py` broadcasts, validates (with multi-indices in the messages) and
//! reshapes. The core validates again, so bad input never panics.

use crate::errors::IntoPyResult;
use crate::medium::{stack_from_py, LayerTuple};
use numpy::{PyArray1, PyReadonlyArray1};
use pyo3::prelude::*;
use subsurf_core::hk;
use subsurf_core::medium::Stack;
use subsurf_core::Error;

type StackTuple = (Vec<LayerTuple>, f64, f64);

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

/// Name the failing element: `wi.z` → `wi[k].z`, `|wi|` → `|wi[k]|`.
fn index_error(e: Error, k: usize) -> Error {
    match e {
        Error::Parameter { field, value, allowed } => {
            let field = if let Some(rest) = field.strip_prefix('|') {
                format!("|{}[{k}]|", rest.trim_end_matches('|'))
            } else if let Some((name, comp)) = field.split_once('.') {
                format!("{name}[{k}].{comp}")
            } else {
                format!("{field}[{k}]")
            };
            Error::Parameter { field, value, allowed }
        }
        other => other,
    }
}

fn pairwise(
    py: Python<'_>,
    stack_t: StackTuple,
    wi: PyReadonlyArray1<'_, f64>,
    wo: PyReadonlyArray1<'_, f64>,
    f: fn(&Stack, [f64; 3], [f64; 3]) -> subsurf_core::Result<f64>,
) -> PyResult<Py<PyArray1<f64>>> {
    let s = stack(stack_t)?;
    let (a, b) = (triples("wi", &wi)?, triples("wo", &wo)?);
    if a.len() != b.len() {
        return Err(Error::Invalid(format!(
            "wi and wo: {} and {} directions, must be equal",
            a.len() / 3,
            b.len() / 3
        )))
        .py();
    }
    let out: subsurf_core::Result<Vec<f64>> =
        py.detach(|| (0..a.len() / 3).map(|k| f(&s, at(a, k), at(b, k)).map_err(|e| index_error(e, k))).collect());
    Ok(PyArray1::from_vec(py, out.py()?).unbind())
}

/// First-order BRDF f_r(wi, wo) in sr⁻¹ for N direction pairs (flat arrays of 3N).
#[pyfunction]
fn hk_brdf(
    py: Python<'_>,
    stack: StackTuple,
    wi: PyReadonlyArray1<'_, f64>,
    wo: PyReadonlyArray1<'_, f64>,
) -> PyResult<Py<PyArray1<f64>>> {
    pairwise(py, stack, wi, wo, hk::single_scattering_brdf)
}

/// First-order BTDF f_t(wi, wo) in sr⁻¹ for N direction pairs (flat arrays of 3N).
#[pyfunction]
fn hk_btdf(
    py: Python<'_>,
    stack: StackTuple,
    wi: PyReadonlyArray1<'_, f64>,
    wo: PyReadonlyArray1<'_, f64>,
) -> PyResult<Py<PyArray1<f64>>> {
    pairwise(py, stack, wi, wo, hk::single_scattering_btdf)
}

/// Per-layer contributions to the BRDF (`transmission=False`) or BTDF: flat array N × L.
#[pyfunction]
#[pyo3(signature = (stack, wi, wo, transmission=false))]
fn hk_layer_terms(
    py: Python<'_>,
    stack: StackTuple,
    wi: PyReadonlyArray1<'_, f64>,
    wo: PyReadonlyArray1<'_, f64>,
    transmission: bool,
) -> PyResult<Py<PyArray1<f64>>> {
    let s = self::stack(stack)?;
    let (a, b) = (triples("wi", &wi)?, triples("wo", &wo)?);
    if a.len() != b.len() {
        return Err(Error::Invalid(format!(
            "wi and wo: {} and {} directions, must be equal",
            a.len() / 3,
            b.len() / 3
        )))
        .py();
    }
    let f = if transmission { hk::single_scattering_btdf_layers } else { hk::single_scattering_brdf_layers };
    let out: subsurf_core::Result<Vec<f64>> = py.detach(|| {
        let mut v = Vec::with_capacity(a.len() / 3 * s.layers.len());
        for k in 0..a.len() / 3 {
            v.extend(f(&s, at(a, k), at(b, k)).map_err(|e| index_error(e, k))?);
        }
        Ok(v)
    });
    Ok(PyArray1::from_vec(py, out.py()?).unbind())
}

/// An owned 1-D float64 numpy array.
type Arr = Py<PyArray1<f64>>;

/// Unscattered transmittance and exit direction for N incident directions: returns
/// (T: N, wt: 3N; wt is NaN where T = 0).
#[pyfunction]
fn hk_unscattered(py: Python<'_>, stack: StackTuple, wi: PyReadonlyArray1<'_, f64>) -> PyResult<(Arr, Arr)> {
    let s = self::stack(stack)?;
    let a = triples("wi", &wi)?;
    let n = a.len() / 3;
    let out: subsurf_core::Result<(Vec<f64>, Vec<f64>)> = py.detach(|| {
        let (mut t, mut d) = (Vec::with_capacity(n), Vec::with_capacity(3 * n));
        for k in 0..n {
            let (tk, dk) = hk::unscattered_transmittance(&s, at(a, k)).map_err(|e| index_error(e, k))?;
            t.push(tk);
            d.extend(dk.unwrap_or([f64::NAN; 3]));
        }
        Ok((t, d))
    });
    let (t, d) = out.py()?;
    Ok((PyArray1::from_vec(py, t).unbind(), PyArray1::from_vec(py, d).unbind()))
}

/// First-order directional-hemispherical reflectance (or transmittance) for N incident
/// directions, by n_theta × n_phi quadrature.
#[pyfunction]
#[pyo3(signature = (stack, wi, n_theta, n_phi, transmission=false))]
fn hk_albedo(
    py: Python<'_>,
    stack: StackTuple,
    wi: PyReadonlyArray1<'_, f64>,
    n_theta: usize,
    n_phi: usize,
    transmission: bool,
) -> PyResult<Py<PyArray1<f64>>> {
    let s = self::stack(stack)?;
    let a = triples("wi", &wi)?;
    let f = if transmission { hk::single_scattering_transmittance } else { hk::single_scattering_reflectance };
    let out: subsurf_core::Result<Vec<f64>> = py
        .detach(|| (0..a.len() / 3).map(|k| f(&s, at(a, k), n_theta, n_phi).map_err(|e| index_error(e, k))).collect());
    Ok(PyArray1::from_vec(py, out.py()?).unbind())
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(hk_brdf, m)?)?;
    m.add_function(wrap_pyfunction!(hk_btdf, m)?)?;
    m.add_function(wrap_pyfunction!(hk_layer_terms, m)?)?;
    m.add_function(wrap_pyfunction!(hk_unscattered, m)?)?;
    m.add_function(wrap_pyfunction!(hk_albedo, m)?)?;
    Ok(())
}
