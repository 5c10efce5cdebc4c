//! The exit term of `model = "adaptive"`: the angular distribution of the radiance that leaves
//! the surface, per channel, from the engine's own exit-angle tally.
//!
//! Every other model turns the exitance M into radiance with the flat surface's near-Lambertian
//! L(μ_o) = M F_t(η, μ_o)/(π c). The true exit radiance of a low-order medium is flatter in angle:
//! its internal radiance at the surface falls off towards the normal (measured on a flat
//! 400 × 400 × 100 mm ketchup slab under a normal sun, `docs/render.md`: the adaptive model
//! +6.8 % against `random_walk` 5° from the normal, −6.4 % at 75°, red). Here
//!
//! L(μ_o) = M F_t(η, μ_o)/(π c) · s(μ_o),  s(μ) = (1 + β μ_i(μ)) · c₀/(c₀ + β c₁),
//!
//! with μ_i = √(1 − (1 − μ²)/η²) the internal cosine of the exit direction, c₀ = ∫ F_t μ dμ and
//! c₁ = ∫ F_t μ_i μ dμ over [0, 1]: the internal radiance linear in its cosine (as in diffusion
//! theory, with β fitted rather than derived), normalised so that ∫ s F_t μ dμ = c₀, so every
//! hemispherical total (the exitance) is unchanged and only the angular shape moves; β = 0 gives
//! s ≡ 1 exactly.
//!
//! β per channel is the weighted least-squares fit of the engine's exit-angle histogram
//! ([`ExitTally`]: the weight leaving through the top on [`EXIT_BINS`] bins uniform in μ_o) of
//! the semi-infinite stack under diffuse light ([`build_exit`]: seed + 64c + [`SEED_EXIT`], from
//! 4 × the table's photons, doubled (the same run extended, [`crate::mc::run::extend`]) until the
//! fit's standard error moves s by at most [`EXIT_TOLERANCE`] at any angle ([`Exit::spread`]) or the
//! run holds 16 × the table's photons: dark channels escape little weight per photon and need more
//! of them, and trace them fast), to the
//! model's bin integrals ∫_bin F_t (1 + β μ_i) μ dμ. Measured (2026-12-03, 0.4 M photons per run):
//! the one-parameter shape fits every semi-infinite stack tried within the noise (χ² 3–12 for 8
//! degrees of freedom on marble and ketchup; 7–25 on the two-layer skin), and β depends little on
//! the incidence (ketchup red −0.30 under a normal pencil, −0.32 under diffuse light; two-layer
//! skin blue −0.39 and −0.48) and much on the material (marble −0.04 … −0.08, skin1 −0.23 …
//! −0.36, ketchup −0.30 … −0.39). It is the semi-infinite stack's at every thickness and for
//! both classes of entry point (thin parts' R and T have other shapes: `docs/render.md`).

use super::adaptive::{AdaptiveSettings, SEED_STRIDE};
use crate::diffusion::bssrdf::ft;
use crate::error::Result;
use crate::mc::config::CHUNK_PHOTONS;
use crate::mc::run::{extend, finish};
use crate::mc::state::TallyState;
use crate::mc::tally::accum::Accum;
use crate::mc::tally::{Channel, ChannelState};
use crate::mc::{Packet, RunConfig, Side, Source, Tally};
use crate::medium::Stack;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

/// Number of exit-angle bins (uniform in μ_o = cos θ_o outside the medium).
pub const EXIT_BINS: usize = 10;
/// Steps of the midpoint rule of the bin integrals (per bin) and of the normalisation.
const STEPS: usize = 400;
const NORM_STEPS: usize = 20_000;
/// β is held in [`BETA_MIN`, `BETA_MAX`] (the internal radiance 1 + β μ_i stays positive).
const BETA_MIN: f64 = -0.95;
const BETA_MAX: f64 = 20.0;

/// Seed offset of the exit run within a channel's stride.
pub const SEED_EXIT: u64 = 61;
/// The exit run stops doubling once β's standard error moves s(μ) by at most this at any μ.
pub const EXIT_TOLERANCE: f64 = 0.01;
/// Photons of the exit run's first step, and its largest, in the table's photons.
const FIRST: u64 = 4;
const LAST: u64 = 16;

/// An exit-angle histogram ([`ExitTally`]): weight per bin and its standard error.
#[derive(Clone, Debug, PartialEq)]
pub struct ExitBins {
    /// Weight leaving per bin of μ_o (uniform bins over [0, 1]) per incident photon.
    pub weight: Vec<f64>,
    /// Its standard error.
    pub stderr: Vec<f64>,
}

/// The exit run of channel `channel` (see the module docs); `None` when cancelled. `progress`
/// counts the first step's photons (the doublings are not known in advance).
pub fn build_exit(
    stack: &Stack,
    channel: usize,
    s: &AdaptiveSettings,
    cancel: &AtomicBool,
    progress: &AtomicU64,
) -> Result<Option<ExitBins>> {
    let seed = s.seed.wrapping_add(SEED_STRIDE * channel as u64 + SEED_EXIT);
    let eta = stack.layers[0].n / stack.n_above;
    let (first, last) = (exit_photons(s.photons), whole_chunks(s.photons.saturating_mul(LAST)));
    let mut layout = vec![];
    ExitTally::default().channels(&mut layout);
    let mut state = TallyState::new(layout, 0, 0)?;
    let mut photons = first;
    let local = AtomicU64::new(0);
    loop {
        let cfg = RunConfig { photons, seed, threads: s.threads, source: Source::Diffuse, isa: None };
        if extend(stack, &cfg, &mut state, ExitTally::default, cancel, &local)? {
            return Ok(None);
        }
        let (weight, stderr) = finish(&state, ExitTally::default).data();
        let fit = Exit::fit(eta, &weight, &stderr);
        if photons >= last || fit.stderr * fit.spread() <= EXIT_TOLERANCE {
            progress.fetch_add(first, Ordering::Relaxed);
            return Ok(Some(ExitBins { weight, stderr }));
        }
        photons = (2 * photons).min(last);
    }
}

/// Photons counted by [`build_exit`]'s progress.
pub fn exit_photons(photons: u64) -> u64 {
    whole_chunks(photons.saturating_mul(FIRST))
}

/// `n` rounded up to whole engine chunks (at least one): the photons a run of `n` traces.
fn whole_chunks(n: u64) -> u64 {
    n.div_ceil(CHUNK_PHOTONS).max(1).saturating_mul(CHUNK_PHOTONS)
}

/// Weight leaving through the top face by exit cosine (`BINS` bins uniform in μ_o; a photon
/// escapes once, so per-photon moments), and with `AZIMUTH` also weight × cos Δφ per bin (Δφ
/// from the azimuth of a `Source::Pencil` light at φ = 0, propagating along +x, so the light
/// lies towards −x): values `BINS ..` of [`TopExitTally::data`]. The exit run's [`ExitTally`]
/// and the exit coupling's [`super::coupling::CouplingTally`].
#[derive(Clone, Debug)]
pub struct TopExitTally<const BINS: usize, const AZIMUTH: bool> {
    all: Accum,
    photons: u64,
}

/// The bin of `bins` equal bins of the exit cosine [0, 1] that an escape direction falls in.
#[inline]
pub fn mu_bin(dir_out: [f64; 3], bins: usize) -> usize {
    ((dir_out[2].abs().min(1.0) * bins as f64) as usize).min(bins - 1)
}

/// The exit run's tally: weight per exit-cosine bin.
pub type ExitTally = TopExitTally<EXIT_BINS, false>;

impl<const BINS: usize, const AZIMUTH: bool> TopExitTally<BINS, AZIMUTH> {
    /// Values per photon: the bins' weights, then (with `AZIMUTH`) their weights × cos Δφ.
    const LEN: usize = if AZIMUTH { 2 * BINS } else { BINS };

    /// Mean per photon and standard error of each value.
    pub fn data(&self) -> (Vec<f64>, Vec<f64>) {
        (0..Self::LEN).map(|i| self.all.mean_stderr(i, self.photons)).unzip()
    }
}

impl<const BINS: usize, const AZIMUTH: bool> Default for TopExitTally<BINS, AZIMUTH> {
    fn default() -> Self {
        TopExitTally { all: Accum::per_photon(Self::LEN, true), photons: 0 }
    }
}

impl<const BINS: usize, const AZIMUTH: bool> Tally for TopExitTally<BINS, AZIMUTH> {
    const POSITIONS: bool = false;
    const TRACKS: bool = false;
    #[inline]
    fn begin_photon(&mut self, _lane: usize, _photon: u64) {}
    #[inline]
    fn specular(&mut self, _lane: usize, _w: f64) {}
    #[inline]
    fn absorb(&mut self, _lane: usize, _p: &Packet, _dw: f64) {}
    #[inline]
    fn roulette(&mut self, _lane: usize, _p: &Packet, _dw: f64) {}
    #[inline]
    fn escape(&mut self, _lane: usize, _p: &Packet, side: Side, dir_out: [f64; 3], w: f64) {
        if side == Side::Top {
            let b = mu_bin(dir_out, BINS);
            self.all.add(b, w);
            if AZIMUTH {
                let t = dir_out[0].hypot(dir_out[1]);
                if t > 0.0 {
                    self.all.add(BINS + b, -w * dir_out[0] / t);
                }
            }
        }
    }
    #[inline]
    fn end_photon(&mut self, _lane: usize) {
        self.photons += 1;
    }
    fn channels(&self, out: &mut Vec<Channel>) {
        let name = if AZIMUTH { "exit_azimuth" } else { "exit_angle" };
        out.push(Channel { name: name.into(), len: Self::LEN, extremes: false });
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

/// Internal cosine of the exit direction of exterior cosine `mu` (η = n_inside/n_outside ≥ 1).
#[inline]
fn mu_inside(eta: f64, mu: f64) -> f64 {
    (1.0 - (1.0 - mu * mu) / (eta * eta)).max(0.0).sqrt()
}

/// ∫ F_t μ dμ and ∫ F_t μ_i μ dμ over [a, b] (midpoint rule, `steps` steps).
fn moments(eta: f64, a: f64, b: f64, steps: usize) -> (f64, f64) {
    let h = (b - a) / steps as f64;
    (0..steps).fold((0.0, 0.0), |(s0, s1), i| {
        let mu = a + (i as f64 + 0.5) * h;
        let w = ft(eta, mu) * mu * h;
        (s0 + w, s1 + w * mu_inside(eta, mu))
    })
}

/// One channel's exit shape (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Exit {
    /// Slope β of the internal radiance in its cosine (0: the flat surface's term).
    pub beta: f64,
    /// Standard error of the fitted β (0 for a shape not fitted).
    pub stderr: f64,
    eta: f64,
    /// c₀ / (c₀ + β c₁).
    norm: f64,
    /// c₁ / c₀.
    ratio: f64,
}

impl Exit {
    /// The shape of slope `beta` for relative index `eta`.
    pub fn new(eta: f64, beta: f64) -> Exit {
        let (c0, c1) = moments(eta, 0.0, 1.0, NORM_STEPS);
        Exit { beta, stderr: 0.0, eta, norm: c0 / (c0 + beta * c1), ratio: c1 / c0 }
    }

    /// The weighted least-squares β of an exit-angle histogram (`weight[b]`, `stderr[b]` of bins
    /// uniform in μ_o; bins with no standard error are left out), held in [−0.95, 20]; 0 when
    /// the histogram holds nothing to fit. With its standard error.
    pub fn fit(eta: f64, weight: &[f64], stderr: &[f64]) -> Exit {
        let n = weight.len();
        let (mut a, mut r) = ([[0.0; 2]; 2], [0.0; 2]);
        for (b, (&w, &s)) in weight.iter().zip(stderr).enumerate() {
            if !(s > 0.0 && s.is_finite() && w.is_finite()) {
                continue;
            }
            let (m0, m1) = moments(eta, b as f64 / n as f64, (b + 1) as f64 / n as f64, STEPS);
            let x = [m0 / s, m1 / s];
            let y = w / s;
            for i in 0..2 {
                r[i] += x[i] * y;
                for j in 0..2 {
                    a[i][j] += x[i] * x[j];
                }
            }
        }
        let det = a[0][0] * a[1][1] - a[0][1] * a[1][0];
        let amp = (a[1][1] * r[0] - a[0][1] * r[1]) / det;
        let slope = (a[0][0] * r[1] - a[1][0] * r[0]) / det;
        let beta = slope / amp;
        if !(beta.is_finite() && amp > 0.0) {
            return Exit::new(eta, 0.0);
        }
        // the covariance of (amp, slope) is the inverse normal matrix; β's error by the delta method
        let (c00, c01, c11) = (a[1][1] / det, -a[0][1] / det, a[0][0] / det);
        let var = (c11 - 2.0 * beta * c01 + beta * beta * c00) / (amp * amp);
        let mut e = Exit::new(eta, beta.clamp(BETA_MIN, BETA_MAX));
        e.stderr = var.max(0.0).sqrt();
        e
    }

    /// max over μ of |∂s(μ)/∂β|: how far an error of β moves the factor at most (at normal or
    /// grazing exit).
    pub fn spread(&self) -> f64 {
        let lo = mu_inside(self.eta, 0.0);
        (1.0 - self.ratio).max(self.ratio - lo).abs() * self.norm * self.norm
    }

    /// s(μ_o): the factor on the flat surface's F_t(η, μ_o)/(π c) at exterior cosine `mu`.
    #[inline]
    pub fn factor(&self, mu: f64) -> f64 {
        if self.beta == 0.0 {
            return 1.0;
        }
        (1.0 + self.beta * mu_inside(self.eta, mu.clamp(0.0, 1.0))) * self.norm
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every hemispherical total is unchanged: ∫ s F_t μ dμ = ∫ F_t μ dμ (another rule, 10⁻⁶),
    /// for β from −0.9 to 3 and η 1.3, 1.5; β = 0 is exactly 1; `spread` is the largest |∂s/∂β|.
    #[test]
    fn shape_keeps_the_total() {
        for eta in [1.3, 1.5] {
            assert_eq!(Exit::new(eta, 0.0).factor(0.3), 1.0);
            for beta in [-0.9, -0.3, 0.5, 3.0] {
                let e = Exit::new(eta, beta);
                let n = 100_000;
                let (mut with, mut flat) = (0.0, 0.0);
                for i in 0..n {
                    let mu = (i as f64 + 0.5) / n as f64;
                    with += e.factor(mu) * ft(eta, mu) * mu;
                    flat += ft(eta, mu) * mu;
                }
                assert!((with / flat - 1.0).abs() < 1e-6, "η {eta} β {beta}: {}", with / flat);
                assert!((e.factor(1.0) > 1.0) == (beta > 0.0), "peaked when β > 0");
                // spread: the largest |∂s/∂β| over μ (at μ = 0 or 1), by finite differences
                let h = 1e-6;
                let slope = |mu: f64| ((Exit::new(eta, beta + h).factor(mu) - e.factor(mu)) / h).abs();
                let most = [0.0, 1.0].map(slope).into_iter().fold(0.0, f64::max);
                assert!((e.spread() / most - 1.0).abs() < 1e-4, "{} vs {most}", e.spread());
                assert!((0..=100).all(|i| slope(i as f64 / 100.0) <= most * (1.0 + 1e-4)));
            }
        }
    }

    /// The fit recovers β from exact bin integrals of its own model (10⁻⁹), any scale, with a
    /// standard error proportional to the bins'; empty or error-free histograms give β = 0; a bin
    /// without standard error is left out.
    #[test]
    fn fit_recovers_the_slope() {
        let eta = 1.3;
        for beta in [-0.4, 0.0, 0.8] {
            let w: Vec<f64> = (0..EXIT_BINS)
                .map(|b| {
                    let (m0, m1) = moments(eta, b as f64 / EXIT_BINS as f64, (b + 1) as f64 / EXIT_BINS as f64, STEPS);
                    0.37 * (m0 + beta * m1)
                })
                .collect();
            let mut se: Vec<f64> = w.iter().map(|x| 0.01 * x).collect();
            let e = Exit::fit(eta, &w, &se);
            assert!((e.beta - beta).abs() < 1e-9);
            let quarter: Vec<f64> = se.iter().map(|x| 0.25 * x).collect();
            let e4 = Exit::fit(eta, &w, &quarter);
            assert!(e.stderr > 0.0 && (e4.stderr / e.stderr - 0.25).abs() < 1e-6, "β's error scales with the bins'");
            se[3] = 0.0;
            let mut w2 = w.clone();
            w2[3] = 5.0;
            assert!((Exit::fit(eta, &w2, &se).beta - beta).abs() < 1e-9, "bin 3 left out");
        }
        assert_eq!(Exit::fit(eta, &[0.0; EXIT_BINS], &[0.0; EXIT_BINS]).beta, 0.0);
    }
}
