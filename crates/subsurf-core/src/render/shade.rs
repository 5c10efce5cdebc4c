//! What the three methods share outside the translucent objects: tracing a ray through the
//! scene (environment, area-light emission, Lambertian surfaces with direct lighting, Fresnel
//! reflection off translucent surfaces), direct (transmitted) irradiance at a surface point,
//! and the single-scattering term S⁽¹⁾.
//!
//! Light transport outside the objects: Lambertian surfaces are lit directly (lights and the
//! environment seen with shadow rays), plus the specular paths of the smooth dielectric
//! boundaries (up to [`MAX_DEPTH`] bounces). Light arriving at a translucent surface is gathered
//! with [`trace_seen`] (`Seen::NoLights`) beside next-event estimation of the lights (see
//! [`super::irradiance`]), so it includes what other surfaces reflect, as the random walk's exits
//! see it. Each method supplies the translucent term through [`Translucency`].

use super::accel::Hit;
use super::irradiance::Entry;
use super::material::{Material, Translucent};
use super::math::{add, dot, mul, neg, scale, Frame, Rgb, V3};
use super::scene::Scene;
pub use crate::diffusion::bssrdf::ft;
use crate::hk::single_scattering_brdf;
use crate::optics::{fr_dielectric, reflect, refract, sample_cosine_hemisphere};
use crate::rng::PhotonRng;
use std::f64::consts::PI;

/// Most specular bounces (and nested translucent evaluations) on one camera path.
pub const MAX_DEPTH: u32 = 6;

/// A method's light transmitted through a translucent surface: radiance leaving `hit`
/// towards `wo` (unit, on the outside), *not* counting the Fresnel-reflected part.
pub trait Translucency: Send + Sync {
    fn radiance(&self, scene: &Scene, hit: &Hit, wo: V3, depth: u32, rng: &mut PhotonRng) -> Rgb;
    /// Whether the shading (`shade`) adds the light that crosses the object unscattered ([`unscattered`]):
    /// the BSSRDF methods, whose profiles hold only scattered light; not the random walk, whose
    /// paths include it.
    fn adds_unscattered(&self) -> bool {
        false
    }
    /// The probability of tracing a Fresnel-reflected ray (reflectance `fr`) that may meet a
    /// surface in a scene lit by its environment alone (`reflected`): 1 (always) but for the
    /// random walk, where it was measured ([`REFLECTED_F0`]).
    fn reflected_trace_q(&self, _fr: f64) -> f64 {
        1.0
    }
}

/// Radiance arriving at `o` from direction `d` (unit), the first surface after skipping
/// triangle `skip`.
pub fn trace(scene: &Scene, o: V3, d: V3, skip: u32, depth: u32, rng: &mut PhotonRng, tr: &dyn Translucency) -> Rgb {
    trace_seen(scene, (o, d, skip), depth, rng, tr, Seen::All)
}

/// What a traced ray counts of the emitters it meets directly ([`trace_seen`]).
#[derive(Clone, Copy, PartialEq, Eq)]
pub enum Seen {
    /// Lights and the environment ([`trace`]).
    All,
    /// Not the lights (area-light emission counts 0): a gathering ray adds to next-event
    /// estimation of every light (as in [`direct_irradiance`]), so each light path is counted once.
    NoLights,
    /// Not the environment (0 where the ray escapes the scene): the random walk's exits whose
    /// escape to the environment its next-flight estimator counts.
    NoEnvironment,
    /// Neither (the random walk's exits whose lights and environment its next-flight
    /// estimators count).
    NoEmitters,
}

/// [`trace`] of the ray `(o, d, skip)` with the directly seen emitters of `seen` only (what it
/// meets beyond the first surface counts in full).
pub fn trace_seen(
    scene: &Scene,
    (o, d, skip): (V3, V3, u32),
    depth: u32,
    rng: &mut PhotonRng,
    tr: &dyn Translucency,
    seen: Seen,
) -> Rgb {
    let hit = scene.accel.intersect(o, d, f64::INFINITY, skip);
    shade_seen(scene, (o, d), hit, depth, rng, tr, seen)
}

/// [`trace_seen`] of the ray from `o` along `d` whose first surface `hit` was found already.
pub fn shade_seen(
    scene: &Scene,
    (o, d): (V3, V3),
    hit: Option<Hit>,
    depth: u32,
    rng: &mut PhotonRng,
    tr: &dyn Translucency,
    seen: Seen,
) -> Rgb {
    let tmax = hit.map_or(f64::INFINITY, |h| h.t);
    if let Some((_, le)) = scene.light_hit(o, d, tmax) {
        return if matches!(seen, Seen::NoLights | Seen::NoEmitters) { [0.0; 3] } else { le };
    }
    if hit.is_none() && matches!(seen, Seen::NoEnvironment | Seen::NoEmitters) {
        return [0.0; 3];
    }
    shade(scene, hit, d, depth, rng, tr)
}

/// Radiance leaving the first surface `hit` of the ray along `d` (the environment if none),
/// lights along the ray not counted.
pub(super) fn shade(
    scene: &Scene,
    hit: Option<Hit>,
    d: V3,
    depth: u32,
    rng: &mut PhotonRng,
    tr: &dyn Translucency,
) -> Rgb {
    let Some(h) = hit else {
        return scene.environment;
    };
    let wo = neg(d);
    if dot(wo, h.n) <= 0.0 {
        return [0.0; 3]; // the back of a surface (open meshes are one-sided)
    }
    match scene.material(h.object) {
        Material::Lambertian(albedo) => {
            let e = direct_irradiance(scene, &h, None, true, 1, rng);
            scale(mul(*albedo, e), 1.0 / PI)
        }
        Material::Translucent(m) => {
            let cos_o = dot(wo, h.n);
            let fr = fr_dielectric(cos_o, 1.0, m.eta);
            let mut l = tr.radiance(scene, &h, wo, depth, rng);
            if depth < MAX_DEPTH && fr > 0.0 {
                let r = reflect(d, h.n);
                l = add(l, scale(reflected(scene, &h, r, fr, depth, rng, tr), fr));
            }
            if depth < MAX_DEPTH && tr.adds_unscattered() {
                l = add(l, unscattered(scene, &h, d, depth, rng, tr));
            }
            l
        }
    }
}

/// The random walk traces the Fresnel-reflected ray off a translucent surface, in a scene lit by
/// its environment alone and where the ray needs a traversal (`reflected`), with probability
/// q = min(1, F/F₀), F the reflectance, F₀ this: the thinning adds F²(L_r − L_env)²(1/q − 1) to
/// the variance at a cost ∝ q, and q ∝ F is the allocation that minimises their product for a
/// difference L_r − L_env of one size (the rays near normal incidence, F ≈ 0.02 at η 1.3, are
/// traced least). Measured on the bench's skin torus (one thread, 64², six renders of 128 spp;
/// render-pass instructions by callgrind at 64 spp), against the uniform q = 1/4 before: F₀ = 0.1
/// variance −1.7 %, instructions +2.2 %; **0.3: −0.9 %, −1.3 % (1.02×)**; 0.5: −0.0 %, about
/// −2 %; 1: +2.1 %, −3.0 %; 2: +5.7 %. The uniform 1/4 had cost the variance 1.1 % for −7.2 %
/// CPU against tracing every ray (q = 0.1: +2.2 %; the thicker torus of
/// `sobol_walks_change_the_noise_not_the_answer` +5 to +8 %).
pub const REFLECTED_F0: f64 = 0.3;

/// Radiance arriving along the reflected direction `r` at `h`. In a scene lit by its (constant)
/// environment alone a ray that may meet a surface is traced with probability q
/// ([`Translucency::reflected_trace_q`]) and the estimate is L_env + (L_r − L_env)·1[traced]/q:
/// unbiased, and exact where the ray escapes (L_r = L_env), so only the rays that meet the scene
/// add noise (Russian roulette, Arvo & Kirk 1990, "Particle transport and image synthesis",
/// SIGGRAPH, applied to the difference from a control of known value: Owen 2013, *Monte Carlo
/// theory, methods and examples*, §8.9; checked by the test
/// `thinned_reflection_is_unbiased_where_it_meets_the_object`). A ray known to escape
/// ([`super::accel::Accel::escapes`]) and scenes with lights are traced.
fn reflected(scene: &Scene, h: &Hit, r: V3, fr: f64, depth: u32, rng: &mut PhotonRng, tr: &dyn Translucency) -> Rgb {
    reflected_q(scene, h, r, depth, rng, tr, tr.reflected_trace_q(fr))
}

/// [`reflected`] with the trace probability `q` (≤ 1; 1: always traced).
pub(super) fn reflected_q(
    scene: &Scene,
    h: &Hit,
    r: V3,
    depth: u32,
    rng: &mut PhotonRng,
    tr: &dyn Translucency,
    q: f64,
) -> Rgb {
    if q < 1.0 && scene.lights.is_empty() && !scene.accel.escapes(r, h.tri) {
        let env = scene.environment;
        if rng.uniform() >= q {
            return env;
        }
        let lr = trace(scene, h.p, r, h.tri, depth + 1, rng, tr);
        return std::array::from_fn(|k| env[k] + (lr[k] - env[k]) / q);
    }
    trace(scene, h.p, r, h.tri, depth + 1, rng, tr)
}

/// Unscattered attenuation e^(−σt ℓ) below which [`unscattered`] traces nothing (10⁻⁶ of the
/// radiance behind; a 2 mm marble slab transmits 1.2 % of red at normal incidence).
const UNSCATTERED_MIN: f64 = 1e-6;

/// Radiance arriving at `hit` along `d` (the ray met the translucent object there from outside)
/// that crossed the object without scattering: refracted in (F_t), attenuated by e^(−σt ℓ) per
/// channel along the chord ℓ to where the refracted ray leaves the same object, refracted out
/// (F_t; none on total internal reflection) and traced on (η² in and out cancel). The direct
/// pass only (a chord's internal reflections are ≤ F² of it); the adaptive tables' T holds the
/// complement, the engine's scattered bottom escapes (`bssrdf::adaptive::BottomTally`). Media
/// of one layer without a voxel grid (a stack's first layer would not give its chord's
/// attenuation); the entry texel's medium on a textured object. A thin part seen against a
/// light (the validation matrix's 2 mm backlit marble slab) shows the light's image through it:
/// 7.9, 3.8, 1.9 % of that row's object mean (R, G, B), missing before (`docs/render.md`).
pub fn unscattered(scene: &Scene, hit: &Hit, d: V3, depth: u32, rng: &mut PhotonRng, tr: &dyn Translucency) -> Rgb {
    let Some(m) = super::texture::shading_medium(scene, hit) else { return [0.0; 3] };
    if m.grid.is_some() || m.stacks.iter().any(|s| s.layers.len() != 1) {
        return [0.0; 3];
    }
    let Some(t) = refract(d, hit.n, 1.0, m.eta) else { return [0.0; 3] };
    let Some(x) = scene.accel.intersect(hit.p, t, f64::INFINITY, hit.tri) else { return [0.0; 3] };
    let cos_x = dot(t, x.n);
    if x.object != hit.object || cos_x <= 0.0 {
        return [0.0; 3]; // another object (nested) or the inside of a fold: not a chord of this one
    }
    let att: Rgb = std::array::from_fn(|k| (-m.sigma_t[k] * x.t).exp());
    let Some(out) = refract(t, x.n, m.eta, 1.0).filter(|_| att.iter().any(|&a| a > UNSCATTERED_MIN)) else {
        return [0.0; 3];
    };
    let f = (1.0 - fr_dielectric(-dot(d, hit.n), 1.0, m.eta)) * (1.0 - fr_dielectric(cos_x, m.eta, 1.0));
    let l = trace(scene, x.p, out, x.tri, depth + 1, rng, tr);
    std::array::from_fn(|k| l[k] * att[k] * f)
}

/// Irradiance at the surface point of `hit` (on its front side) from the lights (one sample
/// each, shadow rays; if `lights`) and the environment (`env_samples` cosine-weighted rays).
/// With `into` Some(entry) each direction is weighted by [`Entry::weight`] (F_t(η, cos θ), and
/// the adaptive model's oblique gain): the irradiance transmitted into the medium.
pub fn direct_irradiance(
    scene: &Scene,
    hit: &Hit,
    into: Option<Entry<'_>>,
    lights: bool,
    env_samples: u32,
    rng: &mut PhotonRng,
) -> Rgb {
    let n = hit.n;
    let p = scene.accel.offset(hit.p, n, 1.0);
    let mut e = [0.0; 3];
    if lights {
        light_samples(scene, hit, into, rng, |_, _, de| e = add(e, de));
    }
    if scene.environment != [0.0; 3] && env_samples > 0 {
        let f = Frame::new(n);
        let mut acc = [0.0; 3];
        for _ in 0..env_samples {
            let w = sample_cosine_hemisphere(rng.uniform(), rng.uniform());
            let wi = f.to_world(w);
            if !scene.accel.occluded(p, wi, f64::INFINITY, hit.tri) && scene.light_hit(p, wi, f64::INFINITY).is_none() {
                acc = add(acc, into.map_or([1.0; 3], |i| i.weight(w[2])));
            }
        }
        e = add(e, mul(scene.environment, acc.map(|a| PI * a / env_samples as f64)));
    }
    e
}

/// One shadow-ray sample of every light at `hit` (front side), in the scene's order: for each
/// that arrives from the front and is not occluded, `f(ω_i, cos θ_i, E)` with E = L cos θ_i times
/// the entry weight of `into` (1 for `None`). [`direct_irradiance`]'s lights are the sum of the E.
pub fn light_samples(
    scene: &Scene,
    hit: &Hit,
    into: Option<Entry<'_>>,
    rng: &mut PhotonRng,
    f: impl FnMut(V3, f64, Rgb),
) {
    light_samples_in(scene, hit, into, rng, Stratum::WHOLE, f)
}

/// A cell of the unit square of a light's sample coordinates (u1, u2) (for a rectangle, its
/// area; for a sphere, the cone's cos θ and azimuth): column `i`, row `j` of a `k` × `k` grid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stratum {
    pub i: u32,
    pub j: u32,
    pub k: u32,
}

impl Stratum {
    /// The whole square (the unstratified sample: the same draws, the same bits).
    pub const WHOLE: Stratum = Stratum { i: 0, j: 0, k: 1 };

    /// The cell of sample `s` of `n` (jittered sampling): the first k² = ⌊√n⌋² samples one per
    /// cell of the k × k grid, the rest over the whole square. Each is uniform over its cell, so
    /// the mean of the n samples is unbiased, and its variance where a shadow's edge crosses the
    /// light (a penumbra) falls as n^(−3/2) instead of n^(−1).
    pub fn of(s: u32, n: u32) -> Stratum {
        let k = (n as f64).sqrt() as u32;
        let k = if (k + 1) * (k + 1) <= n {
            k + 1
        } else if k * k > n {
            k - 1
        } else {
            k
        };
        if s < k * k {
            Stratum { i: s % k, j: s / k, k }
        } else {
            Stratum::WHOLE
        }
    }

    /// (u1, u2) ∈ [0, 1)² mapped into the cell.
    #[inline]
    pub fn map(&self, u1: f64, u2: f64) -> (f64, f64) {
        let k = self.k as f64;
        ((self.i as f64 + u1) / k, (self.j as f64 + u2) / k)
    }
}

/// [`light_samples`] with each light's sample coordinates in the cell `cell` ([`Stratum`]).
pub fn light_samples_in(
    scene: &Scene,
    hit: &Hit,
    into: Option<Entry<'_>>,
    rng: &mut PhotonRng,
    cell: Stratum,
    mut f: impl FnMut(V3, f64, Rgb),
) {
    let n = hit.n;
    let p = scene.accel.offset(hit.p, n, 1.0);
    for l in &scene.lights {
        let u1 = rng.uniform();
        let (u1, u2) = cell.map(u1, rng.uniform());
        let Some(ls) = l.sample(p, u1, u2) else { continue };
        let c = dot(ls.wi, n);
        if c <= 0.0 || ls.value == [0.0; 3] {
            continue;
        }
        let w = into.map_or([1.0; 3], |i| i.weight(c));
        if !scene.accel.occluded(p, ls.wi, ls.dist, hit.tri) {
            f(ls.wi, c, mul(ls.value, scale(w, c)));
        }
    }
}

/// The single-scattering radiance S⁽¹⁾ at `hit` towards `wo`: the Hanrahan–Krueger
/// first-order BRDF of the semi-infinite medium (Jensen et al. 2001 §2.3, evaluated with the
/// local tangent plane) under the lights (one shadow-ray sample each) and one cosine-weighted
/// gathering ray ([`trace_seen`], `Seen::NoLights`, at `depth` + 1: the environment, light reflected by other
/// surfaces and translucent objects through `tr`; the environment alone, occluded, at
/// [`MAX_DEPTH`]).
pub fn single_scattering(
    scene: &Scene,
    m: &Translucent,
    hit: &Hit,
    wo: V3,
    depth: u32,
    rng: &mut PhotonRng,
    tr: &dyn Translucency,
) -> Rgb {
    let f = Frame::new(hit.n);
    let wo_l = f.to_local(wo);
    if wo_l[2] <= 0.0 {
        return [0.0; 3];
    }
    let brdf =
        |wi_l: V3| -> Rgb { std::array::from_fn(|k| single_scattering_brdf(&m.stacks[k], wi_l, wo_l).unwrap_or(0.0)) };
    let p = scene.accel.offset(hit.p, hit.n, 1.0);
    let mut l = [0.0; 3];
    for light in &scene.lights {
        let Some(ls) = light.sample(p, rng.uniform(), rng.uniform()) else { continue };
        let wi_l = f.to_local(ls.wi);
        if wi_l[2] <= 0.0 || scene.accel.occluded(p, ls.wi, ls.dist, hit.tri) {
            continue;
        }
        l = add(l, scale(mul(brdf(wi_l), ls.value), wi_l[2]));
    }
    let w = sample_cosine_hemisphere(rng.uniform(), rng.uniform());
    let wi = f.to_world(w);
    let li = if depth < MAX_DEPTH {
        trace_seen(scene, (p, wi, hit.tri), depth + 1, rng, tr, Seen::NoLights)
    } else if !scene.accel.occluded(p, wi, f64::INFINITY, hit.tri) && scene.light_hit(p, wi, f64::INFINITY).is_none() {
        scene.environment
    } else {
        [0.0; 3]
    };
    if li != [0.0; 3] {
        l = add(l, scale(mul(brdf(w), li), PI));
    }
    l
}

/// The tint of the surface at `hit` (1 without one).
pub fn tint(scene: &Scene, hit: &Hit) -> Rgb {
    let local = scene.accel.tris[hit.tri as usize].local as usize;
    scene.objects[hit.object].mesh.tint_at(local, hit.b1, hit.b2)
}
