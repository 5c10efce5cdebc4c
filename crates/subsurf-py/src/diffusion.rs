//! Bindings of `subsurf_core::diffusion`. Every function takes flat, equally long float64
//! arrays (python/subsurf/diffusion.py broadcasts and reshapes; points and directions hold 3
//! values per element) and returns flat arrays; an invalid element raises ParameterError
//! naming the field and its flat index (the core's [`Error::at`]).

use crate::errors::IntoPyResult;
use numpy::{PyArray1, PyReadonlyArray1};
use pyo3::prelude::*;
use subsurf_core::diffusion::{self as dif, better_dipole, Model};
use subsurf_core::{Error, Result};

type In<'py> = PyReadonlyArray1<'py, f64>;
type Out<'py> = Bound<'py, PyArray1<f64>>;

fn slice<'a>(a: &'a In<'_>) -> PyResult<&'a [f64]> {
    a.as_slice().map_err(|_| Error::Invalid("diffusion: expected contiguous float64 arrays".into())).py()
}

/// Row `i` of a column holding `w` values per element.
fn row(c: &[f64], w: usize, i: usize) -> &[f64] {
    &c[w * i..w * i + w]
}

/// Apply `f` to the rows of equally long columns (`(array, values per element)`), without the
/// GIL; `K` outputs per element.
fn map_rows<'py, const K: usize>(
    py: Python<'py>,
    cols: &[(&In<'py>, usize)],
    f: impl Fn(&[&[f64]]) -> Result<[f64; K]> + Send + Sync,
) -> PyResult<Vec<Out<'py>>> {
    let data: Vec<(&[f64], usize)> = cols.iter().map(|&(a, w)| Ok((slice(a)?, w))).collect::<PyResult<_>>()?;
    let n = data.first().map_or(0, |(c, w)| c.len() / w);
    if data.iter().any(|(c, w)| c.len() != n * w) {
        return Err(Error::Invalid("diffusion: input arrays must have equal lengths".into())).py();
    }
    let out: Result<Vec<[f64; K]>> = py.detach(|| {
        (0..n)
            .map(|i| {
                let rows: Vec<&[f64]> = data.iter().map(|&(c, w)| row(c, w, i)).collect();
                f(&rows).map_err(|e| if n > 1 { e.at(&[i]) } else { e })
            })
            .collect()
    });
    let out = out.py()?;
    Ok((0..K).map(|k| PyArray1::from_vec(py, out.iter().map(|r| r[k]).collect())).collect())
}

/// [`map_rows`] with one output.
fn map1<'py>(
    py: Python<'py>,
    cols: &[(&In<'py>, usize)],
    f: impl Fn(&[&[f64]]) -> Result<f64> + Send + Sync,
) -> PyResult<Out<'py>> {
    Ok(map_rows::<1>(py, cols, |r| f(r).map(|x| [x]))?.remove(0))
}

fn v3(r: &[f64]) -> [f64; 3] {
    [r[0], r[1], r[2]]
}

fn model(name: &str) -> PyResult<Model> {
    Model::from_name(name).py()
}

/// F_dr(η), Jensen's (Egan–Hilgeman) fit; η validated.
#[pyfunction]
fn diffusion_fdr<'py>(py: Python<'py>, eta: In<'py>) -> PyResult<Out<'py>> {
    map1(py, &[(&eta, 1)], |x| Ok(dif::fdr(dif::check_eta(x[0][0])?)))
}

/// Boundary coefficient A(η) of the model.
#[pyfunction]
fn diffusion_a<'py>(py: Python<'py>, model_name: &str, eta: In<'py>) -> PyResult<Out<'py>> {
    let m = model(model_name)?;
    map1(py, &[(&eta, 1)], |x| {
        let e = dif::check_eta(x[0][0])?;
        Ok(match m {
            Model::Dipole => dif::a_coefficient(e),
            Model::BetterDipole => better_dipole::better_a(e),
        })
    })
}

/// d'Eon's Fresnel moments (C1, C2).
#[pyfunction]
fn diffusion_fresnel_moments<'py>(py: Python<'py>, eta: In<'py>) -> PyResult<(Out<'py>, Out<'py>)> {
    let mut v = map_rows::<2>(py, &[(&eta, 1)], |x| {
        let e = dif::check_eta(x[0][0])?;
        Ok([dif::fresnel_moment1(e), dif::fresnel_moment2(e)])
    })?;
    let c2 = v.pop().expect("two outputs");
    Ok((v.pop().expect("two outputs"), c2))
}

/// The model's constants per element: (alpha_prime, D, sigma_tr, A, z_r, z_v).
#[pyfunction]
fn diffusion_params<'py>(
    py: Python<'py>,
    model_name: &str,
    sigma_a: In<'py>,
    sigma_s_prime: In<'py>,
    eta: In<'py>,
) -> PyResult<Vec<Out<'py>>> {
    let m = model(model_name)?;
    map_rows::<6>(py, &[(&sigma_a, 1), (&sigma_s_prime, 1), (&eta, 1)], |x| {
        let (sa, ssp, e) = (x[0][0], x[1][0], x[2][0]);
        Ok(match m {
            Model::Dipole => {
                let d = dif::Dipole::new(sa, ssp, e)?;
                [d.alpha_prime, d.d, d.sigma_tr, d.a, d.z_r, d.z_v]
            }
            Model::BetterDipole => {
                let d = dif::BetterDipole::new(sa, ssp, e)?;
                [d.alpha_prime, d.d, d.sigma_tr, d.a, d.z_r, d.z_v]
            }
        })
    })
}

/// Bindings `name(model_name, a, b, …) -> array` of a model's function of per-element columns
/// (`arg: values per element`): one line each.
macro_rules! by_model {
    ($($(#[$doc:meta])* $name:ident($($arg:ident: $w:literal),+) => |$m:ident, $x:ident| $body:expr;)+) => {$(
        $(#[$doc])*
        #[pyfunction]
        #[allow(clippy::too_many_arguments)]
        fn $name<'py>(py: Python<'py>, model_name: &str, $($arg: In<'py>),+) -> PyResult<Out<'py>> {
            let $m = model(model_name)?;
            map1(py, &[$((&$arg, $w)),+], |$x| $body)
        }
    )+};
}

by_model! {
    /// R_d(r) in mm⁻².
    diffusion_rd(r: 1, sigma_a: 1, sigma_s_prime: 1, eta: 1) => |m, x| m.rd(x[0][0], x[1][0], x[2][0], x[3][0]);
    /// Total diffuse reflectance from (alpha_prime, eta), closed form.
    diffusion_total_rd(alpha_prime: 1, eta: 1) => |m, x| m.total_rd(x[0][0], x[1][0]);
    /// alpha_prime from a total diffuse reflectance.
    diffusion_alpha_prime_from_rd(rd: 1, eta: 1) => |m, x| dif::alpha_prime_from_rd(x[0][0], x[1][0], m);
    /// S_d(xi, wi, xo, wo) in mm⁻² sr⁻¹; points and directions flat (3n), properties n.
    diffusion_sd(xi: 3, wi: 3, xo: 3, wo: 3, sigma_a: 1, sigma_s_prime: 1, eta: 1) => |m, x| {
        dif::sd(v3(x[0]), v3(x[1]), v3(x[2]), v3(x[3]), m, x[4][0], x[5][0], x[6][0])
    };
    /// The diffusion BRDF (1/π) F_t(wi) R_d,total F_t(wo), sr⁻¹.
    diffusion_brdf(wi: 3, wo: 3, sigma_a: 1, sigma_s_prime: 1, eta: 1) => |m, x| {
        dif::diffusion_brdf(v3(x[0]), v3(x[1]), m, x[2][0], x[3][0], x[4][0])
    };
}

/// F_t(η, cos θ) = 1 − F_r(1 → η) (0 for cos θ ≤ 0); η validated, |cos θ| ≤ 1.
#[pyfunction]
fn diffusion_ft<'py>(py: Python<'py>, eta: In<'py>, cos_theta: In<'py>) -> PyResult<Out<'py>> {
    map1(py, &[(&eta, 1), (&cos_theta, 1)], |x| dif::bssrdf::ft_checked(x[0][0], x[1][0]))
}

/// Validate optical properties (sigma_a, sigma_s_prime ≥ 0, their sum > 0, eta ∈ [1, 2.5]).
#[pyfunction]
fn diffusion_check_properties<'py>(
    py: Python<'py>,
    sigma_a: In<'py>,
    sigma_s_prime: In<'py>,
    eta: In<'py>,
) -> PyResult<()> {
    map1(py, &[(&sigma_a, 1), (&sigma_s_prime, 1), (&eta, 1)], |x| dif::check_properties(x[0][0], x[1][0], x[2][0]))
        .map(|_| ())
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(diffusion_fdr, m)?)?;
    m.add_function(wrap_pyfunction!(diffusion_a, m)?)?;
    m.add_function(wrap_pyfunction!(diffusion_fresnel_moments, m)?)?;
    m.add_function(wrap_pyfunction!(diffusion_params, m)?)?;
    m.add_function(wrap_pyfunction!(diffusion_rd, m)?)?;
    m.add_function(wrap_pyfunction!(diffusion_total_rd, m)?)?;
    m.add_function(wrap_pyfunction!(diffusion_alpha_prime_from_rd, m)?)?;
    m.add_function(wrap_pyfunction!(diffusion_sd, m)?)?;
    m.add_function(wrap_pyfunction!(diffusion_brdf, m)?)?;
    m.add_function(wrap_pyfunction!(diffusion_check_properties, m)?)?;
    m.add_function(wrap_pyfunction!(diffusion_ft, m)?)?;
    Ok(())
}
