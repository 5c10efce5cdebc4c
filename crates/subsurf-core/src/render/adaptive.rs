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
//! Curvature: a convex part of radius ρ leaks light through its curved surface sooner than a slab
//! as thick as its diameter. The kernel evaluates the profiles of the slab with the same mean
//! chord length 4V/S (the mean path of diffuse light across the part; Cauchy's formula): a sphere
//! (d = 2ρ, mean curvature H = 1/ρ) has 4V/S = 4ρ/3, the mean chord of a slab of thickness 2ρ/3;
//! an infinite cylinder (d = 2ρ, H = 1/(2ρ)) 2ρ, that of a slab of thickness ρ. Both are
//! d_eff = d / (1 + d·H), with H ≥ 0 estimated at x_o from the normals of the surface one
//! `median_radius` away along two tangents (two probe rays); concave points (H < 0) keep d.
//! The near/far split uses the probed d.
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

/// The slab thickness with the mean chord of a part of probed thickness `d` and mean curvature
/// `h` (see the module docs).
pub fn equivalent_thickness(d: f64, h: f64) -> f64 {
    if h > 0.0 && d.is_finite() {
        d / (1.0 + d * h)
    } else {
        d
    }
}

/// The adaptive BSSRDF at one shading point (see the module docs).
pub struct Kernel {
    p: V3,
    n: V3,
    /// Local thickness, mm.
    pub d: f64,
    r: [Mix; 3],
    t: [Mix; 3],
}

impl Kernel {
    /// The kernel at `hit` with the material's table.
    pub fn at(scene: &Scene, table: &AdaptiveTable, hit: &Hit) -> Kernel {
        let d = thickness(scene, hit);
        let s = table.median_radius.min(0.25 * d);
        let d_eff = if s > 0.0 { equivalent_thickness(d, mean_curvature(scene, hit, s)) } else { d };
        let local = |k: usize| table.local(k.min(table.channels() - 1), d_eff);
        Kernel {
            p: hit.p,
            n: hit.n,
            d,
            r: std::array::from_fn(|k| table.reflection(k, local(k))),
            t: std::array::from_fn(|k| table.transmission(k, local(k))),
        }
    }

    /// The profile value per channel (mm⁻²) for light entering at `q`.
    pub fn value(&self, q: V3) -> Rgb {
        let (c, r) = self.class(self.p, q);
        let prof = if c == 0 { &self.r } else { &self.t };
        std::array::from_fn(|k| prof[k].rd(r))
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
