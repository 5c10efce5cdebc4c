//! The transmitted irradiance E_t = ∫ F_t(η, cos θ) L_i(ω) cos θ dω at a point of a translucent
//! surface: what the BSSRDF methods spread through the profile (`hierarchical`'s samples,
//! `probe`'s entry points).
//!
//! The lights are sampled by next-event estimation (shadow rays, [`direct_irradiance`]); every
//! other light arriving at the point is gathered with cosine-weighted rays ([`trace_seen`] with `Seen::NoLights`):
//! the environment where it is visible, what Lambertian surfaces reflect (lit directly, as the
//! camera and the random walk's exits see them), the specular paths of the dielectric boundaries,
//! and translucent objects through the method's own [`Translucency`]. A gathering ray that reaches
//! a light counts nothing (next-event estimation counted it), so each path is counted once.
//! These are the paths the random walk gathers where it leaves an object, so the two agree up to
//! the profile's own error.
//!
//! Before (issue 20) the irradiance was the lights and the visible environment only: the light a
//! floor reflects was missing (examples/render/marble_sphere.toml: hierarchical/random_walk object
//! mean 0.711 with the floor of albedo 0.5, 0.580 with albedo 1, 0.947 without a floor).

use super::accel::Hit;
use super::material::Translucent;
use super::math::{add, length, madd, mul, scale, sub, Frame, Rgb, V3};
use super::scene::Scene;
use super::shade::{direct_irradiance, ft, light_samples_in, trace_seen, Seen, Stratum, Translucency, MAX_DEPTH};
use crate::bssrdf::adaptive::AdaptiveTable;
use crate::bssrdf::harmonic::AtRho;
use crate::optics::sample_cosine_hemisphere;
use crate::rng::PhotonRng;
use std::f64::consts::PI;
use std::sync::atomic::{AtomicBool, Ordering};

/// How the light crossing into a translucent medium is weighted per incident direction: the
/// Fresnel transmittance F_t(η, μ) for every model, times, for `model = "adaptive"`, the
/// oblique-incidence gain g_k(μ) = R_k(θi)/R_k(0) per channel ([`crate::bssrdf::oblique`]: the
/// kernel is the normal-incidence profile, and light arriving at θi reflects R(θi) per entering
/// power). So E_t,k = ∫ F_t(η, μ) g_k(μ) L_i,k μ dω.
#[derive(Clone, Copy)]
pub struct Entry<'a> {
    /// Relative index of the medium.
    pub eta: f64,
    /// The adaptive model's table (its gain), `None` for every other model (g ≡ 1).
    pub gain: Option<&'a AdaptiveTable>,
}

impl Entry<'_> {
    /// The weighting of material `m`.
    pub fn of(m: &Translucent) -> Entry<'_> {
        Entry { eta: m.eta, gain: m.adaptive.as_deref() }
    }

    /// F_t(η, μ)·g_k(μ) per channel, for μ = cos θi ∈ (0, 1].
    #[inline]
    pub fn weight(&self, mu: f64) -> Rgb {
        let f = ft(self.eta, mu);
        match self.gain {
            None => [f; 3],
            Some(t) => std::array::from_fn(|k| f * t.oblique_gain(k.min(t.channels() - 1), mu)),
        }
    }
}

/// E_t at `hit` (front side) into the medium of `into`: the mean of `light_samples` shadow-ray
/// samples of every light (none when 0; jittered over the light, [`Stratum::of`]) plus `rays` cosine-weighted gathering rays traced at
/// `depth` + 1 with `tr` for the translucent surfaces they reach, each direction weighted by
/// [`Entry::weight`]. At `depth` ≥ [`MAX_DEPTH`] the rays see the environment only (occluded),
/// ending the recursion through `tr`.
#[allow(clippy::too_many_arguments)]
pub fn transmitted_irradiance(
    scene: &Scene,
    hit: &Hit,
    into: Entry<'_>,
    light_samples: u32,
    rays: u32,
    depth: u32,
    rng: &mut PhotonRng,
    tr: &dyn Translucency,
) -> Rgb {
    let mut e = [0.0; 3];
    for s in 0..light_samples {
        light_samples_in(scene, hit, Some(into), rng, Stratum::of(s, light_samples), |_, _, de| e = add(e, de));
    }
    if light_samples > 1 {
        e = scale(e, 1.0 / light_samples as f64);
    }
    if rays == 0 {
        return e;
    }
    if depth >= MAX_DEPTH {
        return add(e, direct_irradiance(scene, hit, Some(into), false, rays, rng));
    }
    let p = scene.accel.offset(hit.p, hit.n, 1.0);
    let f = Frame::new(hit.n);
    let mut acc = [0.0; 3];
    for _ in 0..rays {
        let w = sample_cosine_hemisphere(rng.uniform(), rng.uniform());
        let li = trace_seen(scene, (p, f.to_world(w), hit.tri), depth + 1, rng, tr, Seen::NoLights);
        acc = add(acc, mul(li, into.weight(w[2])));
    }
    madd(e, acc, PI / rays as f64)
}

/// Per class (0: the kernel's near side, 1: across) and channel, an entry point's harmonic
/// vector m = ⟨a(μ)·t̂⟩ over its transmitted irradiance ([`crate::bssrdf::harmonic`]): t̂ the unit
/// tangent of each light's propagation direction, a the table's amplitude at the light's μ, the
/// mean weighted by the light's share of E_t,k (the gathered light, which arrives from every
/// direction, counts with none). |m| is the pair factor's amplitude, m/|m| its forward direction.
pub type Harm = [[V3; 3]; 2];

/// Per channel, an entry point's exit-coupling vector D = ⟨A·ω_t⟩ over its transmitted
/// irradiance ([`crate::bssrdf::coupling`]): ω_t the tangential part of each light's direction
/// (towards the light; |ω_t| = sin θi), A the table's amplitude, the mean
/// weighted by the light's share of E_t,k (the gathered light counts with none). The radiance
/// of the near class leaving towards ω_o is × (1 + D·ω_o,t).
pub type Coupled = [V3; 3];

/// [`transmitted_irradiance`] and the harmonic vectors of its lights (see [`Harm`]) for the
/// amplitudes `amps` (per channel, at the entry point's curvature; `None`: no harmonic), and
/// their exit-coupling vectors ([`Coupled`], from `into`'s adaptive table; zero without one).
/// The same draws, in the same order, and the same E_t to the last bit: the lights are sampled
/// as [`direct_irradiance`]'s, then the gathering rays are [`transmitted_irradiance`]'s.
#[allow(clippy::too_many_arguments)]
pub fn irradiance_and_harmonic(
    scene: &Scene,
    hit: &Hit,
    into: Entry<'_>,
    light_samples: u32,
    rays: u32,
    depth: u32,
    rng: &mut PhotonRng,
    tr: &dyn Translucency,
    amps: Option<&[AtRho; 3]>,
) -> (Rgb, Harm, Coupled) {
    let n = hit.n;
    let (mut e, mut m, mut d) = ([0.0; 3], [[[0.0; 3]; 3]; 2], [[0.0; 3]; 3]);
    let table = into.gain.filter(|t| t.has_coupling());
    for s in 0..light_samples {
        let mut one = [0.0; 3];
        light_samples_in(scene, hit, Some(into), rng, Stratum::of(s, light_samples), |wi, c, de| {
            one = add(one, de);
            let tan = sub(scale(n, c), wi); // the propagation direction −ω_i, its tangential part
            let tl = length(tan);
            if tl <= 1e-12 {
                return;
            }
            if let Some(amps) = amps {
                for k in 0..3 {
                    let a = amps[k].at(c);
                    for (cl, mc) in m.iter_mut().enumerate() {
                        mc[k] = madd(mc[k], tan, de[k] * a[cl] / tl);
                    }
                }
            }
            if let Some(t) = table {
                for (k, dk) in d.iter_mut().enumerate() {
                    *dk = madd(*dk, tan, -de[k] * t.coupling(k.min(t.channels() - 1)).a);
                }
            }
        });
        e = add(e, one);
    }
    if light_samples > 1 {
        e = scale(e, 1.0 / light_samples as f64);
        m = m.map(|mc| mc.map(|v| scale(v, 1.0 / light_samples as f64)));
        d = d.map(|v| scale(v, 1.0 / light_samples as f64));
    }
    let e = add(e, transmitted_irradiance(scene, hit, into, 0, rays, depth, rng, tr));
    let per_e = |v: V3, k: usize| if e[k] > 0.0 { scale(v, 1.0 / e[k]) } else { [0.0; 3] };
    let m = m.map(|mc| std::array::from_fn(|k| per_e(mc[k], k)));
    let d = std::array::from_fn(|k| per_e(d[k], k));
    (e, m, d)
}

/// A stand-in for the translucent objects while their own irradiance is being computed: black,
/// noting whether a gathering ray reached one (then the hierarchical method gathers again with
/// the first estimate: one bounce of light between translucent surfaces).
#[derive(Default)]
pub struct Unlit {
    /// Set when [`Translucency::radiance`] was called.
    pub reached: AtomicBool,
}

impl Translucency for Unlit {
    fn radiance(&self, _: &Scene, _: &Hit, _: V3, _: u32, _: &mut PhotonRng) -> Rgb {
        self.reached.store(true, Ordering::Relaxed);
        [0.0; 3]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::light::Light;
    use crate::render::material::{Material, TestProfile, Translucent};
    use crate::render::scene::Object;
    use crate::render::shapes::{cuboid, rectangle};
    use std::sync::Arc;

    const ETA: f64 = 1.4;
    const INTO: Entry<'static> = Entry { eta: ETA, gain: None };

    /// A 0.2 mm translucent cube at height `h` over a 400 mm Lambertian floor of albedo `rho`.
    fn cube_over_floor(h: f64, rho: f64, lights: Vec<Light>, env: Rgb) -> Scene {
        let profiles: [Arc<dyn crate::bssrdf::RadialProfile>; 3] =
            std::array::from_fn(|_| Arc::new(TestProfile { total: 0.5, s: 1.0 }) as _);
        let m = Translucent::new("m", [0.01; 3], [1.0; 3], 0.0, ETA, Some(profiles), false).unwrap();
        let objects = vec![
            Object { name: "cube".into(), mesh: cuboid([-0.1, -0.1, h], [0.1, 0.1, h + 0.2]).unwrap(), material: 0 },
            Object { name: "floor".into(), mesh: rectangle(0.0, 0.0, 0.0, 400.0, 400.0).unwrap(), material: 1 },
        ];
        let mats = vec![Material::Translucent(Box::new(m)), Material::Lambertian([rho; 3])];
        Scene::new(objects, mats, lights, env, None).unwrap()
    }

    /// The hit at the centre of the cube's face with outward normal `n`.
    fn face(s: &Scene, h: f64, n: V3) -> Hit {
        let c = [0.0, 0.0, h + 0.1];
        let o = [c[0] + 0.12 * n[0], c[1] + 0.12 * n[1], c[2] + 0.12 * n[2]];
        let hit = s.accel.intersect(o, [-n[0], -n[1], -n[2]], f64::INFINITY, u32::MAX).unwrap();
        assert_eq!(hit.object, 0);
        hit
    }

    /// Mean and standard error of channel 0 of `n` estimates.
    fn mean_se(n: u32, mut f: impl FnMut(u64) -> f64) -> (f64, f64) {
        let (mut s, mut s2) = (0.0, 0.0);
        for i in 0..n {
            let x = f(i as u64);
            s += x;
            s2 += x * x;
        }
        let m = s / n as f64;
        (m, ((s2 / n as f64 - m * m).max(0.0) / (n as f64 - 1.0)).sqrt())
    }

    /// 2π ∫_{μ0}^1 F_t(η, μ) μ dμ (midpoint rule, 10⁵ steps: exact to ~1e-10).
    fn ft_cos(mu0: f64) -> f64 {
        let n = 100_000;
        let h = (1.0 - mu0) / n as f64;
        2.0 * PI * (0..n).map(|i| mu0 + (i as f64 + 0.5) * h).map(|mu| ft(ETA, mu) * mu * h).sum::<f64>()
    }

    /// A face looking down at a floor under a constant environment L: it sees the floor's
    /// radiance ρL (the floor sees the sky but for the 0.2 mm cube 10 mm above it: < 10⁻³ of its
    /// irradiance), so E_t = ρL·2π∫F_t μ dμ over the directions that meet the floor (μ above
    /// 10/√(200² + 10²); the corners of the square add < 0.3 %). Before the fix this was 0 (the
    /// environment occluded, the floor's light missing). Power: 4σ is 0.3 % of the value.
    #[test]
    fn a_face_looking_at_a_floor_receives_its_reflected_light() {
        let (h, rho, env) = (10.0, 0.5, 1.0);
        let s = cube_over_floor(h, rho, vec![], [env; 3]);
        let hit = face(&s, h, [0.0, 0.0, -1.0]);
        let (got, se) = mean_se(20_000, |i| {
            let mut rng = PhotonRng::new(5, i);
            transmitted_irradiance(&s, &hit, INTO, 1, 1, 0, &mut rng, &Unlit::default())[0]
        });
        let lo = rho * env * ft_cos(h / (200.0f64 * 200.0 + h * h).sqrt());
        let hi = rho * env * ft_cos(0.0);
        println!("E_t = {got:.5} ± {se:.5}, expected [{lo:.5}, {hi:.5}]");
        assert!(got > lo - 4.0 * se - 1e-3 * lo && got < hi + 4.0 * se, "{got} vs [{lo}, {hi}]");
    }

    /// A face looking up at an area light and the sky: the light by next-event estimation only
    /// (gathering rays that reach it count nothing: a double count would add ~100 %), the sky by
    /// the gathering rays: E_t = the shadow-ray estimate of the light + L·2π∫F_t μ dμ (the whole
    /// upper hemisphere but the light's solid angle, 0.4 % of the projected one here, is sky).
    /// Power: 4σ of the difference is 1.4 % of the value.
    #[test]
    fn lights_are_counted_once() {
        let (h, env) = (10.0, 0.2);
        let light = Light::rect("l", [0.0, 0.0, 40.0], [2.0, 0.0, 0.0], [0.0, -2.0, 0.0], [500.0; 3]).unwrap();
        let s = cube_over_floor(h, 0.5, vec![light], [env; 3]);
        let hit = face(&s, h, [0.0, 0.0, 1.0]);
        let (got, se) = mean_se(20_000, |i| {
            let mut rng = PhotonRng::new(6, i);
            transmitted_irradiance(&s, &hit, INTO, 1, 4, 0, &mut rng, &Unlit::default())[0]
        });
        let (nee, se_nee) = mean_se(20_000, |i| {
            let mut rng = PhotonRng::new(7, i);
            direct_irradiance(&s, &hit, Some(INTO), true, 0, &mut rng)[0]
        });
        // The light's cosine-weighted solid angle fraction seen from 29.8 mm: (4·4)/(π·29.8²) = 0.57 %.
        let sky_hi = env * ft_cos(0.0);
        let sky_lo = sky_hi * (1.0 - 16.0 / (PI * 29.8 * 29.8));
        let band = 4.0 * (se * se + se_nee * se_nee).sqrt();
        println!("E_t = {got:.5} ± {se:.5}; light {nee:.5} ± {se_nee:.5}, sky [{sky_lo:.5}, {sky_hi:.5}]");
        assert!(band < 0.015 * got, "too noisy: {band} vs {got}");
        assert!(got > nee + sky_lo - band && got < nee + sky_hi + band);
    }

    /// A face in the penumbra of a 4 × 4 mm area light (an opaque screen halfway up hides the
    /// light's part x < 0.3 mm): 16 light samples per estimate, jittered over the light's area
    /// ([`Stratum`], what [`transmitted_irradiance`] draws) against 16 independent ones (the
    /// estimator before): the same mean (4σ of the difference), at under half the variance
    /// (measured 0.21×: the edge crosses one column of the 4 × 4 cells). This is the
    /// hierarchical set-up's noise, which every pixel shares (`docs/render.md`, "The set-up's
    /// noise"). 4 000 estimates each: the variance ratio's own σ is ≈ 3 %.
    #[test]
    fn jittered_light_samples_keep_the_mean_at_a_fraction_of_the_variance() {
        let h = 10.0;
        let light = Light::rect("l", [0.0, 0.0, 40.0], [2.0, 0.0, 0.0], [0.0, -2.0, 0.0], [500.0; 3]).unwrap();
        let s = cube_over_floor(h, 0.5, vec![light], [0.0; 3]);
        let mut objects = s.objects;
        objects.push(Object {
            name: "screen".into(),
            mesh: rectangle(-49.85, 0.0, 25.0, 100.0, 100.0).unwrap(),
            material: 1,
        });
        let s = Scene::new(objects, s.materials, s.lights, [0.0; 3], None).unwrap();
        let hit = face(&s, h, [0.0, 0.0, 1.0]);
        let n = 4_000;
        let stats = |f: &dyn Fn(u64) -> f64| {
            let (m, se) = mean_se(n, f);
            (m, se * se * n as f64)
        };
        let (jit, var_jit) = stats(&|i| {
            let mut rng = PhotonRng::new(9, i);
            transmitted_irradiance(&s, &hit, INTO, 16, 0, 0, &mut rng, &Unlit::default())[0]
        });
        let (rnd, var_rnd) = stats(&|i| {
            let mut rng = PhotonRng::new(10, i);
            (0..16).map(|_| direct_irradiance(&s, &hit, Some(INTO), true, 0, &mut rng)[0]).sum::<f64>() / 16.0
        });
        let band = 4.0 * ((var_jit + var_rnd) / n as f64).sqrt();
        println!("jittered {jit:.4} (var {var_jit:.3e}), independent {rnd:.4} (var {var_rnd:.3e}), 4σ {band:.4}");
        assert!(var_rnd > 0.01 * rnd * rnd, "not a penumbra: {var_rnd} vs {rnd}");
        assert!((jit - rnd).abs() < band, "{jit} vs {rnd} ± {band}");
        assert!(var_jit < 0.5 * var_rnd, "{var_jit} vs {var_rnd}");
    }

    /// [`Stratum::of`]: the first ⌊√n⌋² samples one per cell, the rest over the whole square.
    #[test]
    fn strata_cover_the_grid_once() {
        for n in [1u32, 2, 4, 5, 9, 16, 17, 24, 25, 64] {
            let k = (1..=n).take_while(|k| k * k <= n).last().unwrap();
            let cells: Vec<Stratum> = (0..n).map(|s| Stratum::of(s, n)).collect();
            let mut grid: Vec<(u32, u32)> = cells.iter().filter(|c| c.k == k && k > 1).map(|c| (c.i, c.j)).collect();
            grid.sort_unstable();
            grid.dedup();
            assert_eq!(grid.len() as u32, if k > 1 { k * k } else { 0 }, "n = {n}");
            assert_eq!(
                cells.iter().filter(|&&c| c == Stratum::WHOLE).count() as u32,
                if k > 1 { n - k * k } else { n }
            );
        }
        assert_eq!(Stratum::WHOLE.map(0.3, 0.7), (0.3, 0.7));
        assert_eq!(Stratum::of(6, 16).map(0.5, 0.5), (2.5 / 4.0, 1.5 / 4.0));
    }

    /// The gathering rays see the translucent surfaces through the method's `Translucency`
    /// (here a stand-in that notes the call: a translucent wall beside the cube), and the
    /// recursion ends at [`MAX_DEPTH`] (the rays then see only the environment).
    #[test]
    fn translucent_surfaces_are_seen_through_the_method() {
        let mut s = cube_over_floor(10.0, 0.5, vec![], [1.0; 3]);
        s.objects.push(Object {
            name: "wall".into(),
            mesh: cuboid([0.15, -50.0, 0.0], [0.3, 50.0, 50.0]).unwrap(),
            material: 0,
        });
        let s = Scene::new(s.objects, s.materials, vec![], [1.0; 3], None).unwrap();
        let hit = face(&s, 10.0, [1.0, 0.0, 0.0]);
        let seen = Unlit::default();
        let mut rng = PhotonRng::new(8, 0);
        transmitted_irradiance(&s, &hit, INTO, 1, 16, 0, &mut rng, &seen);
        assert!(seen.reached.load(Ordering::Relaxed));
        let deep = Unlit::default();
        transmitted_irradiance(&s, &hit, INTO, 1, 16, MAX_DEPTH, &mut rng, &deep);
        assert!(!deep.reached.load(Ordering::Relaxed));
    }
}
