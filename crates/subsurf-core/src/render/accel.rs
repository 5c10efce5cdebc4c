//! Ray–scene intersection: every triangle of every object in one BVH.
//!
//! The BVH is `obvhs`'s compressed 8-wide BVH (Ylitie et al. 2017, built by PLOC), chosen over
//! the `bvh` crate (0.13) after a measured comparison on a 1.1·10⁵-triangle mesh, one thread:
//! 5.7–6.4·10⁵ vs 2.1–2.2·10⁵ incoherent rays/s and 0.8–1.2·10⁶ vs 3.3·10⁵ camera rays/s
//! (docs/render.md). The BVH works in f32; each candidate triangle is tested here in f64
//! (Möller & Trumbore 1997) on padded boxes, so the hit points the physics sees are f64 exact
//! to rounding and a ray cannot slip between the f32 boxes of neighbouring triangles.

use super::distance::DistanceGrid;
use super::math::{add, cross, dot, length, madd, normalize, scale, sub, V3};
use super::mesh::Mesh;
use glam::Vec3A;
use obvhs::aabb::Aabb;
use obvhs::cwbvh::builder::build_cwbvh;
use obvhs::cwbvh::CwBvh;
use obvhs::ray::{Ray, RayHit};
use obvhs::{Boundable, BvhBuildParams};

/// One triangle prepared for intersection, aligned to a 64-byte cache line: each of the
/// random accesses of the rays and the mesh walks ([`super::convex`]) reads two lines (with its
/// edge neighbours), where the 104-byte triangles unaligned, with the neighbours in an array of
/// their own, took three on average.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub struct Tri {
    pub v0: V3,
    pub e1: V3,
    pub e2: V3,
    /// Unit geometric normal (outward for closed meshes).
    pub n: V3,
    /// Index of the object (mesh) it belongs to.
    pub object: u32,
    /// Index of the triangle within its mesh.
    pub local: u32,
    /// The triangles sharing each edge ([`Accel::neighbours`]).
    pub nb: [u32; 3],
}

struct Padded(Aabb);
impl Boundable for Padded {
    fn aabb(&self) -> Aabb {
        self.0
    }
}

/// A ray–triangle hit.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    /// Distance along the (unit) ray direction, mm.
    pub t: f64,
    /// Global triangle index.
    pub tri: u32,
    /// Object index.
    pub object: usize,
    /// Barycentrics of v1 and v2.
    pub b1: f64,
    pub b2: f64,
    /// Hit point, mm.
    pub p: V3,
    /// Unit geometric normal of the triangle (outward).
    pub n: V3,
}

/// The scene's triangles and their BVH.
pub struct Accel {
    pub tris: Vec<Tri>,
    bvh: CwBvh,
    /// Scene extent (mm): the diagonal of the bounding box, for epsilons.
    pub extent: f64,
    /// Bounding box of all triangles, mm.
    pub lo: V3,
    pub hi: V3,
    /// A conservative distance-to-surface bound over the translucent objects (set by
    /// [`super::scene::Scene::new`]; None: every collision casts its ray).
    pub distance: Option<DistanceGrid>,
    /// Per triangle, the triangles of the same object sharing each edge (v0v1, v1v2, v2v0;
    /// `u32::MAX` where there is none or more than one).
    pub neighbours: Vec<[u32; 3]>,
    /// The triangles are one mesh that bounds a convex body ([`super::convex`], proved at
    /// build): a segment from inside to a facet point crosses no other facet, and a ray
    /// leaving a facet outwards meets nothing.
    pub convex: Option<super::convex::Convex>,
    /// Per-cell triangle lists on the distance grid's cells ([`super::cells`]; set with
    /// [`Self::distance`]): the walk's short rays without the BVH.
    pub cells: Option<super::cells::CellLists>,
    /// Per triangle, whether its plane supports the scene: every triangle lies on or behind it
    /// (within [`HULL_EPS`] of the extent), so a ray leaving it outwards meets nothing
    /// ([`hull_facets`]; empty where not computed, or for a convex body, [`Self::convex`]).
    pub hull: Vec<bool>,
}

/// The tolerance of [`Accel::hull`], relative to the extent: a vertex this far in front of a
/// facet's plane still counts as behind it.
pub const HULL_EPS: f64 = 1e-13;

/// The least cosine to the facet normal of a ray that [`Accel::hull`] answers: its points past
/// the rays' least distance (10⁻¹⁰ of the extent) are then more than [`HULL_EPS`] (and any
/// rounding of the origin) in front of the plane, where no triangle lies.
const HULL_COS: f64 = 2e-3;

/// Per triangle, whether every vertex of `tris` lies on or behind its plane (within `tol`, mm):
/// the vertices are binned into boxes (8 per axis of the bounding box) and a box whose farthest
/// corner along the normal is behind the plane needs no vertex test.
pub fn hull_facets(tris: &[Tri], lo: V3, hi: V3, tol: f64) -> Vec<bool> {
    const K: usize = 8;
    let size: V3 = std::array::from_fn(|a| (hi[a] - lo[a]).max(1e-300));
    let mut bins: Vec<(V3, V3, Vec<V3>)> = vec![([f64::INFINITY; 3], [f64::NEG_INFINITY; 3], vec![]); K * K * K];
    for t in tris {
        for p in [t.v0, add(t.v0, t.e1), add(t.v0, t.e2)] {
            let c: [usize; 3] = std::array::from_fn(|a| (((p[a] - lo[a]) / size[a] * K as f64) as usize).min(K - 1));
            let b = &mut bins[(c[0] * K + c[1]) * K + c[2]];
            b.0 = std::array::from_fn(|a| b.0[a].min(p[a]));
            b.1 = std::array::from_fn(|a| b.1[a].max(p[a]));
            b.2.push(p);
        }
    }
    bins.retain(|b| !b.2.is_empty());
    tris.iter()
        .map(|t| {
            let top = dot(t.v0, t.n) + tol;
            bins.iter().all(|(bl, bh, ps)| {
                let far: f64 = (0..3).map(|a| (bl[a] * t.n[a]).max(bh[a] * t.n[a])).sum();
                far <= top || ps.iter().all(|&p| dot(p, t.n) <= top)
            })
        })
        .collect()
}

impl Accel {
    /// Build over `meshes` (object index = position in the slice). Zero-area triangles are kept
    /// out of the BVH (they cannot be hit).
    pub fn new(meshes: &[&Mesh]) -> Accel {
        let mut tris = Vec::new();
        // (object, lower vertex, higher vertex) of every edge, with its triangle and side.
        let mut edges: Vec<([u32; 3], u32, u8)> = Vec::new();
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for (o, m) in meshes.iter().enumerate() {
            for i in 0..m.triangles.len() {
                let [a, b, c] = m.vertices(i);
                let (e1, e2) = (sub(b, a), sub(c, a));
                let nn = cross(e1, e2);
                if !(length(nn) > 0.0) {
                    continue;
                }
                let vi = m.triangles[i];
                for k in 0..3 {
                    let (x, y) = (vi[k], vi[(k + 1) % 3]);
                    edges.push(([o as u32, x.min(y), x.max(y)], tris.len() as u32, k as u8));
                }
                for p in [a, b, c] {
                    for k in 0..3 {
                        lo[k] = lo[k].min(p[k]);
                        hi[k] = hi[k].max(p[k]);
                    }
                }
                tris.push(Tri {
                    v0: a,
                    e1,
                    e2,
                    n: normalize(nn),
                    object: o as u32,
                    local: i as u32,
                    nb: [u32::MAX; 3],
                });
            }
        }
        // Edges shared by exactly two triangles, by sorting (as a hash map of edges would).
        edges.sort_unstable();
        let mut neighbours = vec![[u32::MAX; 3]; tris.len()];
        for run in edges.chunk_by(|a, b| a.0 == b.0) {
            if let [(_, p, kp), (_, q, kq)] = *run {
                neighbours[p as usize][kp as usize] = q;
                neighbours[q as usize][kq as usize] = p;
            }
        }
        for (t, nb) in tris.iter_mut().zip(&neighbours) {
            t.nb = *nb;
        }
        let extent = length(sub(hi, lo)).max(1e-12);
        let pad = (extent * 1e-6) as f32;
        let boxes: Vec<Padded> = tris
            .iter()
            .map(|t| {
                let mut bb = Aabb::empty();
                for p in [t.v0, madd(t.v0, t.e1, 1.0), madd(t.v0, t.e2, 1.0)] {
                    bb.extend(Vec3A::new(p[0] as f32, p[1] as f32, p[2] as f32));
                }
                Padded(Aabb::new(bb.min - Vec3A::splat(pad), bb.max + Vec3A::splat(pad)))
            })
            .collect();
        let bvh = build_cwbvh(&boxes, BvhBuildParams::medium_build(), &mut std::time::Duration::default());
        let mut acc =
            Accel { tris, bvh, extent, lo, hi, distance: None, neighbours, convex: None, cells: None, hull: vec![] };
        if meshes.len() == 1 {
            acc.convex = super::convex::Convex::new(&acc);
        }
        if acc.convex.is_none() {
            acc.hull = hull_facets(&acc.tris, lo, hi, HULL_EPS * extent);
        }
        acc
    }

    /// Möller–Trumbore in f64: (t, b1, b2) for a hit with t in (tmin, tmax), else None.
    #[inline(always)]
    pub(super) fn test(&self, i: usize, o: V3, d: V3, tmin: f64, tmax: f64) -> Option<(f64, f64, f64)> {
        let tr = &self.tris[i];
        let p = cross(d, tr.e2);
        let det = dot(tr.e1, p);
        if det == 0.0 {
            return None;
        }
        let inv = 1.0 / det;
        let s = sub(o, tr.v0);
        let b1 = dot(s, p) * inv;
        if !(0.0..=1.0).contains(&b1) {
            return None;
        }
        let q = cross(s, tr.e1);
        let b2 = dot(d, q) * inv;
        if b2 < 0.0 || b1 + b2 > 1.0 {
            return None;
        }
        let t = dot(tr.e2, q) * inv;
        (t > tmin && t < tmax).then_some((t, b1, b2))
    }

    /// Closest hit along the unit direction `d` from `o` with t < `tmax`, ignoring triangle
    /// `skip` (the one the ray starts on, `u32::MAX` for none). A ray leaving a facet of a convex
    /// body outwards ([`Self::convex`]) meets nothing: no traversal.
    pub fn intersect(&self, o: V3, d: V3, tmax: f64, skip: u32) -> Option<Hit> {
        if self.escapes(d, skip) {
            return None;
        }
        let tmin = self.extent * 1e-10;
        let ray = Ray::new(vec3(o), dir3(d), 0.0, tmax.min(f32::MAX as f64) as f32);
        let mut rh = RayHit::none();
        let mut best: Option<(f64, usize, f64, f64)> = None;
        let mut tbest = tmax;
        self.bvh.ray_traverse(ray, &mut rh, |_r, id| {
            let i = self.bvh.primitive_indices[id] as usize;
            if i as u32 == skip {
                return f32::INFINITY;
            }
            match self.test(i, o, d, tmin, tbest) {
                Some((t, b1, b2)) => {
                    tbest = t;
                    best = Some((t, i, b1, b2));
                    (t as f32).next_up()
                }
                None => f32::INFINITY,
            }
        });
        best.map(|(t, i, b1, b2)| self.hit(o, d, t, i as u32, b1, b2))
    }

    /// The [`Hit`] at distance `t` along `d` from `o` on global triangle `i`.
    #[inline]
    pub(super) fn hit(&self, o: V3, d: V3, t: f64, i: u32, b1: f64, b2: f64) -> Hit {
        let tr = &self.tris[i as usize];
        Hit { t, tri: i, object: tr.object as usize, b1, b2, p: madd(o, d, t), n: tr.n }
    }

    /// [`Self::intersect`] for a walk's ray: in a scene that is one convex body
    /// ([`super::convex::Convex`]) and from a point inside it (`skip` = `u32::MAX`: by
    /// [`super::convex::Convex::holds`]; on facet `skip`: heading inwards) the one facet the line
    /// crosses, if the segment's end is not inside too, is found by walking the mesh from the
    /// cube-map cell of the end, and
    /// tested as the BVH traversal tests it (the same hit, to which of two facets an edge
    /// belongs); everywhere else, and where that test fails at an edge, by the BVH.
    /// `held`: the walk's memo that `o` was shown inside (`holds`) — by the previous call, for
    /// the end it returned no hit for (the walk's next start, the same point), kept by the walk
    /// across free paths that `segment_clear` clears; set here for the end when it holds.
    /// Elsewhere the per-cell triangle lists ([`super::cells`]) answer where they can, starting
    /// at `free` (mm; no triangle lies on the ray before it: [`Self::segment_free_in`]), with
    /// the BVH's hit; the BVH answers the rest.
    pub fn intersect_walk(&self, o: V3, d: V3, tmax: f64, skip: u32, held: &mut bool, free: f64) -> Option<Hit> {
        let known = std::mem::replace(held, false);
        if let Some(cv) = &self.convex {
            let inside =
                if skip == u32::MAX { known || cv.holds(self, o) } else { dot(d, self.tris[skip as usize].n) < 0.0 };
            let end = madd(o, d, tmax.min(self.extent));
            if inside && tmax <= self.extent && cv.holds(self, end) {
                *held = true;
                return None; // both ends inside a convex body: so is the segment
            }
            if let Some(f) = inside.then(|| cv.facet_along(self, o, d, cv.guess(end))).flatten().filter(|&f| f != skip)
            {
                if let Some((t, b1, b2)) = self.test(f as usize, o, d, self.extent * 1e-10, f64::INFINITY) {
                    return (t < tmax).then(|| self.hit(o, d, t, f, b1, b2));
                }
            }
        }
        if let Some(found) = self.cells.as_ref().and_then(|c| c.closest(self, o, d, tmax, skip, free)) {
            return found.map(|(t, i, b1, b2)| self.hit(o, d, t, i, b1, b2));
        }
        self.intersect(o, d, tmax, skip)
    }

    /// Whether a ray from a point of triangle `skip` along `d` is known to meet nothing without a
    /// traversal: it leaves a convex body's facet outwards, or a facet whose plane supports the
    /// scene.
    #[inline]
    pub fn escapes(&self, d: V3, skip: u32) -> bool {
        (self.convex.is_some() && skip != u32::MAX && dot(d, self.tris[skip as usize].n) > 0.0)
            || self.leaves_hull(d, skip)
    }

    /// Whether a ray from a point of triangle `skip` along `d` leaves it outwards through a plane
    /// that supports the scene ([`Self::hull`]): it meets nothing.
    #[inline]
    fn leaves_hull(&self, d: V3, skip: u32) -> bool {
        skip != u32::MAX
            && self.hull.get(skip as usize).copied().unwrap_or(false)
            && dot(d, self.tris[skip as usize].n) > HULL_COS
    }

    /// Whether anything blocks the segment from `o` along `d` up to distance `tmax` (nothing
    /// where it leaves triangle `skip` outwards through a plane that supports the scene, or a
    /// facet of a convex body outwards, as [`Self::intersect`]: no traversal. The hierarchical
    /// set-up's shadow rays from a sphere were a fifth of its time).
    pub fn occluded(&self, o: V3, d: V3, tmax: f64, skip: u32) -> bool {
        if self.convex.is_some() && skip != u32::MAX && dot(d, self.tris[skip as usize].n) > 0.0 {
            return false;
        }
        if self.leaves_hull(d, skip) {
            return false;
        }
        let tmin = self.extent * 1e-10;
        let ray = Ray::new(vec3(o), dir3(d), 0.0, tmax.min(f32::MAX as f64) as f32);
        let mut found = false;
        self.bvh.ray_traverse_anyhit(ray, |_r, id| {
            if found {
                return;
            }
            let i = self.bvh.primitive_indices[id] as usize;
            if i as u32 != skip && self.test(i, o, d, tmin, tmax).is_some() {
                found = true;
            }
        });
        found
    }

    /// Centre of the bounding box.
    pub fn center(&self) -> V3 {
        scale(add(self.lo, self.hi), 0.5)
    }

    /// The point at barycentrics (b1, b2) of global triangle `i`.
    pub fn point(&self, i: usize, b1: f64, b2: f64) -> V3 {
        let t = &self.tris[i];
        madd(madd(t.v0, t.e1, b1), t.e2, b2)
    }

    /// Area of global triangle `i`, mm².
    pub fn area(&self, i: usize) -> f64 {
        0.5 * length(cross(self.tris[i].e1, self.tris[i].e2))
    }

    /// A distance (mm) from `p` within which no triangle lies (0 when unknown): the grid's
    /// bound from its marked cells ([`DistanceGrid::cell_bound`]), on which the next-event
    /// decisions' probabilities were tuned.
    #[inline]
    pub fn clear_radius(&self, p: V3) -> f64 {
        self.distance.as_ref().map_or(0.0, |g| g.cell_bound(p))
    }

    /// Whether no triangle lies on the segment from `p` along the unit `d` to distance `s`, by
    /// the distance bound alone (false when it cannot tell): sphere tracing (Hart 1996) with
    /// the conservative bound, forward from `p` and one ball back from the end. Each ball
    /// B(p + tᵢd, rᵢ), rᵢ = bound there, holds no surface point, so the balls at
    /// t₀ = 0, tᵢ₊₁ = tᵢ + rᵢ cover [0, t_k] and the end's ball [s − r_end, s]: once
    /// t_k ≥ s − r_end the segment is clear. At most [`Self::TRACE_STEPS`] forward lookups.
    #[inline]
    pub fn segment_clear(&self, p: V3, d: V3, s: f64) -> bool {
        let mut ball = Ball::NONE;
        self.segment_clear_in(&mut ball, p, d, s)
    }

    /// [`Self::segment_clear`] with a ball known free of surfaces (`ball`: from an earlier
    /// lookup of the same walk): a segment whose two ends lie in it is clear without a lookup
    /// (a ball is convex); otherwise `ball` becomes B(p, bound at p) and the segment is traced.
    /// The same answer wherever the ball decides (it only says clear where a segment is), so
    /// the walk takes the same path; a deep walker (mean free path ≪ bound) keeps its ball for
    /// many collisions.
    #[inline]
    pub fn segment_clear_in(&self, ball: &mut Ball, p: V3, d: V3, s: f64) -> bool {
        self.segment_free_in(ball, p, d, s) >= s
    }

    /// [`Self::segment_clear_in`] as a distance: `s` when the segment is clear, else a distance
    /// f < `s` such that no triangle lies on the segment from `p` along `d` to f (the balls
    /// traced forward; 0 when nothing is known) — where a ray cast for the segment may start
    /// looking ([`Self::intersect_walk`]).
    #[inline(always)]
    pub fn segment_free_in(&self, ball: &mut Ball, p: V3, d: V3, s: f64) -> f64 {
        let Some(g) = &self.distance else { return 0.0 };
        if s.is_finite() && ball.holds(p) && ball.holds(madd(p, d, s)) {
            return s;
        }
        let mut t = g.bound(p);
        *ball = Ball { c: p, r2: t * t };
        if t >= s {
            return s;
        }
        if !(t > 0.0 && s.is_finite()) {
            return t.max(0.0);
        }
        let r_end = g.bound(madd(p, d, s));
        for _ in 0..Self::TRACE_STEPS {
            if t + r_end >= s {
                return s;
            }
            let r = g.bound(madd(p, d, t));
            if !(r > 0.0) {
                return t;
            }
            t += r;
        }
        if t + r_end >= s {
            s
        } else {
            t
        }
    }

    /// Whether `p` lies in the box of the distance grid (the translucent objects' bounding box,
    /// padded; true without a grid): a walk's collision outside it has leaked out of its mesh.
    #[inline]
    pub fn in_walk_box(&self, p: V3) -> bool {
        self.distance.as_ref().is_none_or(|g| g.contains(p))
    }

    /// Most forward bound lookups of [`Self::segment_clear`].
    pub const TRACE_STEPS: usize = 3;

    /// Offset a surface point by a few ulps of the scene extent along `n` (`side` = ±1).
    #[inline]
    pub fn offset(&self, p: V3, n: V3, side: f64) -> V3 {
        madd(p, scale(n, side), self.extent * 1e-9)
    }
}

/// A ball (centre, squared radius in mm²) that holds no surface point: a bound of
/// [`super::distance`] at its centre.
#[derive(Clone, Copy, Debug)]
pub struct Ball {
    c: V3,
    r2: f64,
}

impl Ball {
    /// The empty ball (holds nothing).
    pub const NONE: Ball = Ball { c: [0.0; 3], r2: -1.0 };

    /// Whether `q` lies in the ball (strictly within the bound's radius).
    #[inline]
    fn holds(&self, q: V3) -> bool {
        let v = sub(q, self.c);
        dot(v, v) < self.r2
    }
}

#[inline]
fn vec3(v: V3) -> Vec3A {
    Vec3A::new(v[0] as f32, v[1] as f32, v[2] as f32)
}

/// A direction for the f32 box tests with no zero component: obvhs' compressed-node slab test
/// turns 0 · ∞ into NaN (a ray with an exactly zero component, e.g. along a facet normal
/// (0, −0.9, −0.4), missed every box). The offset (1e-9) is far below the box padding.
#[inline]
fn dir3(d: V3) -> Vec3A {
    let f = |x: f64| if x.abs() < 1e-9 { 1e-9f64.copysign(x) as f32 } else { x as f32 };
    Vec3A::new(f(d[0]), f(d[1]), f(d[2]))
}

/// Closest-hit rays per second on one thread for `n` rays from random points inside the
/// bounding box's inner half in uniform directions (the random walk's rays), and for `n`
/// rays from outside towards the centre (camera-like). For `make bench`.
pub fn rays_per_second(acc: &Accel, n: usize, seed: u64) -> (f64, f64) {
    let mut rng = crate::rng::PhotonRng::new(seed, 0);
    let c = acc.center();
    let half = scale(sub(acc.hi, acc.lo), 0.25);
    let inside: Vec<(V3, V3)> = (0..n)
        .map(|_| {
            let o =
                [c[0] + half[0] * rng.symmetric(), c[1] + half[1] * rng.symmetric(), c[2] + half[2] * rng.symmetric()];
            (o, crate::optics::sample_uniform_sphere(rng.uniform(), rng.uniform()))
        })
        .collect();
    let eye = madd(c, [0.0, -1.0, 0.3], 2.0 * acc.extent);
    let cam: Vec<(V3, V3)> = (0..n)
        .map(|_| {
            let target = [c[0] + half[0] * 2.0 * rng.symmetric(), c[1], c[2] + half[2] * 2.0 * rng.symmetric()];
            (eye, normalize(sub(target, eye)))
        })
        .collect();
    let time = |rays: &[(V3, V3)]| {
        let t0 = std::time::Instant::now();
        let hits = rays.iter().filter(|(o, d)| acc.intersect(*o, *d, f64::INFINITY, u32::MAX).is_some()).count();
        std::hint::black_box(hits);
        rays.len() as f64 / t0.elapsed().as_secs_f64()
    };
    (time(&inside), time(&cam))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::shapes::icosphere;

    #[test]
    fn rays_from_inside_a_sphere_hit_it_once_at_the_radius() {
        let m = icosphere([0.0; 3], 2.0, 4).unwrap();
        let acc = Accel::new(&[&m]);
        let mut rng = crate::rng::PhotonRng::new(1, 2);
        for _ in 0..20_000 {
            let d = crate::optics::sample_uniform_sphere(rng.uniform(), rng.uniform());
            let o = scale([rng.symmetric(), rng.symmetric(), rng.symmetric()], 0.5);
            let h = acc.intersect(o, d, f64::INFINITY, u32::MAX).expect("a closed sphere cannot be missed");
            let r = length(h.p);
            assert!(r <= 2.0 + 1e-12 && r > 2.0 * 0.99, "{r}");
            assert!(dot(h.n, d) > 0.0, "the exit face points along the ray");
            assert!(!acc.occluded(o, d, h.t * (1.0 - 1e-9), u32::MAX));
            assert!(acc.occluded(o, d, h.t * (1.0 + 1e-9), u32::MAX));
        }
        // Edge neighbours of a closed mesh: three per triangle, mutual, sharing an edge.
        for (g, nb) in acc.neighbours.iter().enumerate() {
            for (k, &o) in nb.iter().enumerate() {
                assert!(o != u32::MAX && acc.neighbours[o as usize].contains(&(g as u32)), "{g} {nb:?}");
                assert_eq!(acc.tris[g].nb[k], o, "the triangle's copy of its neighbours");
                let (t, u) = (m.triangles[g], m.triangles[o as usize]);
                assert!(u.contains(&t[k]) && u.contains(&t[(k + 1) % 3]), "edge {k} of {g}");
            }
        }
        // Directions with exactly zero components (axis-aligned and facet normals).
        for d in [[0.0, 0.0, 1.0], [-0.0, -0.8960683512224559, -0.4439161068687069], [1.0, 0.0, -0.0]] {
            let d = normalize(d);
            assert!(acc.intersect([0.1, -0.2, 0.05], d, f64::INFINITY, u32::MAX).is_some(), "{d:?}");
        }
    }
    /// Rays leaving a facet whose plane supports the scene (`Accel::hull`) meet nothing: on a
    /// torus (not convex: the inner side's facets do not support it) the shortcut gives the
    /// BVH's answer for rays from random facets in random outward directions, closest hit and
    /// occlusion, and answers most of the outer side's rays.
    #[test]
    fn rays_leaving_a_supporting_facet_meet_nothing() {
        let m = crate::render::shapes::torus([0.0; 3], 3.0, 1.0, 32, 16).unwrap();
        let acc = Accel::new(&[&m]);
        let mut bvh = Accel::new(&[&m]);
        bvh.hull.clear();
        let on = acc.hull.iter().filter(|&&h| h).count();
        assert!(
            acc.convex.is_none() && on > acc.tris.len() / 4 && on < acc.tris.len() * 3 / 4,
            "{on} of {}",
            acc.tris.len()
        );
        let mut rng = crate::rng::PhotonRng::new(7, 8);
        let mut answered = 0;
        for _ in 0..20_000 {
            let i = (rng.uniform() * acc.tris.len() as f64) as usize % acc.tris.len();
            let o = acc.point(i, 0.3 * rng.uniform(), 0.3 * rng.uniform());
            let d = crate::optics::sample_uniform_sphere(rng.uniform(), rng.uniform());
            let d = if dot(d, acc.tris[i].n) < 0.0 { scale(d, -1.0) } else { d };
            let (a, b) = (acc.intersect(o, d, f64::INFINITY, i as u32), bvh.intersect(o, d, f64::INFINITY, i as u32));
            assert_eq!(a.map(|h| (h.tri, h.t)), b.map(|h| (h.tri, h.t)), "facet {i}, {d:?}");
            assert_eq!(acc.occluded(o, d, 50.0, i as u32), bvh.occluded(o, d, 50.0, i as u32));
            answered += usize::from(acc.leaves_hull(d, i as u32));
        }
        assert!(answered > 5_000, "{answered}");
    }

    /// `segment_clear` never clears a segment that meets the mesh (the closest hit along the ray
    /// lies beyond it), and it clears more than the bound at the start alone would (sphere
    /// tracing pays): random segments of up to 3 mm inside a sphere of radius 5 mm.
    #[test]
    fn segment_clear_never_clears_a_segment_that_meets_the_mesh() {
        let m = icosphere([0.0; 3], 5.0, 3).unwrap();
        let mut acc = Accel::new(&[&m]);
        acc.distance = Some(DistanceGrid::new(&acc.tris, acc.lo, acc.hi, 2.0));
        let mut rng = crate::rng::PhotonRng::new(3, 4);
        let (mut clear, mut traced) = (0, 0);
        for _ in 0..20_000 {
            let d = crate::optics::sample_uniform_sphere(rng.uniform(), rng.uniform());
            let o = scale([rng.symmetric(), rng.symmetric(), rng.symmetric()], 2.8);
            let s = 3.0 * rng.uniform();
            if acc.segment_clear(o, d, s) {
                clear += 1;
                traced += usize::from(s >= acc.clear_radius(o));
                let h = acc.intersect(o, d, f64::INFINITY, u32::MAX).expect("closed");
                assert!(h.t > s, "{o:?} {d:?}: hit at {} within {s}", h.t);
                assert!(acc.intersect(o, d, s, u32::MAX).is_none());
            }
        }
        assert!(clear > 5_000 && traced > 1_000, "{clear} clear, {traced} by tracing");
    }
}
