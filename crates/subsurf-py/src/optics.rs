//! Bindings of `subsurf_core::optics` and `subsurf_core::stats`.
//!
//! Array functions take contiguous 1-D float64 arrays (the Python layer broadcasts and
//! flattens them) and return new 1-D arrays; names end in `_v`. Inputs are validated here
//! against the allowed ranges and refused with `ParameterError` naming the argument.

use crate::errors::IntoPyResult;
use numpy::{PyArray1, PyReadonlyArray1};
use pyo3::prelude::*;
use subsurf_core::optics::{self, Phase, Polarization};
use subsurf_core::{stats, Error, Result};

type Arr<'py> = Bound<'py, PyArray1<f64>>;

fn slice<'a>(a: &'a PyReadonlyArray1<'_, f64>, name: &str) -> Result<&'a [f64]> {
    a.as_slice().map_err(|_| Error::Invalid(format!("{name}: expected a contiguous float64 array")))
}

fn check_all(name: &str, v: &[f64], ok: impl Fn(f64) -> bool, allowed: &'static str) -> Result<()> {
    match v.iter().find(|&&x| !ok(x)) {
        Some(&bad) => Err(Error::param(name, bad, allowed)),
        None => Ok(()),
    }
}

fn same_len(names: &[&str], lens: &[usize]) -> Result<()> {
    if lens.iter().any(|&l| l != lens[0]) {
        return Err(Error::Invalid(format!("arrays {} must have the same length, got {:?}", names.join(", "), lens)));
    }
    Ok(())
}

fn positive(x: f64) -> bool {
    x.is_finite() && x > 0.0
}
fn unit_interval(x: f64) -> bool {
    (0.0..=1.0).contains(&x)
}
fn cosine(x: f64) -> bool {
    (-1.0..=1.0).contains(&x)
}
fn g_ok(x: f64) -> bool {
    x.is_finite() && x.abs() < 1.0
}

const POSITIVE: &str = "a finite number > 0";
const UNIT: &str = "a number in [0, 1]";
const COSINE: &str = "a number in [-1, 1]";
const G_RANGE: &str = "a finite number with |g| < 1";

fn polarization(p: &str) -> Result<Polarization> {
    match p {
        "unpolarized" | "unpolarised" => Ok(Polarization::Unpolarized),
        "s" => Ok(Polarization::S),
        "p" => Ok(Polarization::P),
        _ => {
            Err(Error::Invalid(format!("polarization = {p:?} is not allowed: must be \"unpolarized\", \"s\" or \"p\"")))
        }
    }
}

/// Fresnel reflectance (or transmittance when `transmit`) of 1-D arrays of equal length.
#[pyfunction]
fn fresnel_v<'py>(
    py: Python<'py>,
    cos_theta_i: PyReadonlyArray1<'py, f64>,
    eta_i: PyReadonlyArray1<'py, f64>,
    eta_t: PyReadonlyArray1<'py, f64>,
    polarization: &str,
    transmit: bool,
) -> PyResult<Arr<'py>> {
    let pol = self::polarization(polarization).py()?;
    let (c, ei, et) =
        (slice(&cos_theta_i, "cos_theta_i").py()?, slice(&eta_i, "eta_i").py()?, slice(&eta_t, "eta_t").py()?);
    same_len(&["cos_theta_i", "eta_i", "eta_t"], &[c.len(), ei.len(), et.len()]).py()?;
    check_all("cos_theta_i", c, cosine, COSINE).py()?;
    check_all("eta_i", ei, positive, POSITIVE).py()?;
    check_all("eta_t", et, positive, POSITIVE).py()?;
    let out: Vec<f64> = (0..c.len())
        .map(|k| {
            let r = optics::fresnel_reflectance(c[k], ei[k], et[k], pol);
            if transmit {
                1.0 - r
            } else {
                r
            }
        })
        .collect();
    Ok(PyArray1::from_vec(py, out))
}

/// Refract rows of `d` (flat, 3 per row) about `normal` (flat, 3 per row); NaN rows on TIR.
#[pyfunction]
fn refract_v<'py>(
    py: Python<'py>,
    d: PyReadonlyArray1<'py, f64>,
    normal: PyReadonlyArray1<'py, f64>,
    eta_i: PyReadonlyArray1<'py, f64>,
    eta_t: PyReadonlyArray1<'py, f64>,
) -> PyResult<Arr<'py>> {
    let (d, n, ei, et) = (
        slice(&d, "d").py()?,
        slice(&normal, "normal").py()?,
        slice(&eta_i, "eta_i").py()?,
        slice(&eta_t, "eta_t").py()?,
    );
    same_len(&["d", "normal"], &[d.len(), n.len()]).py()?;
    same_len(&["rows of d", "eta_i", "eta_t"], &[d.len() / 3, ei.len(), et.len()]).py()?;
    check_all("eta_i", ei, positive, POSITIVE).py()?;
    check_all("eta_t", et, positive, POSITIVE).py()?;
    check_all("d", d, f64::is_finite, "finite").py()?;
    check_all("normal", n, f64::is_finite, "finite").py()?;
    let mut out = Vec::with_capacity(d.len());
    for k in 0..ei.len() {
        let dk = [d[3 * k], d[3 * k + 1], d[3 * k + 2]];
        let nk = [n[3 * k], n[3 * k + 1], n[3 * k + 2]];
        out.extend_from_slice(&optics::refract(dk, nk, ei[k], et[k]).unwrap_or([f64::NAN; 3]));
    }
    Ok(PyArray1::from_vec(py, out))
}

/// Mirror reflection of rows of `d` about `normal` (flat, 3 per row).
#[pyfunction]
fn reflect_v<'py>(
    py: Python<'py>,
    d: PyReadonlyArray1<'py, f64>,
    normal: PyReadonlyArray1<'py, f64>,
) -> PyResult<Arr<'py>> {
    let (d, n) = (slice(&d, "d").py()?, slice(&normal, "normal").py()?);
    same_len(&["d", "normal"], &[d.len(), n.len()]).py()?;
    let mut out = Vec::with_capacity(d.len());
    for k in 0..d.len() / 3 {
        out.extend_from_slice(&optics::reflect(
            [d[3 * k], d[3 * k + 1], d[3 * k + 2]],
            [n[3 * k], n[3 * k + 1], n[3 * k + 2]],
        ));
    }
    Ok(PyArray1::from_vec(py, out))
}

/// Diffuse Fresnel reflectance by quadrature for each eta (n_inside/n_outside).
#[pyfunction]
fn diffuse_fresnel_reflectance_v<'py>(
    py: Python<'py>,
    eta: PyReadonlyArray1<'py, f64>,
    internal: bool,
) -> PyResult<Arr<'py>> {
    let e = slice(&eta, "eta").py()?;
    let out: Vec<f64> =
        e.iter().map(|&x| optics::diffuse_fresnel_reflectance(x, internal)).collect::<Result<_>>().py()?;
    Ok(PyArray1::from_vec(py, out))
}

/// Egan–Hilgeman fit of the internal diffuse Fresnel reflectance.
#[pyfunction]
fn diffuse_fresnel_reflectance_fit_v<'py>(py: Python<'py>, eta: PyReadonlyArray1<'py, f64>) -> PyResult<Arr<'py>> {
    let e = slice(&eta, "eta").py()?;
    let out: Vec<f64> = e.iter().map(|&x| optics::diffuse_fresnel_reflectance_fit(x)).collect::<Result<_>>().py()?;
    Ok(PyArray1::from_vec(py, out))
}

/// i-th internal Fresnel moment ∫_0^1 R μ^i dμ for each eta.
#[pyfunction]
fn fresnel_moment_v<'py>(py: Python<'py>, eta: PyReadonlyArray1<'py, f64>, i: u32) -> PyResult<Arr<'py>> {
    let e = slice(&eta, "eta").py()?;
    let out: Vec<f64> = e.iter().map(|&x| optics::fresnel_moment(x, i)).collect::<Result<_>>().py()?;
    Ok(PyArray1::from_vec(py, out))
}

fn phase_from(lobes: &[(f64, f64)]) -> Result<Phase> {
    match lobes {
        [(_, g)] => Phase::hg(*g),
        _ => Phase::mixture(lobes),
    }
}

/// HG phase p(cos θ; g) (sr⁻¹) elementwise.
#[pyfunction]
fn hg_phase_v<'py>(
    py: Python<'py>,
    cos_theta: PyReadonlyArray1<'py, f64>,
    g: PyReadonlyArray1<'py, f64>,
) -> PyResult<Arr<'py>> {
    let (c, g) = (slice(&cos_theta, "cos_theta").py()?, slice(&g, "g").py()?);
    same_len(&["cos_theta", "g"], &[c.len(), g.len()]).py()?;
    check_all("cos_theta", c, cosine, COSINE).py()?;
    check_all("g", g, g_ok, G_RANGE).py()?;
    Ok(PyArray1::from_vec(py, c.iter().zip(g).map(|(&c, &g)| optics::hg_phase(c, g)).collect()))
}

/// HG sampling cos θ = sample_hg(u, g) elementwise.
#[pyfunction]
fn sample_hg_v<'py>(
    py: Python<'py>,
    u: PyReadonlyArray1<'py, f64>,
    g: PyReadonlyArray1<'py, f64>,
) -> PyResult<Arr<'py>> {
    let (u, g) = (slice(&u, "u").py()?, slice(&g, "g").py()?);
    same_len(&["u", "g"], &[u.len(), g.len()]).py()?;
    check_all("u", u, unit_interval, UNIT).py()?;
    check_all("g", g, g_ok, G_RANGE).py()?;
    Ok(PyArray1::from_vec(py, u.iter().zip(g).map(|(&u, &g)| optics::sample_hg(u, g)).collect()))
}

/// Mixture of HG lobes [(weight, g)]: evaluate p(cos θ).
#[pyfunction]
fn mixture_phase_v<'py>(
    py: Python<'py>,
    cos_theta: PyReadonlyArray1<'py, f64>,
    lobes: Vec<(f64, f64)>,
) -> PyResult<Arr<'py>> {
    let ph = phase_from(&lobes).py()?;
    let c = slice(&cos_theta, "cos_theta").py()?;
    check_all("cos_theta", c, cosine, COSINE).py()?;
    Ok(PyArray1::from_vec(py, c.iter().map(|&c| ph.eval(c)).collect()))
}

/// Mixture of HG lobes: sample cos θ from uniform numbers u.
#[pyfunction]
fn sample_mixture_v<'py>(py: Python<'py>, u: PyReadonlyArray1<'py, f64>, lobes: Vec<(f64, f64)>) -> PyResult<Arr<'py>> {
    let ph = phase_from(&lobes).py()?;
    let u = slice(&u, "u").py()?;
    check_all("u", u, unit_interval, UNIT).py()?;
    Ok(PyArray1::from_vec(py, u.iter().map(|&u| ph.sample(u.min(1.0 - f64::EPSILON))).collect()))
}

/// Beer–Lambert transmittance exp(−μt d) elementwise.
#[pyfunction]
fn beer_lambert_v<'py>(
    py: Python<'py>,
    mu_t: PyReadonlyArray1<'py, f64>,
    distance: PyReadonlyArray1<'py, f64>,
) -> PyResult<Arr<'py>> {
    let (m, d) = (slice(&mu_t, "mu_t").py()?, slice(&distance, "distance").py()?);
    same_len(&["mu_t", "distance"], &[m.len(), d.len()]).py()?;
    check_all("mu_t", m, |x| x.is_finite() && x >= 0.0, "a finite number >= 0").py()?;
    check_all("distance", d, |x| x >= 0.0, "a number >= 0 (inf allowed)").py()?;
    Ok(PyArray1::from_vec(py, m.iter().zip(d).map(|(&m, &d)| optics::beer_lambert(m, d)).collect()))
}

/// Free-path sampling s = −ln(1 − u)/σt elementwise.
#[pyfunction]
fn sample_free_path_v<'py>(
    py: Python<'py>,
    u: PyReadonlyArray1<'py, f64>,
    sigma_t: PyReadonlyArray1<'py, f64>,
) -> PyResult<Arr<'py>> {
    let (u, s) = (slice(&u, "u").py()?, slice(&sigma_t, "sigma_t").py()?);
    same_len(&["u", "sigma_t"], &[u.len(), s.len()]).py()?;
    check_all("u", u, unit_interval, UNIT).py()?;
    check_all("sigma_t", s, positive, POSITIVE).py()?;
    Ok(PyArray1::from_vec(py, u.iter().zip(s).map(|(&u, &s)| optics::sample_free_path(u, s)).collect()))
}

/// Cosine-weighted hemisphere directions (flat, 3 per row) from u1, u2.
#[pyfunction]
fn sample_cosine_hemisphere_v<'py>(
    py: Python<'py>,
    u1: PyReadonlyArray1<'py, f64>,
    u2: PyReadonlyArray1<'py, f64>,
) -> PyResult<Arr<'py>> {
    let (a, b) = (slice(&u1, "u1").py()?, slice(&u2, "u2").py()?);
    same_len(&["u1", "u2"], &[a.len(), b.len()]).py()?;
    check_all("u1", a, unit_interval, UNIT).py()?;
    check_all("u2", b, unit_interval, UNIT).py()?;
    let mut out = Vec::with_capacity(3 * a.len());
    for (&x, &y) in a.iter().zip(b) {
        out.extend_from_slice(&optics::sample_cosine_hemisphere(x, y));
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
fn chi2_pooled(
    observed: PyReadonlyArray1<'_, f64>,
    expected: PyReadonlyArray1<'_, f64>,
    min_expected: f64,
) -> PyResult<(f64, usize, f64, usize)> {
    let r = stats::chi2_pooled(slice(&observed, "observed").py()?, slice(&expected, "expected").py()?, min_expected)
        .py()?;
    Ok((r.statistic, r.dof, r.p_value, r.pooled_cells))
}

/// Edges on [−1, 1] refined geometrically towards both poles.
#[pyfunction]
fn graded_cos_edges<'py>(py: Python<'py>, n_end: usize, n_mid: usize, min_gap: f64) -> PyResult<Arr<'py>> {
    if !(min_gap.is_finite() && min_gap > 0.0) {
        return Err(Error::param("min_gap", min_gap, POSITIVE)).py();
    }
    Ok(PyArray1::from_vec(py, stats::graded_cos_edges(n_end, n_mid, min_gap)))
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
    m.add_function(wrap_pyfunction!(mixture_phase_v, m)?)?;
    m.add_function(wrap_pyfunction!(sample_mixture_v, m)?)?;
    m.add_function(wrap_pyfunction!(beer_lambert_v, m)?)?;
    m.add_function(wrap_pyfunction!(sample_free_path_v, m)?)?;
    m.add_function(wrap_pyfunction!(sample_cosine_hemisphere_v, m)?)?;
    m.add_function(wrap_pyfunction!(chi2_sf, m)?)?;
    m.add_function(wrap_pyfunction!(gamma_q, m)?)?;
    m.add_function(wrap_pyfunction!(sidak_alpha, m)?)?;
    m.add_function(wrap_pyfunction!(chi2_pooled, m)?)?;
    m.add_function(wrap_pyfunction!(graded_cos_edges, m)?)?;
    Ok(())
}
