//! Bindings of `subsurf_core::diffusion`. Every function takes flat, equally long float64
//! arrays (python/subsurf/diffusion.py broadcasts and reshapes) and returns flat arrays; an
//! invalid element raises ParameterError naming the field and its flat index.

use crate::errors::IntoPyResult;
use numpy::{PyArray1, PyReadonlyArray1};
use pyo3::prelude::*;
use subsurf_core::diffusion::{self as dif, better_dipole, MeanFreePath, Model};
use subsurf_core::Error;

type Arr<'py> = PyReadonlyArray1<'py, f64>;
type Out<'py> = Bound<'py, PyArray1<f64>>;

fn slice<'a>(a: &'a Arr<'_>) -> PyResult<&'a [f64]> {
    a.as_slice().map_err(|e| pyo3::exceptions::PyValueError::new_err(e.to_string()))
}

/// Name the element: `sigma_a` → `sigma_a[3]` (only for arrays longer than one).
fn at_index(e: Error, i: usize, n: usize) -> Error {
    match e {
        Error::Parameter { field, value, allowed } if n > 1 => {
            Error::Parameter { field: format!("{field}[{i}]"), value, allowed }
        }
        other => other,
    }
}

/// Apply `f` to the i-th elements of equally long columns, without the GIL.
fn map_cols<F>(py: Python<'_>, cols: &[&[f64]], f: F) -> PyResult<Vec<f64>>
where
    F: Fn(&[f64]) -> subsurf_core::Result<f64> + Send + Sync,
{
    let n = cols.first().map_or(0, |c| c.len());
    if cols.iter().any(|c| c.len() != n) {
        return Err(Error::Invalid("diffusion: input arrays must have equal lengths".into())).py();
    }
    py.detach(|| {
        let mut row = vec![0.0; cols.len()];
        let mut out = Vec::with_capacity(n);
        for i in 0..n {
            for (k, c) in cols.iter().enumerate() {
                row[k] = c[i];
            }
            out.push(f(&row).map_err(|e| at_index(e, i, n))?);
        }
        Ok(out)
    })
    .py()
}

fn model(name: &str) -> PyResult<Model> {
    Model::from_name(name).py()
}

/// F_dr(η), Jensen's (Egan–Hilgeman) fit; η validated.
#[pyfunction]
fn diffusion_fdr<'py>(py: Python<'py>, eta: Arr<'py>) -> PyResult<Out<'py>> {
    let v = map_cols(py, &[slice(&eta)?], |x| Ok(dif::fdr(dif::check_eta(x[0])?)))?;
    Ok(PyArray1::from_vec(py, v))
}

/// Boundary coefficient A(η) of the model.
#[pyfunction]
fn diffusion_a<'py>(py: Python<'py>, model_name: &str, eta: Arr<'py>) -> PyResult<Out<'py>> {
    let m = model(model_name)?;
    let v = map_cols(py, &[slice(&eta)?], |x| {
        let e = dif::check_eta(x[0])?;
        Ok(match m {
            Model::Dipole => dif::a_coefficient(e),
            Model::BetterDipole => better_dipole::better_a(e),
        })
    })?;
    Ok(PyArray1::from_vec(py, v))
}

/// d'Eon's Fresnel moments (C1, C2).
#[pyfunction]
fn diffusion_fresnel_moments<'py>(py: Python<'py>, eta: Arr<'py>) -> PyResult<(Out<'py>, Out<'py>)> {
    let e = slice(&eta)?;
    let c1 = map_cols(py, &[e], |x| Ok(dif::fresnel_moment1(dif::check_eta(x[0])?)))?;
    let c2 = map_cols(py, &[e], |x| Ok(dif::fresnel_moment2(dif::check_eta(x[0])?)))?;
    Ok((PyArray1::from_vec(py, c1), PyArray1::from_vec(py, c2)))
}

/// The model's constants per element: (alpha_prime, D, sigma_tr, A, z_r, z_v).
#[pyfunction]
fn diffusion_params<'py>(
    py: Python<'py>,
    model_name: &str,
    sigma_a: Arr<'py>,
    sigma_s_prime: Arr<'py>,
    eta: Arr<'py>,
) -> PyResult<Vec<Out<'py>>> {
    let m = model(model_name)?;
    let cols = [slice(&sigma_a)?, slice(&sigma_s_prime)?, slice(&eta)?];
    let mut outs = Vec::new();
    for k in 0..6 {
        let v = map_cols(py, &cols, |x| {
            let p = match m {
                Model::Dipole => {
                    let d = dif::Dipole::new(x[0], x[1], x[2])?;
                    [d.alpha_prime, d.d, d.sigma_tr, d.a, d.z_r, d.z_v]
                }
                Model::BetterDipole => {
                    let d = dif::BetterDipole::new(x[0], x[1], x[2])?;
                    [d.alpha_prime, d.d, d.sigma_tr, d.a, d.z_r, d.z_v]
                }
            };
            Ok(p[k])
        })?;
        outs.push(PyArray1::from_vec(py, v));
    }
    Ok(outs)
}

/// R_d(r) in mm⁻².
#[pyfunction]
fn diffusion_rd<'py>(
    py: Python<'py>,
    model_name: &str,
    r: Arr<'py>,
    sigma_a: Arr<'py>,
    sigma_s_prime: Arr<'py>,
    eta: Arr<'py>,
) -> PyResult<Out<'py>> {
    let m = model(model_name)?;
    let cols = [slice(&r)?, slice(&sigma_a)?, slice(&sigma_s_prime)?, slice(&eta)?];
    let v = map_cols(py, &cols, |x| m.rd(x[0], x[1], x[2], x[3]))?;
    Ok(PyArray1::from_vec(py, v))
}

/// Total diffuse reflectance from (alpha_prime, eta), closed form.
#[pyfunction]
fn diffusion_total_rd<'py>(
    py: Python<'py>,
    model_name: &str,
    alpha_prime: Arr<'py>,
    eta: Arr<'py>,
) -> PyResult<Out<'py>> {
    let m = model(model_name)?;
    let v = map_cols(py, &[slice(&alpha_prime)?, slice(&eta)?], |x| m.total_rd(x[0], x[1]))?;
    Ok(PyArray1::from_vec(py, v))
}

/// alpha_prime from a total diffuse reflectance.
#[pyfunction]
fn diffusion_alpha_prime_from_rd<'py>(
    py: Python<'py>,
    model_name: &str,
    rd: Arr<'py>,
    eta: Arr<'py>,
) -> PyResult<Out<'py>> {
    let m = model(model_name)?;
    let v = map_cols(py, &[slice(&rd)?, slice(&eta)?], |x| dif::alpha_prime_from_rd(x[0], x[1], m))?;
    Ok(PyArray1::from_vec(py, v))
}

/// (sigma_a, sigma_s_prime) from a diffuse colour and a mean free path.
#[pyfunction]
fn diffusion_properties_from_color<'py>(
    py: Python<'py>,
    model_name: &str,
    mfp_kind: &str,
    rd: Arr<'py>,
    mfp: Arr<'py>,
    eta: Arr<'py>,
) -> PyResult<(Out<'py>, Out<'py>)> {
    let m = model(model_name)?;
    let kind = MeanFreePath::from_name(mfp_kind).py()?;
    let cols = [slice(&rd)?, slice(&mfp)?, slice(&eta)?];
    let sa = map_cols(py, &cols, |x| {
        dif::properties_from_color(x[0], x[1], x[2], m, kind).map(|p| p.0).map_err(|e| rename(e, "rd", "diffuse_color"))
    })?;
    let ssp = map_cols(py, &cols, |x| dif::properties_from_color(x[0], x[1], x[2], m, kind).map(|p| p.1))?;
    Ok((PyArray1::from_vec(py, sa), PyArray1::from_vec(py, ssp)))
}

fn rename(e: Error, from: &str, to: &str) -> Error {
    match e {
        Error::Parameter { field, value, allowed } if field == from => {
            Error::Parameter { field: to.into(), value, allowed }
        }
        other => other,
    }
}

fn v3(c: &[f64], i: usize) -> [f64; 3] {
    [c[3 * i], c[3 * i + 1], c[3 * i + 2]]
}

/// S_d(xi, wi, xo, wo) in mm⁻² sr⁻¹; points and directions flat (3n), properties n.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
fn diffusion_sd<'py>(
    py: Python<'py>,
    model_name: &str,
    xi: Arr<'py>,
    wi: Arr<'py>,
    xo: Arr<'py>,
    wo: Arr<'py>,
    sigma_a: Arr<'py>,
    sigma_s_prime: Arr<'py>,
    eta: Arr<'py>,
) -> PyResult<Out<'py>> {
    let m = model(model_name)?;
    let (xi, wi, xo, wo) = (slice(&xi)?, slice(&wi)?, slice(&xo)?, slice(&wo)?);
    let (sa, ssp, e) = (slice(&sigma_a)?, slice(&sigma_s_prime)?, slice(&eta)?);
    let n = sa.len();
    if [xi, wi, xo, wo].iter().any(|c| c.len() != 3 * n) {
        return Err(Error::Invalid("diffusion_sd: points/directions must hold 3 values per element".into())).py();
    }
    let idx: Vec<f64> = (0..n).map(|i| i as f64).collect();
    let v = map_cols(py, &[&idx, sa, ssp, e], |x| {
        let i = x[0] as usize;
        dif::sd(v3(xi, i), v3(wi, i), v3(xo, i), v3(wo, i), m, x[1], x[2], x[3])
    })?;
    Ok(PyArray1::from_vec(py, v))
}

/// The diffusion BRDF (1/π) F_t(wi) R_d,total F_t(wo), sr⁻¹.
#[pyfunction]
fn diffusion_brdf<'py>(
    py: Python<'py>,
    model_name: &str,
    wi: Arr<'py>,
    wo: Arr<'py>,
    sigma_a: Arr<'py>,
    sigma_s_prime: Arr<'py>,
    eta: Arr<'py>,
) -> PyResult<Out<'py>> {
    let m = model(model_name)?;
    let (wi, wo) = (slice(&wi)?, slice(&wo)?);
    let (sa, ssp, e) = (slice(&sigma_a)?, slice(&sigma_s_prime)?, slice(&eta)?);
    let n = sa.len();
    if wi.len() != 3 * n || wo.len() != 3 * n {
        return Err(Error::Invalid("diffusion_brdf: directions must hold 3 values per element".into())).py();
    }
    let idx: Vec<f64> = (0..n).map(|i| i as f64).collect();
    let v = map_cols(py, &[&idx, sa, ssp, e], |x| {
        let i = x[0] as usize;
        dif::diffusion_brdf(v3(wi, i), v3(wo, i), m, x[1], x[2], x[3])
    })?;
    Ok(PyArray1::from_vec(py, v))
}

/// F_t(η, cos θ) = 1 − F_r(1 → η) (0 for cos θ ≤ 0); η validated, |cos θ| ≤ 1.
#[pyfunction]
fn diffusion_ft<'py>(py: Python<'py>, eta: Arr<'py>, cos_theta: Arr<'py>) -> PyResult<Out<'py>> {
    let v = map_cols(py, &[slice(&eta)?, slice(&cos_theta)?], |x| {
        let e = dif::check_eta(x[0])?;
        if !(x[1].is_finite() && x[1].abs() <= 1.0) {
            return Err(Error::param("cos_theta", x[1], "a finite number in [-1, 1]"));
        }
        Ok(dif::bssrdf::ft(e, x[1]))
    })?;
    Ok(PyArray1::from_vec(py, v))
}

/// Validate optical properties (sigma_a, sigma_s_prime ≥ 0, their sum > 0, eta ∈ [1, 2.5]).
#[pyfunction]
fn diffusion_check_properties<'py>(
    py: Python<'py>,
    sigma_a: Arr<'py>,
    sigma_s_prime: Arr<'py>,
    eta: Arr<'py>,
) -> PyResult<()> {
    let cols = [slice(&sigma_a)?, slice(&sigma_s_prime)?, slice(&eta)?];
    map_cols(py, &cols, |x| dif::check_properties(x[0], x[1], x[2]))?;
    Ok(())
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(diffusion_fdr, m)?)?;
    m.add_function(wrap_pyfunction!(diffusion_a, m)?)?;
    m.add_function(wrap_pyfunction!(diffusion_fresnel_moments, m)?)?;
    m.add_function(wrap_pyfunction!(diffusion_params, m)?)?;
    m.add_function(wrap_pyfunction!(diffusion_rd, m)?)?;
    m.add_function(wrap_pyfunction!(diffusion_total_rd, m)?)?;
    m.add_function(wrap_pyfunction!(diffusion_alpha_prime_from_rd, m)?)?;
    m.add_function(wrap_pyfunction!(diffusion_properties_from_color, m)?)?;
    m.add_function(wrap_pyfunction!(diffusion_sd, m)?)?;
    m.add_function(wrap_pyfunction!(diffusion_brdf, m)?)?;
    m.add_function(wrap_pyfunction!(diffusion_check_properties, m)?)?;
    m.add_function(wrap_pyfunction!(diffusion_ft, m)?)?;
    Ok(())
}
