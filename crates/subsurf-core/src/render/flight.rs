//! Next-flight estimators of the area lights for the random walk ([`super::random_walk`]):
//! what the walk's next straight flight (after a collision) or its next reflection (at the
//! boundary) would see of a light through the boundary, as expected values, in place of the
//! walk's own rare exits that meet a light.
//!
//! - [`light_next_flight`]: at a collision, along the new direction: the straight line to the
//!   boundary, refracted, meeting a light; combined with the facet connections of
//!   [`super::facet_nee`] by multiple importance sampling (balance heuristic), so that the
//!   connections count what the facet search finds and the next flight what it does not (on a
//!   non-convex or thin mesh the search finds one facet and a few near it; a straight exit
//!   through another one was a rare, bright hit on the light: 73 % of the skin torus' variance
//!   under the benchmark's rect light).
//! - [`reflected_light`]: at the boundary reached on a straight path from a collision, the
//!   reflection's next straight flight (Fresnel reflectance as a weight), meeting a light.
//!
//! [`Reach`] bounds the directions in which either can meet a light at all.

use super::accel::Hit;
use super::facet_nee;
use super::fastmath::exp;
use super::light::Light;
use super::material::Translucent;
use super::math::{add, box_corners, dot, madd, normalize, scale, sub, Rgb, V3};
use super::scene::Scene;
use super::walk::Media;
use crate::optics::{fr_dielectric, reflect, refract};

/// The area lights seen through the boundary along the next flight, combined with the facet
/// connections by multiple importance sampling: after a real collision at `p` (in `m` on top
/// of `media`, arrived along `arrive`) drew the new direction `d` (pdf p(ω): the phase
/// function), the walk leaves the objects along the straight line (through index-matched
/// interfaces, [`facet_nee::chain`]) with probability T(ℓ)·F_t per channel, and its refracted
/// ray ω_out then meets an area light first (or not). This returns that light's expected
/// radiance per unit β, T_k F_t L_k / q_f times the balance weight a_f/(a_f + a_c): a_f =
/// q_f p(ω), a_c = q p_c where the facet search from `p` to the point y met on the light
/// finds this facet with walks of `walk` facets ([`facet_nee::points_walked`]; p_c: the
/// connection's solid-angle pdf, see `RandomWalk::nee`; `q` its probability at `p`), else 0.
/// Made with probability `qf` = q_f (every flight's transmittance is ≤ e^{−τ_lb}, whence
/// q_f = min(1, c_f e^{−τ_lb}): the weights stay bounded). The walk's straight exits after a
/// collision count no light they meet directly (`Radiance::exit`): with the connections,
/// the two estimators count every straight path to a light once, whichever facet it leaves
/// by (the facet search alone finds one facet and its edge neighbours: straight exits
/// through other facets, on non-convex and thin meshes, were rare bright hits on the light).
/// Rays: the chain (one per medium crossed) and, where the refracted ray meets a light, its
/// occlusion test and the facet search.
pub fn light_next_flight(
    scene: &Scene,
    m: &Translucent,
    media: &Media,
    (p, arrive, d): (V3, V3, V3),
    (qf, q): (f64, f64),
    walk: usize,
) -> Rgb {
    let Some(c) = facet_nee::chain(scene, media, p, d) else { return [0.0; 3] };
    let (h, eta) = (c.hit, media.index(scene));
    let Some(out) = refract(d, h.n, eta, 1.0) else { return [0.0; 3] }; // total internal reflection
    let Some((y, light, le)) = light_seen(scene, &h, out) else { return [0.0; 3] };
    let af = qf * m.phase.eval(dot(d, arrive));
    let ac = match light.point_pdf(y) {
        Some((pdf, ny)) => {
            let cos_l = dot(ny, normalize(sub(h.p, y)));
            let found = facet_nee::points_walked(scene, media, p, y, walk);
            match found.iter().flatten().find(|x| x.hit.tri == h.tri) {
                Some(x) if cos_l > 0.0 => q * pdf * eta * eta / (x.geometry * cos_l),
                _ => 0.0,
            }
        }
        None => 0.0,
    };
    let w = (1.0 - fr_dielectric(dot(d, h.n).abs(), eta, 1.0)) / (qf * (1.0 + ac / af.max(f64::MIN_POSITIVE)));
    std::array::from_fn(|k| w * exp(-c.tau[k]) * le[k])
}

/// The area lights seen after a reflection, as an expected value: the walk reached the
/// boundary `h` along `d` (inside `media`) on a straight path from its last collision. Where
/// that boundary leaves every object and the mirror direction r [`Reach::reaches`] a light,
/// the walk reflects with probability F_r, flies straight to the first surface along r with
/// probability T(ℓ), leaves there with F_t if that surface too leaves every object, and its
/// refracted ray may meet a light: this returns F_r T_k F_t L_k per unit β (Some(0) where
/// nothing is met), and the walk's exits after exactly that reflection count no light they
/// meet directly (`Radiance::mirrored`). None where the estimate does not apply (the
/// exits then count the lights). A reflection's chance F_r (2–9 % below the critical angle)
/// made those exits rare, bright hits on the light: one ray per boundary reached instead.
pub fn reflected_light(scene: &Scene, media: &Media, h: &Hit, d: V3, reach: &Reach) -> Option<Rgb> {
    let (after, n1, n2) = media.across(scene, h, d)?;
    if !after.is_empty() || n1 == n2 {
        return None;
    }
    let r = reflect(d, h.n);
    if !reach.reaches(r) {
        return None;
    }
    let m = media.medium(scene)?;
    let fr = fr_dielectric(dot(d, h.n).abs(), n1, n2);
    let zero = Some([0.0; 3]);
    let Some(h2) = scene.accel.intersect(h.p, r, f64::INFINITY, h.tri) else { return zero };
    let Some((_, _, m2)) = media.across(scene, &h2, r).filter(|x| x.0.is_empty()) else { return zero };
    let Some(out) = refract(r, h2.n, n1, m2) else { return zero };
    let Some((_, _, le)) = light_seen(scene, &h2, out) else { return zero };
    let tau = super::grid::optical_depth(m, h.p, r, h2.t);
    let w = fr * (1.0 - fr_dielectric(dot(r, h2.n), n1, m2));
    Some(std::array::from_fn(|k| w * exp(-tau[k]) * le[k]))
}

/// The light that the ray leaving the boundary at `h` along `out` meets first (as
/// `Scene::light_hit`), unless a surface comes first (as the exit's `trace_seen`; nothing lies
/// behind a facet of a convex body): the point met, the light and its radiance.
fn light_seen<'a>(scene: &'a Scene, h: &Hit, out: V3) -> Option<(V3, &'a Light, Rgb)> {
    let mut seen: Option<(f64, &Light, Rgb)> = None;
    for light in &scene.lights {
        if let Some((t, le)) = light.hit(h.p, out, seen.map_or(f64::INFINITY, |s| s.0)) {
            seen = Some((t, light, le));
        }
    }
    let (tl, light, le) = seen?;
    if scene.accel.convex.is_none() && scene.accel.occluded(h.p, out, tl, h.tri) {
        return None;
    }
    Some((madd(h.p, out, tl), light, le))
}

/// Per light of `scene`, the cone (unit axis, cosine of the half-angle) that holds every
/// direction in which a straight flight inside a translucent object can leave towards the
/// light (None for point and directional lights, which no flight meets): the directions from
/// the objects' bounding box B to the light L lie in the cone of the convex set L − B (the
/// largest angle to the axis at a pair of corners, widened by asin(r/dist) for a sphere light;
/// the whole sphere where that reaches 90°, or the light touches the box), and a refraction out
/// of a medium of index η turns a ray by at most arccos(min(η, 1/η)).
pub struct Reach {
    cones: Vec<Option<(V3, f64)>>,
}

impl Reach {
    /// Whether a straight flight along `d` may leave towards an area light.
    #[inline]
    pub fn reaches(&self, d: V3) -> bool {
        self.cones.iter().flatten().any(|&(a, c)| dot(d, a) >= c)
    }

    /// Whether the scene has an area light.
    pub fn any(&self) -> bool {
        self.cones.iter().any(Option::is_some)
    }

    pub fn new(scene: &Scene) -> Reach {
        Reach { cones: cones(scene) }
    }
}

fn cones(scene: &Scene) -> Vec<Option<(V3, f64)>> {
    let Some((lo, hi)) = scene.translucent_box() else { return vec![None; scene.lights.len()] };
    let corners = box_corners(lo, hi);
    let mid = scale(add(lo, hi), 0.5);
    let turn = scene
        .materials
        .iter()
        .filter_map(|m| m.translucent())
        .map(|m| m.eta.min(1.0 / m.eta).clamp(-1.0, 1.0).acos())
        .fold(0.0, f64::max);
    let cone = |centre: V3, points: &[V3], radius: f64| -> Option<(V3, f64)> {
        let a = normalize(sub(centre, mid));
        // The distance from the centre to the box (a sphere light's points are at least this
        // far from every point of it, less the radius).
        let gap: V3 = std::array::from_fn(|k| (lo[k] - centre[k]).max(centre[k] - hi[k]).max(0.0));
        let dist = dot(gap, gap).sqrt();
        if !(dist > radius) {
            return Some((a, -1.0));
        }
        let mut half = 0.0f64;
        for &y in points {
            for &b in &corners {
                let v = sub(y, b);
                half = half.max((dot(v, a) / dot(v, v).sqrt()).clamp(-1.0, 1.0).acos());
            }
        }
        let total = half + (radius / dist).asin() + turn;
        let right = 0.5 * std::f64::consts::PI;
        Some((a, if half < right && total < std::f64::consts::PI { total.cos() } else { -1.0 }))
    };
    scene
        .lights
        .iter()
        .map(|l| match *l {
            Light::Rect { center, u, v, .. } => {
                let ys: Vec<V3> = [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)]
                    .iter()
                    .map(|&(a, b)| madd(madd(center, u, a), v, b))
                    .collect();
                cone(center, &ys, 0.0)
            }
            Light::Sphere { center, radius, .. } => cone(center, &[center], radius),
            Light::Point { .. } | Light::Directional { .. } => None,
        })
        .collect()
}
