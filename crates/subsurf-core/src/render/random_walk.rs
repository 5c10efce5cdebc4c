//! `random_walk`: brute-force volumetric path tracing inside the closed meshes, no diffusion
//! assumption (the ground truth the BSSRDF images are compared with).
//!
//! The camera path refracts into the object at x_o (Fresnel on the triangle's normal; the
//! reflected part is traced by [`super::shade::trace`]) and walks with the engine's physics:
//! - free paths with spectral MIS (one-sample balance heuristic over the RGB channels, with
//!   the channel chosen in proportion to the path throughput β, as Cycles' random walk and
//!   Chiang, Kutz & Burley 2016 §4): with w_k = β_k/Σβ a channel c ~ w is chosen,
//!   s ~ σt,c e^{−σt,c s}; at a collision β_k ← β_k σs,k T_k(s) / p̄(s), p̄ = Σ_j w_j σt,j T_j(s);
//!   reaching the boundary at t, β_k ← β_k T_k(t) / Σ_j w_j T_j(t). Unbiased in every channel,
//!   and Σβ never grows (for albedo ≤ 1), so colour-dependent σt gives no fireflies (a
//!   uniform channel choice makes β a product of many mean-one factors: heavy-tailed);
//! - Henyey–Greenstein scattering from [`crate::optics::Phase`] and the direction update
//!   [`crate::optics::spin`], random numbers from [`crate::rng::PhotonRng`];
//! - smooth-dielectric boundaries with the triangle's geometric normal: reflect with the
//!   Fresnel probability ([`crate::optics::fr_dielectric`]) else refract
//!   ([`crate::optics::refract`]); nested closed objects are separate media (a stack of the
//!   objects containing the path), so layered materials are nested meshes;
//! - Russian roulette on max_k β_k.
//!
//! Light reaches the interior in two ways: the path leaves the object and the ray continues
//! outside ([`super::shade::trace`]: environment, area lights, Lambertian surfaces with
//! next-event estimation to every light); and next-event estimation from every collision in
//! the outermost object to every light *through* the smooth boundary, solved exactly on a flat
//! facet ([`super::facet_nee`]: directional beams, point lights and points sampled on area
//! lights). A straight exit after such a collision that reaches an area light along the very
//! connection the facet search finds counts nothing (see `exit_counted_by_nee`); other exits
//! (through another facet, or after an internal reflection) count the light: the two
//! estimators partition the paths, so nothing is counted twice or lost. Connections through two refractions (nested media) are not
//! made: lights reach inner layers through the outer one by the random walk itself.

use super::accel::Hit;
use super::facet_nee;
use super::light::Light;
use super::material::{Material, Translucent};
use super::math::{add, dot, madd, max3, mul, neg, normalize, scale, sub, Rgb, V3};
use super::scene::Scene;
use super::shade::{tint, trace, Translucency, MAX_DEPTH};
use crate::optics::{fr_dielectric, reflect, refract, spin};
use crate::rng::PhotonRng;

/// Safety net: most events (collisions and boundary hits) in one walk.
pub const MAX_EVENTS: u32 = 1_000_000;

/// The objects containing the current point, innermost last.
#[derive(Clone, Copy, Debug)]
pub struct Media {
    ids: [u32; 8],
    len: usize,
}

impl Media {
    /// Outside every object.
    pub fn empty() -> Media {
        Media { ids: [0; 8], len: 0 }
    }
    /// Inside `object` only.
    pub fn inside(object: usize) -> Media {
        let mut m = Media::empty();
        m.push(object);
        m
    }
    pub fn top(&self) -> Option<usize> {
        (self.len > 0).then(|| self.ids[self.len - 1] as usize)
    }
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
    pub fn depth(&self) -> usize {
        self.len
    }
    fn push(&mut self, o: usize) {
        if self.len < self.ids.len() {
            self.ids[self.len] = o as u32;
            self.len += 1;
        }
    }
    fn remove(&mut self, o: usize) {
        if let Some(i) = self.ids[..self.len].iter().rposition(|&x| x as usize == o) {
            self.ids.copy_within(i + 1..self.len, i);
            self.len -= 1;
        }
    }
    /// Refractive index of the innermost medium (1 outside every object).
    fn index(&self, scene: &Scene) -> f64 {
        self.top().and_then(|o| scene.material(o).translucent()).map_or(1.0, |m| m.eta)
    }
}

/// What happened at a boundary.
pub enum Crossing {
    Reflected(V3),
    Transmitted(V3),
    /// The path met an opaque surface from inside a medium: it ends there.
    Opaque,
}

/// Fresnel reflection or refraction at `hit` for a path travelling along `d` with the media
/// `media` (updated on transmission); `u` decides (reflect if u < F).
pub fn cross_boundary(scene: &Scene, media: &mut Media, hit: &Hit, d: V3, u: f64) -> Crossing {
    let Some(m) = scene.material(hit.object).translucent() else { return Crossing::Opaque };
    let entering = dot(d, hit.n) < 0.0;
    let n1 = media.index(scene);
    let mut after = *media;
    if entering {
        after.push(hit.object);
    } else {
        after.remove(hit.object);
    }
    let n2 = if entering { m.eta } else { after.index(scene) };
    let cos = dot(d, hit.n).abs();
    let f = fr_dielectric(cos, n1, n2);
    if u < f {
        return Crossing::Reflected(reflect(d, hit.n));
    }
    match refract(d, hit.n, n1, n2) {
        Some(t) => {
            *media = after;
            Crossing::Transmitted(t)
        }
        None => Crossing::Reflected(reflect(d, hit.n)),
    }
}

/// The random-walk method.
pub struct RandomWalk {
    /// Next-event estimation through facets (off only to test it against plain path tracing).
    pub nee: bool,
}

impl RandomWalk {
    pub fn new(_scene: &Scene) -> RandomWalk {
        RandomWalk { nee: true }
    }

    /// Radiance carried back along a path that has just refracted into `hit.object` at `hit`
    /// with direction `d` (per unit of the radiance-carrying throughput).
    fn walk(&self, scene: &Scene, hit: &Hit, d0: V3, depth: u32, rng: &mut PhotonRng) -> Rgb {
        let mut media = Media::inside(hit.object);
        let (mut beta, mut l) = ([1.0; 3], [0.0; 3]);
        let (mut p, mut d, mut skip) = (hit.p, d0, hit.tri);
        let mut covered = false;
        let mut last = (p, hit.object, 1.0);
        for _ in 0..MAX_EVENTS {
            let Some(top) = media.top() else { break };
            let Some(m) = scene.material(top).translucent() else { break };
            let Some(h) = scene.accel.intersect(p, d, f64::INFINITY, skip) else {
                break; // numerically leaked out of a closed mesh: the path is lost
            };
            let st = m.sigma_t;
            // Channel chosen with probability ∝ β_k (throughput-weighted spectral MIS).
            let bsum = beta[0] + beta[1] + beta[2];
            if !(bsum > 0.0) {
                break;
            }
            let w: Rgb = scale(beta, 1.0 / bsum);
            let u = rng.uniform();
            let c = if u < w[0] {
                0
            } else if u < w[0] + w[1] {
                1
            } else {
                2
            };
            let s = if st[c] > 0.0 { -(-rng.uniform()).ln_1p() / st[c] } else { f64::INFINITY };
            if s < h.t {
                let tr: Rgb = std::array::from_fn(|k| (-st[k] * s).exp());
                let pbar = dot(w, mul(st, tr));
                if !(pbar > 0.0) {
                    break;
                }
                beta = std::array::from_fn(|k| beta[k] * m.sigma_s[k] * tr[k] / pbar);
                p = madd(p, d, s);
                skip = u32::MAX;
                let q = if self.nee && media.depth() == 1 { self.nee_probability(scene, m, p) } else { 0.0 };
                covered = q > 0.0 && rng.uniform() < q;
                if covered {
                    l = add(l, mul(beta, self.nee(scene, m, top, p, d, q, rng)));
                    last = (p, top, m.eta);
                }
                let cos = m.phase.sample(rng.uniform());
                let phi = 2.0 * std::f64::consts::PI * rng.uniform();
                d = spin(d, cos, phi.cos(), phi.sin());
                let q = max3(beta);
                if q < 1.0 {
                    if rng.uniform() >= q {
                        break;
                    }
                    beta = scale(beta, 1.0 / q);
                }
            } else {
                let tr: Rgb = std::array::from_fn(|k| (-st[k] * h.t).exp());
                let pbar = dot(w, tr);
                if !(pbar > 0.0) {
                    break;
                }
                beta = std::array::from_fn(|k| beta[k] * tr[k] / pbar);
                p = h.p;
                skip = h.tri;
                match cross_boundary(scene, &mut media, &h, d, rng.uniform()) {
                    Crossing::Opaque => break,
                    Crossing::Reflected(r) => {
                        d = r;
                        covered = false;
                    }
                    Crossing::Transmitted(t) => {
                        d = t;
                        if media.is_empty() {
                            if covered && self.exit_counted_by_nee(scene, last, &h, p, d) {
                                break;
                            }
                            if depth < MAX_DEPTH {
                                l = add(l, mul(beta, trace(scene, p, d, h.tri, depth + 1, rng, self)));
                            }
                            break;
                        }
                        covered = false;
                    }
                }
            }
        }
        l
    }

    /// Whether a straight exit (from the collision `last` = (point, object, η) through the
    /// boundary at `h`, leaving at `p` along `d`) reaches an area light along a connection that
    /// next-event estimation at that collision already counted: the facet search from the
    /// collision to the light point found this very facet. Those exits count nothing; every
    /// other exit (other facets, failed searches) counts the light, so the two estimators
    /// partition the paths exactly.
    fn exit_counted_by_nee(&self, scene: &Scene, last: (V3, usize, f64), h: &Hit, p: V3, d: V3) -> bool {
        let tmax = scene.accel.intersect(p, d, f64::INFINITY, h.tri).map_or(f64::INFINITY, |x| x.t);
        let Some((tl, _)) = scene.light_hit(p, d, tmax) else { return false };
        let y = madd(p, d, tl);
        facet_nee::point(scene, last.1, last.2, last.0, y).is_some_and(|c| c.hit.tri == h.tri)
    }

    /// The probability q of making the connections at this collision: 1 within a few mean free
    /// paths of the boundary towards the lights, 20 e^{−σt,min t} beyond (t: the straight
    /// distance to the boundary towards the nearest light), so deep collisions, whose
    /// connections are attenuated by e^{−σt t}, mostly skip the rays. Area lights are not
    /// reweighted: a collision without connections leaves its exits to count them (`covered`
    /// false), so each path is counted by exactly one estimator. Delta lights, which no exit
    /// can reach, are weighted by 1/q. Both are unbiased.
    fn nee_probability(&self, scene: &Scene, m: &Translucent, v: V3) -> f64 {
        let st = m.sigma_t[0].min(m.sigma_t[1]).min(m.sigma_t[2]);
        let mut t = f64::INFINITY;
        for light in &scene.lights {
            let dir = match *light {
                Light::Directional { to_light, .. } => to_light,
                Light::Point { position, .. } => normalize(sub(position, v)),
                Light::Sphere { center, .. } => normalize(sub(center, v)),
                Light::Rect { center, .. } => normalize(sub(center, v)),
            };
            if let Some(h) = scene.accel.intersect(v, dir, t, u32::MAX) {
                t = t.min(h.t);
            }
        }
        if t.is_finite() {
            (20.0 * (-st * t).exp()).min(1.0)
        } else {
            0.0
        }
    }

    /// Next-event estimation of every light from the collision at `p` (camera path direction
    /// `d`) in the outermost object `obj`, through one flat facet ([`super::facet_nee`]); area
    /// lights by one uniformly sampled point each; delta lights weighted by 1/`q` (the
    /// probability the connections are made here). Returns the in-scattered radiance per unit
    /// β, times 1/η² (the radiance change at the exit x_o, which the walk's paired entry/exit
    /// factors otherwise cancel).
    #[allow(clippy::too_many_arguments)]
    fn nee(&self, scene: &Scene, m: &Translucent, obj: usize, p: V3, d: V3, q: f64, rng: &mut PhotonRng) -> Rgb {
        let mut l = [0.0; 3];
        for light in &scene.lights {
            let (conn, power): (Option<facet_nee::Connection>, Rgb) = match *light {
                Light::Directional { to_light, irradiance } => {
                    (facet_nee::directional(scene, obj, m.eta, p, to_light), scale(irradiance, 1.0 / q))
                }
                Light::Point { position, intensity } => {
                    (facet_nee::point(scene, obj, m.eta, p, position), scale(intensity, 1.0 / q))
                }
                Light::Sphere { .. } | Light::Rect { .. } => {
                    let Some((y, ny, le, pdf)) = light.sample_point(rng.uniform(), rng.uniform()) else { continue };
                    let Some(c) = facet_nee::point(scene, obj, m.eta, p, y) else { continue };
                    let cos_l = dot(ny, normalize(sub(c.hit.p, y)));
                    if cos_l <= 0.0 {
                        continue;
                    }
                    (Some(c), scale(le, cos_l / pdf))
                }
            };
            let Some(c) = conn else { continue };
            let w = c.factor * m.phase.eval(dot(c.d_in, neg(d))) / (m.eta * m.eta);
            l = add(l, std::array::from_fn(|k| w * power[k] * (-m.sigma_t[k] * c.dist_in).exp()));
        }
        l
    }
}

impl Translucency for RandomWalk {
    fn radiance(&self, scene: &Scene, hit: &Hit, wo: V3, depth: u32, rng: &mut PhotonRng) -> Rgb {
        let Material::Translucent(m) = scene.material(hit.object) else { return [0.0; 3] };
        let d = neg(wo);
        let f = fr_dielectric(dot(wo, hit.n), 1.0, m.eta);
        let Some(t) = refract(d, hit.n, 1.0, m.eta) else { return [0.0; 3] };
        scale(mul(self.walk(scene, hit, t, depth, rng), tint(scene, hit)), 1.0 - f)
    }
}
