//! How many walks of each group a camera path starts in scenes lit by the environment alone
//! (`RandomWalk::walk_repeats`): the allocation of a stratified estimator's samples to its
//! strata in proportion to σ/√cost (Neyman 1934; Owen 2013, *Monte Carlo theory, methods and
//! examples*, §8.4), here the walk groups of `env_walk::walk_starts`.
//!
//! A camera path into an object whose channels walk in n ≥ 2 groups (one walk per channel, or a
//! short channel joined to its neighbour) scores the sum of the groups' walks. Group w walked
//! k_w times, each walk weighted 1/k_w, keeps the estimator unbiased for any k fixed before the
//! render; its variance is Σ_w V_w/k_w and its cost C₀ + Σ_w k_w C_w (V_w: the variance of one
//! walk's score summed over the channels; C_w: its cost; C₀: the camera path's own). k minimises
//! the product (the variance at equal time) over 1 … [`MAX_REPEATS`] per group, one group walked
//! once ([`allocate`]).
//!
//! V_w and C_w come from a pilot before the render ([`repeats`]; fixed seed: the same k for any
//! thread count and every render): [`PILOT_WALKS`] walks of each group from the same starts as
//! the Fresnel control's pilot (`fresnel_control::Entries`), their score's variance and
//! their events (collisions and boundary hits, a deterministic cost) plus [`WALK_COST`] events
//! per walk; C₀ is [`PATH_COST`] events.
//!
//! `RandomWalk::walks` (here) starts a camera path's walks: each group k_w times, each walk
//! weighted 1/k_w. The copies of a group take the group's Sobol coordinates at consecutive indices
//! (`PhotonRng::qmc_walk_copy`): over a pixel's N samples the k copies are the first k·N points of
//! its sequence, stratified together.
//!
//! Measured (docs/render.md, "Walks per camera path"): on the benchmark's ear (skin2: red
//! alone, green and blue together) red's walks had 5 % of the variance at 45 % of the cost; the
//! pilot's (1, 4) gave 1.20× the efficiency with a Sobol walk slot per copy, 1.52× with the
//! copies stratified together.

use super::accel::Hit;
use super::env_walk::walk_starts;
use super::fresnel_control::Entries;
use super::math::{add, scale, Rgb, V3};
use super::random_walk::RandomWalk;
use super::scene::Scene;
use super::walk::FirstFlight;
use crate::rng::PhotonRng;
use rayon::prelude::*;

/// The most walks of one group per camera path.
pub const MAX_REPEATS: u32 = 4;

/// Pilot walks per object and group.
pub const PILOT_WALKS: u64 = 512;

/// A camera path's cost outside its walks, in walk events (its camera ray, the entry's Fresnel
/// split, its pixel's sample: about a thousand instructions, against about two thousand per
/// event of the ear's walks; callgrind, docs/render.md).
pub const PATH_COST: f64 = 1.0;

/// A walk's cost outside its events, in events (its exit ray and start).
pub const WALK_COST: f64 = 1.5;

/// The pilot's seed (a constant: the counts are part of the method, not of a render).
const PILOT_SEED: u64 = 0x414c_4c4f_4341_5445; // "ALLOCATE"

/// Per object (by index), the walks per camera path of each walk group ([1; 3] where a path
/// starts one group, or the object is opaque); see the module's documentation.
pub fn repeats(scene: &Scene, rw: &RandomWalk) -> Vec<[u32; 3]> {
    (0..scene.objects.len()).map(|o| object_repeats(scene, rw, o)).collect()
}

fn object_repeats(scene: &Scene, rw: &RandomWalk, object: usize) -> [u32; 3] {
    let Some(m) = scene.material(object).translucent() else { return [1; 3] };
    let (starts, n) = walk_starts(m, rw.split_albedo);
    if !rw.split_channels || n < 2 {
        return [1; 3];
    }
    let Some(entries) = Entries::new(scene, object, PILOT_SEED) else { return [1; 3] };
    let (mut v, mut c) = ([0.0; 3], [0.0; 3]);
    for w in 0..n {
        let (mut s, mut s2, mut events) = ([0.0; 3], [0.0; 3], 0u64);
        // The walks in parallel, summed in their order (the same counts for any thread count).
        let runs: Vec<(Rgb, u32)> = (0..PILOT_WALKS)
            .into_par_iter()
            .map(|i| {
                let (hit, d, mut rng) = entries.entry(i);
                rw.walk_one(scene, &hit, d, 0, starts[w], &mut rng, &mut FirstFlight::default())
            })
            .collect();
        for (l, e) in runs {
            for k in 0..3 {
                s[k] += l[k];
                s2[k] += l[k] * l[k];
            }
            events += e as u64;
        }
        let p = PILOT_WALKS as f64;
        v[w] = (0..3).map(|k| (s2[k] / p - (s[k] / p).powi(2)).max(0.0)).sum();
        c[w] = events as f64 / p + WALK_COST;
    }
    allocate(&v[..n], &c[..n])
}

/// The walks per group k ∈ 1 … [`MAX_REPEATS`], one group walked once, minimising
/// (Σ V_w/k_w)(C₀ + Σ k_w C_w); the fewest walks where two tie. One group stays at one walk:
/// the model would otherwise multiply every count to spread C₀, but a camera path's walks share
/// its pixel position and entry point, and their correlation is not in it.
pub fn allocate(v: &[f64], c: &[f64]) -> [u32; 3] {
    let cost = |k: &[u32; 3]| {
        let var: f64 = v.iter().zip(k).map(|(v, &k)| v / k as f64).sum();
        var * (PATH_COST + c.iter().zip(k).map(|(c, &k)| c * k as f64).sum::<f64>())
    };
    let total = |k: &[u32; 3]| k.iter().sum::<u32>();
    let mut best = ([1; 3], f64::INFINITY);
    let m = MAX_REPEATS;
    for i in 0..m.pow(v.len() as u32) {
        let k: [u32; 3] = std::array::from_fn(|w| if w < v.len() { 1 + i / m.pow(w as u32) % m } else { 1 });
        let e = cost(&k);
        if k[..v.len()].contains(&1) && (e < best.1 || (e == best.1 && total(&k) < total(&best.0))) {
            best = (k, e);
        }
    }
    best.0
}

impl RandomWalk {
    /// The walks of one camera path (`walk_starts`) from `hit` into its object along `t` (the
    /// refracted direction) at `depth`: their radiance per unit throughput, before the entry's
    /// Fresnel transmittance and tint. On a camera path (depth 0) walk group w is walked
    /// `walk_repeats[object][w]` times and their mean taken ([`super::walk_alloc`]).
    pub(super) fn walks(&self, scene: &Scene, hit: &Hit, t: V3, depth: u32, rng: &mut PhotonRng) -> Rgb {
        let Some(m) = scene.material(hit.object).translucent() else { return [0.0; 3] };
        // One walk carrying every channel (spectral MIS), or walks of one or two channels.
        let (starts, n) = if self.split_channels { walk_starts(m, self.split_albedo) } else { ([[1.0; 3]; 3], 1) };
        let reps = match self.walk_repeats.get(hit.object) {
            Some(r) if depth == 0 => *r,
            _ => [1; 3],
        };
        // The camera path's walks take the sample's Sobol coordinates (`Qmc`: once per sample);
        // the copies of a repeated group take its coordinates at consecutive Sobol indices.
        let qmc = depth == 0 && self.qmc && rng.qmc_arm(n as u32);
        let mut l = [0.0; 3];
        // Every walk starts at hit.p along t: their first flights share what they find.
        let mut first = FirstFlight::default();
        for (w, (&beta, &r)) in starts[..n].iter().zip(&reps).enumerate() {
            for copy in 0..r {
                if qmc {
                    // The last walk (the channels of the largest σt: the shortest walks, the
                    // noisiest scores) takes the first Sobol coordinates: on the benchmark's ear
                    // (skin2: red alone, green and blue together) the per-pixel variance in the
                    // environment fell 16 % (2.71 → 2.27·10⁻⁴, and 2.70 → 2.26 on other seeds)
                    // against the walks' events interleaved in the order of the starts; the
                    // marble's three walks the same within the noise (6.20 → 6.27·10⁻⁴). Its
                    // copies at consecutive indices: the ear's variance 7.58 → 6.02·10⁻⁵ against
                    // a Sobol walk slot of their own each (`walk_alloc`).
                    rng.qmc_walk_copy((n - 1 - w) as u32, copy, r);
                }
                let (lw, _) = self.walk_one(scene, hit, t, depth, beta, rng, &mut first);
                l = add(l, scale(lw, 1.0 / r as f64));
            }
        }
        l
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The allocation of the model: equal groups walk once each; a group with 16× the other's
    /// variance at the same cost walks 4 times (σ/√C 4× the other's), as does one of 4× the
    /// variance at a quarter of the cost; of three equal-cost groups the one with 4× the
    /// variance walks twice; a group without variance walks once, the other up to the cap.
    #[test]
    fn walks_follow_sigma_over_root_cost() {
        assert_eq!(allocate(&[1.0, 1.0], &[5.0, 5.0]), [1, 1, 1]);
        assert_eq!(allocate(&[1.0, 16.0], &[5.0, 5.0]), [1, 4, 1]);
        assert_eq!(allocate(&[4.0, 1.0], &[1.0, 4.0]), [4, 1, 1]);
        assert_eq!(allocate(&[1.0, 4.0, 1.0], &[8.0, 8.0, 8.0]), [1, 2, 1]);
        assert_eq!(allocate(&[0.0, 1.0], &[3.0, 3.0]), [1, 4, 1]);
    }
}
