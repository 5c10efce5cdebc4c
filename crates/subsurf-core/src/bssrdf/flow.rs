//! The exit direction's flow along the light in `model = "adaptive"`: the first azimuthal harmonic
//! of the radiance leaving x_o about t̂, the tangential direction from the entry point x_i to x_o,
//! per distance r = ‖x_o − x_i‖, measured from the engine (issue 20).
//!
//! Light that entered at x_i and leaves at x_o has been moving away from x_i, and leaves tilted
//! along t̂. Under uniform light the tilts of all entry points cancel; under a light that falls on
//! one patch they add up to a flow away from the patch, and an exit term symmetric about the
//! normal ([`super::exit`]) sends too much light back towards the light (the validation matrix's
//! ketchup sphere under its tilted rectangle: +18.9 % red seen from the matrix's camera, −9.9 %
//! from the far side; `docs/render.md`, "The matrix's area light"). Per pair (x_o, x_i) of the
//! near class the radiance is
//!
//! L(ω_o) = L_sym(μ_o) · (1 + B(r) · t̂ · ω_o,t),
//!
//! ω_o,t the tangential part of ω_o (|ω_o,t| = sin θo): its mean over the exit azimuth is 0, so
//! every hemispherical total is unchanged. (The pair's weight is the kernel's without the entry
//! harmonic of [`super::harmonic`]: the harmonic is where light leaves, not the direction it
//! leaves in; measured, `docs/render.md`.)
//!
//! B per channel and r bin ([`FLOW_EDGES`], in the transport length ℓ of the stack,
//! [`super::adaptive`]) is the weighted least-squares fit of the engine's tally ([`FlowTally`]:
//! the flat semi-infinite stack under diffuse light, seed + 64c + [`SEED_FLOW`],
//! [`flow_photons`] of the table's; weight leaving through the top per r bin and exit-cosine
//! bin, and the same × cos Δφ, Δφ the exit direction's azimuth from t̂): 2⟨cos Δφ⟩ = B ⟨sin θo⟩
//! per exit-cosine bin, the exit coupling's fit ([`super::coupling::fit`] at θi = 90°). Between
//! the bins' geometric centres B is linear in ln r, held outside them. Diffusion gives the
//! shape far from x_i: the radiance's internal first harmonic is 3|F|/φ = ℓ(σtr + 1/r) for the
//! fluence φ ∝ e^{−σtr r}/r, falling with r towards ℓσtr (marble's 0.05–0.1), so the last bins
//! reach 64 ℓ: a marble's pairs are at many ℓ (ℓ ≈ 0.4 mm, diffusion lengths 4–8.5 mm).

#[cfg(test)]
use super::coupling::mean_sine;
use super::coupling::{fit, COUPLING_BINS};
use super::exit::ExitBins;
use crate::error::{Error, Result};
use crate::mc::tally::accum::Accum;
use crate::mc::tally::{Channel, ChannelState};
use crate::mc::{run, Packet, RunConfig, Side, Source, Tally};
use crate::medium::Stack;
use std::sync::atomic::{AtomicBool, AtomicU64};

/// Inner edges of the r bins in units of ℓ: bins [0, 0.5), [0.5, 1), …, [32, 64), [64, ∞).
pub const FLOW_EDGES: [f64; 8] = [0.5, 1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0];
/// Number of r bins.
pub const FLOW_BINS: usize = FLOW_EDGES.len() + 1;
/// Seed offset of the flow run within a channel's stride.
pub const SEED_FLOW: u64 = 62;
/// Photons of the flow run, in the table's photons (at most [`MAX_FLOW_RUN`] or the table's own
/// photons, whichever is more: a 10 000-photon table's run, the validation matrix's, is 80 000).
pub const FLOW_PHOTONS: u64 = 8;
/// The flow run's photons beyond which [`FLOW_PHOTONS`] no longer multiplies (B's bins are held to
/// a standard error of [`MAX_FLOW_STDERR`] anyway; a 100 000-photon table's run took 800 000 a
/// channel, most of its build).
pub const MAX_FLOW_RUN: u64 = 80_000;
/// |B| is held at most this per bin (the engine's are up to 1.45 at r < ℓ/2 on ketchup; the
/// summed radiance is held ≥ 0 by the renderer).
pub const MAX_FLOW: f64 = 1.5;
/// A bin's B is used only when its standard error is at most this (else the neighbours' hold).
pub const MAX_FLOW_STDERR: f64 = 0.1;

/// Whether the renderer applies the flow: on unless the environment variable
/// `SUBSURF_ADAPTIVE_FLOW` is `0` (an A/B switch for measurements; read once).
pub fn enabled() -> bool {
    static ON: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *ON.get_or_init(|| std::env::var("SUBSURF_ADAPTIVE_FLOW").map_or(true, |v| v.trim() != "0"))
}

/// Weight leaving through the top per (r bin, exit-cosine bin), then the same × cos Δφ (Δφ the
/// azimuth of the exit direction from t̂ = the lateral position's direction: the source enters
/// at the origin). Values: [`FLOW_BINS`] × [`COUPLING_BINS`] weights (r bin major), then as many
/// moments.
#[derive(Clone, Debug)]
pub struct FlowTally {
    all: Accum,
    photons: u64,
    /// 1/ℓ (mm⁻¹).
    inv_ell: f64,
}

impl FlowTally {
    const LEN: usize = 2 * FLOW_BINS * COUPLING_BINS;

    /// The tally of a stack of transport length `ell` (mm).
    pub fn new(ell: f64) -> FlowTally {
        FlowTally { all: Accum::per_photon(Self::LEN, true), photons: 0, inv_ell: 1.0 / ell }
    }

    /// Mean per photon and standard error of each value.
    pub fn data(&self) -> (Vec<f64>, Vec<f64>) {
        (0..Self::LEN).map(|i| self.all.mean_stderr(i, self.photons)).unzip()
    }
}

/// The r bin of a distance in ℓ.
fn r_bin(r_ell: f64) -> usize {
    FLOW_EDGES.partition_point(|&e| e <= r_ell)
}

impl Tally for FlowTally {
    const POSITIONS: bool = false;
    const TRACKS: bool = true;
    #[inline]
    fn begin_photon(&mut self, _lane: usize, _photon: u64) {}
    #[inline]
    fn specular(&mut self, _lane: usize, _w: f64) {}
    #[inline]
    fn absorb(&mut self, _lane: usize, _p: &Packet, _dw: f64) {}
    #[inline]
    fn roulette(&mut self, _lane: usize, _p: &Packet, _dw: f64) {}
    #[inline]
    fn escape(&mut self, _lane: usize, p: &Packet, side: Side, dir_out: [f64; 3], w: f64) {
        if side != Side::Top {
            return;
        }
        let r = p.pos[0].hypot(p.pos[1]);
        let j = super::exit::mu_bin(dir_out, COUPLING_BINS);
        let b = r_bin(r * self.inv_ell) * COUPLING_BINS + j;
        self.all.add(b, w);
        let t = dir_out[0].hypot(dir_out[1]);
        if t > 0.0 && r > 0.0 {
            let c = (dir_out[0] * p.pos[0] + dir_out[1] * p.pos[1]) / (t * r);
            self.all.add(FLOW_BINS * COUPLING_BINS + b, w * c);
        }
    }
    #[inline]
    fn end_photon(&mut self, _lane: usize) {
        self.photons += 1;
    }
    fn channels(&self, out: &mut Vec<Channel>) {
        out.push(Channel { name: "exit_flow".into(), len: Self::LEN, extremes: false });
    }
    fn drain_into(&mut self, state: &mut [ChannelState]) -> Option<usize> {
        let ok = self.all.drain_into(&mut state[0]);
        self.photons = 0;
        ok.then_some(1)
    }
    fn load_from(&mut self, state: &[ChannelState], photons: u64) -> usize {
        self.all.load_from(&state[0]);
        self.photons = photons;
        1
    }
}

/// The flow run of channel `channel` (see the module docs); `None` when cancelled.
pub fn build_flow(
    stack: &Stack,
    channel: usize,
    s: &super::adaptive::AdaptiveSettings,
    cancel: &AtomicBool,
    progress: &AtomicU64,
) -> Result<Option<ExitBins>> {
    let seed = s.seed.wrapping_add(super::adaptive::SEED_STRIDE * channel as u64 + SEED_FLOW);
    let ell = super::adaptive::transport_length(stack);
    let photons = flow_photons(s.photons);
    let cfg = RunConfig { photons, seed, threads: s.threads, source: Source::Diffuse, isa: None };
    let o = run(stack, &cfg, || FlowTally::new(ell), cancel, progress)?;
    if o.cancelled {
        return Ok(None);
    }
    let (weight, stderr) = o.tally.data();
    Ok(Some(ExitBins { weight, stderr }))
}

/// Photons of [`build_flow`].
pub fn flow_photons(photons: u64) -> u64 {
    photons.saturating_mul(FLOW_PHOTONS).min(MAX_FLOW_RUN.max(photons))
}

/// One channel's flow amplitudes B(r) (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct Flow {
    /// B per r bin as fitted (unclamped), and its standard error (0: not fitted).
    pub b: Vec<f64>,
    pub stderr: Vec<f64>,
    /// ln r (mm) of the nodes used and B there (clamped to ±[`MAX_FLOW`]); empty: no flow.
    ln_r: Vec<f64>,
    node_b: Vec<f64>,
}

/// The geometric centre of r bin `i` in ℓ (the first bin's: ℓ/4; the last's: 90.5 ℓ).
fn bin_centre(i: usize) -> f64 {
    match i {
        0 => 0.5 * FLOW_EDGES[0],
        i if i == FLOW_BINS - 1 => FLOW_EDGES[i - 1] * std::f64::consts::SQRT_2,
        i => (FLOW_EDGES[i - 1] * FLOW_EDGES[i]).sqrt(),
    }
}

impl Flow {
    /// No flow (B = 0).
    pub fn none() -> Flow {
        Flow { b: vec![], stderr: vec![], ln_r: vec![], node_b: vec![] }
    }

    /// The amplitudes fitted to the flow run `bins` of a stack of transport length `ell` (mm) and
    /// relative index `eta`: per r bin the exit coupling's fit at θi = 90°; nodes at the bins'
    /// centres where the standard error is ≤ [`MAX_FLOW_STDERR`].
    pub fn new(eta: f64, ell: f64, bins: &ExitBins) -> Result<Flow> {
        let n = FLOW_BINS * COUPLING_BINS;
        if bins.weight.len() != 2 * n || bins.stderr.len() != 2 * n {
            return Err(Error::Invalid(format!("adaptive table: the exit flow needs {} values", 2 * n)));
        }
        let (mut b, mut stderr, mut ln_r, mut node_b) = (vec![], vec![], vec![], vec![]);
        for i in 0..FLOW_BINS {
            let pick = |v: &[f64]| -> Vec<f64> {
                let (a, m) = (i * COUPLING_BINS, n + i * COUPLING_BINS);
                v[a..a + COUPLING_BINS].iter().chain(&v[m..m + COUPLING_BINS]).copied().collect()
            };
            let f = fit(
                eta,
                std::f64::consts::FRAC_PI_2,
                &ExitBins { weight: pick(&bins.weight), stderr: pick(&bins.stderr) },
            );
            b.push(f.a);
            stderr.push(f.stderr);
            if f.bins > 0 && f.stderr > 0.0 && f.stderr <= MAX_FLOW_STDERR {
                ln_r.push((bin_centre(i) * ell).ln());
                node_b.push(f.a.clamp(-MAX_FLOW, MAX_FLOW));
            }
        }
        Ok(Flow { b, stderr, ln_r, node_b })
    }

    /// Whether B = 0 everywhere.
    pub fn is_zero(&self) -> bool {
        self.node_b.iter().all(|&b| b == 0.0)
    }

    /// B at ln r (r in mm): linear in ln r between the nodes, held outside them.
    #[inline]
    pub fn at_ln(&self, ln_r: f64) -> f64 {
        let n = self.ln_r.len();
        if n == 0 {
            return 0.0;
        }
        if ln_r <= self.ln_r[0] {
            return self.node_b[0];
        }
        if ln_r >= self.ln_r[n - 1] {
            return self.node_b[n - 1];
        }
        let i = self.ln_r.partition_point(|&x| x <= ln_r); // ln_r[i-1] ≤ ln_r < ln_r[i]
        let t = (ln_r - self.ln_r[i - 1]) / (self.ln_r[i] - self.ln_r[i - 1]);
        self.node_b[i - 1] + t * (self.node_b[i] - self.node_b[i - 1])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bins: r in ℓ to its bin; the nodes' centres increase; the fit recovers B per bin from
    /// the model's own moments and interpolates in ln r; noisy bins are left out.
    #[test]
    fn bins_and_interpolation() {
        assert_eq!(r_bin(0.0), 0);
        assert_eq!(r_bin(0.5), 1);
        assert_eq!(r_bin(63.9), FLOW_BINS - 2);
        assert_eq!(r_bin(1e9), FLOW_BINS - 1);
        assert!((0..FLOW_BINS - 1).all(|i| bin_centre(i) < bin_centre(i + 1)));
        let (eta, ell) = (1.4, 0.5);
        let want: Vec<f64> = (0..FLOW_BINS).map(|i| 1.2 - 0.1 * i as f64).collect();
        // the model's moments: ⟨cos Δφ⟩ = B ⟨sin θo⟩_j / 2 per exit-cosine bin (weights 1)
        let sines: Vec<f64> = (0..COUPLING_BINS).map(|j| mean_sine(eta, j)).collect();
        let n = FLOW_BINS * COUPLING_BINS;
        let mut weight = vec![1.0; n];
        for &b in &want {
            weight.extend(sines.iter().map(|&sj| 0.5 * b * sj));
        }
        let mut stderr = vec![0.01; 2 * n];
        // bin 3's moments too noisy: left out of the nodes
        for x in &mut stderr[n + 3 * COUPLING_BINS..n + 4 * COUPLING_BINS] {
            *x = 1.0;
        }
        let f = Flow::new(eta, ell, &ExitBins { weight, stderr }).unwrap();
        for i in 0..FLOW_BINS {
            assert!((f.b[i] - want[i]).abs() < 1e-9, "bin {i}: {} vs {}", f.b[i], want[i]);
        }
        assert_eq!(f.ln_r.len(), FLOW_BINS - 1);
        assert!((f.at_ln((bin_centre(0) * ell).ln()) - MAX_FLOW.min(want[0])).abs() < 1e-12);
        assert!((f.at_ln((bin_centre(5) * ell).ln()) - want[5]).abs() < 1e-12);
        assert_eq!(f.at_ln(-50.0), f.node_b[0]);
        assert_eq!(f.at_ln(50.0), want[FLOW_BINS - 1]);
        // bin 3 skipped: between the centres of 2 and 4, linear in ln r
        let (a, b) = ((bin_centre(2) * ell).ln(), (bin_centre(4) * ell).ln());
        let mid = f.at_ln(0.5 * (a + b));
        assert!((mid - 0.5 * (want[2] + want[4])).abs() < 1e-12);
        assert!(Flow::none().is_zero() && Flow::none().at_ln(0.0) == 0.0);
        assert!(Flow::new(eta, ell, &ExitBins { weight: vec![0.0; 3], stderr: vec![0.0; 3] }).is_err());
    }
}
