//! Bindings of `subsurf_core::bssrdf`: a `Profile` class wrapping any core profile, the
//! `ProfileTable` and `SlabTable` classes, and the inverse functions. python/subsurf/bssrdf.py
//! shapes arrays and documents the API; everything is computed here, without the GIL.

use crate::errors::IntoPyResult;
use crate::medium::{stack_from_py, LayerTuple};
use crate::wait::{interrupted, interruptible};
use numpy::{PyArray1, PyReadonlyArray1};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::sync::Arc;
use subsurf_core::bssrdf::inverse::{self, Fit, SlabTable};
use subsurf_core::bssrdf::monte_carlo::{McSettings, MonteCarloProfile, RadialData};
use subsurf_core::bssrdf::normalized_diffusion::{NormalizedDiffusion, ShapeFit};
use subsurf_core::bssrdf::table::{build_point, default_albedos, ProfileTable, TableSettings};
use subsurf_core::bssrdf::{chandrasekhar, medium_profile, profile, Medium, Model, Query, RadialProfile};
use subsurf_core::Error;

type Arr<'py> = PyReadonlyArray1<'py, f64>;
type Out<'py> = Bound<'py, PyArray1<f64>>;
type StackTuple = (Vec<LayerTuple>, f64, f64);

fn slice<'a>(a: &'a Arr<'_>) -> PyResult<&'a [f64]> {
    a.as_slice().map_err(|e| pyo3::exceptions::PyValueError::new_err(e.to_string()))
}

fn model(name: &str) -> PyResult<Model> {
    Model::from_name("model", name).py()
}

fn stack(s: &StackTuple) -> PyResult<subsurf_core::medium::Stack> {
    stack_from_py(&s.0, s.1, s.2).py()
}

/// A radial profile of any model (see `subsurf.bssrdf.Profile`).
#[pyclass(name = "Profile", module = "subsurf._core", frozen)]
pub struct PyProfile {
    inner: Arc<dyn RadialProfile>,
    mc: Option<Arc<MonteCarloProfile>>,
    #[pyo3(get)]
    model: String,
}

impl PyProfile {
    pub(crate) fn new(inner: Arc<dyn RadialProfile>, model: &str) -> Self {
        PyProfile { inner, mc: None, model: model.to_string() }
    }
    /// `q` of `p` (this profile, or its single-scattering part) at every element of `x`,
    /// checked ([`Query`]: an argument out of its range is an error naming it).
    fn query<'py>(py: Python<'py>, p: &dyn RadialProfile, q: Query, x: Arr<'py>) -> PyResult<Out<'py>> {
        let xs = slice(&x)?;
        let v = py.detach(|| xs.iter().map(|&r| q.eval(p, r)).collect::<Result<Vec<f64>, Error>>()).py()?;
        Ok(PyArray1::from_vec(py, v))
    }
    fn map<'py>(&self, py: Python<'py>, x: Arr<'py>, q: Query) -> PyResult<Out<'py>> {
        Self::query(py, self.inner.as_ref(), q, x)
    }
}

#[pymethods]
impl PyProfile {
    fn rd<'py>(&self, py: Python<'py>, r: Arr<'py>) -> PyResult<Out<'py>> {
        self.map(py, r, Query::Rd)
    }
    fn pdf<'py>(&self, py: Python<'py>, r: Arr<'py>) -> PyResult<Out<'py>> {
        self.map(py, r, Query::Pdf)
    }
    fn cdf<'py>(&self, py: Python<'py>, r: Arr<'py>) -> PyResult<Out<'py>> {
        self.map(py, r, Query::Cdf)
    }
    fn sample_r<'py>(&self, py: Python<'py>, u: Arr<'py>) -> PyResult<Out<'py>> {
        self.map(py, u, Query::SampleR)
    }
    fn radius_for_fraction<'py>(&self, py: Python<'py>, q: Arr<'py>) -> PyResult<Out<'py>> {
        self.map(py, q, Query::RadiusForFraction)
    }
    fn total(&self) -> f64 {
        self.inner.total()
    }
    fn has_single(&self) -> bool {
        self.inner.single_scattering().is_some()
    }
    fn single_total(&self) -> f64 {
        self.inner.single_scattering().map_or(0.0, |s| s.total())
    }
    fn single_rd<'py>(&self, py: Python<'py>, r: Arr<'py>) -> PyResult<Out<'py>> {
        match self.inner.single_scattering() {
            Some(s) => Self::query(py, s, Query::Rd, r),
            None => Err(crate::errors::to_py(Error::Invalid(format!(
                "model {:?} has no separate single-scattering part",
                self.model
            )))),
        }
    }
    /// Monte Carlo profiles: the tallied data as a dict (None for other models).
    fn mc_data<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        let Some(mc) = &self.mc else { return Ok(None) };
        let d = data_to_py(py, mc.data())?;
        d.set_item("tail_start", mc.tail().0)?;
        d.set_item("tail_sigma", mc.tail().1)?;
        Ok(Some(d))
    }
}

pub(crate) fn data_to_py<'py>(py: Python<'py>, d: &RadialData) -> PyResult<Bound<'py, PyDict>> {
    let o = PyDict::new(py);
    for (k, v) in [
        ("edges", &d.edges),
        ("weight", &d.weight),
        ("stderr", &d.stderr),
        ("single", &d.single),
        ("single_stderr", &d.single_stderr),
    ] {
        o.set_item(k, PyArray1::from_vec(py, v.clone()))?;
    }
    o.set_item("total", d.total)?;
    o.set_item("total_stderr", d.total_stderr)?;
    o.set_item("photons", d.photons)?;
    Ok(o)
}

pub(crate) fn data_from_py(d: &Bound<'_, PyDict>) -> PyResult<RadialData> {
    macro_rules! get {
        ($k:literal) => {
            d.get_item($k)?
                .ok_or_else(|| crate::errors::to_py(Error::Invalid(format!("table point: missing {}", $k))))?
                .extract()?
        };
    }
    Ok(RadialData {
        edges: get!("edges"),
        weight: get!("weight"),
        stderr: get!("stderr"),
        single: get!("single"),
        single_stderr: get!("single_stderr"),
        total: get!("total"),
        total_stderr: get!("total_stderr"),
        photons: get!("photons"),
    })
}

/// A profile of a closed-form model for a homogeneous semi-infinite medium.
#[pyfunction]
fn bssrdf_medium_profile(
    py: Python<'_>,
    model_name: &str,
    sigma_a: f64,
    sigma_s: f64,
    g: f64,
    eta: f64,
) -> PyResult<PyProfile> {
    let m = model(model_name)?;
    let med = Medium::new(sigma_a, sigma_s, g, eta).py()?;
    let p = py.detach(|| medium_profile(m, &med)).py()?;
    Ok(PyProfile::new(Arc::from(p), model_name))
}

/// A profile of `model_name` for a stack (Monte Carlo settings used by "monte_carlo" only; its
/// run can be interrupted with Ctrl-C or by `progress(done, total)` raising KeyboardInterrupt).
#[pyfunction]
#[pyo3(signature = (model_name, stack_tuple, photons, seed, threads, per_decade, max_rel_err, r_min=None, r_max=None, progress=None))]
#[allow(clippy::too_many_arguments)]
fn bssrdf_stack_profile(
    py: Python<'_>,
    model_name: &str,
    stack_tuple: StackTuple,
    photons: u64,
    seed: u64,
    threads: Option<usize>,
    per_decade: usize,
    max_rel_err: f64,
    r_min: Option<f64>,
    r_max: Option<f64>,
    progress: Option<Py<PyAny>>,
) -> PyResult<PyProfile> {
    let m = model(model_name)?;
    let s = stack(&stack_tuple)?;
    let cfg = McSettings { photons, seed, threads, r_min, r_max, per_decade, max_rel_err };
    if matches!(m, Model::MonteCarlo | Model::Adaptive) {
        let (out, stop) = interruptible(py, progress.as_ref(), photons, move |c, d| {
            MonteCarloProfile::simulate_with(&s, &cfg, c, d)
        })?;
        if stop.is_some() {
            return Err(interrupted("the Monte Carlo profile"));
        }
        let p = Arc::new(out.py()?.0);
        return Ok(PyProfile { inner: p.clone(), mc: Some(p), model: model_name.into() });
    }
    let p = py.detach(|| profile(m, &s, &cfg)).py()?;
    Ok(PyProfile::new(Arc::from(p), model_name))
}

/// Christensen–Burley profile from a surface albedo, a length and the fit variant.
#[pyfunction]
fn bssrdf_normalized_diffusion(albedo: f64, mfp: f64, variant: &str) -> PyResult<PyProfile> {
    let p = NormalizedDiffusion::new(albedo, mfp, ShapeFit::from_name(variant).py()?).py()?;
    Ok(PyProfile::new(Arc::new(p), "normalized_diffusion"))
}

/// Names of the models.
#[pyfunction]
fn bssrdf_models() -> Vec<&'static str> {
    Model::ALL.iter().map(|m| m.name()).collect()
}

/// Check a homogeneous medium (σa, σs in mm⁻¹, g, η) as every profile model takes it.
#[pyfunction]
fn bssrdf_check_medium(sigma_a: f64, sigma_s: f64, g: f64, eta: f64) -> PyResult<()> {
    Medium::new(sigma_a, sigma_s, g, eta).py().map(|_| ())
}

/// The Monte Carlo profile's defaults (`McSettings::default()`) a user can give.
fn mc_defaults(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    let McSettings { photons, seed, threads: _, r_min, r_max, per_decade, max_rel_err } = McSettings::default();
    let d = PyDict::new(py);
    d.set_item("photons", photons)?;
    d.set_item("seed", seed)?;
    d.set_item("per_decade", per_decade)?;
    d.set_item("max_rel_err", max_rel_err)?;
    d.set_item("r_min", r_min)?;
    d.set_item("r_max", r_max)?;
    Ok(d)
}

/// 1 − H(1)√(1 − a): exact reflectance of a semi-infinite index-matched isotropic medium.
#[pyfunction]
fn bssrdf_chandrasekhar_reflectance(a: f64) -> PyResult<f64> {
    chandrasekhar::semi_infinite_reflectance(a).py()
}

fn settings_from_py(d: &Bound<'_, PyDict>) -> PyResult<TableSettings> {
    macro_rules! get {
        ($k:literal) => {
            d.get_item($k)?
                .ok_or_else(|| crate::errors::to_py(Error::Invalid(format!("table settings: missing {}", $k))))?
                .extract()?
        };
    }
    let s = TableSettings {
        g: get!("g"),
        eta: get!("eta"),
        albedos: get!("albedos"),
        photons: get!("photons"),
        seed: get!("seed"),
        r_min: get!("r_min"),
        r_max: get!("r_max"),
        per_decade: get!("per_decade"),
        max_rel_err: get!("max_rel_err"),
        threads: get!("threads"),
    };
    s.validate().py()?;
    Ok(s)
}

/// Default table settings as a dict (`n_albedos` albedos).
#[pyfunction]
fn bssrdf_table_defaults<'py>(py: Python<'py>, g: f64, eta: f64, n_albedos: usize) -> PyResult<Bound<'py, PyDict>> {
    let s = TableSettings { albedos: default_albedos(n_albedos), ..TableSettings::new(g, eta) };
    let d = PyDict::new(py);
    d.set_item("g", s.g)?;
    d.set_item("eta", s.eta)?;
    d.set_item("albedos", s.albedos)?;
    d.set_item("photons", s.photons)?;
    d.set_item("seed", s.seed)?;
    d.set_item("r_min", s.r_min)?;
    d.set_item("r_max", s.r_max)?;
    d.set_item("per_decade", s.per_decade)?;
    d.set_item("max_rel_err", s.max_rel_err)?;
    d.set_item("threads", s.threads)?;
    Ok(d)
}

/// Trace albedo point `index` of a table (interruptible); returns its data dict.
#[pyfunction]
#[pyo3(signature = (settings, index, progress=None))]
fn bssrdf_table_point<'py>(
    py: Python<'py>,
    settings: Bound<'py, PyDict>,
    index: usize,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let s = settings_from_py(&settings)?;
    let total = s.photons;
    let (out, stop) = interruptible(py, progress.as_ref(), total, move |c, d| build_point(&s, index, c, d))?;
    if stop.is_some() {
        return Err(interrupted(&format!("table point {index}")));
    }
    data_to_py(py, &out.py()?)
}

/// Monte Carlo profile table (see `subsurf.bssrdf.ProfileTable`).
#[pyclass(name = "ProfileTable", module = "subsurf._core", frozen)]
pub struct PyProfileTable {
    inner: Arc<ProfileTable>,
}

#[pymethods]
impl PyProfileTable {
    /// Assemble from settings and one data dict per albedo.
    #[staticmethod]
    fn assemble(settings: Bound<'_, PyDict>, points: Vec<Bound<'_, PyDict>>) -> PyResult<Self> {
        let s = settings_from_py(&settings)?;
        let pts = points.iter().map(data_from_py).collect::<PyResult<Vec<_>>>()?;
        Ok(PyProfileTable { inner: Arc::new(ProfileTable::assemble(s, pts).py()?) })
    }
    fn rho_eff<'py>(&self, py: Python<'py>, albedo: Arr<'py>) -> PyResult<Out<'py>> {
        let v =
            slice(&albedo)?.iter().map(|&a| self.inner.rho_eff(a)).collect::<subsurf_core::Result<Vec<_>>>().py()?;
        Ok(PyArray1::from_vec(py, v))
    }
    fn albedo_for<'py>(&self, py: Python<'py>, rho: Arr<'py>) -> PyResult<Out<'py>> {
        let v = slice(&rho)?
            .iter()
            .map(|&r| self.inner.albedo_for(r, "rho_eff"))
            .collect::<subsurf_core::Result<Vec<_>>>()
            .py()?;
        Ok(PyArray1::from_vec(py, v))
    }
    fn profile(&self, sigma_a: f64, sigma_s: f64) -> PyResult<PyProfile> {
        Ok(PyProfile::new(Arc::new(self.inner.profile(sigma_a, sigma_s).py()?), "monte_carlo"))
    }
    fn node_totals(&self) -> Vec<f64> {
        self.inner.nodes().iter().map(|p| p.total()).collect()
    }
    fn points<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        self.inner.nodes().iter().map(|p| data_to_py(py, p.data())).collect()
    }
}

fn fit_to_py<'py>(py: Python<'py>, f: Fit) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("stderr", f.stderr())?;
    d.set_item("params", f.params)?;
    d.set_item("cov", f.cov)?;
    d.set_item("chi2", f.chi2)?;
    d.set_item("dof", f.dof)?;
    d.set_item("iterations", f.iterations)?;
    Ok(d)
}

/// One semi-infinite layer per channel from a reflectance and a mean free path per channel:
/// (n, mua, mus, g) tuples ([`inverse::material_from_reflectance`]).
#[pyfunction]
#[pyo3(signature = (reflectance, mfp, eta, g, model_name, power, mfp_kind, table=None))]
#[allow(clippy::too_many_arguments)]
fn bssrdf_material_from_reflectance(
    py: Python<'_>,
    reflectance: Vec<f64>,
    mfp: Vec<f64>,
    eta: f64,
    g: f64,
    model_name: &str,
    power: &str,
    mfp_kind: &str,
    table: Option<&PyProfileTable>,
) -> PyResult<Vec<(f64, f64, f64, f64)>> {
    let m = model(model_name)?;
    let conv = inverse::Conventions {
        power: inverse::Power::from_name(power).py()?,
        mfp_kind: inverse::MeanFreePath::from_name(mfp_kind).py()?,
    };
    let t = table.map(|t| t.inner.clone());
    let layers =
        py.detach(|| inverse::material_from_reflectance(&reflectance, &mfp, eta, g, m, conv, t.as_deref())).py()?;
    Ok(layers.iter().map(|l| (l.n, l.mua, l.mus, l.g())).collect())
}

/// Fit (σa, σs') of a semi-infinite medium to R_d(r) data.
#[pyfunction]
#[pyo3(signature = (model_name, r, rd, sigma, g, eta, initial, table=None))]
#[allow(clippy::too_many_arguments)]
fn bssrdf_fit_profile<'py>(
    py: Python<'py>,
    model_name: &str,
    r: Vec<f64>,
    rd: Vec<f64>,
    sigma: Vec<f64>,
    g: f64,
    eta: f64,
    initial: [f64; 2],
    table: Option<&PyProfileTable>,
) -> PyResult<Bound<'py, PyDict>> {
    let m = model(model_name)?;
    let t = table.map(|t| t.inner.clone());
    let f = py.detach(|| inverse::fit_profile(m, &r, &rd, &sigma, g, eta, initial, t.as_deref())).py()?;
    fit_to_py(py, f)
}

/// Fit (μa, μs') of one layer of a stack to R_d(r) data with the layered multipole.
#[pyfunction]
fn bssrdf_fit_profile_layer<'py>(
    py: Python<'py>,
    stack_tuple: StackTuple,
    layer: usize,
    r: Vec<f64>,
    rd: Vec<f64>,
    sigma: Vec<f64>,
    initial: [f64; 2],
) -> PyResult<Bound<'py, PyDict>> {
    let s = stack(&stack_tuple)?;
    let f = py.detach(|| inverse::fit::fit_profile_layer(&s, layer, &r, &rd, &sigma, initial)).py()?;
    fit_to_py(py, f)
}

/// Monte Carlo slab totals on an (albedo, optical thickness) grid.
#[pyclass(name = "SlabTable", module = "subsurf._core", frozen)]
pub struct PySlabTable {
    inner: Arc<SlabTable>,
}

#[pymethods]
impl PySlabTable {
    /// A table from its grid and one (rd, rd_stderr, tt, tt_stderr) per point, row-major.
    #[staticmethod]
    #[allow(clippy::too_many_arguments)]
    fn from_totals(
        g: f64,
        n: f64,
        n_above: f64,
        n_below: f64,
        albedos: Vec<f64>,
        taus: Vec<f64>,
        totals: Vec<[f64; 4]>,
    ) -> PyResult<Self> {
        let t = SlabTable::from_totals(g, n, n_above, n_below, albedos, taus, &totals).py()?;
        Ok(PySlabTable { inner: Arc::new(t) })
    }
    fn totals(&self, albedo: f64, tau: f64) -> PyResult<(f64, f64)> {
        self.inner.totals(albedo, tau).py()
    }
}

/// One point of a slab table: (rd, rd_stderr, tt, tt_stderr) of the slab of albedo `a` and
/// optical thickness `tau` (interruptible).
#[pyfunction]
#[pyo3(signature = (g, n, n_above, n_below, a, tau, photons, seed, threads=None, progress=None))]
#[allow(clippy::too_many_arguments)]
fn bssrdf_slab_point(
    py: Python<'_>,
    g: f64,
    n: f64,
    n_above: f64,
    n_below: f64,
    a: f64,
    tau: f64,
    photons: u64,
    seed: u64,
    threads: Option<usize>,
    progress: Option<Py<PyAny>>,
) -> PyResult<[f64; 4]> {
    let (out, stop) = interruptible(py, progress.as_ref(), photons, move |c, d| {
        SlabTable::point(g, n, n_above, n_below, a, tau, photons, seed, threads, c, d)
    })?;
    match out.py()? {
        Some(p) if stop.is_none() => Ok(p),
        _ => Err(interrupted(&format!("slab point (albedo {a}, tau {tau})"))),
    }
}

/// Fit (μa, μs') of a slab to its total Rd and Tt.
#[pyfunction]
#[pyo3(signature = (rd, tt, sigma, thickness, g, n, n_above, n_below, model_name, initial, table=None))]
#[allow(clippy::too_many_arguments)]
fn bssrdf_fit_slab_totals<'py>(
    py: Python<'py>,
    rd: f64,
    tt: f64,
    sigma: [f64; 2],
    thickness: f64,
    g: f64,
    n: f64,
    n_above: f64,
    n_below: f64,
    model_name: &str,
    initial: [f64; 2],
    table: Option<&PySlabTable>,
) -> PyResult<Bound<'py, PyDict>> {
    let m = model(model_name)?;
    let t = table.map(|t| t.inner.clone());
    let f = py
        .detach(|| inverse::fit_slab_totals(rd, tt, sigma, thickness, g, n, n_above, n_below, m, t.as_deref(), initial))
        .py()?;
    fit_to_py(py, f)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyProfile>()?;
    m.add_class::<PyProfileTable>()?;
    m.add_class::<PySlabTable>()?;
    m.add_function(wrap_pyfunction!(bssrdf_medium_profile, m)?)?;
    m.add_function(wrap_pyfunction!(bssrdf_stack_profile, m)?)?;
    m.add_function(wrap_pyfunction!(bssrdf_normalized_diffusion, m)?)?;
    m.add_function(wrap_pyfunction!(bssrdf_models, m)?)?;
    m.add_function(wrap_pyfunction!(bssrdf_check_medium, m)?)?;
    m.add("BSSRDF_MODELS", Model::NAMES.to_vec())?;
    m.add("BSSRDF_MC_DEFAULTS", mc_defaults(m.py())?)?;
    m.add_function(wrap_pyfunction!(bssrdf_chandrasekhar_reflectance, m)?)?;
    m.add_function(wrap_pyfunction!(bssrdf_table_defaults, m)?)?;
    m.add_function(wrap_pyfunction!(bssrdf_table_point, m)?)?;
    m.add_function(wrap_pyfunction!(bssrdf_slab_point, m)?)?;
    m.add_function(wrap_pyfunction!(bssrdf_material_from_reflectance, m)?)?;
    m.add("BSSRDF_POWERS", inverse::Power::NAMES)?;
    m.add("BSSRDF_MFP_KINDS", inverse::MeanFreePath::NAMES)?;
    m.add_function(wrap_pyfunction!(bssrdf_fit_profile, m)?)?;
    m.add_function(wrap_pyfunction!(bssrdf_fit_profile_layer, m)?)?;
    m.add_function(wrap_pyfunction!(bssrdf_fit_slab_totals, m)?)?;
    Ok(())
}
