//! The coupling of the exit direction to the light's direction in `model = "adaptive"`: the first
//! azimuthal harmonic of the exit radiance about the surface normal, measured from the engine.
//!
//! The exit term of [`super::exit`] is symmetric about the normal. It cannot be right under a
//! collimated light: a forward-scattering medium sends its light on, away from where it came
//! from, and leaves less back towards the light (measured with the exact tally
//! `curved::sun_retro`, `docs/render.md`: with exact exitance and an exact polar shape, any exit
//! term symmetric about the normal sends +4.7, +7.0, +9.8 % too much light back towards a sun on a
//! *flat* two-layer skin). Here the radiance leaving a flat surface lit from the unit direction
//! ω_i (towards the light) is
//!
//! L(ω_o) = L_sym(μ_o) · (1 + A · (ω_i,t · ω_o,t)),
//!
//! ω_t the tangential part of a unit direction (|ω_t| = sin θ): a first harmonic in the azimuth
//! between the exit and the incident direction, of amplitude A sin θi sin θo. Its mean over the
//! exit azimuth is 0 at every μ_o, so every hemispherical total (the exitance, the polar exit
//! shape) is unchanged; A < 0 sends less back towards the light and more on, to the mirror side.
//!
//! A per channel, at each of the oblique runs' angles [`OBLIQUE_THETA_DEG`], is the weighted least-squares
//! fit of the engine's tally ([`CouplingTally`]: the weight leaving the flat semi-infinite stack
//! through the top under a pencil beam at θi, and the same weight × cos Δφ, Δφ the exit direction's
//! azimuth from the light's, on [`COUPLING_BINS`] bins uniform in μ_o): in bin j the model's
//! ⟨cos Δφ⟩ is A sin θi ⟨sin θo⟩_j / 2 (⟨·⟩_j over the bin with the weight F_t(μ) μ). The runs
//! are the oblique gain's own ([`super::oblique::build_oblique`]: 4 × the table's photons each,
//! seed + 64c + 30 + i), which tally this beside their totals at no extra tracing (and the same
//! totals, bit for bit). A depends little on θi (the two-layer skin, 10 000-photon tables: green
//! −0.17, −0.22, −0.18, −0.19 at 30, 50, 65, 80°, each ± 0.02–0.04), so the kept A is one per
//! channel, the inverse-variance mean of the four angles' fits (half their noise), held in
//! ±[`MAX_AMPLITUDE`] (the radiance stays positive).
//! The renderer carries, per irradiance sample, the vector D = ⟨A ω_i,t⟩ over its
//! lights weighted by their share of E_t (gathered light counts with none), the octree the
//! power-weighted sums, and multiplies the near class' exitance by 1 + ⟨D⟩·ω_o,t (`render::hierarchical`,
//! `render::probe`).

use super::exit::{ExitBins, TopExitTally};
use super::oblique::OBLIQUE_THETA_DEG;
use crate::diffusion::bssrdf::ft;
use crate::error::{Error, Result};

/// Number of exit-cosine bins of the tally (uniform in μ_o outside the medium).
pub const COUPLING_BINS: usize = 5;
/// |A| is held at most this (1 + A sin θi sin θo > 0).
pub const MAX_AMPLITUDE: f64 = 0.9;
const STEPS: usize = 400;

/// Weight leaving through the top per exit-cosine bin, and weight × cos Δφ (Δφ from the azimuth
/// of the light: the source is `Source::Pencil` at φ = 0, propagating along +x, so the light
/// lies towards −x; [`TopExitTally`]).
pub type CouplingTally = TopExitTally<COUPLING_BINS, true>;

/// ⟨sin θo⟩ over exit-cosine bin `j` weighted by F_t(η, μ) μ.
pub(crate) fn mean_sine(eta: f64, j: usize) -> f64 {
    let (a, h) = (j as f64 / COUPLING_BINS as f64, 1.0 / (COUPLING_BINS * STEPS) as f64);
    let (mut s0, mut s1) = (0.0, 0.0);
    for i in 0..STEPS {
        let mu = a + (i as f64 + 0.5) * h;
        let w = ft(eta, mu) * mu;
        s0 += w;
        s1 += w * (1.0 - mu * mu).sqrt();
    }
    s1 / s0
}

/// One angle's fitted amplitude.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fit {
    /// A (unclamped).
    pub a: f64,
    /// Its standard error.
    pub stderr: f64,
    /// χ² of the fit over the bins used (degrees of freedom: bins used − 1).
    pub chi2: f64,
    /// Bins used.
    pub bins: usize,
}

/// The weighted least-squares A of one run's tally (`bins`: [`COUPLING_BINS`] weights then the
/// cos Δφ moments) at polar angle `theta` (radians), relative index `eta`. Bins with no weight
/// or no standard error are left out; A = 0 when none is left.
pub fn fit(eta: f64, theta: f64, bins: &ExitBins) -> Fit {
    let (w, se) = (&bins.weight, &bins.stderr);
    let mut pts = vec![];
    for j in 0..COUPLING_BINS {
        let (m, c, s) = (w[j], w[COUPLING_BINS + j], se[COUPLING_BINS + j]);
        if m > 0.0 && s > 0.0 && s.is_finite() && c.is_finite() {
            // ⟨cos Δφ⟩ = c/m; the model's is A sin θi ⟨sin θo⟩/2
            pts.push((2.0 * c / m, 2.0 * s / m, theta.sin() * mean_sine(eta, j)));
        }
    }
    let (sxy, sxx) = pts.iter().fold((0.0, 0.0), |(a, b), &(y, s, x)| (a + x * y / (s * s), b + x * x / (s * s)));
    if pts.is_empty() || !(sxx > 0.0) {
        return Fit { a: 0.0, stderr: 0.0, chi2: 0.0, bins: 0 };
    }
    let a = sxy / sxx;
    let chi2 = pts.iter().map(|&(y, s, x)| ((y - a * x) / s).powi(2)).sum();
    Fit { a, stderr: 1.0 / sxx.sqrt(), chi2, bins: pts.len() }
}

/// One channel's amplitude A: the joint weighted least-squares fit of the runs at every angle of
/// [`OBLIQUE_THETA_DEG`] (the inverse-variance mean of the per-angle fits, which are kept: A
/// depends little on θi, measured, and pooling halves its noise; see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct Coupling {
    /// A, held in ±[`MAX_AMPLITUDE`].
    pub a: f64,
    /// Its standard error (0 when nothing was fitted).
    pub stderr: f64,
    /// The fits, per angle.
    pub fits: Vec<Fit>,
}

impl Coupling {
    /// No coupling (A = 0).
    pub fn none() -> Coupling {
        Coupling { a: 0.0, stderr: 0.0, fits: vec![] }
    }

    /// The amplitude fitted to the runs `runs` (one per angle of [`OBLIQUE_THETA_DEG`]).
    pub fn new(eta: f64, runs: &[ExitBins]) -> Result<Coupling> {
        let n = OBLIQUE_THETA_DEG.len();
        if runs.len() != n
            || runs.iter().any(|r| r.weight.len() != 2 * COUPLING_BINS || r.stderr.len() != 2 * COUPLING_BINS)
        {
            return Err(Error::Invalid(format!(
                "adaptive table: the exit coupling needs {n} runs of {} values",
                2 * COUPLING_BINS
            )));
        }
        let fits: Vec<Fit> = runs.iter().zip(OBLIQUE_THETA_DEG).map(|(r, d)| fit(eta, d.to_radians(), r)).collect();
        let (sw, swa) = fits
            .iter()
            .filter(|f| f.bins > 0 && f.stderr > 0.0)
            .fold((0.0, 0.0), |(w, wa), f| (w + 1.0 / (f.stderr * f.stderr), wa + f.a / (f.stderr * f.stderr)));
        if !(sw > 0.0) {
            return Ok(Coupling { fits, ..Coupling::none() });
        }
        Ok(Coupling { a: (swa / sw).clamp(-MAX_AMPLITUDE, MAX_AMPLITUDE), stderr: 1.0 / sw.sqrt(), fits })
    }

    /// Whether A = 0.
    pub fn is_zero(&self) -> bool {
        self.a == 0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Bins of the model's own ⟨cos Δφ⟩ at amplitude `a` (weights 1 per bin, errors `se`).
    fn model_bins(eta: f64, theta: f64, a: f64, se: f64) -> ExitBins {
        let mut weight = vec![1.0; COUPLING_BINS];
        weight.extend((0..COUPLING_BINS).map(|j| 0.5 * a * theta.sin() * mean_sine(eta, j)));
        ExitBins { weight, stderr: vec![se; 2 * COUPLING_BINS] }
    }

    /// The fit recovers A from its own model's bins (10⁻¹², χ² 0), with an error proportional to
    /// the bins'; the pooled A is the inverse-variance mean of the angles' (an angle with 4× the
    /// error counts 1/16), held in ±0.9; empty runs give A = 0; a wrong number of runs is refused.
    #[test]
    fn fit_recovers_the_amplitude_and_pools_the_angles() {
        let eta = 1.4;
        let a = [-0.3, -0.2, -0.12, -0.25];
        let se = [0.04, 0.01, 0.01, 0.01];
        let runs: Vec<ExitBins> =
            (0..4).map(|i| model_bins(eta, OBLIQUE_THETA_DEG[i].to_radians(), a[i], se[i])).collect();
        let c = Coupling::new(eta, &runs).unwrap();
        for (f, want) in c.fits.iter().zip(a) {
            assert!((f.a - want).abs() < 1e-12 && f.chi2 < 1e-20 && f.bins == COUPLING_BINS, "{f:?}");
        }
        let w: Vec<f64> = c.fits.iter().map(|f| 1.0 / (f.stderr * f.stderr)).collect();
        let want = (0..4).map(|i| w[i] * a[i]).sum::<f64>() / w.iter().sum::<f64>();
        assert!((c.a - want).abs() < 1e-12 && (c.stderr - 1.0 / w.iter().sum::<f64>().sqrt()).abs() < 1e-15);
        assert!(
            (w[0] / w[1] * 16.0
                - (OBLIQUE_THETA_DEG[0].to_radians().sin() / OBLIQUE_THETA_DEG[1].to_radians().sin()).powi(2))
            .abs()
                < 1e-9
        );
        let half = fit(eta, 0.5, &ExitBins { stderr: vec![0.005; 2 * COUPLING_BINS], ..runs[1].clone() });
        assert!((half.stderr / fit(eta, 0.5, &runs[1]).stderr - 0.5).abs() < 1e-9);
        let big: Vec<ExitBins> =
            (0..4).map(|i| model_bins(eta, OBLIQUE_THETA_DEG[i].to_radians(), 2.0, 0.01)).collect();
        assert_eq!(Coupling::new(eta, &big).unwrap().a, MAX_AMPLITUDE);
        let empty = ExitBins { weight: vec![0.0; 2 * COUPLING_BINS], stderr: vec![0.0; 2 * COUPLING_BINS] };
        assert_eq!(fit(eta, 0.5, &empty).a, 0.0);
        assert!(Coupling::new(eta, &vec![empty; 4]).unwrap().is_zero());
        assert!(Coupling::new(eta, &runs[..3]).is_err());
    }
}
