//! The random walk as a simulation for tissue optics: photon packets from a pencil beam or a
//! uniform collimated illumination enter the closed meshes of a scene and are traced with
//! the same boundary physics as `random_walk` ([`cross_boundary`], nested media: every crossing,
//! the entry included, is all-or-none Fresnel), implicit capture (weight × σa/σt deposited at
//! each collision) and HG scattering. Its Russian roulette is its own, not the engine's
//! (`mc::kernel` step 5): it uses the engine's constants ([`ROULETTE_THRESHOLD`], [`ROULETTE_M`])
//! on the absolute weight (a packet enters with weight 1, where the engine's threshold is
//! relative to 1 − R_sp), and it deposits the zero-mean control term (+w for a killed packet,
//! −(m − 1)w for a survivor) as absorption, in `absorbed` *and* in the voxel grid (which can
//! therefore hold negative values), where the engine books it apart (`Tally::roulette`) and keeps
//! its absorption histograms physical. A fresh free path is drawn after every boundary hit (the
//! engine carries the remaining optical depth; the same law in homogeneous media), and a packet
//! still alive after `random_walk::MAX_EVENTS` events is deposited where it stands. Energy
//! balance is exact to rounding in every run.
//!
//! Tallies: the specular reflection, the weight leaving through each triangle (exitance per
//! triangle), the absorbed weight on a voxel grid, and the weight lost (beam missing the
//! objects, paths ending on an opaque surface, numerical leaks). One colour channel
//! (`channel`) of the translucent materials is simulated. Photon i uses the stream
//! `PhotonRng::new(seed, i)`; photons run in fixed chunks merged in order, so results are
//! bit-identical for any thread count.

use super::material::Material;
use super::math::{dot, madd, unit, Frame, V3};
use super::mesh::MAX_COORDINATE;
use super::random_walk::{cross_boundary, Crossing, Media};
use super::scene::Scene;
use crate::error::{Error, Result};
use crate::mc::config::{ROULETTE_M, ROULETTE_THRESHOLD};
use crate::optics::spin;
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
    pub absorbed: f64,
    pub voxels: Vec<f64>,
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

fn trace_photon(scene: &Scene, cfg: &WalkConfig, i: u64, t: &mut WalkTally) {
    let mut rng = PhotonRng::new(cfg.seed, i);
    t.photons += 1;
    let (o, d0) = launch(scene, cfg.source, &mut rng);
    let deposit = |t: &mut WalkTally, p: V3, w: f64| {
        t.absorbed += w;
        if let (Some(g), true) = (&cfg.voxels, w != 0.0) {
            if let Some(k) = g.index(p) {
                t.voxels[k] += w;
            }
        }
    };
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
    let mut d = match cross_boundary(scene, &mut media, &h0, d0, rng.uniform()) {
        Crossing::Transmitted(d) => d,
        _ => {
            t.specular += 1.0;
            return;
        }
    };
    let (mut p, mut skip, mut w) = (h0.p, h0.tri, 1.0f64);
    for _ in 0..super::random_walk::MAX_EVENTS {
        let Some(top) = media.top() else { break };
        let Some(m) = scene.material(top).translucent() else { break };
        let Some(h) = scene.accel.intersect(p, d, f64::INFINITY, skip) else {
            t.lost += w;
            return;
        };
        let (st, sa) = (m.sigma_t[cfg.channel], m.sigma_a[cfg.channel]);
        let s = if st > 0.0 { -(-rng.uniform()).ln_1p() / st } else { f64::INFINITY };
        if s < h.t {
            p = madd(p, d, s);
            skip = u32::MAX;
            let dw = w * sa / st;
            deposit(t, p, dw);
            w -= dw;
            let cos = m.phase.sample(rng.uniform());
            let phi = 2.0 * std::f64::consts::PI * rng.uniform();
            d = spin(d, cos, phi.cos(), phi.sin());
            if w < ROULETTE_THRESHOLD {
                if rng.uniform() * ROULETTE_M <= 1.0 {
                    deposit(t, p, -(ROULETTE_M - 1.0) * w);
                    w *= ROULETTE_M;
                } else {
                    deposit(t, p, w);
                    return;
                }
            }
        } else {
            p = h.p;
            skip = h.tri;
            match cross_boundary(scene, &mut media, &h, d, rng.uniform()) {
                Crossing::Opaque => {
                    t.lost += w;
                    return;
                }
                Crossing::Reflected(r) => d = r,
                Crossing::Transmitted(tr) => {
                    d = tr;
                    if media.is_empty() {
                        t.exit[h.tri as usize] += w;
                        t.exit_sum += w;
                        t.exit_sum2 += w * w;
                        return;
                    }
                }
            }
        }
    }
    deposit(t, p, w);
}
