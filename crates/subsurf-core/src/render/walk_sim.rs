//! The random walk as a simulation for tissue optics: photon packets from a pencil beam or a
//! uniform collimated illumination enter the closed meshes of a scene and are traced by the
//! same transport core as `random_walk` ([`super::walk`]: free paths, HG scattering, smooth
//! boundaries, nested media) with the Monte Carlo engine's weight rules (`Packet`; MCML, see
//! `mc::kernel`): implicit capture (w′ = w σs/σt, the exact difference w − w′ deposited), and
//! Russian roulette relative to the entering weight (below 10⁻⁴ of it a packet survives with
//! probability 1/10 at ten times its weight) whose zero-mean control term is booked apart in
//! `roulette` (a killed packet +w, a survivor −9w), not as absorption, so the absorbed
//! deposits and the voxels are never negative and the energy balance is exact:
//! specular + exitance + absorbed + roulette + lost = 1 to rounding.
//!
//! Tallies: the specular reflection, the weight leaving through each triangle (exitance per
//! triangle), the absorbed weight (physical deposits; also on a voxel grid), the roulette
//! term (also a walk stopped by the event cap, as the engine books a trapped packet), and the
//! weight lost (beam missing the objects, paths ending on an opaque surface, numerical leaks).
//! One colour channel
//! (`channel`) of the translucent materials is simulated. Photon i uses the stream
//! `PhotonRng::new(seed, i)`; photons run in fixed chunks merged in order, so results are
//! bit-identical for any thread count.

use super::accel::Hit;
use super::grid::Local;
use super::material::{Material, Translucent};
use super::math::{dot, madd, unit, Frame, V3};
use super::mesh::MAX_COORDINATE;
use super::scene::Scene;
use super::walk::{cross_boundary, walk, Carrier, Crossing, FirstFlight, Media};
use crate::error::{Error, Result};
use crate::mc::config::{ROULETTE_M, ROULETTE_THRESHOLD};
use crate::rng::PhotonRng;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

/// Where the photons come from.
#[derive(Clone, Copy, Debug)]
pub enum BeamSource {
    /// A pencil beam from `origin` (outside the objects) along the unit `direction`.
    Pencil { origin: V3, direction: V3 },
    /// Uniform collimated illumination along `direction` over a disc covering the scene:
    /// every triangle facing the light receives the same irradiance.
    Collimated { direction: V3 },
}

/// An axis-aligned voxel grid from `lo` to `hi` (mm) with `n` voxels per axis.
#[derive(Clone, Copy, Debug)]
pub struct VoxelGrid {
    pub lo: V3,
    pub hi: V3,
    pub n: [usize; 3],
}

impl VoxelGrid {
    pub fn validate(&self) -> Result<()> {
        for k in 0..3 {
            if !(self.hi[k] > self.lo[k]) || !self.lo[k].is_finite() || !self.hi[k].is_finite() {
                return Err(Error::Invalid(format!("voxels: hi[{k}] must be greater than lo[{k}] (finite mm)")));
            }
            if self.n[k] == 0 || self.n[k] > 1024 {
                return Err(Error::param(format!("voxels.n[{k}]"), self.n[k] as f64, "an integer in [1, 1024]"));
            }
        }
        Ok(())
    }
    fn index(&self, p: V3) -> Option<usize> {
        let mut idx = 0;
        for k in 0..3 {
            let f = (p[k] - self.lo[k]) / (self.hi[k] - self.lo[k]);
            if !(0.0..1.0).contains(&f) {
                return None;
            }
            let i = ((f * self.n[k] as f64) as usize).min(self.n[k] - 1);
            idx = idx * self.n[k] + i;
        }
        Some(idx)
    }
    fn len(&self) -> usize {
        self.n[0] * self.n[1] * self.n[2]
    }
}

/// Settings of a simulation.
#[derive(Clone, Copy, Debug)]
pub struct WalkConfig {
    pub source: BeamSource,
    pub photons: u64,
    pub seed: u64,
    pub channel: usize,
    pub voxels: Option<VoxelGrid>,
}

/// Tallies (fractions of the launched power).
#[derive(Clone, Debug, Default)]
pub struct WalkTally {
    pub specular: f64,
    /// Weight leaving through each global triangle (BVH order: see `exit_object/exit_local`).
    pub exit: Vec<f64>,
    /// Physical deposits (implicit capture), never negative; also per voxel in `voxels`.
    pub absorbed: f64,
    pub voxels: Vec<f64>,
    /// The zero-mean control term of Russian roulette and the weight of capped walks (the
    /// engine's `roulette`; its totals count it in `absorbed`).
    pub roulette: f64,
    pub lost: f64,
    /// Σ and Σ² of each photon's exiting weight (for the standard error of the total).
    pub exit_sum: f64,
    pub exit_sum2: f64,
    pub photons: u64,
}

impl WalkTally {
    fn new(ntri: usize, nvox: usize) -> WalkTally {
        WalkTally { exit: vec![0.0; ntri], voxels: vec![0.0; nvox], ..Default::default() }
    }
    fn merge(&mut self, o: &WalkTally) {
        self.specular += o.specular;
        self.absorbed += o.absorbed;
        self.roulette += o.roulette;
        self.lost += o.lost;
        self.exit_sum += o.exit_sum;
        self.exit_sum2 += o.exit_sum2;
        self.photons += o.photons;
        for (a, b) in self.exit.iter_mut().zip(&o.exit) {
            *a += b;
        }
        for (a, b) in self.voxels.iter_mut().zip(&o.voxels) {
            *a += b;
        }
    }
    /// Total diffuse exitance (fraction) and its standard error.
    pub fn exitance_total(&self) -> (f64, f64) {
        let n = self.photons.max(1) as f64;
        let m = self.exit_sum / n;
        (m, ((self.exit_sum2 / n - m * m).max(0.0) / (n - 1.0).max(1.0)).sqrt())
    }
}

const CHUNK: u64 = 1024;

/// Run the simulation. Errors: open translucent meshes, a bad channel or grid.
pub fn simulate(scene: &Scene, cfg: &WalkConfig, cancel: &AtomicBool, progress: &AtomicU64) -> Result<WalkTally> {
    scene.require_closed_translucent("the random-walk simulation")?;
    if cfg.channel > 2 {
        return Err(Error::param("channel", cfg.channel as f64, "0, 1 or 2"));
    }
    if let Some(g) = &cfg.voxels {
        g.validate()?;
    }
    let dir = match cfg.source {
        BeamSource::Pencil { direction, .. } | BeamSource::Collimated { direction } => direction,
    };
    if unit(dir).is_none() {
        return Err(Error::Invalid("source.direction: must be a finite non-zero vector".into()));
    }
    if let BeamSource::Pencil { origin, .. } = cfg.source {
        if let Some(&c) = origin.iter().find(|c| !(c.abs() <= MAX_COORDINATE)) {
            return Err(Error::param("source.origin", c, "coordinates in [-1e15, 1e15] (mm)"));
        }
        if let Some(name) = scene.enclosing_object(origin) {
            return Err(Error::Invalid(format!(
                "source.origin: the pencil beam starts inside {name}; it must start outside every object"
            )));
        }
    }
    let ntri = scene.accel.tris.len();
    let nvox = cfg.voxels.map_or(0, |g| g.len());
    let nchunks = cfg.photons.div_ceil(CHUNK);
    let parts: Vec<Option<WalkTally>> = (0..nchunks)
        .into_par_iter()
        .map(|c| {
            if cancel.load(Ordering::Relaxed) {
                return None;
            }
            let mut t = WalkTally::new(ntri, nvox);
            for i in c * CHUNK..((c + 1) * CHUNK).min(cfg.photons) {
                trace_photon(scene, cfg, i, &mut t);
            }
            progress.fetch_add(t.photons, Ordering::Relaxed);
            Some(t)
        })
        .collect();
    let mut acc = WalkTally::new(ntri, nvox);
    for p in parts.iter().flatten() {
        acc.merge(p);
    }
    Ok(acc)
}

fn launch(scene: &Scene, src: BeamSource, rng: &mut PhotonRng) -> (V3, V3) {
    match src {
        BeamSource::Pencil { origin, direction } => (origin, unit(direction).expect("checked in simulate")),
        BeamSource::Collimated { direction } => {
            let d = unit(direction).expect("checked in simulate");
            let ext = scene.accel.extent;
            let c = scene.accel.center();
            let f = Frame::new(d);
            let r = 0.5 * ext * rng.uniform().sqrt();
            let phi = 2.0 * std::f64::consts::PI * rng.uniform();
            let o = madd(madd(madd(c, d, -ext), f.t, r * phi.cos()), f.b, r * phi.sin());
            (o, d)
        }
    }
}

/// The simulation's carrier: one channel's weight, the tallies and the voxel grid.
struct Packet<'a> {
    cfg: &'a WalkConfig,
    t: &'a mut WalkTally,
    w: f64,
    /// The roulette threshold (relative to the entering weight, as in the engine).
    w_min: f64,
}

impl Carrier for Packet<'_> {
    fn channel(&mut self, _: &Translucent, _rng: &mut PhotonRng) -> Option<usize> {
        Some(self.cfg.channel)
    }

    fn collide(&mut self, _: &Scene, m: &Translucent, _: &Media, _: f64, p: V3, _: V3, _: &mut PhotonRng) -> bool {
        self.capture(m.sigma_s, m.sigma_t, p)
    }

    fn delta(
        &mut self,
        _: &Scene,
        m: &Translucent,
        local: &Local,
        _: &Media,
        _: f64,
        p: V3,
        _: V3,
        rng: &mut PhotonRng,
    ) -> Option<bool> {
        // Woodcock: real with probability σt(x)/σ̄ (no draw where σt(x) = σ̄, so a constant
        // grid is the homogeneous walk, bit for bit); the weight is untouched either way.
        let c = self.cfg.channel;
        let (st, sb) = (local.sigma_t[c], m.sigma_bar[c]);
        if st < sb && rng.uniform() * sb >= st {
            return Some(false);
        }
        self.capture(local.sigma_s, local.sigma_t, p).then_some(true)
    }

    fn roulette(&mut self, _p: V3, rng: &mut PhotonRng) -> bool {
        if self.w < self.w_min {
            if rng.uniform() * ROULETTE_M <= 1.0 {
                self.t.roulette -= (ROULETTE_M - 1.0) * self.w;
                self.w *= ROULETTE_M;
            } else {
                self.t.roulette += self.w;
                return false;
            }
        }
        true
    }

    fn reach(&mut self, _: &Translucent, _: f64) -> bool {
        true
    }

    fn bounced(&mut self, _: &Crossing) {}

    fn exit(&mut self, _: &Scene, h: &Hit, _: V3, _: &mut PhotonRng) {
        let w = self.w;
        self.t.exit[h.tri as usize] += w;
        self.t.exit_sum += w;
        self.t.exit_sum2 += w * w;
    }

    fn lost(&mut self, _p: V3, capped: bool) {
        if capped {
            self.t.roulette += self.w; // as the engine books a trapped packet
        } else {
            self.t.lost += self.w;
        }
    }
}

impl Packet<'_> {
    /// The engine's implicit capture at a real collision where the medium is (σs, σt):
    /// w′ = w σs/σt and the exact difference w − w′ (exact for w′ ≥ w/2) deposited, so the
    /// balance closes to rounding of the tallies' sums.
    fn capture(&mut self, sigma_s: [f64; 3], sigma_t: [f64; 3], p: V3) -> bool {
        let c = self.cfg.channel;
        let w_new = self.w * (sigma_s[c] / sigma_t[c]);
        let dw = self.w - w_new;
        self.w = w_new;
        self.t.absorbed += dw;
        if let (Some(g), true) = (&self.cfg.voxels, dw != 0.0) {
            if let Some(k) = g.index(p) {
                self.t.voxels[k] += dw;
            }
        }
        self.w > 0.0
    }
}

fn trace_photon(scene: &Scene, cfg: &WalkConfig, i: u64, t: &mut WalkTally) {
    let mut rng = PhotonRng::new(cfg.seed, i);
    t.photons += 1;
    let (o, d0) = launch(scene, cfg.source, &mut rng);
    let Some(h0) = scene.accel.intersect(o, d0, f64::INFINITY, u32::MAX) else {
        t.lost += 1.0;
        return;
    };
    if !matches!(scene.material(h0.object), Material::Translucent(_)) || dot(d0, h0.n) >= 0.0 {
        t.lost += 1.0;
        return;
    }
    // Enter through the first boundary with the shared crossing rule (all-or-none Fresnel).
    let mut media = Media::empty();
    let d = match cross_boundary(scene, &mut media, &h0, d0, &mut rng) {
        Crossing::Transmitted { d, .. } => d,
        _ => {
            t.specular += 1.0;
            return;
        }
    };
    let mut packet = Packet { cfg, t, w: 1.0, w_min: ROULETTE_THRESHOLD };
    walk(scene, media, h0.p, d, h0.tri, &mut packet, &mut rng, &mut FirstFlight::default());
}
