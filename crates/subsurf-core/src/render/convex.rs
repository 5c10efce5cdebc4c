//! A proof, at scene load, that the scene's triangles bound one convex body: then a straight
//! segment from a point inside to a point of a boundary facet crosses no other facet, and a ray
//! leaving a facet outwards meets nothing, so the facet connections of the random walk
//! ([`super::facet_nee`]) skip their verification and occlusion rays.
//!
//! The test (each part linear in the triangles):
//! 1. closed: every edge is shared by exactly two triangles ([`super::accel::Accel::neighbours`]);
//! 2. star-shaped about the vertex mean c: c lies strictly behind every triangle's plane
//!    (outward normals), so radial projection from c maps each triangle onto a spherical triangle
//!    of positive orientation, and the surface onto the sphere as a (branched) covering whose
//!    degree is the sum of those solid angles (Van Oosterom & Strackee 1983) over 4π; degree 1
//!    (a sum below 6π) makes the surface a radial graph about c: embedded, a topological sphere;
//! 3. locally convex: every neighbour's vertices lie on or behind each triangle's plane (every
//!    dihedral angle ≤ π).
//!
//! An embedded closed polyhedral surface whose dihedral angles are all ≤ π is locally convex at
//! its vertices as well (the link of a vertex is a simple spherical polygon with convex turns)
//! and so bounds a convex body (Tietze–Nakajima: a closed connected locally convex set is
//! convex). Tolerances are 10⁻¹² of the scene extent, below the ray tests' own margins
//! (10⁻¹⁰ of the extent).

use super::accel::{Accel, Tri};
use super::math::{add, cross, dot, length, madd, normalize, scale, sub, V3};

/// A proved convex body's facet lookup: the facet radially from an interior point c in each
/// cell of a cube map of directions (`CELLS`² per face), a first guess for [`Convex::facet_along`].
#[derive(Clone, Debug)]
pub struct Convex {
    c: V3,
    cells: Vec<u32>,
    /// The squared radius (mm²) of a ball about c that lies inside every facet's plane by more
    /// than [`PLANE_EPS`] of the extent: the nearest plane's distance less that margin (and a
    /// relative 10⁻⁹ for rounding). A point in it [`Convex::holds`] without a mesh walk.
    ball2: f64,
    /// The squared radius (mm²) of the circumscribed sphere about c (the farthest vertex).
    outer2: f64,
}

/// Plane refinements of [`Convex::facet_of_line`]'s first guess.
const REFINE: usize = 2;

/// Cells per cube-map face side. Measured on the 81,920-triangle benchmark sphere (callgrind,
/// docs/render.md "Random walk speed"): 32 → 64 cuts the mesh walks from a guess from about
/// 3.6 facets to about 2.
const CELLS: usize = 128;

/// Most facets [`Convex::facet_along`] visits.
const WALK_STEPS: usize = 64;

impl Convex {
    /// The lookup for `acc` when its triangles are one convex body (`bounds_convex_body`),
    /// else `None`. Each cell holds the facet the ray from c through the cell's centre leaves
    /// by, found by [`Self::facet_along`] from the previous cell's facet (a BVH ray for the
    /// first cell of a row, and wherever the walk fails): cheaper than a ray per cell.
    pub fn new(acc: &Accel) -> Option<Convex> {
        if !bounds_convex_body(&acc.tris, &acc.neighbours, acc.extent) {
            return None;
        }
        let c = vertex_mean(&acc.tris);
        let nearest = acc.tris.iter().map(|t| dot(t.n, sub(t.v0, c))).fold(f64::INFINITY, f64::min);
        let r = nearest * (1.0 - 1e-9) - 2.0 * PLANE_EPS * acc.extent;
        let ball2 = if r > 0.0 { r * r } else { 0.0 };
        let verts = acc.tris.iter().flat_map(|t| [t.v0, add(t.v0, t.e1), add(t.v0, t.e2)]);
        let outer2 = verts.map(|w| dot(sub(w, c), sub(w, c))).fold(0.0, f64::max);
        let mut cv = Convex { c, cells: Vec::with_capacity(6 * CELLS * CELLS), ball2, outer2 };
        for face in 0..6 {
            for j in 0..CELLS {
                let mut prev = None;
                for k in 0..CELLS {
                    let (a, b) = ((2 * j + 1) as f64 / CELLS as f64 - 1.0, (2 * k + 1) as f64 / CELLS as f64 - 1.0);
                    let s = if face % 2 == 0 { 1.0 } else { -1.0 };
                    let mut d = [0.0; 3];
                    let ax = face / 2;
                    (d[ax], d[(ax + 1) % 3], d[(ax + 2) % 3]) = (s, a, b);
                    let d = normalize(d);
                    let walked = prev.and_then(|f| cv.facet_along(acc, c, d, f));
                    let f = match walked {
                        Some(f) => f,
                        None => acc.intersect(c, d, f64::INFINITY, u32::MAX)?.tri,
                    };
                    cv.cells.push(f);
                    prev = Some(f);
                }
            }
        }
        Some(cv)
    }

    /// The facet in the cube-map cell of the direction from c to `p`.
    #[inline]
    pub fn guess(&self, p: V3) -> u32 {
        let d = sub(p, self.c);
        let a = [d[0].abs(), d[1].abs(), d[2].abs()];
        let ax = if a[0] > a[1] && a[0] > a[2] {
            0
        } else if a[1] > a[2] {
            1
        } else {
            2
        };
        let face = 2 * ax + usize::from(d[ax] < 0.0);
        // (x/m + 1)·C/2 for a coordinate x of the face with |x| ≤ m = |d[ax]|; the f64 → i32
        // cast saturates (and maps NaN to 0), the clamp keeps it in the face.
        let half = 0.5 * CELLS as f64;
        let inv = half / a[ax].max(1e-300);
        let cell = |x: f64| ((x * inv + half) as i32).clamp(0, CELLS as i32 - 1) as usize;
        self.cells[(face * CELLS + cell(d[(ax + 1) % 3])) * CELLS + cell(d[(ax + 2) % 3])]
    }

    /// Whether `p` lies inside the body by more than 10⁻¹² of the extent: in the inscribed ball
    /// (behind every facet's plane), else behind the plane of the facet that the ray from c
    /// through `p` leaves by (c is inside, and that ray crosses the surface once). False where
    /// the walk fails. Measured on the 81,920-triangle benchmark sphere (docs/render.md, "Random
    /// walk speed"): the ball answers nearly every call of a walk, without the mesh walk's
    /// chain of dependent loads.
    #[inline]
    pub fn holds(&self, acc: &Accel, p: V3) -> bool {
        let d = sub(p, self.c);
        let l2 = dot(d, d);
        l2 < self.ball2 || self.holds_walked(acc, p, d, l2)
    }

    /// [`Self::holds`] outside the inscribed ball, for `d` = p − c (|d|² = `l2`).
    fn holds_walked(&self, acc: &Accel, p: V3, d: V3, l2: f64) -> bool {
        let l = l2.sqrt();
        if !(l > 0.0) {
            return true;
        }
        let Some(g) = self.facet_along(acc, self.c, scale(d, 1.0 / l), self.guess(p)) else { return false };
        let t = &acc.tris[g as usize];
        dot(t.n, sub(p, t.v0)) < -PLANE_EPS * acc.extent
    }

    /// [`Self::facet_along`] from a first guess: the cube-map cell of the line's exit from the
    /// circumscribed sphere about c (the body lies between it and the inscribed ball, so on a
    /// round body that point is next to the facet crossed), refined `REFINE` times by the
    /// crossing with the guessed facet's plane (a body far from round: a box).
    pub fn facet_of_line(&self, acc: &Accel, v: V3, dir: V3) -> Option<u32> {
        let w = sub(v, self.c);
        let b = dot(w, dir);
        let s = -b + (b * b - dot(w, w) + self.outer2).max(0.0).sqrt();
        let mut g = self.guess(madd(v, dir, s));
        for _ in 0..REFINE {
            let t = &acc.tris[g as usize];
            let s = dot(sub(t.v0, v), t.n) / dot(dir, t.n);
            if !(s > 0.0 && s.is_finite()) {
                break;
            }
            g = self.guess(madd(v, dir, s));
        }
        self.facet_along(acc, v, dir, g)
    }

    /// The facet that the line from `v` (inside) along `dir` crosses, walking from facet `from`
    /// across an edge the line passes beyond: edge k of a facet (vertices k, k + 1, relative to
    /// v: P_k, P_k₊₁) has the line beyond it where det(P_k, P_k₊₁, dir) < 0 (each determinant
    /// is the barycentric coordinate opposite the edge times a positive volume); the walk takes
    /// the least. Radial projection from v maps the convex surface one to one onto the sphere,
    /// so the facet found is the one crossed. `None` after `WALK_STEPS` facets.
    pub fn facet_along(&self, acc: &Accel, v: V3, dir: V3, from: u32) -> Option<u32> {
        let mut f = from;
        for _ in 0..WALK_STEPS {
            let t = &acc.tris[f as usize];
            let p = [sub(t.v0, v), sub(add(t.v0, t.e1), v), sub(add(t.v0, t.e2), v)];
            let s: [f64; 3] = std::array::from_fn(|k| dot(cross(p[k], p[(k + 1) % 3]), dir));
            // The first least s[k] (as `min_by` with `total_cmp`), by selects, not branches.
            let k01 = usize::from(s[1].total_cmp(&s[0]).is_lt());
            let k = if s[2].total_cmp(&s[k01]).is_lt() { 2 } else { k01 };
            if s[k] >= 0.0 {
                return Some(f);
            }
            f = t.nb[k];
        }
        None
    }
}

fn vertex_mean(tris: &[Tri]) -> V3 {
    scale(tris.iter().fold([0.0; 3], |s, t| add(s, t.v0)), 1.0 / tris.len() as f64)
}

/// Relative tolerance (of the extent) of the plane tests.
const PLANE_EPS: f64 = 1e-12;

/// Whether `tris` (with their edge `neighbours`, `u32::MAX` where an edge is not shared by
/// exactly two) bound one convex body (module docs). `extent`: the bounding-box diagonal, mm.
pub fn bounds_convex_body(tris: &[Tri], neighbours: &[[u32; 3]], extent: f64) -> bool {
    if tris.len() < 4 || neighbours.iter().any(|nb| nb.contains(&u32::MAX)) {
        return false;
    }
    let verts = |t: &Tri| [t.v0, add(t.v0, t.e1), add(t.v0, t.e2)];
    let c = vertex_mean(tris);
    let tol = PLANE_EPS * extent;
    let mut solid = 0.0;
    for (t, nb) in tris.iter().zip(neighbours) {
        if dot(t.n, sub(t.v0, c)) <= tol {
            return false;
        }
        let behind = |w: V3| dot(t.n, sub(w, t.v0)) <= tol;
        if !nb.iter().all(|&o| verts(&tris[o as usize]).into_iter().all(behind)) {
            return false;
        }
        solid += solid_angle(verts(t).map(|w| sub(w, c)));
    }
    solid < 6.0 * std::f64::consts::PI
}

/// The solid angle of the triangle (a, b, c) seen from the origin (Van Oosterom & Strackee
/// 1983: tan(Ω/2) = a·(b×c) / (|a||b||c| + (a·b)|c| + (a·c)|b| + (b·c)|a|)), signed by the
/// orientation.
fn solid_angle([a, b, c]: [V3; 3]) -> f64 {
    let (la, lb, lc) = (length(a), length(b), length(c));
    let num = dot(a, cross(b, c));
    let den = la * lb * lc + dot(a, b) * lc + dot(a, c) * lb + dot(b, c) * la;
    2.0 * num.atan2(den)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::accel::Accel;
    use crate::render::mesh::Mesh;
    use crate::render::shapes::{icosphere, torus};

    fn convex(meshes: &[&Mesh]) -> bool {
        Accel::new(meshes).convex.is_some()
    }

    /// Spheres and a box are convex; a torus, a dented sphere, an open mesh and two spheres are
    /// not.
    #[test]
    fn convexity_proof_accepts_convex_bodies_only() {
        let s = icosphere([1.0, 2.0, 3.0], 4.0, 3).unwrap();
        assert!(convex(&[&s]) && convex(&[&icosphere([0.0; 3], 1.0, 0).unwrap()]));
        let cube = crate::render::shapes::cuboid([0.0; 3], [2.0, 1.0, 3.0]).unwrap();
        assert!(convex(&[&cube]), "flat faces split in two triangles (dihedral π)");
        assert!(!convex(&[&torus([0.0; 3], 7.0, 3.0, 32, 16).unwrap()]));
        let mut dent = s.clone();
        let p = dent.positions[0];
        dent.positions[0] = [1.0 + 0.97 * (p[0] - 1.0), 2.0 + 0.97 * (p[1] - 2.0), 3.0 + 0.97 * (p[2] - 3.0)];
        assert!(!convex(&[&Mesh::new("dent", dent.positions, dent.triangles, None).unwrap()]));
        let open: Vec<[u32; 3]> = s.triangles[1..].to_vec();
        assert!(!convex(&[&Mesh::new("open", s.positions.clone(), open, None).unwrap()]));
        assert!(!convex(&[&s, &icosphere([20.0, 0.0, 0.0], 1.0, 2).unwrap()]));
    }

    /// The ray-free paths give what the BVH gives: the walk's segments from inside and from a
    /// facet (`Accel::intersect_walk` against `Accel::intersect`), and the facet connections
    /// (`facet_nee::points` with and without the convex lookup) to points of a light above, and
    /// shadow rays from a facet (`Accel::occluded`); on a tessellated sphere and on a box
    /// (coplanar facet pairs).
    #[test]
    fn convex_paths_match_the_bvh() {
        let cuboid = crate::render::shapes::cuboid([-4.0, -3.0, -5.0], [4.0, 3.0, 5.0]).unwrap();
        for (k, mesh) in [icosphere([0.0; 3], 5.0, 3).unwrap(), cuboid].into_iter().enumerate() {
            convex_paths_match_the_bvh_on(mesh, 7 + k as u64);
        }
    }

    fn convex_paths_match_the_bvh_on(mesh: Mesh, seed: u64) {
        use crate::render::facet_nee::points;
        use crate::render::material::{Material, Translucent};
        use crate::render::scene::{Object, Scene};
        use crate::render::walk::Media;
        let sc = || {
            let m = Translucent::new("m", [0.1; 3], [1.0, 1.5, 2.0], 0.0, 1.4, None, false).unwrap();
            let o = Object { name: "o".into(), mesh: mesh.clone(), material: 0 };
            Scene::new(vec![o], vec![Material::Translucent(Box::new(m))], vec![], [0.0; 3], None).unwrap()
        };
        let (a, mut b) = (sc(), sc());
        b.accel.convex = None;
        assert!(a.accel.convex.is_some());
        let (acc, media) = (&a.accel, Media::inside(0));
        let mut rng = crate::rng::PhotonRng::new(seed, 6);
        let (mut hits, mut found) = (0, 0);
        for _ in 0..3_000 {
            let d = crate::optics::sample_uniform_sphere(rng.uniform(), rng.uniform());
            let o = scale([rng.symmetric(), rng.symmetric(), rng.symmetric()], 2.8);
            let s = 6.0 * rng.uniform();
            let (w, r) = (acc.intersect_walk(o, d, s, u32::MAX, &mut false, 0.0), acc.intersect(o, d, s, u32::MAX));
            assert_eq!(w.map(|h| (h.tri, h.t)), r.map(|h| (h.tri, h.t)), "{o:?} {d:?} {s}");
            let Some(h) = acc.intersect(o, d, f64::INFINITY, u32::MAX) else { panic!("closed") };
            let back = crate::optics::sample_uniform_sphere(rng.uniform(), rng.uniform());
            let inward = if dot(back, h.n) < 0.0 { back } else { scale(back, -1.0) };
            let (w, r) =
                (acc.intersect_walk(h.p, inward, s, h.tri, &mut false, 0.0), acc.intersect(h.p, inward, s, h.tri));
            assert_eq!(w.map(|h| (h.tri, h.t)), r.map(|h| (h.tri, h.t)), "from facet {}", h.tri);
            // a shadow ray leaving the facet outwards (from the offset point, as the shading
            // code casts it): `occluded`'s convex answer is the BVH's
            let out = scale(inward, -1.0);
            let p = acc.offset(h.p, h.n, 1.0);
            assert!(!acc.occluded(p, out, 50.0, h.tri) && !b.accel.occluded(p, out, 50.0, h.tri), "facet {}", h.tri);
            // and inwards (not answered by the shortcut): both see the far side
            let q = acc.offset(h.p, h.n, -1.0);
            assert_eq!(acc.occluded(q, inward, 50.0, h.tri), b.accel.occluded(q, inward, 50.0, h.tri));
            hits += usize::from(r.is_some());
            let y = [8.0 * rng.symmetric(), 8.0 * rng.symmetric(), 7.0];
            let v = scale(o, 1.7);
            let (pa, pb) = (points(&a, &media, v, y), points(&b, &media, v, y));
            for (ca, cb) in pa.iter().zip(&pb) {
                assert_eq!(ca.is_some(), cb.is_some(), "{v:?} {y:?}");
                if let (Some(ca), Some(cb)) = (ca, cb) {
                    found += 1;
                    assert!(ca.hit.tri == cb.hit.tri && length(sub(ca.hit.p, cb.hit.p)) < 1e-9);
                    assert!((ca.tau[2] / cb.tau[2] - 1.0).abs() < 1e-9 && (ca.factor / cb.factor - 1.0).abs() < 1e-9);
                }
            }
        }
        assert!(hits > 500 && found > 500, "{hits} hits, {found} connections");
    }
}
