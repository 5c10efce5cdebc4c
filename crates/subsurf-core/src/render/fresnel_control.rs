//! The Fresnel coin's control variate for the random walk in scenes lit by a constant
//! environment alone (`RandomWalk::fresnel_control`).
//!
//! Where a walk meets, from inside, a boundary that leaves every object at an angle below the
//! critical one, it reflects with probability F (Fresnel, [`crate::optics::fr_dielectric`]) and
//! otherwise leaves along the refracted direction t, all or none ([`super::walk`]). Where the
//! refracted ray escapes to the environment (no surface along it; a deterministic test of the
//! ray, made only where the coefficients are not zero), the walk also scores, per channel k,
//!
//!   c_k β_k L_env,k (1\[reflected\] − F),
//!
//! which has mean zero given the contact (E 1\[ξ < F\] = F), so the estimator stays unbiased for
//! any c fixed before the render (a control variate, e.g. Owen 2013, *Monte Carlo theory,
//! methods and examples*, §8.9). A reflection adds c (1 − F) β L_env and goes on at β; an exit
//! scores (1 − c F) β L_env instead of β L_env. The coin's own variance at the contact,
//! F (1 − F) (L − V)² with V the expected score of the reflected walk per unit β, becomes
//! F (1 − F) ((1 − c) L − V)²: zero at c = 1 − V/L. The random numbers and the walks are those
//! of the plain walk; the control changes only what a leaving contact scores.
//!
//! The coefficients come from a pilot before the render ([`coefficients`]): per object, walks
//! (the scene's [`PILOT_WALKS`] shared by its translucent objects, at least [`PILOT_MIN`] each;
//! fixed seed: the same c for any thread count and every render) start at area-sampled points of
//! its surface in directions cosine-distributed inside the critical cone about the inward normal
//! (where a sub-critical reflection sends a walk), and V_k is their mean score per unit L_env,k;
//! c_k = 1 − V_k less two standard errors of the pilot, clamped to [0, 1] (an error δ in c costs
//! F (1 − F) δ² L² per contact, so the pilot's error is shrunk towards no control: a furnace,
//! V = 1, keeps c = 0 and its exact samples).
//!
//! Measured (docs/render.md, "The Fresnel coin at a boundary that leaves every object"): the
//! coin is about 5 % of the variance of the benchmark's skin and ear scenes in the environment
//! (η 1.3: sub-critical contacts have a cosine-weighted mean F of 0.06), and the control removes
//! 4.6 % (skin), 4.4 % (ear), 2.8 % (marble) at +0.6 %, −0.1 %, −0.1 % of the render pass's
//! instructions; taking the coin's expected value instead (score (1 − F) β L_env, go on with
//! β F) removed 5–7.5 % at 17–30 % more instructions (the reflected walks go on).

use super::accel::Hit;
use super::math::{neg, Frame, Rgb, V3};
use super::random_walk::RandomWalk;
use super::scene::Scene;
use crate::optics::sample_cosine_hemisphere;
use crate::rng::PhotonRng;
use rayon::prelude::*;

/// Pilot walks of a scene, shared by its translucent objects (one object's: a standard error of
/// the mean of about 0.02 for the benchmark's media; 3–28 ms for skin, ear and marble).
pub const PILOT_WALKS: u64 = 512;

/// The least pilot walks per translucent object (a larger error, which the two-standard-error
/// shrinkage turns into a smaller c).
pub const PILOT_MIN: u64 = 64;

/// The pilot's seed (a constant: the coefficients are part of the method, not of a render).
const PILOT_SEED: u64 = 0x46_5245_534e_454c; // "FRESNEL"

/// Per object (by index), the control coefficients c per channel ([0; 3] for an opaque object
/// or where the environment's channel is dark); see the module's documentation.
pub fn coefficients(scene: &Scene, rw: &RandomWalk) -> Vec<Rgb> {
    let translucent = (0..scene.objects.len()).filter(|&o| scene.material(o).translucent().is_some()).count();
    let walks = (PILOT_WALKS / translucent.max(1) as u64).max(PILOT_MIN);
    (0..scene.objects.len()).map(|o| object_coefficients(scene, rw, o, walks)).collect()
}

fn object_coefficients(scene: &Scene, rw: &RandomWalk, object: usize, walks: u64) -> Rgb {
    let Some(entries) = Entries::new(scene, object, PILOT_SEED) else { return [0.0; 3] };
    let env = scene.environment;
    let (mut s, mut s2) = ([0.0; 3], [0.0; 3]);
    // The walks in parallel, summed in their order (the same c for any thread count).
    let runs: Vec<Rgb> = (0..walks)
        .into_par_iter()
        .map(|i| {
            let (hit, d, mut rng) = entries.entry(i);
            rw.walks(scene, &hit, d, 1, &mut rng)
        })
        .collect();
    for l in runs {
        for k in 0..3 {
            let v = if env[k] > 0.0 { l[k] / env[k] } else { 0.0 };
            s[k] += v;
            s2[k] += v * v;
        }
    }
    let n = walks as f64;
    std::array::from_fn(|k| {
        if !(env[k] > 0.0) {
            return 0.0;
        }
        let v = s[k] / n;
        let se = ((s2[k] / n - v * v).max(0.0) / (n - 1.0)).sqrt();
        (1.0 - v - 2.0 * se).clamp(0.0, 1.0)
    })
}

/// The pilots' walk starts on one object's surface (this module's and [`super::walk_alloc`]'s):
/// area-sampled points, directions cosine-distributed inside the critical cone about the inward
/// normal (where a camera ray refracts in, and where a sub-critical reflection sends a walk).
pub(super) struct Entries<'a> {
    scene: &'a Scene,
    object: usize,
    seed: u64,
    tris: Vec<usize>,
    cum: Vec<f64>,
    total: f64,
    sin2_max: f64,
}

impl<'a> Entries<'a> {
    /// None for an opaque object, one without area, or η ≤ 1 (no critical cone).
    pub(super) fn new(scene: &'a Scene, object: usize, seed: u64) -> Option<Entries<'a>> {
        let m = scene.material(object).translucent()?;
        let acc = &scene.accel;
        let tris: Vec<usize> = (0..acc.tris.len()).filter(|&i| acc.tris[i].object as usize == object).collect();
        let mut cum = Vec::with_capacity(tris.len());
        let mut total = 0.0;
        for &i in &tris {
            total += acc.area(i);
            cum.push(total);
        }
        // Directions inside the critical cone: cos θ ≥ cos θ_c, sin² θ ≤ 1/η².
        let ok = total > 0.0 && m.eta > 1.0;
        ok.then(|| Entries { scene, object, seed, tris, cum, total, sin2_max: 1.0 / (m.eta * m.eta) })
    }

    /// Start `i`: the surface point (as a hit), the inward direction, and the walk's stream.
    pub(super) fn entry(&self, i: u64) -> (Hit, V3, PhotonRng) {
        let acc = &self.scene.accel;
        let mut rng = PhotonRng::new(self.seed, i);
        let u = rng.uniform() * self.total;
        let j = self.cum.partition_point(|&a| a < u).min(self.tris.len() - 1);
        let tri = self.tris[j];
        let (r1, r2) = (rng.uniform().sqrt(), rng.uniform());
        let (b1, b2) = (r1 * (1.0 - r2), r1 * r2);
        let n = acc.tris[tri].n;
        let d = Frame::new(neg(n)).to_world(sample_cosine_hemisphere(self.sin2_max * rng.uniform(), rng.uniform()));
        let hit = Hit { t: 0.0, tri: tri as u32, object: self.object, b1, b2, p: acc.point(tri, b1, b2), n };
        (hit, d, rng)
    }
}
