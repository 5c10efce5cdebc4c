//! The oblique-incidence gain of the `adaptive` model: per channel, the engine's total diffuse
//! reflectance of the semi-infinite stack per unit *entering* power under a pencil beam at polar
//! angle θi, relative to normal incidence,
//!
//! g(μ) = R(θi) / R(0),  μ = cos θi (outside the medium), R per unit entering power.
//!
//! Why: the kernel of `render::adaptive` is the engine's normal-incidence profile (per unit
//! entering power), and the renderer spreads the transmitted irradiance E_t = ∫ F_t L_i μ dω of
//! every direction through it. Light that arrives obliquely is refracted towards the surface
//! (θt up to the critical angle), scatters first at a shallower depth and comes back more: the
//! engine's totals per entering power rise with θi by up to 17 % at 80° (ketchup red 0.1465 at
//! 0°, 0.1721 at 80°; skin1 diffuse/normal 1.04, 1.07, 1.09 per channel; marble 1.00:
//! `docs/render.md`). So under diffuse or oblique light the rendered exitance was low by the
//! channel's ratio of the two, on flat and curved surfaces alike (the curvature scales convert
//! the curved escapes by R_∞/R_flat, [`crate::bssrdf::curvature::Scales`], which is exact only
//! if E_t carries this gain). The renderer now weights each incident direction of an
//! irradiance sample by g_k(μ) per channel (`render::irradiance`, [`super::adaptive::AdaptiveTable::oblique_gain`]),
//! so that on a flat semi-infinite surface the exitance is the engine's pencil total R(θi)·F_t(θi)
//! per unit incident power at every θi and its diffuse reflectance under diffuse light.
//!
//! The runs: the engine's collimated source (MCML's launch: specular part R_sp(θi) scored, the
//! packet refracted by Snell's law with weight 1 − R_sp; Wang, Jacques & Zheng 1995 §3.2,
//! [`crate::mc::Source::Pencil`]) at the angles [`OBLIQUE_THETA_DEG`], [`OBLIQUE_PHOTONS`] × the
//! table's photons each,
//! seed + 64c + [`SEED_OBLIQUE`] + i, tallying the diffuse reflectance (all that leaves through the
//! top, [`Total::Diffuse`]) per incident photon; R(0) is the table's own normal-incidence
//! semi-infinite node (the `monte_carlo` profile's total), so g(1) = 1 exactly and normal
//! incidence is unchanged bit for bit. Between nodes g is linear in μ (the totals are close to
//! linear in μ: ketchup red rises 0.030, 0.029, 0.038, 0.027 per unit μ over the four intervals),
//! and held at its last node below μ = cos 80° (3 % of diffuse light's F_t-weighted power).
//! The gain is the semi-infinite one at every thickness (thin parts and the transmission T
//! across them use it too: the curvature scales, which hold T's share of a sphere's escape,
//! assume every class of entry point receives the same E_t).

use super::adaptive::{AdaptiveSettings, SEED_STRIDE};
use super::coupling::CouplingTally;
use super::curved::Escape;
use super::exit::ExitBins;
use crate::error::Result;
use crate::mc::tally::totals::{Total, Totals};
use crate::mc::{run, RunConfig, Source};
use crate::medium::Stack;
use crate::optics::fr_dielectric;
use std::sync::atomic::{AtomicBool, AtomicU64};

/// Polar angles θi (degrees) of the oblique pencil runs (0° is the table's ∞ node).
pub const OBLIQUE_THETA_DEG: [f64; 4] = [30.0, 50.0, 65.0, 80.0];
/// Seed offset of the first oblique run within a channel's stride (the others follow).
pub const SEED_OBLIQUE: u64 = 30;
/// Photons of each oblique run, in the table's photons per node: the gain is a ratio of two
/// totals of a few per cent standard error each at 10 000 photons for dark channels (ketchup's
/// green and blue: up to ±8 % per node, measured), and these flat runs are cheap beside the curved
/// ones (marble at 10 000 photons: the 12 thickness nodes 0.7 CPU s of an 8.6 s build).
pub const OBLIQUE_PHOTONS: u64 = 4;

/// The engine's diffuse reflectance (per unit incident power, specular excluded) of `stack`
/// under pencil beams at [`OBLIQUE_THETA_DEG`] (channel `channel`'s seeds), and the same runs'
/// exit-coupling tallies ([`CouplingTally`], [`super::coupling`]: the tally draws no random
/// numbers, so the totals are the same bits with it); `None` when cancelled.
pub fn build_oblique(
    stack: &Stack,
    channel: usize,
    s: &AdaptiveSettings,
    cancel: &AtomicBool,
    progress: &AtomicU64,
) -> Result<Option<(Vec<Escape>, Vec<ExitBins>)>> {
    let base = s.seed.wrapping_add(SEED_STRIDE * channel as u64 + SEED_OBLIQUE);
    let (mut out, mut coupling) = (vec![], vec![]);
    for (i, deg) in OBLIQUE_THETA_DEG.iter().enumerate() {
        let source = Source::Pencil { theta: deg.to_radians(), phi: 0.0 };
        let photons = s.photons.saturating_mul(OBLIQUE_PHOTONS);
        let cfg = RunConfig { photons, seed: base + i as u64, threads: s.threads, source, isa: None };
        let tallies = || (Totals::new(stack.layers.len()), CouplingTally::default());
        let o = run(stack, &cfg, tallies, cancel, progress)?;
        if o.cancelled {
            return Ok(None);
        }
        let (mean, stderr) = o.tally.0.get(Total::Diffuse);
        out.push(Escape { mean, stderr, near: mean, near_stderr: stderr, bins: vec![], shift: 0.0, harmonic: vec![] });
        let (weight, stderr) = o.tally.1.data();
        coupling.push(ExitBins { weight, stderr });
    }
    Ok(Some((out, coupling)))
}

/// One channel's gain g(μ) at its nodes (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct Gain {
    /// μ = cos θi of the nodes, decreasing from 1.
    mu: Vec<f64>,
    /// g at the nodes (1 at μ = 1).
    g: Vec<f64>,
}

impl Gain {
    /// The gain of a stack whose normal-incidence semi-infinite total is `r0` (per unit
    /// *incident* power) and whose oblique runs gave `oblique` (per unit incident power, at
    /// [`OBLIQUE_THETA_DEG`]); 1 everywhere when nothing is reflected at normal incidence.
    pub fn new(stack: &Stack, r0: f64, oblique: &[Escape]) -> Gain {
        let n_top = stack.layers[0].n;
        let entering = |mu: f64| 1.0 - fr_dielectric(mu, stack.n_above, n_top);
        let per_entering0 = r0 / entering(1.0);
        let mut mu = vec![1.0];
        let mut g = vec![1.0];
        for (deg, e) in OBLIQUE_THETA_DEG.iter().zip(oblique) {
            let m = deg.to_radians().cos();
            mu.push(m);
            let w = entering(m);
            g.push(if per_entering0 > 0.0 && w > 0.0 { e.mean / w / per_entering0 } else { 1.0 });
        }
        Gain { mu, g }
    }

    /// g(μ) for μ = cos θi in [0, 1] (linear between nodes, held below the last).
    pub fn at(&self, mu: f64) -> f64 {
        let n = self.mu.len();
        if mu >= self.mu[0] {
            return self.g[0];
        }
        if mu <= self.mu[n - 1] {
            return self.g[n - 1];
        }
        let i = self.mu.partition_point(|&m| m > mu); // mu[i-1] > mu ≥ mu[i]
        let t = (self.mu[i - 1] - mu) / (self.mu[i - 1] - self.mu[i]);
        (1.0 - t) * self.g[i - 1] + t * self.g[i]
    }

    /// The node values (μ, g), μ decreasing from 1.
    pub fn nodes(&self) -> (&[f64], &[f64]) {
        (&self.mu, &self.g)
    }

    /// 2∫₀¹ F_t(μ) g(μ) μ dμ for `stack`'s top interface: the transmitted irradiance per unit
    /// incident irradiance of uniform diffuse light as the renderer weights it, so the model's
    /// flat diffuse reflectance is the kernel's total (per entering power) times this (midpoint
    /// rule, [`DIFFUSE_STEPS`] steps; g is linear between its nodes and F_t smooth).
    pub fn diffuse_weight(&self, stack: &Stack) -> f64 {
        let n_top = stack.layers[0].n;
        let h = 1.0 / DIFFUSE_STEPS as f64;
        let f = |i: usize| {
            let mu = (i as f64 + 0.5) * h;
            (1.0 - fr_dielectric(mu, stack.n_above, n_top)) * self.at(mu) * mu
        };
        2.0 * h * (0..DIFFUSE_STEPS).map(f).sum::<f64>()
    }
}

/// Midpoints of [`Gain::diffuse_weight`].
pub const DIFFUSE_STEPS: usize = 4000;
