//! Next-event estimation through one flat facet of a smooth dielectric boundary, for the
//! random walk: from a collision point v inside the outermost object to a light outside.
//!
//! A smooth boundary makes the connection v → p → light specular at p, so a random direction
//! never finds it; on a flat triangle it can be solved exactly:
//! - directional light: the refracted beam direction is fixed by the facet normal;
//! - point y (a point light, or a point sampled on an area light): p minimises the optical
//!   path η‖p − v‖ + ‖y − p‖ on the facet's plane (Fermat; Snell's law is its stationarity
//!   condition). The minimiser lies on the line of the plane of incidence; the derivative of
//!   the path length along it is monotone, so bisection finds it.
//!
//! The facet is not known in advance: the straight segment v → light gives a first guess, and
//! the facet the refracted connection actually crosses replaces it (at most four steps).
//!
//! Geometry factor of a point source through a flat interface (ray-tube widths, sagittal and
//! tangential): with d₁ = ‖y − p‖ outside, d₂ = ‖p − v‖ inside and the angles θ₁, θ₂ to the
//! normal, the irradiance at v normal to the ray from a source of intensity I is
//! E = I T(θ₁) / [(d₁ + d₂/η)(d₁ cos θ₂/cos θ₁ + d₂ cos θ₁/(η cos θ₂))]
//! (η = 1 gives the inverse-square law 1/(d₁ + d₂)²). For a collimated beam of irradiance E₀
//! the irradiance inside is T(θ₁) E₀ cos θ₁/cos θ₂.

use super::accel::Hit;
use super::math::{dot, madd, neg, normalize, scale, sub, V3};
use super::scene::Scene;
use crate::optics::{fr_dielectric, refract};

/// A solved connection: the facet point, the propagation direction inside (from p to v), the
/// distance inside and the irradiance factor (per unit E₀ for a directional light, per unit
/// intensity for a point).
pub struct Connection {
    pub hit: Hit,
    pub d_in: V3,
    pub dist_in: f64,
    pub factor: f64,
}

/// The connection from `v` (inside object `obj`, index `eta`) to a directional light.
pub fn directional(scene: &Scene, obj: usize, eta: f64, v: V3, to_light: V3) -> Option<Connection> {
    let mut h = scene.accel.intersect(v, to_light, f64::INFINITY, u32::MAX)?;
    for _ in 0..4 {
        if h.object != obj {
            return None;
        }
        let cos_i = dot(to_light, h.n);
        if cos_i <= 0.0 {
            return None;
        }
        let d_in = refract(neg(to_light), h.n, 1.0, eta)?;
        let h2 = scene.accel.intersect(v, neg(d_in), f64::INFINITY, u32::MAX)?;
        if h2.tri == h.tri {
            let cos_t = -dot(d_in, h2.n);
            if cos_t <= 0.0 || blocked(scene, &h2, to_light, f64::INFINITY) {
                return None;
            }
            let factor = (1.0 - fr_dielectric(cos_i, 1.0, eta)) * cos_i / cos_t;
            return Some(Connection { hit: h2, d_in, dist_in: h2.t, factor });
        }
        h = h2;
    }
    None
}

/// The connection from `v` (inside object `obj`, index `eta`) to the point `y` outside.
pub fn point(scene: &Scene, obj: usize, eta: f64, v: V3, y: V3) -> Option<Connection> {
    let mut h = scene.accel.intersect(v, normalize(sub(y, v)), f64::INFINITY, u32::MAX)?;
    for _ in 0..4 {
        if h.object != obj {
            return None;
        }
        let n = h.n;
        let q = scene.accel.tris[h.tri as usize].v0;
        let (hv, hy) = (dot(sub(q, v), n), dot(sub(y, q), n));
        if !(hv > 0.0 && hy > 0.0) {
            return None;
        }
        let (pv, py) = (madd(v, n, hv), madd(y, n, -hy));
        let dd = sub(py, pv);
        let big_d = dot(dd, dd).sqrt();
        let t = if big_d > 1e-300 { fermat_t(eta, hv, hy, big_d) } else { 0.0 };
        let p = if big_d > 1e-300 { madd(pv, dd, t / big_d) } else { pv };
        let to_p = sub(p, v);
        let d2 = dot(to_p, to_p).sqrt();
        let h2 = scene.accel.intersect(v, scale(to_p, 1.0 / d2), f64::INFINITY, u32::MAX)?;
        if h2.tri == h.tri {
            let d1 = ((big_d - t).powi(2) + hy * hy).sqrt();
            let (cos1, cos2) = (hy / d1, hv / d2);
            let out = scale(sub(y, h2.p), 1.0 / d1);
            if blocked(scene, &h2, out, d1) {
                return None;
            }
            let tr = 1.0 - fr_dielectric(cos1, 1.0, eta);
            let factor = tr / ((d1 + d2 / eta) * (d1 * cos2 / cos1 + d2 * cos1 / (eta * cos2)));
            return Some(Connection { hit: h2, d_in: scale(to_p, -1.0 / d2), dist_in: h2.t, factor });
        }
        h = h2;
    }
    None
}

/// The t ∈ [0, D] minimising η√(t² + h_v²) + √((D − t)² + h_y²) (bisection on the derivative,
/// which increases monotonically from negative at 0 to positive at D).
fn fermat_t(eta: f64, hv: f64, hy: f64, big_d: f64) -> f64 {
    let (mut lo, mut hi) = (0.0, big_d);
    for _ in 0..64 {
        let t = 0.5 * (lo + hi);
        let g = eta * t / (t * t + hv * hv).sqrt() - (big_d - t) / ((big_d - t).powi(2) + hy * hy).sqrt();
        if g > 0.0 {
            hi = t;
        } else {
            lo = t;
        }
    }
    0.5 * (lo + hi)
}

fn blocked(scene: &Scene, h: &Hit, dir: V3, dist: f64) -> bool {
    let o = scene.accel.offset(h.p, h.n, 1.0);
    scene.accel.occluded(o, dir, dist * (1.0 - 1e-9), h.tri)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Snell's law holds at the solved point and the factor reduces to the inverse-square law
    /// at η = 1.
    #[test]
    fn fermat_point_obeys_snell() {
        for &(eta, hv, hy, d) in &[(1.4, 0.3, 5.0, 2.0), (1.33, 2.0, 0.5, 7.0), (1.0, 1.0, 1.0, 3.0)] {
            let t: f64 = fermat_t(eta, hv, hy, d);
            let sin2 = t / (t * t + hv * hv).sqrt();
            let sin1 = (d - t) / ((d - t).powi(2) + hy * hy).sqrt();
            assert!((sin1 - eta * sin2).abs() < 1e-12, "{eta} {t}");
        }
    }
}
