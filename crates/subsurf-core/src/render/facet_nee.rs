//! Next-event estimation through a smooth dielectric boundary, for the random walk: from a
//! collision point v inside the objects (at any depth of the media stack) to a light outside.
//!
//! The connection runs straight from v through index-matched inner interfaces (the same η on
//! both sides: no refraction, no Fresnel loss; each medium's σt attenuates its own segment, a
//! voxel grid's exactly voxel by voxel, [`super::grid::optical_depth`]) and
//! refracts once, at one flat facet of the boundary that leaves every object ([`chain`]). A
//! smooth boundary makes the connection v → p → light specular at p, so a random direction
//! never finds it; on a flat triangle it can be solved exactly:
//! - directional light: the refracted beam direction is fixed by the facet normal;
//! - point y (a point light, or a point sampled on an area light): p minimises the optical
//!   path η‖p − v‖ + ‖y − p‖ on the facet's plane (Fermat; Snell's law is its stationarity
//!   condition). The minimiser lies on the line of the plane of incidence; the derivative of
//!   the path length along it is monotone, so bisection finds it.
//!
//! The facet is not known in advance. For an area light's sampled point the straight line
//! v → light gives a first guess, and the facet the refracted connection actually crosses
//! replaces it (at most four steps), and the edge neighbours of the facet found are tried too;
//! what this misses, exits count. A point or directional light, which no exit reaches, connects
//! through every facet whose beam reaches v ([`super::beams`], [`through_facet`]).
//! Exact for index-matched chains; a line that meets an inner interface whose indices differ
//! (it would refract there too) or an opaque object makes no connection (see
//! [`super::random_walk`] for what that leaves out).
//!
//! Geometry factor of a point source through a flat interface (ray-tube widths, sagittal and
//! tangential): with d₁ = ‖y − p‖ outside, d₂ = ‖p − v‖ inside and the angles θ₁, θ₂ to the
//! normal, the irradiance at v normal to the ray from a source of intensity I is
//! E = I T(θ₁) / [(d₁ + d₂/η)(d₁ cos θ₂/cos θ₁ + d₂ cos θ₁/(η cos θ₂))]
//! (η = 1 gives the inverse-square law 1/(d₁ + d₂)²). For a collimated beam of irradiance E₀
//! the irradiance inside is T(θ₁) E₀ cos θ₁/cos θ₂. Index-matched interfaces leave both as
//! they are.

use super::accel::Hit;
use super::beams::Beams;
use super::convex::Convex;
use super::light::Light;
use super::math::{dot, madd, neg, normalize, scale, sub, Rgb, V3};
use super::scene::Scene;
use super::walk::Media;
use crate::optics::{fr_dielectric, refract};

/// Most interfaces one straight connection may cross.
const MAX_CHAIN: usize = 16;

/// A solved connection: the facet point, the propagation direction inside (from p to v), the
/// optical depth inside per channel (Σ σt ℓ over the media crossed), the irradiance factor
/// (per unit E₀ for a directional light, per unit intensity for a point) and, for a point, its
/// ray-tube geometry factor G alone (the factor without the Fresnel transmittance; 0 for a
/// directional light): the solid angle at v per unit area normal to the ray at the source is
/// G/η² (étendue η² dA dω is conserved through the refraction), which converts a light's area
/// pdf into the connection's solid-angle pdf at v.
pub struct Connection {
    pub hit: Hit,
    pub d_in: V3,
    pub tau: Rgb,
    pub factor: f64,
    pub geometry: f64,
}

/// The straight line from `v` (inside `media`) along the unit `dir` to the boundary that leaves
/// every object: where it leaves (`hit`, with `hit.t` the distance from the last interface) and
/// the optical depth per channel on the way.
pub struct Chain {
    pub hit: Hit,
    pub tau: Rgb,
}

/// Follow the line from `v` along `dir` through index-matched interfaces to the outer boundary;
/// `None` where it meets an interface whose indices differ, an opaque object, or no surface.
pub fn chain(scene: &Scene, media: &Media, v: V3, dir: V3) -> Option<Chain> {
    let (mut med, mut o, mut skip, mut tau) = (*media, v, u32::MAX, [0.0; 3]);
    for _ in 0..MAX_CHAIN {
        let m = med.medium(scene)?;
        let h = scene.accel.intersect(o, dir, f64::INFINITY, skip)?;
        let dt = super::grid::optical_depth(m, o, dir, h.t);
        tau = std::array::from_fn(|k| tau[k] + dt[k]);
        let (after, n1, n2) = med.across(scene, &h, dir)?;
        if after.is_empty() {
            return Some(Chain { hit: h, tau });
        }
        if n1 != n2 {
            return None;
        }
        (med, o, skip) = (after, h.p, h.tri);
    }
    None
}

/// Every connection from `v` (inside `media`) to a point or directional light: through each
/// facet of `beams` (the light's [`Beams`]) listed at `v` whose refracted beam reaches `v`
/// ([`through_facet`]), passed to `f`.
pub fn delta_connections(
    scene: &Scene,
    beams: &Beams,
    media: &Media,
    v: V3,
    light: &Light,
    mut f: impl FnMut(Connection),
) {
    let (eta, cv) = (media.index(scene), convex_from(scene, v));
    for &t in beams.candidates(v) {
        if let Some(c) = through_facet(scene, media, eta, cv, v, light, t, beams.inward(t)) {
            f(c);
        }
    }
}

/// The connection from `v` to a delta light through facet `tri` alone, if that facet's
/// refracted beam reaches `v`: for a directional light the line from `v` against the facet's
/// refracted direction `d_in` (given, or refracted here), for a point light the Fermat point
/// (`attempt`), must lie in the facet, and the line from `v` must leave every object through
/// it first with nothing blocking the light.
#[allow(clippy::too_many_arguments)]
pub fn through_facet(
    scene: &Scene,
    media: &Media,
    eta: f64,
    cv: Option<&Convex>,
    v: V3,
    light: &Light,
    tri: u32,
    d_in: Option<V3>,
) -> Option<Connection> {
    match *light {
        Light::Point { position, .. } => match attempt(scene, media, eta, v, position, tri, true, cv) {
            Attempt::Found(c) => Some(c),
            _ => None,
        },
        Light::Directional { to_light, .. } => {
            let tr = &scene.accel.tris[tri as usize];
            let hv = dot(sub(tr.v0, v), tr.n);
            if !(hv > 0.0) {
                return None;
            }
            let cos_i = dot(to_light, tr.n);
            if !(cos_i > 0.0) {
                return None;
            }
            let d_in = match d_in {
                Some(d) => d,
                None => refract(neg(to_light), tr.n, 1.0, eta)?,
            };
            let cos_t = -dot(d_in, tr.n);
            let s = hv / cos_t;
            let p = madd(v, d_in, -s);
            if outside_edge(tr, p).is_some() {
                return None;
            }
            let dir = neg(d_in);
            let c2 = match cv.and_then(|cv| convex_exit(scene, cv, media, v, dir, tri, s, p)) {
                Some(Ok(c)) => c,
                Some(Err(_)) => return None,
                None => chain(scene, media, v, dir)?,
            };
            if c2.hit.tri != tri || blocked(scene, &c2.hit, to_light, f64::INFINITY) {
                return None;
            }
            let factor = (1.0 - fr_dielectric(cos_i, 1.0, eta)) * cos_i / cos_t;
            Some(Connection { hit: c2.hit, d_in, tau: c2.tau, factor, geometry: 0.0 })
        }
        Light::Sphere { .. } | Light::Rect { .. } => None,
    }
}

/// The connection from `v` (inside `media`) to the point `y` outside.
pub fn point(scene: &Scene, media: &Media, v: V3, y: V3) -> Option<Connection> {
    point_in(scene, media, v, y, convex_from(scene, v))
}

/// [`point`] with the convex lookup decided ([`convex_from`]): the first facet by walking the
/// mesh from a cube-map guess ([`Convex::facet_of_line`]), else by [`chain`].
fn point_in(scene: &Scene, media: &Media, v: V3, y: V3, cv: Option<&Convex>) -> Option<Connection> {
    let eta = media.index(scene);
    let dir = normalize(sub(y, v));
    let walked = cv.and_then(|cv| cv.facet_of_line(&scene.accel, v, dir));
    let mut tri = match walked {
        Some(t) => t,
        None => chain(scene, media, v, dir)?.hit.tri,
    };
    for _ in 0..4 {
        match attempt(scene, media, eta, v, y, tri, false, cv) {
            Attempt::Found(c) => return Some(c),
            Attempt::Next(t) => tri = t,
            Attempt::Beyond(_) | Attempt::Fail => return None,
        }
    }
    None
}

/// Most connections [`points`] returns: the facet search's and one per edge neighbour's walk.
pub const MAX_POINTS: usize = 4;

/// Every connection from `v` to `y` through the facet [`point`] finds and through those of its
/// edge neighbours whose plane also holds a solution inside the triangle ([`points_walked`] with
/// walks of one facet).
pub fn points(scene: &Scene, media: &Media, v: V3, y: V3) -> [Option<Connection>; MAX_POINTS] {
    points_walked(scene, media, v, y, 1)
}

/// Every connection from `v` to `y` through the facet [`point`] finds and through facets near
/// it whose plane also holds a solution inside the triangle: on a tessellated surface a large
/// light is refracted towards one point by several facets, and those paths would otherwise be
/// left to other estimators (exits, next flights: rare, bright hits on the light). From each
/// edge neighbour of the facet found, a walk over the mesh: the neighbour's Fermat point (or,
/// without a Newton solve, the interval that holds it) lies in the triangle (a connection, if
/// its ray confirms it) or beyond one of its edges, and the walk steps across that edge unless
/// it leads back, up to `steps` facets. Each facet is counted once.
pub fn points_walked(scene: &Scene, media: &Media, v: V3, y: V3, steps: usize) -> [Option<Connection>; MAX_POINTS] {
    let mut out = [None, None, None, None];
    let cv = convex_from(scene, v);
    let Some(c) = point_in(scene, media, v, y, cv) else { return out };
    let eta = media.index(scene);
    let f0 = c.hit.tri;
    let nbs = scene.accel.tris[f0 as usize].nb;
    out[0] = Some(c);
    for (k, nb) in nbs.into_iter().enumerate() {
        let (mut cur, mut prev) = (nb, f0);
        for _ in 0..steps {
            if cur == u32::MAX {
                break;
            }
            match attempt(scene, media, eta, v, y, cur, true, cv) {
                Attempt::Found(c) => {
                    if !out.iter().flatten().any(|o| o.hit.tri == c.hit.tri) {
                        out[k + 1] = Some(c);
                    }
                    break;
                }
                Attempt::Beyond(e) => {
                    let next = scene.accel.tris[cur as usize].nb[e];
                    if next == prev || next == f0 || nbs.contains(&next) {
                        break;
                    }
                    (prev, cur) = (cur, next);
                }
                Attempt::Next(_) | Attempt::Fail => break,
            }
        }
    }
    out
}

enum Attempt {
    Found(Connection),
    /// The refracted connection crosses this other facet first.
    Next(u32),
    /// The Fermat point lies beyond this edge of the triangle (0: v₀v₁, 1: v₁v₂, 2: v₂v₀; with
    /// `inside` only).
    Beyond(usize),
    Fail,
}

/// The connection from `v` to `y` refracted at the plane of facet `tri` (Fermat point p), if
/// the line from `v` to p crosses that facet first and nothing blocks p → `y`. With `inside`
/// the ray is cast only when p lies inside the triangle (neighbour facets: most fail there).
/// With `cv` (the scene is one convex body and `v` lies inside it) no ray is cast where the
/// Fermat point lies inside the facet ([`convex_exit`]).
#[allow(clippy::too_many_arguments)]
fn attempt(
    scene: &Scene,
    media: &Media,
    eta: f64,
    v: V3,
    y: V3,
    tri: u32,
    inside: bool,
    cv: Option<&Convex>,
) -> Attempt {
    let tr = &scene.accel.tris[tri as usize];
    let (n, q) = (tr.n, tr.v0);
    let (hv, hy) = (dot(sub(q, v), n), dot(sub(y, q), n));
    if !(hv > 0.0 && hy > 0.0) {
        return Attempt::Fail;
    }
    let (pv, py) = (madd(v, n, hv), madd(y, n, -hy));
    let dd = sub(py, pv);
    let big_d = dot(dd, dd).sqrt();
    if inside && big_d > 1e-300 {
        // The Fermat point lies between pv and the straight line's point (η ≥ 1; between that
        // and py for η < 1): where both ends are beyond one edge of the triangle, so is it
        // (barycentric coordinates are affine), and the Newton solve is skipped.
        let ps = madd(pv, dd, hv / (hv + hy));
        let (a, b) = if eta >= 1.0 { (pv, ps) } else { (ps, py) };
        if let Some(e) = beyond_one_edge(tr, a, b) {
            return Attempt::Beyond(e);
        }
    }
    let t = if big_d > 1e-300 { fermat_t(eta, hv, hy, big_d) } else { 0.0 };
    let p = if big_d > 1e-300 { madd(pv, dd, t / big_d) } else { pv };
    if inside {
        if let Some(e) = outside_edge(tr, p) {
            return Attempt::Beyond(e);
        }
    }
    let to_p = sub(p, v);
    let d2 = dot(to_p, to_p).sqrt();
    let dir = scale(to_p, 1.0 / d2);
    let c2 = match cv.and_then(|cv| convex_exit(scene, cv, media, v, dir, tri, d2, p)) {
        Some(Ok(c)) => c,
        Some(Err(next)) => return Attempt::Next(next),
        None => match chain(scene, media, v, dir) {
            Some(c) => c,
            None => return Attempt::Fail,
        },
    };
    if c2.hit.tri != tri {
        return Attempt::Next(c2.hit.tri);
    }
    let h2 = c2.hit;
    let d1 = ((big_d - t).powi(2) + hy * hy).sqrt();
    let (cos1, cos2) = (hy / d1, hv / d2);
    let out = scale(sub(y, h2.p), 1.0 / d1);
    if blocked(scene, &h2, out, d1) {
        return Attempt::Fail;
    }
    let geometry = point_geometry(eta, d1, d2, cos1, cos2);
    let factor = (1.0 - fr_dielectric(cos1, 1.0, eta)) * geometry;
    Attempt::Found(Connection { hit: h2, d_in: scale(to_p, -1.0 / d2), tau: c2.tau, factor, geometry })
}

/// Where `p` (on the plane of `t`) lies outside the triangle with a relative margin of 10⁻⁹ (a
/// point the margin wrongly admits only costs a ray: the chain decides), the edge it lies
/// farthest beyond (0: v₀v₁, 1: v₁v₂, 2: v₂v₀); None inside.
fn outside_edge(t: &super::accel::Tri, p: V3) -> Option<usize> {
    let (b1, b2) = barycentric(t, p);
    // Barycentric coordinates: b₂ < 0 beyond v₀v₁, 1 − b₁ − b₂ < 0 beyond v₁v₂, b₁ < 0 beyond v₂v₀.
    let over = [-b2, b1 + b2 - 1.0, -b1];
    let e = (0..3).fold(0, |m, k| if over[k] > over[m] { k } else { m });
    (over[e] > IN_EPS).then_some(e)
}

/// The relative margin of [`outside_edge`].
const IN_EPS: f64 = 1e-9;

/// Barycentric coordinates (b₁, b₂) of `p` (on the plane of `t`) along its edges e₁, e₂.
fn barycentric(t: &super::accel::Tri, p: V3) -> (f64, f64) {
    let w = sub(p, t.v0);
    let (d00, d01, d11) = (dot(t.e1, t.e1), dot(t.e1, t.e2), dot(t.e2, t.e2));
    let (d20, d21) = (dot(w, t.e1), dot(w, t.e2));
    let den = d00 * d11 - d01 * d01;
    ((d11 * d20 - d01 * d21) / den, (d00 * d21 - d01 * d20) / den)
}

/// The edge (as [`outside_edge`]) beyond which the points `a` and `b` (on the plane of `t`) both
/// lie by more than its margin: then so does every point between them.
fn beyond_one_edge(t: &super::accel::Tri, a: V3, b: V3) -> Option<usize> {
    let ((a1, a2), (b1, b2)) = (barycentric(t, a), barycentric(t, b));
    if a2 < -IN_EPS && b2 < -IN_EPS {
        Some(0)
    } else if a1 + a2 > 1.0 + IN_EPS && b1 + b2 > 1.0 + IN_EPS {
        Some(1)
    } else if a1 < -IN_EPS && b1 < -IN_EPS {
        Some(2)
    } else {
        None
    }
}

/// The ray-tube geometry factor of a point source seen through a flat interface (module docs):
/// the solid angle at the source per unit area normal to the ray at the receiver,
/// 1/[(d₁ + d₂/η)(d₁ cos θ₂/cos θ₁ + d₂ cos θ₁/(η cos θ₂))].
fn point_geometry(eta: f64, d1: f64, d2: f64, cos1: f64, cos2: f64) -> f64 {
    1.0 / ((d1 + d2 / eta) * (d1 * cos2 / cos1 + d2 * cos1 / (eta * cos2)))
}

/// The t ∈ [0, D] minimising η√(t² + h_v²) + √((D − t)² + h_y²): the root of the derivative
/// g(t) = ηt/√(t² + h_v²) − (D − t)/√((D − t)² + h_y²), which increases monotonically from
/// negative at 0 to positive at D, by Newton's method safeguarded by bisection (a step leaving
/// the bracket is replaced by its midpoint): about 5 steps instead of bisection's 64 (−7 % walk
/// instructions on the marble sphere). It starts from the far-source limit where that lies in
/// the bracket (the outside ray's direction taken as at t = 0), else from the straight line's t
/// (the root at η = 1): measured on the benchmark's skin and ear under the rect light, −1.6 and
/// −2.0 % instructions per spp, −5.5 and −6 % CPU time (interleaved A/B).
fn fermat_t(eta: f64, hv: f64, hy: f64, big_d: f64) -> f64 {
    let (mut lo, mut hi) = (0.0, big_d);
    let mut t = if hv + hy > 0.0 { big_d * hv / (hv + hy) } else { 0.5 * big_d };
    // Where the source is far (h_y ≫ h_v, an area light seen from a collision near the
    // surface): start from the outside ray's sine as at t = 0, refracted (sin θ₂ = sin θ₁/η).
    let s2 = big_d / (eta * (big_d * big_d + hy * hy).sqrt());
    if s2 < 1.0 {
        let g = hv * s2 / (1.0 - s2 * s2).sqrt();
        if g > 0.0 && g < big_d {
            t = g;
        }
    }
    // A Newton step of at most 10⁻⁸ of the smaller scale (h_v or D) ends the solve: Newton
    // converges quadratically there (error ≈ C·step², C ≲ 1/min(h_v, D)), so the point it
    // reaches is exact to rounding; the former stop, a step below 10⁻¹⁵ D, took one step more.
    let tol = 1e-8 * hv.min(big_d);
    for _ in 0..64 {
        let (ia, ib) = (1.0 / (t * t + hv * hv).sqrt(), 1.0 / ((big_d - t).powi(2) + hy * hy).sqrt());
        let g = eta * t * ia - (big_d - t) * ib;
        if g > 0.0 {
            hi = t;
        } else {
            lo = t;
        }
        let dg = eta * hv * hv * ia * ia * ia + hy * hy * ib * ib * ib;
        let step = g / dg;
        let mut next = t - step;
        if !(next > lo && next < hi) {
            next = 0.5 * (lo + hi);
        } else if step.abs() <= tol {
            return next;
        }
        if (next - t).abs() <= 1e-15 * big_d {
            return next;
        }
        t = next;
    }
    t
}

/// The scene's convex lookup ([`super::accel::Accel::convex`]) where `v` lies inside the body
/// (a walker that leaked out numerically connects as before, by [`chain`]).
fn convex_from(scene: &Scene, v: V3) -> Option<&Convex> {
    scene.accel.convex.as_ref().filter(|cv| cv.holds(&scene.accel, v))
}

/// In a scene that is one convex body ([`super::accel::Accel::convex`]), what [`chain`] finds
/// along the straight line from `v` (inside) along `dir` to the point `p` (at distance `t`) on
/// the plane of facet `tri`, without its ray: the chain itself (`Ok`) where p lies inside the
/// facet (the line crosses it first and no other), else the facet the line crosses (`Err`,
/// [`super::convex::Convex::facet_along`]). `None` where this does not apply: [`chain`] decides.
#[allow(clippy::too_many_arguments)]
fn convex_exit(
    scene: &Scene,
    cv: &Convex,
    media: &Media,
    v: V3,
    dir: V3,
    tri: u32,
    t: f64,
    p: V3,
) -> Option<Result<Chain, u32>> {
    let tr = &scene.accel.tris[tri as usize];
    let (b1, b2) = barycentric(tr, p);
    if !(b1 >= 0.0 && b2 >= 0.0 && b1 + b2 <= 1.0) {
        let next = cv.facet_along(&scene.accel, v, dir, cv.guess(p))?;
        return (next != tri).then_some(Err(next));
    }
    let hit = Hit { t, tri, object: tr.object as usize, b1, b2, p, n: tr.n };
    let m = media.medium(scene)?;
    let (after, _, _) = media.across(scene, &hit, dir)?;
    after.is_empty().then(|| Ok(Chain { hit, tau: super::grid::optical_depth(m, v, dir, t) }))
}

/// Whether anything blocks the ray from the facet point of `h` along `dir` (outwards:
/// dir·n > 0) up to `dist`; never in a scene that is one convex body, which lies behind the
/// plane of each of its facets.
fn blocked(scene: &Scene, h: &Hit, dir: V3, dist: f64) -> bool {
    if scene.accel.convex.is_some() {
        return false;
    }
    let o = scene.accel.offset(h.p, h.n, 1.0);
    scene.accel.occluded(o, dir, dist * (1.0 - 1e-9), h.tri)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Snell's law holds at the solved point, and at η = 1 the point is on the straight segment
    /// and the factor is the inverse-square law 1/(d₁ + d₂)².
    #[test]
    fn fermat_point_obeys_snell() {
        for &(eta, hv, hy, d) in &[(1.4, 0.3, 5.0, 2.0), (1.33, 2.0, 0.5, 7.0), (1.0, 1.0, 1.0, 3.0)] {
            let t: f64 = fermat_t(eta, hv, hy, d);
            let sin2 = t / (t * t + hv * hv).sqrt();
            let sin1 = (d - t) / ((d - t).powi(2) + hy * hy).sqrt();
            assert!((sin1 - eta * sin2).abs() < 1e-12, "{eta} {t}");
        }
        for &(hv, hy, d) in &[(1.0, 1.0, 3.0), (0.2, 4.0, 0.5), (3.0, 0.1, 6.0)] {
            let t = fermat_t(1.0, hv, hy, d);
            assert!((t - d * hv / (hv + hy)).abs() < 1e-12 * d, "straight line: {t}");
            let (d1, d2) = (((d - t).powi(2) + hy * hy).sqrt(), (t * t + hv * hv).sqrt());
            let g = point_geometry(1.0, d1, d2, hy / d1, hv / d2);
            assert!((g * (d1 + d2).powi(2) - 1.0).abs() < 1e-13, "inverse square: {g}");
        }
    }

    /// The safeguarded Newton solve against plain bisection to the last bit (the root of the
    /// monotone g), over scales from grazing collisions (h_v = 10⁻⁹ D) to far sources: within
    /// the root's conditioning, a few ulps of g over g′ there (g's terms are at most 1 + η).
    #[test]
    fn fermat_solve_matches_bisection() {
        let mut rng = crate::rng::PhotonRng::new(3, 1);
        for i in 0..4000 {
            let eta = [1.0, 1.3, 1.5, 2.5][i % 4];
            let (hv, hy, big_d) =
                (10f64.powf(-9.0 + 10.0 * rng.uniform()), 10f64.powf(-2.0 + 6.0 * rng.uniform()), 1.0);
            let (mut lo, mut hi) = (0.0, big_d);
            for _ in 0..200 {
                let t = 0.5 * (lo + hi);
                let g = eta * t / (t * t + hv * hv).sqrt() - (big_d - t) / ((big_d - t).powi(2) + hy * hy).sqrt();
                if g > 0.0 {
                    hi = t;
                } else {
                    lo = t;
                }
            }
            let t = fermat_t(eta, hv, hy, big_d);
            let (a, b) = ((lo * lo + hv * hv).sqrt(), ((big_d - lo).powi(2) + hy * hy).sqrt());
            let dg = eta * hv * hv / (a * a * a) + hy * hy / (b * b * b);
            let tol = 8.0 * f64::EPSILON * ((1.0 + eta) / dg + big_d);
            assert!((t - lo).abs() <= tol, "eta {eta} hv {hv} hy {hy}: {t} vs {lo} (tolerance {tol:e})");
        }
    }

    /// The Fermat point on the plane z = 0 for v below it (inside, index η) and y above it.
    fn facet_point(eta: f64, v: V3, y: V3) -> V3 {
        let (pv, py) = ([v[0], v[1], 0.0], [y[0], y[1], 0.0]);
        let dd = sub(py, pv);
        let big_d = dot(dd, dd).sqrt();
        if big_d == 0.0 {
            return pv; // normal incidence
        }
        madd(pv, dd, fermat_t(eta, -v[2], y[2], big_d) / big_d)
    }

    /// The geometry factor against finite differences of the ray bundle: the solid angle at the
    /// source y of the rays that reach a small patch normal to the inside ray at v, per unit
    /// patch area, |∂u/∂a × ∂u/∂b| (u the unit direction y → facet point, a, b orthonormal and
    /// normal to the inside ray; central differences, step 10⁻⁴ of the inside distance: the
    /// truncation error is O(10⁻⁸) relative, rounding O(10⁻¹²)). Tolerance 10⁻⁶.
    #[test]
    fn point_geometry_matches_finite_differences() {
        let cases = [
            (1.33, [0.0, 0.0, -0.5], [3.0, 1.0, 4.0]),
            (1.5, [0.2, -0.1, -2.0], [-1.0, 0.5, 0.3]),
            (1.4, [0.0, 0.0, -0.05], [10.0, 0.0, 1.0]),
            (1.0, [0.0, 0.0, -1.0], [2.0, 2.0, 2.0]),
            (2.5, [1.0, 1.0, -3.0], [1.0, 1.0, 2.0]),
        ];
        for (eta, v, y) in cases {
            let p = facet_point(eta, v, y);
            let (to_v, to_y) = (sub(v, p), sub(y, p));
            let (d2, d1) = (dot(to_v, to_v).sqrt(), dot(to_y, to_y).sqrt());
            let g = point_geometry(eta, d1, d2, to_y[2] / d1, -to_v[2] / d2);
            let w = scale(to_v, 1.0 / d2);
            let helper = if w[0].abs() < 0.9 { [1.0, 0.0, 0.0] } else { [0.0, 1.0, 0.0] };
            let a = normalize(sub(helper, scale(w, dot(helper, w))));
            let b = [w[1] * a[2] - w[2] * a[1], w[2] * a[0] - w[0] * a[2], w[0] * a[1] - w[1] * a[0]];
            let h = 1e-4 * d2;
            let u = |x: V3| normalize(sub(facet_point(eta, x, y), y));
            let du = |e: V3| scale(sub(u(madd(v, e, h)), u(madd(v, e, -h))), 0.5 / h);
            let (ua, ub) = (du(a), du(b));
            let c = [ua[1] * ub[2] - ua[2] * ub[1], ua[2] * ub[0] - ua[0] * ub[2], ua[0] * ub[1] - ua[1] * ub[0]];
            let fd = dot(c, c).sqrt();
            assert!((fd / g - 1.0).abs() < 1e-6, "eta {eta}, v {v:?}, y {y:?}: formula {g}, finite differences {fd}");
        }
    }
}
