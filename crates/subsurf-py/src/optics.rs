//! Bindings of `subsurf_core::optics` (its validated entry points, `optics::checked`) and
//! `subsurf_core::stats`.
//!
//! Array functions take contiguous 1-D float64 arrays of equal length (the Python layer
//! broadcasts and flattens them), map a checked core function over them and return new 1-D
//! arrays; names end in `_v`. Every argument check is the core's.

use crate::errors::IntoPyResult;
use numpy::{PyArray1, PyReadonlyArray1};
use pyo3::prelude::*;
use subsurf_core::optics::{self, checked, Phase};
use subsurf_core::{stats, Error, Result};

type In<'py> = PyReadonlyArray1<'py, f64>;
type Arr<'py> = Bound<'py, PyArray1<f64>>;

fn slice<'a>(a: &'a In<'_>, name: &str) -> PyResult<&'a [f64]> {
    a.as_slice().map_err(|_| Error::Invalid(format!("{name}: expected a contiguous float64 array"))).py()
}

/// Named input columns of equal length (`rows` elements of `width` values each).
fn columns<'a>(cols: &[(&'a In<'_>, &str, usize)]) -> PyResult<(Vec<&'a [f64]>, usize)> {
    let mut out = Vec::with_capacity(cols.len());
    for (a, name, _) in cols {
        out.push(slice(a, name)?);
    }
    let rows: Vec<usize> = out.iter().zip(cols).map(|(s, c)| s.len() / c.2).collect();
    if rows.iter().any(|&r| r != rows[0]) || out.iter().zip(cols).any(|(s, c)| s.len() % c.2 != 0) {
        let names: Vec<&str> = cols.iter().map(|c| c.1).collect();
        return Err(Error::Invalid(format!(
            "arrays {} must have the same number of rows, got {rows:?}",
            names.join(", ")
        )))
        .py();
    }
    Ok((out, rows.first().copied().unwrap_or(0)))
}

/// Map `f` over rows of scalar columns into one output value per row.
fn map_rows<'py, const K: usize>(
    py: Python<'py>,
    cols: [(&In<'py>, &str); K],
    f: impl Fn([f64; K]) -> Result<f64>,
) -> PyResult<Arr<'py>> {
    let spec: Vec<(&In<'py>, &str, usize)> = cols.iter().map(|&(a, n)| (a, n, 1)).collect();
    let (c, n) = columns(&spec)?;
    let out: Result<Vec<f64>> = (0..n).map(|i| f(std::array::from_fn(|k| c[k][i]))).collect();
    Ok(PyArray1::from_vec(py, out.py()?))
}

/// Elementwise bindings `name_v(a, b, …) -> array` of checked core functions of scalars: one
/// line each (doc, name, the argument names as Python passes them, the core function).
macro_rules! elementwise {
    ($($(#[$doc:meta])* $name:ident($($arg:ident),+) => $f:expr;)+) => {$(
        $(#[$doc])*
        #[pyfunction]
        fn $name<'py>(py: Python<'py>, $($arg: In<'py>),+) -> PyResult<Arr<'py>> {
            map_rows(py, [$((&$arg, stringify!($arg))),+], |[$($arg),+]| $f($($arg),+))
        }
    )+};
}

elementwise! {
    /// Egan–Hilgeman fit of the internal diffuse Fresnel reflectance.
    diffuse_fresnel_reflectance_fit_v(eta) => optics::diffuse_fresnel_reflectance_fit;
    /// HG phase p(cos θ; g) (sr⁻¹).
    hg_phase_v(cos_theta, g) => checked::hg_phase;
    /// HG sampling cos θ = sample_hg(u, g).
    sample_hg_v(u, g) => checked::sample_hg;
    /// The isotropic phase function 1/(4π) at each cos θ.
    isotropic_phase_v(cos_theta) => checked::isotropic_phase;
    /// Beer–Lambert transmittance exp(−μt d).
    beer_lambert_v(mu_t, distance) => checked::beer_lambert;
    /// Free-path sampling s = −ln(1 − u)/σt.
    sample_free_path_v(u, sigma_t) => checked::sample_free_path;
    /// Free-path pdf σt exp(−σt s) (0 for s < 0).
    free_path_pdf_v(s, sigma_t) => checked::free_path_pdf;
    /// pdf max(cos θ, 0)/π of the cosine-weighted hemisphere.
    cosine_hemisphere_pdf_v(cos_theta) => checked::cosine_hemisphere_pdf;
}

fn v3(c: &[f64], i: usize) -> [f64; 3] {
    [c[3 * i], c[3 * i + 1], c[3 * i + 2]]
}

/// Fresnel reflectance (or transmittance when `transmit`) of 1-D arrays of equal length.
#[pyfunction]
fn fresnel_v<'py>(
    py: Python<'py>,
    cos_theta_i: In<'py>,
    eta_i: In<'py>,
    eta_t: In<'py>,
    polarization: &str,
    transmit: bool,
) -> PyResult<Arr<'py>> {
    let pol = checked::polarization(polarization).py()?;
    map_rows(py, [(&cos_theta_i, "cos_theta_i"), (&eta_i, "eta_i"), (&eta_t, "eta_t")], |[c, a, b]| {
        checked::fresnel_rt(c, a, b, pol, transmit)
    })
}

/// Refract rows of `d` (flat, 3 per row) about `normal` (flat, 3 per row); NaN rows on TIR.
#[pyfunction]
fn refract_v<'py>(py: Python<'py>, d: In<'py>, normal: In<'py>, eta_i: In<'py>, eta_t: In<'py>) -> PyResult<Arr<'py>> {
    let (c, n) = columns(&[(&d, "d", 3), (&normal, "normal", 3), (&eta_i, "eta_i", 1), (&eta_t, "eta_t", 1)])?;
    let mut out = Vec::with_capacity(3 * n);
    for i in 0..n {
        out.extend(checked::refract(v3(c[0], i), v3(c[1], i), c[2][i], c[3][i]).py()?.unwrap_or([f64::NAN; 3]));
    }
    Ok(PyArray1::from_vec(py, out))
}

/// Mirror reflection of rows of `d` about `normal` (flat, 3 per row).
#[pyfunction]
fn reflect_v<'py>(py: Python<'py>, d: In<'py>, normal: In<'py>) -> PyResult<Arr<'py>> {
    let (c, n) = columns(&[(&d, "d", 3), (&normal, "normal", 3)])?;
    let mut out = Vec::with_capacity(3 * n);
    for i in 0..n {
        out.extend(checked::reflect(v3(c[0], i), v3(c[1], i)).py()?);
    }
    Ok(PyArray1::from_vec(py, out))
}

/// Diffuse Fresnel reflectance by quadrature for each eta (n_inside/n_outside).
#[pyfunction]
fn diffuse_fresnel_reflectance_v<'py>(py: Python<'py>, eta: In<'py>, internal: bool) -> PyResult<Arr<'py>> {
    map_rows(py, [(&eta, "eta")], |[e]| optics::diffuse_fresnel_reflectance(e, internal))
}

/// i-th internal Fresnel moment ∫_0^1 R μ^i dμ for each eta.
#[pyfunction]
fn fresnel_moment_v<'py>(py: Python<'py>, eta: In<'py>, i: u32) -> PyResult<Arr<'py>> {
    map_rows(py, [(&eta, "eta")], |[e]| optics::fresnel_moment(e, i))
}

fn phase_from(lobes: &[(f64, f64)]) -> Result<Phase> {
    match lobes {
        [(_, g)] => Phase::hg(*g),
        _ => Phase::mixture(lobes),
    }
}

/// Mixture of HG lobes [(weight, g)]: evaluate p(cos θ).
#[pyfunction]
fn mixture_phase_v<'py>(py: Python<'py>, cos_theta: In<'py>, lobes: Vec<(f64, f64)>) -> PyResult<Arr<'py>> {
    let ph = phase_from(&lobes).py()?;
    map_rows(py, [(&cos_theta, "cos_theta")], |[c]| checked::phase_eval(&ph, c))
}

/// Mixture of HG lobes: sample cos θ from uniform numbers u.
#[pyfunction]
fn sample_mixture_v<'py>(py: Python<'py>, u: In<'py>, lobes: Vec<(f64, f64)>) -> PyResult<Arr<'py>> {
    let ph = phase_from(&lobes).py()?;
    map_rows(py, [(&u, "u")], |[u]| checked::phase_sample(&ph, u))
}

/// Cosine-weighted hemisphere directions (flat, 3 per row) from u1, u2.
#[pyfunction]
fn sample_cosine_hemisphere_v<'py>(py: Python<'py>, u1: In<'py>, u2: In<'py>) -> PyResult<Arr<'py>> {
    let (c, n) = columns(&[(&u1, "u1", 1), (&u2, "u2", 1)])?;
    let mut out = Vec::with_capacity(3 * n);
    for i in 0..n {
        out.extend(checked::sample_cosine_hemisphere(c[0][i], c[1][i]).py()?);
    }
    Ok(PyArray1::from_vec(py, out))
}

// ------------------------------------------------------------------------------------------
// stats
// ------------------------------------------------------------------------------------------

/// χ² survival function P(X² ≥ statistic) with `dof` degrees of freedom.
#[pyfunction]
fn chi2_sf(statistic: f64, dof: f64) -> PyResult<f64> {
    stats::chi2_sf(statistic, dof).py()
}

/// Regularised upper incomplete gamma Q(a, x).
#[pyfunction]
fn gamma_q(a: f64, x: f64) -> PyResult<f64> {
    stats::gamma_q(a, x).py()
}

/// Šidák per-test significance 1 − (1 − α)^(1/m).
#[pyfunction]
fn sidak_alpha(significance: f64, tests: usize) -> PyResult<f64> {
    stats::sidak_alpha(significance, tests).py()
}

/// Pearson χ² with pooling: returns (statistic, dof, p_value, pooled_cells).
#[pyfunction]
fn chi2_pooled(observed: In<'_>, expected: In<'_>, min_expected: f64) -> PyResult<(f64, usize, f64, usize)> {
    let r = stats::chi2_pooled(slice(&observed, "observed")?, slice(&expected, "expected")?, min_expected).py()?;
    Ok((r.statistic, r.dof, r.p_value, r.pooled_cells))
}

/// The χ² test on a grid of 1 or 2 axes (`subsurf_core::stats::grid`): samples and edges per
/// axis (named by `names` in errors), `pdf(*coordinates)` a vectorised density returning a flat
/// float64 array; returns (statistic, dof, p_value, pooled_cells, outside, pdf_integral,
/// quadrature_error). An exception raised by `pdf` propagates.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
fn chi2_test_grid(
    py: Python<'_>,
    samples: Vec<In<'_>>,
    edges: Vec<In<'_>>,
    names: Vec<String>,
    pdf: Py<PyAny>,
    min_expected: f64,
    quad_points: usize,
    max_subdivisions: usize,
) -> PyResult<(f64, usize, f64, usize, usize, f64, f64)> {
    let s: Vec<&[f64]> = samples.iter().map(|a| slice(a, "samples")).collect::<PyResult<_>>()?;
    let e: Vec<&[f64]> = edges.iter().map(|a| slice(a, "edges")).collect::<PyResult<_>>()?;
    let names: Vec<&str> = names.iter().map(String::as_str).collect();
    let mut raised: Option<PyErr> = None;
    let mut batch = |coords: &[Vec<f64>]| -> Result<Vec<f64>> {
        let args: Vec<Bound<'_, PyArray1<f64>>> = coords.iter().map(|c| PyArray1::from_slice(py, c)).collect();
        let called = pyo3::types::PyTuple::new(py, args).and_then(|t| pdf.call1(py, t)).and_then(|v| {
            let a: PyReadonlyArray1<'_, f64> = v.extract(py)?;
            Ok(a.as_slice()?.to_vec())
        });
        called.map_err(|e| {
            raised = Some(e);
            Error::Invalid("pdf raised an exception".into())
        })
    };
    let r = stats::chi2_test_grid(&s, &e, &names, &mut batch, min_expected, quad_points, max_subdivisions);
    if let Some(e) = raised {
        return Err(e);
    }
    let r = r.py()?;
    let c = r.chi2;
    Ok((c.statistic, c.dof, c.p_value, c.pooled_cells, r.outside, r.pdf_integral, r.quadrature_error))
}

/// Edges on [−1, 1] refined geometrically towards both poles.
#[pyfunction]
fn graded_cos_edges<'py>(py: Python<'py>, n_end: usize, n_mid: usize, min_gap: f64) -> PyResult<Arr<'py>> {
    Ok(PyArray1::from_vec(py, stats::graded_cos_edges(n_end, n_mid, min_gap).py()?))
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(fresnel_v, m)?)?;
    m.add_function(wrap_pyfunction!(refract_v, m)?)?;
    m.add_function(wrap_pyfunction!(reflect_v, m)?)?;
    m.add_function(wrap_pyfunction!(diffuse_fresnel_reflectance_v, m)?)?;
    m.add_function(wrap_pyfunction!(diffuse_fresnel_reflectance_fit_v, m)?)?;
    m.add_function(wrap_pyfunction!(fresnel_moment_v, m)?)?;
    m.add_function(wrap_pyfunction!(hg_phase_v, m)?)?;
    m.add_function(wrap_pyfunction!(sample_hg_v, m)?)?;
    m.add_function(wrap_pyfunction!(isotropic_phase_v, m)?)?;
    m.add_function(wrap_pyfunction!(mixture_phase_v, m)?)?;
    m.add_function(wrap_pyfunction!(sample_mixture_v, m)?)?;
    m.add_function(wrap_pyfunction!(beer_lambert_v, m)?)?;
    m.add_function(wrap_pyfunction!(sample_free_path_v, m)?)?;
    m.add_function(wrap_pyfunction!(free_path_pdf_v, m)?)?;
    m.add_function(wrap_pyfunction!(sample_cosine_hemisphere_v, m)?)?;
    m.add_function(wrap_pyfunction!(cosine_hemisphere_pdf_v, m)?)?;
    m.add_function(wrap_pyfunction!(chi2_sf, m)?)?;
    m.add_function(wrap_pyfunction!(gamma_q, m)?)?;
    m.add_function(wrap_pyfunction!(sidak_alpha, m)?)?;
    m.add_function(wrap_pyfunction!(chi2_pooled, m)?)?;
    m.add_function(wrap_pyfunction!(graded_cos_edges, m)?)?;
    m.add_function(wrap_pyfunction!(chi2_test_grid, m)?)?;
    Ok(())
}
