//! Bindings of `subsurf_core::bssrdf::adaptive`: the `AdaptiveTable` class (built here without
//! the GIL and interruptibly, or assembled from the nodes python/subsurf/bssrdf.py read from its
//! HDF5 cache) and its queries.

use crate::bssrdf::{data_from_py, data_to_py, PyProfile};
use crate::errors::{to_py, IntoPyResult};
use crate::medium::{stack_from_py, LayerTuple};
use crate::wait::{interrupted, interruptible};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::sync::atomic::{AtomicBool, AtomicU64};
use std::sync::Arc;
use subsurf_core::bssrdf::adaptive::{thickness_nodes, AdaptiveSettings, AdaptiveTable, SlabData};
use subsurf_core::bssrdf::curvature::{curvature_nodes, CurvatureData};
use subsurf_core::bssrdf::curved::{escape_from, sun_exitance, Curved, Escape};
use subsurf_core::bssrdf::exit::ExitBins;
use subsurf_core::bssrdf::oblique::OBLIQUE_THETA_DEG;
use subsurf_core::mc::Source;
use subsurf_core::medium::Stack;
use subsurf_core::Error;

type StackTuple = (Vec<LayerTuple>, f64, f64);

fn stacks(s: &[StackTuple]) -> PyResult<Vec<Stack>> {
    s.iter()
        .enumerate()
        .map(|(k, t)| stack_from_py(&t.0, t.1, t.2).map_err(|e| e.within(&format!("stacks[{k}]."))).py())
        .collect()
}

/// The adaptive model's finite-slab tables (see `subsurf.bssrdf.AdaptiveTable`).
#[pyclass(name = "AdaptiveTable", module = "subsurf._core", frozen)]
pub struct PyAdaptiveTable {
    pub inner: Arc<AdaptiveTable>,
}

fn item<'py>(n: &Bound<'py, PyDict>, k: &str) -> PyResult<Bound<'py, PyAny>> {
    n.get_item(k)?.ok_or_else(|| to_py(Error::Invalid(format!("adaptive table node: missing {k}"))))
}

#[pymethods]
impl PyAdaptiveTable {
    /// Trace every node (interruptible; `progress(done, total)` counts photons).
    #[staticmethod]
    #[pyo3(signature = (stacks_in, photons, seed, threads=None, max_rel_err=0.2, progress=None))]
    fn build(
        py: Python<'_>,
        stacks_in: Vec<StackTuple>,
        photons: u64,
        seed: u64,
        threads: Option<usize>,
        max_rel_err: f64,
        progress: Option<Py<PyAny>>,
    ) -> PyResult<Self> {
        let st = stacks(&stacks_in)?;
        let s = AdaptiveSettings { photons, seed, threads, max_rel_err };
        let total = AdaptiveTable::photons(&st, &s);
        let (out, stop) = interruptible(py, progress.as_ref(), total, move |c, d| AdaptiveTable::build(&st, &s, c, d))?;
        match (stop, out.py()?) {
            (None, Some(t)) => Ok(PyAdaptiveTable { inner: Arc::new(t) }),
            _ => Err(interrupted("the adaptive table")),
        }
    }

    /// Assemble from the stacks, one list of node dicts per channel ({d, top, bottom}), one
    /// curvature dict per channel (as `curvature()` gives them) and the settings it was built with.
    #[staticmethod]
    fn assemble(
        stacks_in: Vec<StackTuple>,
        nodes: Vec<Vec<Bound<'_, PyDict>>>,
        curvature: Vec<Bound<'_, PyDict>>,
        photons: u64,
        seed: u64,
        max_rel_err: f64,
    ) -> PyResult<Self> {
        let st = stacks(&stacks_in)?;
        let mut data = vec![];
        for ch in &nodes {
            let mut v = vec![];
            for n in ch {
                let top = data_from_py(item(n, "top")?.cast::<PyDict>()?)?;
                let bottom = data_from_py(item(n, "bottom")?.cast::<PyDict>()?)?;
                v.push(SlabData { d: item(n, "d")?.extract()?, top, bottom });
            }
            data.push(v);
        }
        let curv = curvature.iter().map(curvature_from_py).collect::<PyResult<Vec<_>>>()?;
        let s = AdaptiveSettings { photons, seed, threads: None, max_rel_err };
        Ok(PyAdaptiveTable { inner: Arc::new(AdaptiveTable::assemble(&st, data, curv, s).py()?) })
    }

    /// Per channel: {rho, sphere, sphere_stderr, sphere_near, sphere_near_stderr, the same for
    /// cavity and cylinder, sphere_bins, cylinder_bins, flat, flat_stderr, oblique_theta (deg),
    /// oblique, oblique_stderr (the flat pencil runs of the oblique gain), harmonic_near,
    /// harmonic_far (the sphere's ⟨cos φ⟩ under pencil beams, per ρ node × oblique angle), exit,
    /// exit_stderr (the flat exit-angle histogram under diffuse light), exit_beta (its fitted slope),
    /// coupling, coupling_stderr (the flat pencil runs' exit weight and cos Δφ moment per exit-cosine
    /// bin, per oblique angle), coupling_a, coupling_a_stderr (the kept amplitude A, pooled over
    /// the angles), coupling_a_theta, coupling_a_theta_stderr, coupling_chi2 (the fit per angle;
    /// `bssrdf::coupling`), flow, flow_stderr (the flat diffuse run's exit weight and cos Δφ moment
    /// about the direction from the entry point per distance bin and exit-cosine bin), flow_b,
    /// flow_b_stderr (its B per distance bin; `bssrdf::flow`), scale_convex,
    /// scale_convex_far, scale_cylinder, scale_cylinder_far, scale_concave} (lists over the
    /// curvature nodes; `scale_*`, `exit_beta`, `coupling_a*`/`coupling_chi2` and `flow_b*` derived, not read back).
    fn curvature<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        let mut out = vec![];
        for (c, cd) in self.inner.curvature().iter().enumerate() {
            let o = PyDict::new(py);
            o.set_item("rho", cd.rho.clone())?;
            for (k, v) in [("sphere", &cd.sphere), ("cavity", &cd.cavity), ("cylinder", &cd.cylinder)] {
                o.set_item(k, v.iter().map(|e| e.mean).collect::<Vec<_>>())?;
                o.set_item(format!("{k}_stderr"), v.iter().map(|e| e.stderr).collect::<Vec<_>>())?;
                o.set_item(format!("{k}_near"), v.iter().map(|e| e.near).collect::<Vec<_>>())?;
                o.set_item(format!("{k}_near_stderr"), v.iter().map(|e| e.near_stderr).collect::<Vec<_>>())?;
            }
            o.set_item("sphere_bins", cd.sphere.iter().map(|e| e.bins.clone()).collect::<Vec<_>>())?;
            o.set_item("cylinder_bins", cd.cylinder.iter().map(|e| e.bins.clone()).collect::<Vec<_>>())?;
            o.set_item("flat", cd.flat.mean)?;
            o.set_item("flat_stderr", cd.flat.stderr)?;
            o.set_item("oblique_theta", OBLIQUE_THETA_DEG.to_vec())?;
            o.set_item("oblique", cd.oblique.iter().map(|e| e.mean).collect::<Vec<_>>())?;
            o.set_item("oblique_stderr", cd.oblique.iter().map(|e| e.stderr).collect::<Vec<_>>())?;
            for (k, i) in [("harmonic_near", 0), ("harmonic_far", 1)] {
                o.set_item(k, cd.harmonic.iter().map(|r| r.iter().map(|a| a[i]).collect()).collect::<Vec<Vec<f64>>>())?;
            }
            o.set_item("exit", cd.exit.weight.clone())?;
            o.set_item("exit_stderr", cd.exit.stderr.clone())?;
            o.set_item("exit_beta", self.inner.exit(c).beta)?;
            o.set_item("coupling", cd.coupling.iter().map(|b| b.weight.clone()).collect::<Vec<_>>())?;
            o.set_item("coupling_stderr", cd.coupling.iter().map(|b| b.stderr.clone()).collect::<Vec<_>>())?;
            let cp = self.inner.coupling(c);
            o.set_item("coupling_a", cp.a)?;
            o.set_item("coupling_a_stderr", cp.stderr)?;
            o.set_item("coupling_a_theta", cp.fits.iter().map(|f| f.a).collect::<Vec<_>>())?;
            o.set_item("coupling_a_theta_stderr", cp.fits.iter().map(|f| f.stderr).collect::<Vec<_>>())?;
            o.set_item("coupling_chi2", cp.fits.iter().map(|f| f.chi2).collect::<Vec<_>>())?;
            o.set_item("flow", cd.flow.weight.clone())?;
            o.set_item("flow_stderr", cd.flow.stderr.clone())?;
            o.set_item("flow_b", self.inner.flow(c).b.clone())?;
            o.set_item("flow_b_stderr", self.inner.flow(c).stderr.clone())?;
            o.set_item("scale_convex", self.inner.scales(c).convex.iter().map(|a| a.to_vec()).collect::<Vec<_>>())?;
            o.set_item("scale_convex_far", self.inner.scales(c).convex_far.clone())?;
            o.set_item("scale_cylinder", self.inner.scales(c).cylinder.iter().map(|a| a.to_vec()).collect::<Vec<_>>())?;
            o.set_item("scale_cylinder_far", self.inner.scales(c).cylinder_far.clone())?;
            o.set_item("scale_concave", self.inner.scales(c).concave.clone())?;
            out.push(o);
        }
        Ok(out)
    }

    /// The oblique-incidence gain g(μ) = R(θi)/R(0) of `channel` at μ = cos θi in [0, 1].
    fn oblique_gain(&self, channel: usize, mu: f64) -> PyResult<f64> {
        self.check(channel, 1.0)?;
        if !(0.0..=1.0).contains(&mu) {
            return Err(to_py(Error::param("mu", mu, "a cosine in [0, 1]")));
        }
        Ok(self.inner.oblique_gain(channel, mu))
    }

    /// The exit term's factor s(μ_o) of `channel` on the flat surface's F_t(η, μ_o)/(π c), at the
    /// exterior exit cosine μ_o in [0, 1] (`subsurf_core::bssrdf::exit`).
    fn exit_factor(&self, channel: usize, mu: f64) -> PyResult<f64> {
        self.check(channel, 1.0)?;
        if !(0.0..=1.0).contains(&mu) {
            return Err(to_py(Error::param("mu", mu, "a cosine in [0, 1]")));
        }
        Ok(self.inner.exit(channel).factor(mu))
    }

    /// The curvature scales (near side per chord bin, far side) of `channel` at mean curvature
    /// `h` (mm⁻¹; > 0 convex, < 0 concave).
    fn curvature_scale(&self, channel: usize, h: f64) -> PyResult<(Vec<f64>, f64)> {
        self.check(channel, 1.0)?;
        if !h.is_finite() {
            return Err(to_py(Error::param("h", h, "a finite mean curvature (mm^-1)")));
        }
        let s = self.inner.curvature_scale(channel, h);
        Ok((s.near.to_vec(), s.far))
    }

    /// The nodes: per channel, a list of {d, top, bottom} dicts.
    fn nodes<'py>(&self, py: Python<'py>) -> PyResult<Vec<Vec<Bound<'py, PyDict>>>> {
        self.inner
            .data()
            .iter()
            .map(|ch| {
                ch.iter()
                    .map(|n| {
                        let o = PyDict::new(py);
                        o.set_item("d", n.d)?;
                        o.set_item("top", data_to_py(py, &n.top)?)?;
                        o.set_item("bottom", data_to_py(py, &n.bottom)?)?;
                        Ok(o)
                    })
                    .collect()
            })
            .collect()
    }

    /// (R, T) totals per unit entering power of `channel` at thickness `d` (mm).
    fn totals(&self, channel: usize, d: f64) -> PyResult<(f64, f64)> {
        self.check(channel, d)?;
        Ok(self.inner.totals(channel, d))
    }

    /// The reflection (`which` = "R") or transmission ("T") profile of `channel` at thickness `d`.
    fn profile(&self, channel: usize, d: f64, which: &str) -> PyResult<PyProfile> {
        self.check(channel, d)?;
        let at = self.inner.local(channel, d);
        let p: Arc<dyn subsurf_core::bssrdf::RadialProfile> = match which {
            "R" => Arc::new(self.inner.reflection(channel, at)),
            "T" => Arc::new(self.inner.transmission(channel, at)),
            w => return Err(to_py(Error::Invalid(format!("which = {w:?}: must be \"R\" or \"T\"")))),
        };
        Ok(PyProfile::new(p, "adaptive"))
    }
}

impl PyAdaptiveTable {
    fn check(&self, channel: usize, d: f64) -> PyResult<()> {
        if channel >= self.inner.channels() {
            return Err(to_py(Error::param("channel", channel as f64, "a channel index of the table")));
        }
        if !(d > 0.0) {
            return Err(to_py(Error::param("d", d, "a thickness > 0 (mm) or inf")));
        }
        Ok(())
    }
}

fn curvature_from_py(d: &Bound<'_, PyDict>) -> PyResult<CurvatureData> {
    let list = |k: &str| -> PyResult<Vec<f64>> { item(d, k)?.extract() };
    let pairs = |k: &str| -> PyResult<Vec<Escape>> {
        let (m, e) = (list(k)?, list(&format!("{k}_stderr"))?);
        let (a, b) = (list(&format!("{k}_near"))?, list(&format!("{k}_near_stderr"))?);
        if [e.len(), a.len(), b.len()].iter().any(|&l| l != m.len()) {
            return Err(to_py(Error::Invalid(format!("adaptive table curvature: {k}'s lists differ in length"))));
        }
        Ok((0..m.len())
            .map(|i| Escape {
                mean: m[i],
                stderr: e[i],
                near: a[i],
                near_stderr: b[i],
                bins: vec![],
                shift: 0.0,
                harmonic: vec![],
            })
            .collect())
    };
    let (mean, stderr) = (item(d, "flat")?.extract()?, item(d, "flat_stderr")?.extract()?);
    let flat = Escape { mean, stderr, near: mean, near_stderr: stderr, bins: vec![], shift: 0.0, harmonic: vec![] };
    let binned = |k: &str| -> PyResult<Vec<Escape>> {
        let mut v = pairs(k)?;
        let bins: Vec<Vec<f64>> = item(d, &format!("{k}_bins"))?.extract()?;
        if bins.len() != v.len() {
            return Err(to_py(Error::Invalid(format!("adaptive table curvature: {k}_bins has another length"))));
        }
        for (e, b) in v.iter_mut().zip(bins) {
            e.bins = b;
        }
        Ok(v)
    };
    let (sphere, cylinder) = (binned("sphere")?, binned("cylinder")?);
    let (m, e) = (list("oblique")?, list("oblique_stderr")?);
    if e.len() != m.len() {
        return Err(to_py(Error::Invalid("adaptive table curvature: oblique_stderr has another length".into())));
    }
    let oblique = m.iter().zip(&e).map(|(&mean, &stderr)| Escape {
        mean,
        stderr,
        near: mean,
        near_stderr: stderr,
        bins: vec![],
        shift: 0.0,
        harmonic: vec![],
    });
    let oblique = oblique.collect();
    let (hn, hf): (Vec<Vec<f64>>, Vec<Vec<f64>>) =
        (item(d, "harmonic_near")?.extract()?, item(d, "harmonic_far")?.extract()?);
    if hn.len() != hf.len() || hn.iter().zip(&hf).any(|(a, b)| a.len() != b.len()) {
        return Err(to_py(Error::Invalid("adaptive table curvature: harmonic_near and harmonic_far differ".into())));
    }
    let harmonic = hn.iter().zip(&hf).map(|(a, b)| a.iter().zip(b).map(|(&x, &y)| [x, y]).collect()).collect();
    let exit = ExitBins { weight: list("exit")?, stderr: list("exit_stderr")? };
    let (cw, cs): (Vec<Vec<f64>>, Vec<Vec<f64>>) =
        (item(d, "coupling")?.extract()?, item(d, "coupling_stderr")?.extract()?);
    if cw.len() != cs.len() {
        return Err(to_py(Error::Invalid("adaptive table curvature: coupling_stderr has another length".into())));
    }
    let coupling = cw.into_iter().zip(cs).map(|(weight, stderr)| ExitBins { weight, stderr }).collect();
    let flow = ExitBins { weight: list("flow")?, stderr: list("flow_stderr")? };
    let cavity = pairs("cavity")?;
    Ok(CurvatureData { rho: list("rho")?, sphere, cavity, cylinder, flat, oblique, harmonic, exit, coupling, flow })
}

/// The curvature nodes (mm) of a stack's adaptive table.
#[pyfunction]
fn bssrdf_adaptive_curvature_nodes(stack: StackTuple) -> PyResult<Vec<f64>> {
    curvature_nodes(&stack_from_py(&stack.0, stack.1, stack.2).py()?).py()
}

fn curved_kind(kind: &str) -> PyResult<Curved> {
    match kind {
        "sphere" => Ok(Curved::Sphere),
        "cavity" => Ok(Curved::Cavity),
        "cylinder" => Ok(Curved::Cylinder),
        w => Err(to_py(Error::Invalid(format!("kind = {w:?}: must be \"sphere\", \"cavity\" or \"cylinder\"")))),
    }
}

/// Escape fraction (mean, stderr) of uniform diffuse light from a sphere, a spherical cavity or
/// an infinite cylinder of radius `rho` (mm) made of `stack` (exact transport).
#[pyfunction]
#[pyo3(signature = (stack, kind, rho, photons, seed, threads=None))]
fn bssrdf_curved_escape(
    py: Python<'_>,
    stack: StackTuple,
    kind: &str,
    rho: f64,
    photons: u64,
    seed: u64,
    threads: Option<usize>,
) -> PyResult<(f64, f64)> {
    let e = curved_parts(py, stack, kind, rho, None, photons, seed, threads)?;
    Ok((e.mean, e.stderr))
}

#[allow(clippy::too_many_arguments)] // the run's inputs, spelled out
fn curved_parts(
    py: Python<'_>,
    stack: StackTuple,
    kind: &str,
    rho: f64,
    theta_deg: Option<f64>,
    photons: u64,
    seed: u64,
    threads: Option<usize>,
) -> PyResult<Escape> {
    let k = curved_kind(kind)?;
    let st = stack_from_py(&stack.0, stack.1, stack.2).py()?;
    let source = match theta_deg {
        None => Source::Diffuse,
        Some(t) => Source::Pencil { theta: t.to_radians(), phi: 0.0 },
    };
    source.validate().py()?;
    let (c, p) = (AtomicBool::new(false), AtomicU64::new(0));
    let out = py.detach(|| escape_from(&st, k, rho, source, photons, seed, threads, &c, &p));
    Ok(out.py()?.expect("not cancelled"))
}

/// (mean, stderr, near, near_stderr, bins, shift, harmonic) of a curved run.
type EscapeParts = (f64, f64, f64, f64, Vec<f64>, f64, Vec<f64>);

/// The escape of a curved run in parts: (mean, stderr, near, near_stderr, chord bins of the
/// near half, shift, first azimuthal harmonic per near bin and the far half), under uniform diffuse light (`theta_deg` None) or a collimated beam at polar
/// angle `theta_deg` to the entry point's normal, and the mean exit offset along the beam's
/// tangential direction (mm).
#[pyfunction]
#[pyo3(signature = (stack, kind, rho, photons, seed, theta_deg=None, threads=None))]
#[allow(clippy::too_many_arguments)] // the run's inputs, spelled out
fn bssrdf_curved_escape_parts(
    py: Python<'_>,
    stack: StackTuple,
    kind: &str,
    rho: f64,
    photons: u64,
    seed: u64,
    theta_deg: Option<f64>,
    threads: Option<usize>,
) -> PyResult<EscapeParts> {
    let e = curved_parts(py, stack, kind, rho, theta_deg, photons, seed, threads)?;
    Ok((e.mean, e.stderr, e.near, e.near_stderr, e.bins, e.shift, e.harmonic))
}

/// The exitance of a sphere under a sun of unit irradiance by equal-area bins of cos α (α from
/// the sub-solar point; exact transport, `curved::sun_exitance`).
#[pyfunction]
#[pyo3(signature = (stack, rho, bins, photons, seed, threads=None))]
fn bssrdf_sun_exitance(
    py: Python<'_>,
    stack: StackTuple,
    rho: f64,
    bins: usize,
    photons: u64,
    seed: u64,
    threads: Option<usize>,
) -> PyResult<Vec<f64>> {
    let st = stack_from_py(&stack.0, stack.1, stack.2).py()?;
    let (c, p) = (AtomicBool::new(false), AtomicU64::new(0));
    let out = py.detach(|| sun_exitance(&st, rho, bins, photons, seed, threads, &c, &p));
    Ok(out.py()?.expect("not cancelled"))
}

/// The thickness nodes (mm) of a stack's adaptive table (∞ not listed).
#[pyfunction]
fn bssrdf_adaptive_nodes(stack: StackTuple) -> PyResult<Vec<f64>> {
    thickness_nodes(&stack_from_py(&stack.0, stack.1, stack.2).py()?).py()
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyAdaptiveTable>()?;
    m.add_function(wrap_pyfunction!(bssrdf_adaptive_nodes, m)?)?;
    m.add_function(wrap_pyfunction!(bssrdf_adaptive_curvature_nodes, m)?)?;
    m.add_function(wrap_pyfunction!(bssrdf_curved_escape, m)?)?;
    m.add_function(wrap_pyfunction!(bssrdf_curved_escape_parts, m)?)?;
    m.add_function(wrap_pyfunction!(bssrdf_sun_exitance, m)?)?;
    Ok(())
}
