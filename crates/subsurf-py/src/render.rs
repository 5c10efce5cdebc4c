//! Bindings of `subsurf_core::render`: a `RenderJob` (scene + method, rendered pass by pass
//! with the GIL released so Python can draw progress and catch Ctrl-C between passes),
//! built-in shapes, mesh checks, the random-walk simulation, and the render registries
//! (methods, light types and their parameters, the hierarchical method's defaults).
//!
//! Scenes arrive as the plain dicts python/subsurf/render/scene.py makes, extracted into the
//! typed structs below ([`SceneArgs`]); every integer goes through the one argument mapping
//! ([`u64_arg`]), so a negative or huge value gets the core's range error for its field.

use crate::errors::{threads_arg, to_py, u64_arg, IntoPyResult};
use crate::medium::{stack_from_py, LayerTuple};
use crate::wait::{interrupted, interruptible, interruptible_ctl};
use numpy::{
    PyArray1, PyArray2, PyArray3, PyArrayMethods, PyReadonlyArray2, PyReadonlyArray3, PyReadonlyArray4, ToPyArray,
};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::sync::atomic::Ordering;
use std::sync::Arc;
use subsurf_core::bssrdf::monte_carlo::McSettings;
use subsurf_core::mc::config::{PHOTONS_ALLOWED, SEED_ALLOWED};
use subsurf_core::render::camera::RESOLUTION_ALLOWED;
use subsurf_core::render::driver::{check_spp, SPP_ALLOWED};
use subsurf_core::render::grid::MediumGrid;
use subsurf_core::render::shapes::{MAX_SUBDIVISIONS, SUBDIVISIONS_ALLOWED};
use subsurf_core::render::texture::TextureSpec;
use subsurf_core::render::walk_sim::{simulate, BeamSource, VoxelGrid, WalkConfig};
use subsurf_core::render::{
    shapes, Camera, Control, HierarchicalParams, Light, LightKind, Material, Mesh, Method, Object, Renderer, Scene,
    TranslucentSpec,
};
use subsurf_core::Error;

fn invalid(msg: String) -> PyErr {
    to_py(Error::Invalid(msg))
}

/// A mesh: `Object._mesh_dict()`.
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
struct MeshArgs<'py> {
    name: String,
    positions: PyReadonlyArray2<'py, f64>,
    triangles: PyReadonlyArray2<'py, i64>,
    tint: Option<PyReadonlyArray2<'py, f64>>,
    /// (u, v) of each triangle's corners, shape (n_triangles, 3, 2).
    #[pyo3(default)]
    uv: Option<PyReadonlyArray3<'py, f64>>,
}

/// Rows of an (n, 3) array; errors name `what`.
fn rows3<T: Copy + numpy::Element>(a: &PyReadonlyArray2<'_, T>, what: &str) -> PyResult<Vec<[T; 3]>> {
    let a = a.as_array();
    if a.ncols() != 3 {
        return Err(invalid(format!("{what}: expected an array of shape (n, 3), got {:?}", a.shape())));
    }
    Ok(a.rows().into_iter().map(|r| [r[0], r[1], r[2]]).collect())
}

impl MeshArgs<'_> {
    fn build(&self) -> PyResult<Mesh> {
        let name = &self.name;
        let positions = rows3(&self.positions, &format!("{name}.positions"))?;
        let nv = positions.len();
        let mut triangles = Vec::new();
        for (i, t) in rows3(&self.triangles, &format!("{name}.triangles"))?.into_iter().enumerate() {
            if let Some(&k) = t.iter().find(|&&k| k < 0 || k as u64 >= nv as u64) {
                return Err(invalid(format!(
                    "{name}: triangle {i} refers to vertex {k}, but the mesh has {nv} vertices (indices 0 … {})",
                    nv as i64 - 1
                )));
            }
            triangles.push(t.map(|k| k as u32));
        }
        let tint = self.tint.as_ref().map(|t| rows3(t, &format!("{name}.tint"))).transpose()?;
        let mesh = Mesh::new(name, positions, triangles, tint).py()?;
        let Some(uv) = &self.uv else { return Ok(mesh) };
        let a = uv.as_array();
        if a.shape()[1..] != [3, 2] {
            return Err(invalid(format!(
                "{name}.uv: expected shape (n_triangles, 3, 2) (u, v per corner), got {:?}",
                a.shape()
            )));
        }
        let corners = a.outer_iter().map(|t| std::array::from_fn(|c| [t[[c, 0]], t[[c, 1]]])).collect();
        mesh.with_uv(name, corners).py()
    }
}

/// An object: its mesh and the index of its material.
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
struct ObjectArgs<'py> {
    mesh: MeshArgs<'py>,
    material: usize,
}

/// A translucent material: `Translucent._to_core()`.
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
struct TranslucentArgs<'py> {
    name: String,
    sigma_a: [f64; 3],
    sigma_s: [f64; 3],
    g: f64,
    eta: f64,
    model: String,
    stacks: Vec<(Vec<LayerTuple>, f64, f64)>,
    mc_photons: Bound<'py, PyAny>,
    mc_seed: Bound<'py, PyAny>,
    single_scattering: Option<bool>,
    reflectance: Option<[f64; 3]>,
    #[pyo3(default)]
    grid: Option<GridArgs<'py>>,
    /// A surface colour / mean-free-path map: σa, σs per texel (and the reflectance each was
    /// inverted from), shape (height, width, 3), rows from the top.
    #[pyo3(default)]
    texture: Option<TextureArgs<'py>>,
    #[pyo3(default)]
    adaptive_table: Option<Py<crate::adaptive::PyAdaptiveTable>>,
}

/// A surface map: `Translucent._to_core()["texture"]` (float64 arrays (height, width, 3)).
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
struct TextureArgs<'py> {
    sigma_a: PyReadonlyArray3<'py, f64>,
    sigma_s: PyReadonlyArray3<'py, f64>,
    reflectance: Option<PyReadonlyArray3<'py, f64>>,
}

impl TextureArgs<'_> {
    fn build(&self, field: &str) -> PyResult<TextureSpec> {
        let shape = self.sigma_a.as_array().shape().to_vec();
        let texels = |name: &str, a: &PyReadonlyArray3<'_, f64>| -> PyResult<Vec<[f64; 3]>> {
            let a = a.as_array();
            if a.shape()[2] != 3 || a.shape() != shape.as_slice() {
                return Err(invalid(format!(
                    "{field}.{name}: expected shape (height, width, 3) as sigma_a's {shape:?}, got {:?}",
                    a.shape()
                )));
            }
            let v: Vec<f64> = a.iter().copied().collect();
            Ok(v.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
        };
        let (sa, ss) = (texels("sigma_a", &self.sigma_a)?, texels("sigma_s", &self.sigma_s)?);
        let r = self.reflectance.as_ref().map(|r| texels("reflectance", r)).transpose()?;
        TextureSpec::new(field, shape[1], shape[0], sa, ss, r).py()
    }
}

/// A medium grid: `MediumGrid._to_core()` (σa, σs as (nx, ny, nz, 3) arrays, the box in
/// object space, the object's world → object map as 3 rows of (A | b)).
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
struct GridArgs<'py> {
    sigma_a: PyReadonlyArray4<'py, f64>,
    sigma_s: PyReadonlyArray4<'py, f64>,
    lo: [f64; 3],
    hi: [f64; 3],
    to_object: [[f64; 4]; 3],
}

impl GridArgs<'_> {
    fn build(&self, field: &str) -> PyResult<MediumGrid> {
        let (a, s) = (self.sigma_a.as_array(), self.sigma_s.as_array());
        for (name, arr) in [("sigma_a", &a), ("sigma_s", &s)] {
            if arr.shape()[3] != 3 {
                return Err(invalid(format!(
                    "{field}.{name}: expected shape (nx, ny, nz) or (nx, ny, nz, 3), got {:?}",
                    arr.shape()
                )));
            }
        }
        if a.shape() != s.shape() {
            return Err(invalid(format!(
                "{field}: sigma_a has shape {:?} but sigma_s {:?}; they must be the same",
                a.shape(),
                s.shape()
            )));
        }
        let n = [a.shape()[0], a.shape()[1], a.shape()[2]];
        let rgb = |x: &numpy::ndarray::ArrayView4<'_, f64>| -> Vec<[f64; 3]> {
            x.iter().copied().collect::<Vec<f64>>().chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
        };
        MediumGrid::new(field, (self.lo, self.hi), n, rgb(&a), rgb(&s), self.to_object).py()
    }
}

/// An opaque Lambertian material: `Lambertian._to_core()`.
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
struct LambertianArgs {
    name: String,
    albedo: [f64; 3],
}

/// (Extracted once per scene and dropped: the size of the largest variant does not matter.)
#[derive(FromPyObject)]
#[allow(clippy::large_enum_variant)]
enum MaterialArgs<'py> {
    Translucent(TranslucentArgs<'py>),
    Lambertian(LambertianArgs),
}

/// A material as given: Lambertian ones are ready; translucent ones compute their profiles
/// later, off the GIL and cancellably ([`SceneSpec::build`]).
enum MaterialSpec {
    Ready(Material),
    Translucent(Box<TranslucentSpec>),
}

impl TranslucentArgs<'_> {
    /// The material's inputs, checked (the profiles are computed by [`TranslucentSpec::build`]).
    fn spec(&self, threads: Option<usize>) -> PyResult<TranslucentSpec> {
        let ctx = format!("materials.{}", self.name);
        let mut st = Vec::with_capacity(3);
        for (k, (layers, above, below)) in self.stacks.iter().enumerate() {
            st.push(stack_from_py(layers, *above, *below).map_err(|e| invalid(format!("{ctx}.stacks[{k}]: {e}")))?);
        }
        let stacks: [_; 3] =
            st.try_into().map_err(|_| invalid(format!("{ctx}.stacks: one stack per RGB channel (3) needed")))?;
        let mc = McSettings {
            photons: u64_arg(&self.mc_photons, &format!("{ctx}.mc_photons"), PHOTONS_ALLOWED)?,
            seed: u64_arg(&self.mc_seed, &format!("{ctx}.mc_seed"), SEED_ALLOWED)?,
            threads,
            ..McSettings::default()
        };
        subsurf_core::bssrdf::Model::from_name(&format!("{ctx}.model"), &self.model).py()?;
        let grid = self.grid.as_ref().map(|g| g.build(&format!("{ctx}.grid"))).transpose()?.map(Arc::new);
        let texture = self.texture.as_ref().map(|t| t.build(&format!("{ctx}.texture"))).transpose()?.map(Arc::new);
        Ok(TranslucentSpec {
            field: ctx,
            sigma_a: self.sigma_a,
            sigma_s: self.sigma_s,
            g: self.g,
            eta: self.eta,
            model: self.model.clone(),
            stacks,
            mc,
            reflectance: self.reflectance,
            single_scattering: self.single_scattering,
            grid,
            texture,
            adaptive: self.adaptive_table.as_ref().map(|t| t.get().inner.clone()),
        })
    }
}

/// A light: `kind` (a [`LightKind`] name) and the parameters [`LightKind::params`] lists.
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
struct LightArgs {
    kind: String,
    #[pyo3(default)]
    position: Option<[f64; 3]>,
    #[pyo3(default)]
    power: Option<[f64; 3]>,
    #[pyo3(default)]
    direction: Option<[f64; 3]>,
    #[pyo3(default)]
    irradiance: Option<[f64; 3]>,
    #[pyo3(default)]
    radius: Option<f64>,
    #[pyo3(default)]
    u: Option<[f64; 3]>,
    #[pyo3(default)]
    v: Option<[f64; 3]>,
}

impl LightArgs {
    fn build(&self, i: usize) -> PyResult<Light> {
        let ctx = format!("lights[{i}]");
        let need = |v: Option<[f64; 3]>, key: &str| v.ok_or_else(|| invalid(format!("{ctx}: missing {key}")));
        match LightKind::from_name(&format!("{ctx}.type"), &self.kind).py()? {
            LightKind::Point => Light::point(&ctx, need(self.position, "position")?, need(self.power, "power")?),
            LightKind::Directional => {
                Light::directional(&ctx, need(self.direction, "direction")?, need(self.irradiance, "irradiance")?)
            }
            LightKind::Sphere => {
                let radius = self.radius.ok_or_else(|| invalid(format!("{ctx}: missing radius")))?;
                Light::sphere(&ctx, need(self.position, "position")?, radius, need(self.power, "power")?)
            }
            LightKind::Rect => Light::rect(
                &ctx,
                need(self.position, "position")?,
                need(self.u, "u")?,
                need(self.v, "v")?,
                need(self.power, "power")?,
            ),
        }
        .py()
    }
}

/// The camera: `Camera._to_core()`.
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
struct CameraArgs<'py> {
    position: [f64; 3],
    look_at: [f64; 3],
    up: [f64; 3],
    fov: f64,
    width: Bound<'py, PyAny>,
    height: Bound<'py, PyAny>,
}

impl CameraArgs<'_> {
    fn build(&self) -> PyResult<Camera> {
        let size = |v: &Bound<'_, PyAny>, f: &str| -> PyResult<usize> {
            Ok(usize::try_from(u64_arg(v, f, RESOLUTION_ALLOWED)?).unwrap_or(usize::MAX))
        };
        let (w, h) = (size(&self.width, "camera.width")?, size(&self.height, "camera.height")?);
        Camera::new(self.position, self.look_at, self.up, self.fov, w, h).py()
    }
}

/// A scene: `Scene._to_core()`.
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
struct SceneArgs<'py> {
    objects: Vec<ObjectArgs<'py>>,
    materials: Vec<MaterialArgs<'py>>,
    lights: Vec<LightArgs>,
    environment: [f64; 3],
    camera: Option<CameraArgs<'py>>,
}

impl SceneArgs<'_> {
    /// The scene's inputs, checked, with the GIL: everything but the materials' profiles.
    fn spec(&self, threads: Option<usize>) -> PyResult<SceneSpec> {
        let mut materials = vec![];
        for m in &self.materials {
            materials.push(match m {
                MaterialArgs::Translucent(t) => MaterialSpec::Translucent(Box::new(t.spec(threads)?)),
                MaterialArgs::Lambertian(l) => {
                    MaterialSpec::Ready(Material::lambertian(&format!("materials.{}", l.name), l.albedo).py()?)
                }
            });
        }
        let mut objects = vec![];
        for o in &self.objects {
            objects.push(Object { name: o.mesh.name.clone(), mesh: o.mesh.build()?, material: o.material });
        }
        let lights = self.lights.iter().enumerate().map(|(i, l)| l.build(i)).collect::<PyResult<Vec<_>>>()?;
        let camera = self.camera.as_ref().map(CameraArgs::build).transpose()?;
        Ok(SceneSpec { objects, materials, lights, env: self.environment, camera })
    }

    /// The core scene without profiles (the random walk and the BVH benchmark: nothing long).
    fn build_without_profiles(&self, py: Python<'_>, threads: Option<usize>) -> PyResult<Scene> {
        let spec = self.spec(threads)?;
        let scene = py.detach(|| spec.build(false, &Control::default())).py()?;
        Ok(scene.expect("never cancelled"))
    }
}

/// A scene read from Python, before its materials' profiles are computed.
struct SceneSpec {
    objects: Vec<Object>,
    materials: Vec<MaterialSpec>,
    lights: Vec<Light>,
    env: [f64; 3],
    camera: Option<Camera>,
}

impl SceneSpec {
    /// Photons the materials' Monte Carlo profiles trace, if `profiles` are built.
    fn photons(&self, profiles: bool) -> u64 {
        let specs = self.materials.iter().filter_map(|m| match m {
            MaterialSpec::Translucent(t) if profiles => Some(t.photons()),
            _ => None,
        });
        specs.fold(0, u64::saturating_add)
    }

    /// The core scene; materials get profiles only when `profiles` (the method uses them).
    /// `None` when `ctl.cancel` stopped a Monte Carlo profile (which counts photons in `ctl.done`).
    fn build(self, profiles: bool, ctl: &Control) -> subsurf_core::Result<Option<Scene>> {
        let mut materials = Vec::with_capacity(self.materials.len());
        for m in self.materials {
            materials.push(match m {
                MaterialSpec::Ready(m) => m,
                MaterialSpec::Translucent(t) => match t.build(profiles, &ctl.cancel, &ctl.done)? {
                    Some(t) => Material::Translucent(Box::new(t)),
                    None => return Ok(None),
                },
            });
        }
        Scene::new(self.objects, materials, self.lights, self.env, self.camera).map(Some)
    }
}

/// `progress` bound to a stage name: `functools.partial(progress, stage)`.
fn staged(py: Python<'_>, progress: Option<&Py<PyAny>>, stage: &str) -> PyResult<Option<Py<PyAny>>> {
    let Some(p) = progress else { return Ok(None) };
    let partial = py.import("functools")?.getattr("partial")?;
    Ok(Some(partial.call1((p, stage))?.unbind()))
}

/// Settings of the hierarchical method: the dict `render(hierarchical=...)` completes with
/// [`hierarchical_defaults`].
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
struct HierarchicalArgs<'py> {
    spacing: f64,
    epsilon: f64,
    env_samples: Bound<'py, PyAny>,
    light_samples: Bound<'py, PyAny>,
    samples_per_exitance: Bound<'py, PyAny>,
}

impl HierarchicalArgs<'_> {
    fn build(&self) -> PyResult<HierarchicalParams> {
        let count = |v: &Bound<'_, PyAny>, f: &str, allowed: &'static str| -> PyResult<u32> {
            let n = u64_arg(v, f, allowed)?;
            u32::try_from(n).map_err(|_| to_py(Error::param_int(f, n as i128, allowed)))
        };
        let hp = HierarchicalParams {
            spacing: self.spacing,
            epsilon: self.epsilon,
            env_samples: count(&self.env_samples, "hierarchical.env_samples", "an integer in [0, 4294967295]")?,
            light_samples: count(&self.light_samples, "hierarchical.light_samples", "an integer in [1, 4294967295]")?,
            samples_per_exitance: count(
                &self.samples_per_exitance,
                "hierarchical.samples_per_exitance",
                "an integer in [1, 4294967295]",
            )?,
            ..HierarchicalParams::default()
        };
        hp.validate().py()?;
        Ok(hp)
    }
}

/// The hierarchical method's settings a user can give, with their defaults.
fn hierarchical_defaults(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    let HierarchicalParams { spacing, epsilon, env_samples, light_samples, max_samples: _, samples_per_exitance } =
        HierarchicalParams::default();
    let d = PyDict::new(py);
    d.set_item("spacing", spacing)?;
    d.set_item("epsilon", epsilon)?;
    d.set_item("env_samples", env_samples)?;
    d.set_item("light_samples", light_samples)?;
    d.set_item("samples_per_exitance", samples_per_exitance)?;
    Ok(d)
}

/// (spp, seed) of a render, validated: spp in [1, 2³² − 1], seed in [0, 2⁶⁴).
#[pyfunction]
fn render_check_settings(spp: &Bound<'_, PyAny>, seed: &Bound<'_, PyAny>) -> PyResult<(u32, u64)> {
    let spp = check_spp(u64_arg(spp, "spp", SPP_ALLOWED)?).py()?;
    Ok((spp, u64_arg(seed, "seed", SEED_ALLOWED)?))
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
    /// Prepare `scene` (a dict) for `method`; `hierarchical`: the method's settings (a dict of
    /// every key of `RENDER_HIERARCHICAL_DEFAULTS`) or None for the defaults. The set-up runs
    /// with the GIL released and stops on Ctrl-C (KeyboardInterrupt) or SIGTERM:
    /// `monte_carlo` profiles (built only for methods that use profiles) call
    /// `progress("profiles", photons done, total)`, the hierarchical irradiance samples
    /// `progress("irradiance", samples done, total)`; stages with nothing to do are not reported.
    #[new]
    #[pyo3(signature = (scene, method, seed, threads=None, hierarchical=None, progress=None))]
    fn new(
        py: Python<'_>,
        scene: SceneArgs<'_>,
        method: &str,
        seed: &Bound<'_, PyAny>,
        threads: Option<&Bound<'_, PyAny>>,
        hierarchical: Option<HierarchicalArgs<'_>>,
        progress: Option<Py<PyAny>>,
    ) -> PyResult<Self> {
        let m = Method::from_name("method", method).py()?;
        let seed = u64_arg(seed, "seed", SEED_ALLOWED)?;
        let threads = threads.map(threads_arg).transpose()?;
        let hp = hierarchical.as_ref().map_or_else(|| Ok(HierarchicalParams::default()), HierarchicalArgs::build)?;
        let spec = scene.spec(threads)?;
        let (profiles, photons) = (m.uses_profiles(), spec.photons(m.uses_profiles()));
        let cb = staged(py, progress.as_ref().filter(|_| photons > 0), "profiles")?;
        let (sc, stop) = interruptible_ctl(py, cb.as_ref(), photons, move |ctl| spec.build(profiles, ctl))?;
        let Some(sc) = sc.py()?.filter(|_| stop.is_none()) else {
            return Err(stop.unwrap_or_else(|| interrupted("the render set-up")));
        };
        let sc = Arc::new(sc);
        let (w, h) = sc.camera.as_ref().map(|c| (c.width, c.height)).unwrap_or((0, 0));
        let cb = staged(py, progress.as_ref().filter(|_| m == Method::Hierarchical), "irradiance")?;
        let (r, stop) = interruptible_ctl(py, cb.as_ref(), 0, move |ctl| {
            subsurf_core::render::with_threads(threads, || Renderer::prepare(sc, m, seed, &hp, ctl))
        })?;
        let Some(r) = r.py()?.py()?.filter(|_| stop.is_none()) else {
            return Err(stop.unwrap_or_else(|| interrupted("the render set-up")));
        };
        Ok(RenderJob { renderer: Arc::new(r), accum: vec![0.0; w * h * 3], spp: 0, threads })
    }

    /// Warnings about the scene (lights that cannot light anything), one line each.
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.renderer.scene.warnings()
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

/// A built-in shape as (positions (N, 3), triangles (M, 3)): kind "sphere" (center, radius `c`,
/// subdivisions `level`), "box" (lo, hi), "plane" (center, sizes `c`, `d`) or "torus" (center,
/// R = `c`, r = `d`, nu, nv). Sizes are checked by the core (`render::shapes`).
#[pyfunction]
#[pyo3(signature = (kind, a, b=None, c=0.0, d=0.0, level=None, nu=64, nv=32))]
#[allow(clippy::too_many_arguments)]
fn render_shape<'py>(
    py: Python<'py>,
    kind: &str,
    a: [f64; 3],
    b: Option<[f64; 3]>,
    c: f64,
    d: f64,
    level: Option<&Bound<'py, PyAny>>,
    nu: u32,
    nv: u32,
) -> PyResult<MeshArrays<'py>> {
    let mesh = match kind {
        "sphere" => {
            let level = level.map_or(Ok(4), |l| u64_arg(l, "subdivisions", SUBDIVISIONS_ALLOWED))?;
            if level > MAX_SUBDIVISIONS as u64 {
                return Err(to_py(Error::param_int("subdivisions", level as i128, SUBDIVISIONS_ALLOWED)));
            }
            shapes::icosphere(a, c, level as u32)
        }
        "box" => shapes::cuboid(a, b.ok_or_else(|| invalid("box: give lo and hi corners".into()))?),
        "plane" => shapes::rectangle(a[0], a[1], a[2], c, d),
        "torus" => shapes::torus(a, c, d, nu, nv),
        other => return Err(invalid(format!("shape = {other:?}: must be sphere, box, plane or torus"))),
    }
    .py()?;
    let p: Vec<f64> = mesh.positions.iter().flatten().copied().collect();
    let t: Vec<i64> = mesh.triangles.iter().flatten().map(|&x| x as i64).collect();
    Ok((
        PyArray1::from_vec(py, p).reshape([mesh.positions.len(), 3])?,
        PyArray1::from_vec(py, t).reshape([mesh.triangles.len(), 3])?,
    ))
}

/// (closed, open_edges, area, volume) of a mesh (`Object._mesh_dict()`), validating it.
#[pyfunction]
fn render_mesh_info(mesh: MeshArgs<'_>) -> PyResult<(bool, usize, f64, f64)> {
    let m = mesh.build()?;
    Ok((m.closed, m.open_edges, m.total_area(), m.volume()))
}

/// A voxel grid: (lo, hi, (nx, ny, nz)); the counts through [`u64_arg`].
type VoxelArgs<'py> = ([f64; 3], [f64; 3], [Bound<'py, PyAny>; 3]);

/// The random-walk simulation: `source` = ("pencil", origin, direction) or ("collimated",
/// direction, direction); `voxels` = (lo, hi, (nx, ny, nz)); returns a dict of tallies
/// (fractions of launched power). Ctrl-C stops it with KeyboardInterrupt.
#[pyfunction]
#[pyo3(signature = (scene, source, photons, seed, channel=None, voxels=None, threads=None))]
#[allow(clippy::too_many_arguments)]
fn render_walk_simulate<'py>(
    py: Python<'py>,
    scene: SceneArgs<'py>,
    source: (String, [f64; 3], [f64; 3]),
    photons: &Bound<'py, PyAny>,
    seed: &Bound<'py, PyAny>,
    channel: Option<&Bound<'py, PyAny>>,
    voxels: Option<VoxelArgs<'py>>,
    threads: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let threads = threads.map(threads_arg).transpose()?;
    let photons = u64_arg(photons, "photons", PHOTONS_ALLOWED)?;
    let seed = u64_arg(seed, "seed", SEED_ALLOWED)?;
    let channel = channel.map_or(Ok(0), |c| u64_arg(c, "channel", "0, 1 or 2"))?;
    let voxels = match voxels {
        Some((lo, hi, n)) => {
            let mut counts = [0usize; 3];
            for (k, v) in n.iter().enumerate() {
                let c = u64_arg(v, &format!("voxels.n[{k}]"), "an integer >= 1")?;
                counts[k] = usize::try_from(c).unwrap_or(usize::MAX);
            }
            Some(VoxelGrid { lo, hi, n: counts })
        }
        None => None,
    };
    let sc = scene.build_without_profiles(py, threads)?;
    let src = match source.0.as_str() {
        "pencil" => BeamSource::Pencil { origin: source.1, direction: source.2 },
        "collimated" => BeamSource::Collimated { direction: source.2 },
        other => return Err(invalid(format!("source: unknown kind {other:?} (pencil or collimated)"))),
    };
    if photons == 0 {
        return Err(to_py(Error::param_int("photons", 0, PHOTONS_ALLOWED)));
    }
    let channel = usize::try_from(channel).unwrap_or(usize::MAX);
    let cfg = WalkConfig { source: src, photons, seed, channel, voxels };
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
fn render_bvh_benchmark(py: Python<'_>, scene: SceneArgs<'_>, n: usize) -> PyResult<(f64, f64)> {
    let sc = scene.build_without_profiles(py, None)?;
    Ok(py.detach(|| subsurf_core::render::accel::rays_per_second(&sc.accel, n, 1)))
}

/// Light types and the parameters each takes, in the core's order.
fn light_kinds(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    let d = PyDict::new(py);
    for &k in LightKind::ALL {
        d.set_item(k.name(), k.params().to_vec())?;
    }
    Ok(d)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(render_bvh_benchmark, m)?)?;
    m.add_class::<RenderJob>()?;
    m.add_function(wrap_pyfunction!(render_check_settings, m)?)?;
    m.add_function(wrap_pyfunction!(render_shape, m)?)?;
    m.add_function(wrap_pyfunction!(render_mesh_info, m)?)?;
    m.add_function(wrap_pyfunction!(render_walk_simulate, m)?)?;
    m.add("RENDER_METHODS", Method::NAMES.to_vec())?;
    m.add("RENDER_LIGHTS", light_kinds(m.py())?)?;
    m.add("RENDER_HIERARCHICAL_DEFAULTS", hierarchical_defaults(m.py())?)?;
    Ok(())
}
