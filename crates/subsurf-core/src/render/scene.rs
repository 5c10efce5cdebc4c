//! The scene: objects (meshes with a material), lights, a constant environment, the camera,
//! and the BVH over all triangles.

use super::accel::Accel;
use super::camera::Camera;
use super::distance::DistanceGrid;
use super::light::Light;
use super::material::Material;
use super::math::{dot, Rgb, V3};
use super::mesh::Mesh;
use crate::error::{Error, Result};

/// One object: a mesh and the index of its material.
#[derive(Clone, Debug)]
pub struct Object {
    /// Name used in errors (`objects[1]` or the user's name).
    pub name: String,
    pub mesh: Mesh,
    pub material: usize,
}

/// A scene ready to render.
pub struct Scene {
    pub objects: Vec<Object>,
    pub materials: Vec<Material>,
    pub lights: Vec<Light>,
    /// Constant environment radiance per channel (W mm⁻² sr⁻¹).
    pub environment: Rgb,
    /// The camera (None for simulations that need no image).
    pub camera: Option<Camera>,
    pub accel: Accel,
}

/// Directions for the point-in-mesh parity test (irrational-ish, to avoid edges and vertices).
const PARITY_DIRS: [V3; 3] = [[0.5377, 0.1832, 0.8230], [-0.6915, 0.6404, -0.3341], [0.1238, -0.9717, 0.2012]];

impl Scene {
    /// Validate and build the BVH. Errors: a material index out of range, a negative
    /// environment, the camera inside a closed object.
    pub fn new(
        objects: Vec<Object>,
        materials: Vec<Material>,
        lights: Vec<Light>,
        environment: Rgb,
        camera: Option<Camera>,
    ) -> Result<Scene> {
        if objects.is_empty() {
            return Err(Error::Invalid("objects: the scene has no objects".into()));
        }
        for o in &objects {
            if o.material >= materials.len() {
                return Err(Error::Invalid(format!(
                    "{}.material: index {} but only {} materials",
                    o.name,
                    o.material,
                    materials.len()
                )));
            }
        }
        for o in &objects {
            let textured = materials[o.material].translucent().is_some_and(|m| m.texture.is_some());
            if textured && o.mesh.uv.is_none() {
                return Err(Error::Invalid(format!(
                    "{}.uv: the material has a surface texture but the mesh has no texture coordinates \
                     (load an OBJ/PLY/GLB with UVs, or give uv)",
                    o.name
                )));
            }
        }
        super::light::check_power("environment", environment)?;
        let meshes: Vec<&Mesh> = objects.iter().map(|o| &o.mesh).collect();
        let accel = Accel::new(&meshes);
        let mut scene = Scene { objects, materials, lights, environment, camera, accel };
        if let Some((lo, hi)) = scene.translucent_box() {
            let st = scene
                .materials
                .iter()
                .filter_map(|m| m.translucent())
                .map(|m| m.sigma_t_floor())
                .fold(f64::INFINITY, f64::min);
            let grid = DistanceGrid::new(&scene.accel.tris, lo, hi, st).with_band(&scene.accel.tris);
            scene.accel.cells = grid.cell_lists(&scene.accel.tris);
            scene.accel.distance = Some(grid);
        }
        if let Some(cam) = &scene.camera {
            if let Some(name) = scene.enclosing_object(cam.position) {
                return Err(Error::Invalid(format!(
                    "camera.position: the camera is inside {name}; move it outside the object"
                )));
            }
        }
        Ok(scene)
    }

    /// The bounding box (lo, hi) of the translucent objects (where walks run; None if there
    /// are none).
    pub fn translucent_box(&self) -> Option<(V3, V3)> {
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for o in self.objects.iter().filter(|o| matches!(self.materials[o.material], Material::Translucent(_))) {
            for p in &o.mesh.positions {
                lo = std::array::from_fn(|k| lo[k].min(p[k]));
                hi = std::array::from_fn(|k| hi[k].max(p[k]));
            }
        }
        (lo[0] <= hi[0]).then_some((lo, hi))
    }

    /// Warnings about lights that cannot light anything: a point, sphere or rectangle light inside
    /// a closed object (its light never leaves it).
    pub fn warnings(&self) -> Vec<String> {
        let mut out = vec![];
        for (i, l) in self.lights.iter().enumerate() {
            let at = match *l {
                Light::Point { position, .. } => position,
                Light::Sphere { center, .. } | Light::Rect { center, .. } => center,
                Light::Directional { .. } => continue,
            };
            if let Some(name) = self.enclosing_object(at) {
                out.push(format!("lights[{i}] is inside the closed object {name}: it lights nothing outside it"));
            }
        }
        out
    }

    /// The name of a closed object containing `p`, if any (majority of three parity counts).
    pub fn enclosing_object(&self, p: V3) -> Option<String> {
        for (oi, o) in self.objects.iter().enumerate() {
            if !o.mesh.closed {
                continue;
            }
            let votes =
                PARITY_DIRS.iter().filter(|&&d| self.crossings(p, super::math::normalize(d), oi) % 2 == 1).count();
            if votes >= 2 {
                return Some(o.name.clone());
            }
        }
        None
    }

    fn crossings(&self, p: V3, d: V3, object: usize) -> usize {
        let (mut o, mut skip, mut n) = (p, u32::MAX, 0);
        while let Some(h) = self.accel.intersect(o, d, f64::INFINITY, skip) {
            if h.object == object {
                n += 1;
            }
            o = h.p;
            skip = h.tri;
            if n > 100_000 {
                break;
            }
        }
        n
    }

    /// `Ok` if every translucent object's mesh is closed (random walks need an inside).
    pub fn require_closed_translucent(&self, method: &str) -> Result<()> {
        for o in &self.objects {
            if matches!(self.materials[o.material], Material::Translucent(_)) {
                o.mesh.require_closed(&o.name, method)?;
            }
        }
        Ok(())
    }

    /// Material of object `i`.
    #[inline]
    pub fn material(&self, object: usize) -> &Material {
        &self.materials[self.objects[object].material]
    }

    /// The nearest area-light emission along (o, d) before `tmax`.
    pub fn light_hit(&self, o: V3, d: V3, tmax: f64) -> Option<(f64, Rgb)> {
        let mut best: Option<(f64, Rgb)> = None;
        for l in &self.lights {
            if let Some((t, le)) = l.hit(o, d, best.map_or(tmax, |b| b.0)) {
                best = Some((t, le));
            }
        }
        best
    }

    /// Whether the unit direction `d` leaves through the front of the surface with normal `n`.
    #[inline]
    pub fn front(d: V3, n: V3) -> bool {
        dot(d, n) > 0.0
    }
}
