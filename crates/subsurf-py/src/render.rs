//! Bindings of `subsurf_core::render`: a `RenderJob` (scene + method, rendered pass by pass
//! with the GIL released so Python can draw progress and catch Ctrl-C between passes),
//! built-in shapes, mesh checks and the random-walk simulation.
//!
//! Scenes arrive as plain dicts built by python/subsurf/render/scene.py (see `scene_from_py`).

use crate::errors::{to_py, IntoPyResult};
use crate::medium::{stack_from_py, LayerTuple};
use crate::wait::interruptible;
use numpy::{PyArray1, PyArray2, PyArray3, PyArrayMethods, PyReadonlyArray2, ToPyArray};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::sync::atomic::Ordering;
use std::sync::Arc;
use subsurf_core::bssrdf::monte_carlo::McSettings;
use subsurf_core::render::material::channel_profiles;
use subsurf_core::render::walk_sim::{simulate, BeamSource, VoxelGrid, WalkConfig};
use subsurf_core::render::{
    shapes, Camera, HierarchicalParams, Light, Material, Mesh, Method, Object, Renderer, Scene, Translucent,
};
use subsurf_core::Error;

fn v3(d: &Bound<'_, PyDict>, key: &str, ctx: &str) -> PyResult<[f64; 3]> {
    let v: Vec<f64> = get_any(d, key, ctx)?;
    v.try_into().map_err(|_| to_py(Error::Invalid(format!("{ctx}.{key}: expected 3 numbers"))))
}

fn get_any<'py, T>(d: &Bound<'py, PyDict>, key: &str, ctx: &str) -> PyResult<T>
where
    T: for<'a> FromPyObject<'a, 'py>,
{
    match d.get_item(key)? {
        Some(v) => v.extract::<T>().map_err(|_| to_py(Error::Invalid(format!("{ctx}.{key}: wrong type")))),
        None => Err(to_py(Error::Invalid(format!("{ctx}: missing key {key:?}")))),
    }
}

fn mesh_from_py(d: &Bound<'_, PyDict>, name: &str) -> PyResult<Mesh> {
    let pos: PyReadonlyArray2<f64> = get_any(d, "positions", name)?;
    let tri: PyReadonlyArray2<i64> = get_any(d, "triangles", name)?;
    let (pos, tri) = (pos.as_array(), tri.as_array());
    if pos.ncols() != 3 || tri.ncols() != 3 {
        return Err(to_py(Error::Invalid(format!("{name}: positions and triangles must have 3 columns"))));
    }
    let positions: Vec<[f64; 3]> = pos.rows().into_iter().map(|r| [r[0], r[1], r[2]]).collect();
    let mut triangles = Vec::with_capacity(tri.nrows());
    for r in tri.rows() {
        if r.iter().any(|&k| k < 0 || k > u32::MAX as i64) {
            return Err(to_py(Error::Invalid(format!("{name}: a triangle has a negative vertex index"))));
        }
        triangles.push([r[0] as u32, r[1] as u32, r[2] as u32]);
    }
    let tint = match d.get_item("tint")? {
        Some(t) if !t.is_none() => {
            let t: PyReadonlyArray2<f64> = t.extract()?;
            Some(t.as_array().rows().into_iter().map(|r| [r[0], r[1], r[2]]).collect())
        }
        _ => None,
    };
    Mesh::new(name, positions, triangles, tint).py()
}

fn material_from_py(d: &Bound<'_, PyDict>, threads: Option<usize>) -> PyResult<Material> {
    let name: String = get_any(d, "name", "material")?;
    let ctx = format!("materials.{name}");
    let kind: String = get_any(d, "kind", &ctx)?;
    match kind.as_str() {
        "lambertian" => Material::lambertian(&ctx, v3(d, "albedo", &ctx)?).py(),
        "translucent" => {
            let (sa, ss) = (v3(d, "sigma_a", &ctx)?, v3(d, "sigma_s", &ctx)?);
            let (g, eta): (f64, f64) = (get_any(d, "g", &ctx)?, get_any(d, "eta", &ctx)?);
            let model: String = get_any(d, "model", &ctx)?;
            let stacks: Vec<(Vec<LayerTuple>, f64, f64)> = get_any(d, "stacks", &ctx)?;
            if stacks.len() != 3 {
                return Err(to_py(Error::Invalid(format!("{ctx}.stacks: one stack per RGB channel (3) needed"))));
            }
            let mut st = Vec::with_capacity(3);
            for (k, (layers, above, below)) in stacks.iter().enumerate() {
                st.push(
                    stack_from_py(layers, *above, *below)
                        .map_err(|e| to_py(Error::Invalid(format!("{ctx}.stacks[{k}]: {e}"))))?,
                );
            }
            let stacks: [_; 3] = st.try_into().map_err(|_| to_py(Error::Invalid("stacks".into())))?;
            let mc = McSettings {
                photons: get_any(d, "mc_photons", &ctx)?,
                seed: get_any(d, "mc_seed", &ctx)?,
                threads,
                ..McSettings::default()
            };
            let colour: Option<[f64; 3]> = get_any(d, "colour", &ctx)?;
            let (profiles, ss_default) = channel_profiles(&model, &stacks, &mc, colour.as_ref())
                .map_err(|e| to_py(Error::Invalid(format!("{ctx}: {e}"))))?;
            let single: Option<bool> = get_any(d, "single_scattering", &ctx)?;
            let t = Translucent::new(&ctx, sa, ss, g, eta, profiles, single.unwrap_or(ss_default)).py()?;
            Ok(Material::Translucent(Box::new(t)))
        }
        other => {
            Err(to_py(Error::Invalid(format!("{ctx}.kind = {other:?}: must be \"translucent\" or \"lambertian\""))))
        }
    }
}

fn light_from_py(d: &Bound<'_, PyDict>, i: usize) -> PyResult<Light> {
    let ctx = format!("lights[{i}]");
    let kind: String = get_any(d, "kind", &ctx)?;
    match kind.as_str() {
        "point" => Light::point(&ctx, v3(d, "position", &ctx)?, v3(d, "power", &ctx)?),
        "directional" => Light::directional(&ctx, v3(d, "direction", &ctx)?, v3(d, "irradiance", &ctx)?),
        "sphere" => Light::sphere(&ctx, v3(d, "position", &ctx)?, get_any(d, "radius", &ctx)?, v3(d, "power", &ctx)?),
        "rect" => {
            Light::rect(&ctx, v3(d, "position", &ctx)?, v3(d, "u", &ctx)?, v3(d, "v", &ctx)?, v3(d, "power", &ctx)?)
        }
        other => Err(Error::Invalid(format!("{ctx}.kind = {other:?}: must be point, directional, sphere or rect"))),
    }
    .py()
}

/// Build a core scene from the dict python/subsurf/render/scene.py makes.
fn scene_from_py(py: Python<'_>, d: &Bound<'_, PyDict>, threads: Option<usize>) -> PyResult<Scene> {
    let mut materials = vec![];
    for m in get_any::<Bound<PyList>>(d, "materials", "scene")?.iter() {
        let md = m.cast::<PyDict>()?;
        materials.push(material_from_py(md, threads)?);
    }
    let mut objects = vec![];
    for o in get_any::<Bound<PyList>>(d, "objects", "scene")?.iter() {
        let od = o.cast::<PyDict>()?;
        let name: String = get_any(od, "name", "object")?;
        let mesh = mesh_from_py(od, &name)?;
        objects.push(Object { name, mesh, material: get_any(od, "material", "object")? });
    }
    let mut lights = vec![];
    for (i, l) in get_any::<Bound<PyList>>(d, "lights", "scene")?.iter().enumerate() {
        lights.push(light_from_py(l.cast::<PyDict>()?, i)?);
    }
    let env = v3(d, "environment", "scene")?;
    let camera = match d.get_item("camera")? {
        Some(c) if !c.is_none() => {
            let c = c.cast::<PyDict>()?.clone();
            Some(
                Camera::new(
                    v3(&c, "position", "camera")?,
                    v3(&c, "look_at", "camera")?,
                    v3(&c, "up", "camera")?,
                    get_any(&c, "fov", "camera")?,
                    get_any(&c, "width", "camera")?,
                    get_any(&c, "height", "camera")?,
                )
                .py()?,
            )
        }
        _ => None,
    };
    py.detach(|| Scene::new(objects, materials, lights, env, camera)).py()
}

/// A scene prepared for one method; `render_pass` adds samples to its accumulator.
#[pyclass(module = "subsurf._core")]
struct RenderJob {
    renderer: Arc<Renderer>,
    accum: Vec<f64>,
    spp: u32,
    threads: Option<usize>,
}

#[pymethods]
impl RenderJob {
    /// Prepare `scene` (a dict) for `method`; `hierarchical` = (spacing, epsilon, env_samples,
    /// light_samples) or None for the defaults.
    #[new]
    #[pyo3(signature = (scene, method, seed, threads=None, hierarchical=None))]
    fn new(
        py: Python<'_>,
        scene: &Bound<'_, PyDict>,
        method: &str,
        seed: u64,
        threads: Option<usize>,
        hierarchical: Option<(f64, f64, u32, u32)>,
    ) -> PyResult<Self> {
        let m = Method::from_name(method).py()?;
        let mut hp = HierarchicalParams::default();
        if let Some((a, b, c, e)) = hierarchical {
            (hp.spacing, hp.epsilon, hp.env_samples, hp.light_samples) = (a, b, c, e);
        }
        let sc = Arc::new(scene_from_py(py, scene, threads)?);
        let (w, h) = sc.camera.as_ref().map(|c| (c.width, c.height)).unwrap_or((0, 0));
        let r =
            py.detach(|| subsurf_core::render::with_threads(threads, || Renderer::new(sc, m, seed, &hp))).py()?.py()?;
        Ok(RenderJob { renderer: Arc::new(r), accum: vec![0.0; w * h * 3], spp: 0, threads })
    }

    /// Render `n` more samples per pixel; returns the total so far. The pass runs on a worker
    /// thread while this one waits with the GIL released ([`interruptible`]): a KeyboardInterrupt
    /// cancels the pass (its samples are discarded, the image keeps every completed pass) and is
    /// re-raised.
    fn render_pass(&mut self, py: Python<'_>, n: u32) -> PyResult<u32> {
        let (s0, s1) = (self.spp, self.spp.saturating_add(n));
        let (r, threads) = (self.renderer.clone(), self.threads);
        let mut acc = std::mem::take(&mut self.accum);
        let ((ok, acc), stop) = interruptible(py, None, 0, move |cancel, _| {
            let ok = subsurf_core::render::with_threads(threads, || r.pass(s0, s1, &mut acc, cancel));
            (ok, acc)
        })?;
        self.accum = acc;
        if ok.py()? {
            self.spp = s1;
        }
        match stop {
            Some(e) => Err(e),
            None => Ok(self.spp),
        }
    }

    /// The mean radiance image (height, width, 3) of the samples so far.
    fn image<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray3<f64>>> {
        let c = self.renderer.scene.camera.as_ref().expect("a render job has a camera");
        let k = 1.0 / self.spp.max(1) as f64;
        let v: Vec<f64> = self.accum.iter().map(|x| x * k).collect();
        PyArray1::from_vec(py, v).reshape([c.height, c.width, 3])
    }

    #[getter]
    fn spp(&self) -> u32 {
        self.spp
    }

    /// Samples whose radiance was not finite (dropped).
    #[getter]
    fn dropped(&self) -> u64 {
        self.renderer.dropped.load(Ordering::Relaxed)
    }
}

/// Positions (N, 3) and triangles (M, 3) of a mesh.
type MeshArrays<'py> = (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray2<i64>>);

/// A built-in shape as (positions (N, 3), triangles (M, 3)): kind "sphere" (center, radius,
/// subdivisions), "box" (lo, hi), "plane" (cx, cy, z, sx, sy) or "torus" (center, R, r, nu, nv).
#[pyfunction]
#[pyo3(signature = (kind, a, b=None, c=0.0, d=0.0, level=4, nu=64, nv=32))]
#[allow(clippy::too_many_arguments)]
fn render_shape<'py>(
    py: Python<'py>,
    kind: &str,
    a: [f64; 3],
    b: Option<[f64; 3]>,
    c: f64,
    d: f64,
    level: u32,
    nu: u32,
    nv: u32,
) -> PyResult<MeshArrays<'py>> {
    let mesh = match kind {
        "sphere" if c > 0.0 && level <= 8 => shapes::icosphere(a, c, level),
        "box" => {
            let hi = b.ok_or_else(|| to_py(Error::Invalid("box: give lo and hi corners".into())))?;
            if (0..3).any(|k| !(hi[k] > a[k])) {
                return Err(to_py(Error::Invalid("box: every coordinate of hi must exceed lo's".into())));
            }
            shapes::cuboid(a, hi)
        }
        "plane" if c > 0.0 && d > 0.0 => shapes::rectangle(a[0], a[1], a[2], c, d),
        "torus" if c > d && d > 0.0 && nu >= 3 && nv >= 3 => shapes::torus(a, c, d, nu, nv),
        _ => {
            return Err(to_py(Error::Invalid(format!(
                "shape {kind:?}: unknown kind or sizes out of range (radius > 0, level <= 8; torus R > r > 0)"
            ))))
        }
    };
    let p: Vec<f64> = mesh.positions.iter().flatten().copied().collect();
    let t: Vec<i64> = mesh.triangles.iter().flatten().map(|&x| x as i64).collect();
    Ok((
        PyArray1::from_vec(py, p).reshape([mesh.positions.len(), 3])?,
        PyArray1::from_vec(py, t).reshape([mesh.triangles.len(), 3])?,
    ))
}

/// (closed, open_edges, area, volume) of a mesh, validating it (errors name `name`).
#[pyfunction]
fn render_mesh_info(mesh: &Bound<'_, PyDict>, name: &str) -> PyResult<(bool, usize, f64, f64)> {
    let m = mesh_from_py(mesh, name)?;
    Ok((m.closed, m.open_edges, m.total_area(), m.volume()))
}

/// The random-walk simulation: `source` = ("pencil", origin, direction) or ("collimated",
/// direction, direction); returns a dict of tallies (fractions of launched power). Ctrl-C stops
/// it with KeyboardInterrupt.
#[pyfunction]
#[pyo3(signature = (scene, source, photons, seed, channel=0, voxels=None, threads=None))]
#[allow(clippy::too_many_arguments)]
fn render_walk_simulate<'py>(
    py: Python<'py>,
    scene: &Bound<'py, PyDict>,
    source: (String, [f64; 3], [f64; 3]),
    photons: u64,
    seed: u64,
    channel: usize,
    voxels: Option<([f64; 3], [f64; 3], [usize; 3])>,
    threads: Option<usize>,
) -> PyResult<Bound<'py, PyDict>> {
    let sc = scene_from_py(py, scene, threads)?;
    let src = match source.0.as_str() {
        "pencil" => BeamSource::Pencil { origin: source.1, direction: source.2 },
        "collimated" => BeamSource::Collimated { direction: source.2 },
        other => return Err(to_py(Error::Invalid(format!("source: unknown kind {other:?} (pencil or collimated)")))),
    };
    if photons == 0 {
        return Err(to_py(Error::param("photons", 0.0, "an integer >= 1")));
    }
    let cfg =
        WalkConfig { source: src, photons, seed, channel, voxels: voxels.map(|(lo, hi, n)| VoxelGrid { lo, hi, n }) };
    let sc = Arc::new(sc);
    let shared = sc.clone();
    let (t, stop) = interruptible(py, None, photons, move |cancel, done| {
        subsurf_core::render::with_threads(threads, || simulate(&shared, &cfg, cancel, done))
    })?;
    if stop.is_some() {
        return Err(crate::wait::interrupted("the random-walk simulation"));
    }
    let t = t.py()?.py()?;
    let n = t.photons as f64;
    let out = PyDict::new(py);
    // Exitance per triangle, in mesh order: object index and local triangle index of each.
    let mut per_obj: Vec<Vec<f64>> = sc.objects.iter().map(|o| vec![0.0; o.mesh.triangles.len()]).collect();
    for (g, tr) in sc.accel.tris.iter().enumerate() {
        per_obj[tr.object as usize][tr.local as usize] = t.exit[g] / n;
    }
    let ex = PyList::empty(py);
    for v in per_obj {
        ex.append(v.to_pyarray(py))?;
    }
    let (rd, se) = t.exitance_total();
    out.set_item("exitance_per_triangle", ex)?;
    out.set_item("exitance", rd)?;
    out.set_item("exitance_stderr", se)?;
    out.set_item("specular", t.specular / n)?;
    // As the engine's totals: `absorbed` = physical deposits + the roulette term.
    out.set_item("absorbed", (t.absorbed + t.roulette) / n)?;
    out.set_item("roulette", t.roulette / n)?;
    out.set_item("lost", t.lost / n)?;
    out.set_item("voxels", t.voxels.iter().map(|v| v / n).collect::<Vec<f64>>().to_pyarray(py))?;
    out.set_item("photons", t.photons)?;
    Ok(out)
}

/// (inside rays/s, camera rays/s) of the BVH over `scene`'s meshes, one thread, `n` rays each.
#[pyfunction]
fn render_bvh_benchmark(py: Python<'_>, scene: &Bound<'_, PyDict>, n: usize) -> PyResult<(f64, f64)> {
    let sc = scene_from_py(py, scene, None)?;
    Ok(py.detach(|| subsurf_core::render::accel::rays_per_second(&sc.accel, n, 1)))
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(render_bvh_benchmark, m)?)?;
    m.add_class::<RenderJob>()?;
    m.add_function(wrap_pyfunction!(render_shape, m)?)?;
    m.add_function(wrap_pyfunction!(render_mesh_info, m)?)?;
    m.add_function(wrap_pyfunction!(render_walk_simulate, m)?)?;
    Ok(())
}
