//! The geometry-aware BSSRDF of `model = "adaptive"` at a shading point x_o: the local thickness
//! d (a probe ray along −n_o to the object's far surface; ∞ if it leaves the object open) picks
//! the slab profiles R(r; d) and T(r; d) of [`crate::bssrdf::adaptive::AdaptiveTable`], and each
//! entry point x_i is put on the near side or across the part by its depth below x_o's tangent
//! plane, h = (x_o − x_i)·n_o:
//!
//! - h ≤ d/2 (the near side): R(‖x_o − x_i‖; d), the finite slab's reflection;
//! - h > d/2 (across): T(r⊥; d) with r⊥ = √(‖x_o − x_i‖² − h²), the lateral offset in the
//!   slab tangent at x_o — light that crossed a thin part (ears, leaves, a cup's handle).
//!
//! Curvature: the mean curvature H at x_o (mm⁻¹; > 0 convex, < 0 concave) is estimated from the
//! normals of the surface one `median_radius` away along two tangents (two probe rays), and the
//! profiles are scaled by the table's scales at H ([`AdaptiveTable::curvature_scale`],
//! [`crate::bssrdf::curvature`]): R per chord bin of a sphere of radius 1/|H| ([`Binned`]) and T
//! as a whole, so that this kernel, integrated over each bin of the near hemisphere and over the
//! far hemisphere of that sphere, gives the exact escape there of diffuse light entering the
//! sphere (traced by [`crate::bssrdf::curved`]); concave points scale R by the cavity's total.
//! The thickness part is inside those integrals (the sphere's probed d is its diameter), so a
//! sphere's light is counted once. (The mean-chord slab
//! d/(1 + dH) used before moved light into T, to the far side, where on a sphere the extra light
//! leaves near where it entered; measured worse on spheres and the torus, see `docs/render.md`.)
//!
//! On a flat surface of a thick object (d ≥ the table's last node, several diffusion lengths)
//! this is the semi-infinite Monte Carlo profile, so exitance = total × E_t as for
//! `monte_carlo`. The BSSRDF is the renderer's (`material`): F_t R F_t /(π c) and the same
//! for T, both per unit entering power.

use super::accel::Hit;
use super::hierarchical::PairProfiles;
use super::math::{dot, length, madd, neg, sub, Frame, Rgb, V3};
use super::scene::Scene;
use crate::bssrdf::adaptive::{AdaptiveTable, Mix};
use crate::bssrdf::curvature::Binned;
use crate::bssrdf::RadialProfile;

/// Most surfaces a thickness probe passes (other objects' or back faces) before it gives up (∞).
const MAX_CROSSINGS: usize = 16;

/// The local thickness (mm) of the object of `hit` along −n: distance to the first surface of
/// the same object; ∞ if there is none (an open mesh).
pub fn thickness(scene: &Scene, hit: &Hit) -> f64 {
    let d = neg(hit.n);
    let mut o = scene.accel.offset(hit.p, hit.n, -1.0);
    let (mut skip, mut travelled) = (hit.tri, 0.0);
    for _ in 0..MAX_CROSSINGS {
        let Some(h) = scene.accel.intersect(o, d, f64::INFINITY, skip) else { return f64::INFINITY };
        travelled += h.t;
        if h.object == hit.object {
            return travelled;
        }
        o = h.p;
        skip = h.tri;
    }
    f64::INFINITY
}

/// Mean curvature H (mm⁻¹, > 0 convex) of the object of `hit` from the normals one step `s` (mm)
/// away along two tangents: κ ≈ (n_q − n)·t / s per tangent t; a tangent whose probe finds no
/// surface of the object within 3s counts 0.
pub fn mean_curvature(scene: &Scene, hit: &Hit, s: f64) -> f64 {
    let f = Frame::new(hit.n);
    let mut k = 0.0;
    for t in [f.t, f.b] {
        let o = madd(madd(hit.p, t, s), hit.n, s);
        let mut skip = u32::MAX;
        let mut origin = o;
        let mut travelled = 0.0;
        for _ in 0..MAX_CROSSINGS {
            let Some(h) = scene.accel.intersect(origin, neg(hit.n), 3.0 * s - travelled, skip) else { break };
            travelled += h.t;
            if h.object == hit.object && dot(h.n, hit.n) > 0.0 {
                k += dot(sub(h.n, hit.n), t) / s;
                break;
            }
            origin = h.p;
            skip = h.tri;
        }
    }
    0.5 * k
}

/// The adaptive BSSRDF at one shading point (see the module docs).
pub struct Kernel {
    p: V3,
    n: V3,
    /// Local thickness, mm.
    pub d: f64,
    /// Local mean curvature, mm⁻¹ (> 0 convex).
    pub h: f64,
    r: [Binned; 3],
    t: [Mix; 3],
}

impl Kernel {
    /// The kernel at `hit` with the material's table.
    pub fn at(scene: &Scene, table: &AdaptiveTable, hit: &Hit) -> Kernel {
        let d = thickness(scene, hit);
        let s = table.median_radius.min(0.25 * d);
        let h = if s > 0.0 { mean_curvature(scene, hit, s) } else { 0.0 };
        let pair = |k: usize| {
            let c = k.min(table.channels() - 1);
            let sc = table.curvature_scale(c, h);
            let (r, t) = table.scaled(c, table.local(c, d), (1.0, sc.far));
            (Binned::new(r, &sc), t)
        };
        let [a, b, c] = [pair(0), pair(1), pair(2)];
        Kernel { p: hit.p, n: hit.n, d, h, r: [a.0, b.0, c.0], t: [a.1, b.1, c.1] }
    }

    /// The profile value per channel (mm⁻²) for light entering at `q`.
    pub fn value(&self, q: V3) -> Rgb {
        let (c, r) = self.class(self.p, q);
        std::array::from_fn(|k| self.profile(c, k).rd(r))
    }
}

impl PairProfiles for Kernel {
    fn class(&self, x: V3, q: V3) -> (usize, f64) {
        let v = sub(x, q);
        let h = dot(v, self.n);
        let r = length(v);
        if h > 0.5 * self.d {
            (1, (r * r - h * h).max(0.0).sqrt())
        } else {
            (0, r)
        }
    }
    fn profile(&self, c: usize, k: usize) -> &dyn RadialProfile {
        if c == 0 {
            &self.r[k]
        } else {
            &self.t[k]
        }
    }
}

#[cfg(test)]
#[path = "adaptive_tests.rs"]
mod tests;
