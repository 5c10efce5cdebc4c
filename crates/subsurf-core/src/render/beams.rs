//! Every facet through which a collision sees a point or directional light ([`Beams`]).
//!
//! A smooth dielectric boundary refracts a delta light's rays at each flat facet into a beam
//! inside: for a directional light a prism (the facet swept along its fixed refracted
//! direction), for a point light the rays refracted at every point of the facet. On a curved
//! tessellated surface the beams of neighbouring facets overlap (a convex surface focuses), so a
//! collision point can receive the light through several facets at once, and the facet search of
//! [`super::facet_nee`], which follows one facet, misses the others (measured on an icosphere of
//! radius 10 mm, η 1.35, a sun, points uniform inside: the single facet carried 41–49 % of the
//! transmitted irradiance; for a point light 63–89 %). No exit of a walk can reach a delta light,
//! so what the facet search misses is lost. Here each light-facing facet's beam is listed, at
//! load time, in the cells of a uniform grid over the translucent objects that it may cross
//! (conservatively: the hull of its cross-sections at the two ends of each step of one cell);
//! a collision tests the facets listed in its cell exactly ([`super::facet_nee::through_facet`])
//! and connects through every one that holds a solution.

use super::light::Light;
use super::math::{add as vadd, dot, madd, neg, normalize, scale, sub, V3};
use super::scene::Scene;
use crate::optics::refract;

/// Cells along the longest side of the grid at most (and at least [`MIN_CELLS`]); the cell is
/// about two facet edges otherwise.
const MAX_CELLS: usize = 32;
const MIN_CELLS: usize = 4;

/// The beams of one delta light over the translucent objects' box.
pub struct Beams {
    lo: V3,
    h: f64,
    n: [usize; 3],
    /// CSR: the facets listed in cell c are `items[start[c]..start[c + 1]]`, ascending.
    start: Vec<u32>,
    items: Vec<u32>,
    /// A directional light's refracted direction inside each facet (empty for a point light).
    d_in: Vec<V3>,
}

impl Beams {
    /// The beams of `light` (a point or directional light; `None` for area lights, or without
    /// translucent objects).
    pub fn new(scene: &Scene, light: &Light) -> Option<Beams> {
        if !matches!(light, Light::Point { .. } | Light::Directional { .. }) {
            return None;
        }
        let (lo, hi) = scene.translucent_box()?;
        let side = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max).max(1e-9);
        let tris = &scene.accel.tris;
        let edge = tris.iter().map(|t| (dot(t.e1, t.e1)).sqrt()).sum::<f64>() / tris.len().max(1) as f64;
        let cells = ((side / (2.0 * edge.max(1e-12))).round() as usize).clamp(MIN_CELLS, MAX_CELLS);
        let h = side / cells as f64;
        let pad = 1e-6 * side;
        let lo = [lo[0] - pad, lo[1] - pad, lo[2] - pad];
        let n: [usize; 3] = std::array::from_fn(|k| (((hi[k] + pad - lo[k]) / h).ceil() as usize).max(1));
        let d_in = match *light {
            Light::Directional { to_light, .. } => tris
                .iter()
                .map(|t| {
                    let eta = scene.material(t.object as usize).translucent().map_or(1.0, |m| m.eta);
                    refract(neg(to_light), t.n, 1.0, eta).unwrap_or([0.0; 3])
                })
                .collect(),
            _ => vec![],
        };
        let mut b = Beams { lo, h, n, start: vec![0; n[0] * n[1] * n[2] + 1], items: vec![], d_in };
        // Two passes (count, then fill) instead of holding every facet's cell list.
        let mut cells_of = Vec::new();
        for pass in 0..2 {
            let mut fill: Vec<u32> = if pass == 1 { b.start[..b.start.len() - 1].to_vec() } else { vec![] };
            for i in 0..tris.len() {
                cells_of.clear();
                b.beam_cells(scene, light, i, &mut cells_of);
                cells_of.sort_unstable();
                cells_of.dedup();
                for &c in &cells_of {
                    if pass == 0 {
                        b.start[c + 1] += 1;
                    } else {
                        b.items[fill[c] as usize] = i as u32;
                        fill[c] += 1;
                    }
                }
            }
            if pass == 0 {
                for c in 0..b.start.len() - 1 {
                    b.start[c + 1] += b.start[c];
                }
                b.items = vec![0; *b.start.last().expect("cells") as usize];
            }
        }
        Some(b)
    }

    /// The facets whose beams may reach `p` (empty outside the grid).
    pub fn candidates(&self, p: V3) -> &[u32] {
        let mut idx = [0usize; 3];
        for k in 0..3 {
            let f = (p[k] - self.lo[k]) / self.h;
            if !(f >= 0.0 && f < self.n[k] as f64) {
                return &[];
            }
            idx[k] = f as usize;
        }
        let c = (idx[2] * self.n[1] + idx[1]) * self.n[0] + idx[0];
        &self.items[self.start[c] as usize..self.start[c + 1] as usize]
    }

    /// A directional light's refracted direction inside facet `t` (None for a point light).
    pub fn inward(&self, t: u32) -> Option<V3> {
        self.d_in.get(t as usize).copied()
    }

    /// The cells facet `i`'s beam may cross, pushed to `out` (with repeats).
    fn beam_cells(&self, scene: &Scene, light: &Light, i: usize, out: &mut Vec<usize>) {
        let t = &scene.accel.tris[i];
        let Some(m) = scene.material(t.object as usize).translucent() else { return };
        let corners = [t.v0, madd(t.v0, t.e1, 1.0), madd(t.v0, t.e2, 1.0)];
        // Points of the facet whose refracted rays bound its beam's cross-sections: the corners,
        // and for a point light also the edge midpoints and the centre (the rays' directions vary
        // over the facet; the cross-section between sampled points deviates from their hull by
        // far less than the margin below, which the tests check against every facet).
        let mut pts: Vec<(V3, V3)> = Vec::with_capacity(7);
        let mut add = |p: V3| -> bool {
            let towards = match *light {
                Light::Directional { to_light, .. } => to_light,
                Light::Point { position, .. } => normalize(sub(position, p)),
                _ => return false,
            };
            if dot(towards, t.n) <= 0.0 {
                return false;
            }
            match refract(neg(towards), t.n, 1.0, m.eta) {
                Some(d) => {
                    pts.push((p, d));
                    true
                }
                None => false,
            }
        };
        // Whether a point of the facet faces the light is the same for all of its points (a
        // directional light's cos θ and a point light's height above the plane).
        for p in corners {
            if !add(p) {
                return;
            }
        }
        if matches!(light, Light::Point { .. }) {
            for (a, b) in [(0, 1), (1, 2), (2, 0)] {
                add(scale(vadd(corners[a], corners[b]), 0.5));
            }
            add(scale(vadd(vadd(corners[0], corners[1]), corners[2]), 1.0 / 3.0));
        }
        let margin = 0.05 * self.h + 1e-9;
        let hi: V3 = std::array::from_fn(|k| self.lo[k] + self.h * self.n[k] as f64);
        let reach = (0..3).map(|k| (hi[k] - self.lo[k]).powi(2)).sum::<f64>().sqrt();
        let mut s = 0.0;
        while s < reach {
            let s1 = (s + self.h).min(reach);
            let (mut a, mut b) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
            for &(p, d) in &pts {
                for q in [madd(p, d, s), madd(p, d, s1)] {
                    for k in 0..3 {
                        a[k] = a[k].min(q[k]);
                        b[k] = b[k].max(q[k]);
                    }
                }
            }
            if s == 0.0 {
                for q in corners {
                    for k in 0..3 {
                        a[k] = a[k].min(q[k]);
                        b[k] = b[k].max(q[k]);
                    }
                }
            }
            if (0..3).any(|k| b[k] + margin < self.lo[k] || a[k] - margin > hi[k]) {
                break; // the beam has left the box (it only moves away from here: straight rays)
            }
            self.cells_of_box(a, b, margin, out);
            s = s1;
        }
    }

    fn cells_of_box(&self, a: V3, b: V3, margin: f64, out: &mut Vec<usize>) {
        let range = |k: usize| {
            let i0 = ((a[k] - margin - self.lo[k]) / self.h).floor().max(0.0) as usize;
            let i1 = (((b[k] + margin - self.lo[k]) / self.h).floor().max(0.0) as usize).min(self.n[k] - 1);
            (i0.min(self.n[k] - 1), i1)
        };
        let ((x0, x1), (y0, y1), (z0, z1)) = (range(0), range(1), range(2));
        for z in z0..=z1 {
            for y in y0..=y1 {
                for x in x0..=x1 {
                    out.push((z * self.n[1] + y) * self.n[0] + x);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::facet_nee::{delta_connections, through_facet};
    use crate::render::material::{Material, Translucent};
    use crate::render::scene::{Object, Scene};
    use crate::render::shapes::{icosphere, torus};
    use crate::render::walk::Media;

    /// The grid lists every facet whose beam reaches a point: for points inside a tessellated
    /// sphere (convex: no rays) and a torus (rays), a sun and a near point light, the connections
    /// through the listed facets are exactly those through all facets of the mesh, and many
    /// points see the light through several facets (one facet carries less than 90 % of it).
    #[test]
    fn beams_list_every_facet_that_reaches_a_point() {
        let m = || Translucent::new("m", [0.01; 3], [0.2; 3], 0.0, 1.35, None, false).unwrap();
        let meshes = [icosphere([0.0; 3], 10.0, 3).unwrap(), torus([0.0; 3], 7.0, 2.5, 24, 12).unwrap()];
        let lights = [
            Light::directional("l", normalize([0.3, -0.2, 1.0]), [1.0; 3]).unwrap(),
            Light::point("l", [3.0, 0.0, 14.0], [1.0; 3]).unwrap(),
        ];
        for (k, mesh) in meshes.into_iter().enumerate() {
            let o = Object { name: "o".into(), mesh, material: 0 };
            let sc = Scene::new(vec![o], vec![Material::Translucent(Box::new(m()))], vec![], [0.0; 3], None).unwrap();
            let media = Media::inside(0);
            for light in &lights {
                let b = Beams::new(&sc, light).unwrap();
                let mut rng = crate::rng::PhotonRng::new(5, k as u64);
                let (mut n, mut multi, mut sum, mut first) = (0, 0, 0.0, 0.0);
                while n < 300 {
                    let v = scale([rng.symmetric(), rng.symmetric(), rng.symmetric()], 10.0);
                    if sc.enclosing_object(v).is_none() {
                        continue;
                    }
                    n += 1;
                    let all: Vec<(u32, f64)> = (0..sc.accel.tris.len() as u32)
                        .filter_map(|t| {
                            through_facet(&sc, &media, 1.35, None, v, light, t, None).map(|c| (t, c.factor))
                        })
                        .collect();
                    let mut listed: Vec<(u32, f64)> = vec![];
                    delta_connections(&sc, &b, &media, v, light, |c| listed.push((c.hit.tri, c.factor)));
                    assert_eq!(all.len(), listed.len(), "mesh {k}, v {v:?}: {all:?} {listed:?}");
                    for (a, l) in all.iter().zip(&listed) {
                        assert!(a.0 == l.0 && (a.1 / l.1 - 1.0).abs() < 1e-9, "mesh {k}, v {v:?}: {a:?} {l:?}");
                    }
                    multi += usize::from(all.len() > 1);
                    sum += all.iter().map(|x| x.1).sum::<f64>();
                    first += all.first().map_or(0.0, |x| x.1);
                }
                assert!(multi > 30, "mesh {k}: {multi} of {n} points see the light through several facets");
                assert!(first < 0.9 * sum, "mesh {k}: one facet carries {first} of {sum}");
            }
        }
    }
}
