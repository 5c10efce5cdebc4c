//! Guided ("zero-variance-based") sampling of the random walk's directions and free paths
//! towards the surface, with one-sample MIS against the classic walk, as Cycles' random walk
//! does (`intern/cycles/kernel/integrator/subsurface_random_walk.h`, after Křivánek & d'Eon
//! 2014, "A zero-variance-based sampling scheme for Monte Carlo subsurface scattering", and
//! Meng, Hanika & Dachsbacher 2016, "Improving the Dwivedi sampling scheme").
//!
//! In a half-space of single-scattering albedo α the zero-variance walk towards the surface
//! (outward normal N) samples cos θ_N = ω·N from the Dwivedi pdf
//! p(cos θ_N) = 1/((v − cos θ_N) ln((v + 1)/(v − 1))) (Křivánek & d'Eon eq. 9; sampled by
//! eq. 10: cos θ_N = v − (v + 1) ((v − 1)/(v + 1))^ξ), azimuth uniform, and the free path with
//! the stretched σt (1 − cos θ_N/v); v is the diffusion length in mean free paths, from α by
//! their fit eq. 67, v = 1/√(1 − α^(2.44294 − 0.0215813 α + 0.578637/α)). The guide direction
//! N is the outward normal of the facet where the walk entered (Cycles: the entry normal).
//!
//! At each real collision of a guided walk the technique is chosen: guided with probability
//! f = 1 − max(0.5, |g|^⅛) (Cycles' heuristic: less guiding for forward-peaked phase
//! functions), classic (the phase function and σt) otherwise; the flight's pdf is the
//! one-sample MIS mixture (balance heuristic) of both, per colour channel (with the spectral
//! MIS of [`super::random_walk`] on top: Cycles' "nine estimators"). Only the first segment
//! of a flight is guided; after a boundary (reflection or crossing) the rest is classic.
//! Homogeneous media only (a voxel grid or a texture keeps the classic walk). Cycles'
//! backward guiding (towards an opposite interface of thin objects) is not implemented.

use super::material::Translucent;
use super::math::{dot, Frame, V3};
use crate::optics::spin;
use crate::rng::PhotonRng;
use std::f64::consts::PI;

/// How a flight's free path is sampled and weighted.
#[derive(Clone, Copy, Debug)]
pub struct Flight {
    /// Probability of the guided technique at the collision that started the flight (0: the
    /// classic walk only).
    pub gf: f64,
    /// The guided direction pdf over the phase function's pdf at the sampled direction.
    pub factor: f64,
    /// The guided free path's σt factor 1 − cos θ_N/v.
    pub stretch: f64,
    /// Whether this flight's free path is drawn with the stretched σt.
    pub guided: bool,
}

impl Flight {
    /// A classic flight (the first one, and after every boundary).
    pub const CLASSIC: Flight = Flight { gf: 0.0, factor: 0.0, stretch: 1.0, guided: false };

    /// The σt factor the free path is drawn with.
    #[inline]
    pub fn sample_factor(&self) -> f64 {
        if self.guided {
            self.stretch
        } else {
            1.0
        }
    }
}

/// The Dwivedi sampling parameters of one medium.
#[derive(Clone, Copy, Debug)]
pub struct Dwivedi {
    v: f64,
    /// ln((v + 1)/(v − 1)).
    log: f64,
    /// Probability of the guided technique.
    gf: f64,
}

impl Dwivedi {
    /// The parameters for `m` (v from the largest single-scattering albedo over the channels,
    /// as Cycles: a too low α gives fireflies, a too high one only some noise); None where the
    /// walk stays classic (heterogeneous or textured medium, α ∉ (0, 1), no guided fraction).
    pub fn for_medium(m: &Translucent) -> Option<Dwivedi> {
        if m.grid.is_some() || m.texture.is_some() {
            return None;
        }
        let alpha = (0..3).filter(|&k| m.sigma_t[k] > 0.0).map(|k| m.sigma_s[k] / m.sigma_t[k]).fold(0.0, f64::max);
        let gf = 1.0 - m.phase.g().abs().powf(0.125).max(0.5);
        if !(alpha > 0.0 && alpha < 1.0 && gf > 0.0) {
            return None;
        }
        let v = 1.0 / (1.0 - alpha.powf(2.44294 - 0.0215813 * alpha + 0.578637 / alpha)).sqrt();
        let log = ((v + 1.0) / (v - 1.0)).ln();
        (v.is_finite() && v > 1.0 && log.is_finite() && log > 0.0).then_some(Dwivedi { v, log, gf })
    }

    /// The pdf of cos θ_N (per unit cos θ_N; per steradian divide by 2π).
    #[inline]
    fn pdf_cos(&self, c: f64) -> f64 {
        1.0 / ((self.v - c) * self.log)
    }
}

/// A new direction from the phase function of `m` after travelling along `d`, without
/// trigonometry: isotropic scattering takes Marsaglia's (1972) uniform direction from a point
/// (x, y) uniform in the unit disc ([`PhotonRng::disc_point`], ρ² = x² + y²):
/// (2x√(1 − ρ²), 2y√(1 − ρ²), 1 − 2ρ²); otherwise cos θ is sampled ([`Phase::sample`], one ξ)
/// and the azimuth is the doubled angle of a disc point, cos φ = (x² − y²)/ρ², sin φ = 2xy/ρ²
/// (uniform; von Neumann 1951, as the engine's kernel draws it), then MCML's [`spin`].
/// Measured on the 81,920-triangle marble sphere: 275 → 111 instructions per collision
/// against cos θ, φ = 2πξ and `sincos` (docs/render.md, "Per-collision work").
///
/// [`Phase::sample`]: crate::optics::Phase::sample
#[inline(always)]
pub fn classic(m: &Translucent, d: V3, rng: &mut PhotonRng) -> V3 {
    if m.phase.is_isotropic() {
        let (x, y) = rng.disc_point();
        let r2 = x * x + y * y;
        let a = 2.0 * (1.0 - r2).sqrt();
        return [a * x, a * y, 1.0 - 2.0 * r2];
    }
    let cos = m.phase.sample(rng.uniform());
    let (x, y) = rng.disc_point();
    let r2 = x * x + y * y;
    spin(d, cos, (x * x - y * y) / r2, 2.0 * x * y / r2)
}

/// The new direction at a real collision in `m` of a walk arriving along `d`, and how its
/// flight is sampled. Without a guide (`None`): the phase function ([`classic`]: the classic
/// walk's numbers). With one (the entry frame around N and the medium's parameters): a ξ for
/// the technique, then two ξ for cos θ (phase or Dwivedi) and the azimuth (about d or about N).
#[inline(always)]
pub fn scatter(m: &Translucent, d: V3, guide: Option<(&Frame, &Dwivedi)>, rng: &mut PhotonRng) -> (V3, Flight) {
    let Some((frame, dw)) = guide else { return (classic(m, d, rng), Flight::CLASSIC) };
    let guided = rng.uniform() < dw.gf;
    let (u1, u2) = (rng.uniform(), rng.uniform());
    let phi = 2.0 * PI * u2;
    let (d_new, cos_n) = if guided {
        let c = (dw.v - (dw.v + 1.0) * (-u1 * dw.log).exp()).clamp(-1.0, 1.0);
        let s = (1.0 - c * c).max(0.0).sqrt();
        (frame.to_world([s * phi.cos(), s * phi.sin(), c]), c)
    } else {
        let w = spin(d, m.phase.sample(u1), phi.cos(), phi.sin());
        (w, dot(w, frame.n).clamp(-1.0, 1.0))
    };
    let phase = m.phase.eval(dot(d, d_new).clamp(-1.0, 1.0));
    let factor = dw.pdf_cos(cos_n) / (2.0 * PI * phase);
    (d_new, Flight { gf: dw.gf, factor, stretch: 1.0 - cos_n / dw.v, guided })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The Dwivedi sampler draws from its pdf: the mean of cos θ_N against the pdf's mean by
    /// quadrature (4σ), and the pdf integrates to 1 over [−1, 1].
    #[test]
    fn dwivedi_sampler_matches_its_pdf() {
        for alpha in [0.5, 0.9, 0.99] {
            let m = Translucent::new("m", [1.0 - alpha; 3], [alpha; 3], 0.0, 1.4, None, false).unwrap();
            let dw = Dwivedi::for_medium(&m).unwrap();
            let n = 20_000;
            let (mut integral, mut mean) = (0.0, 0.0);
            for i in 0..n {
                let c = -1.0 + 2.0 * (i as f64 + 0.5) / n as f64;
                integral += dw.pdf_cos(c) * 2.0 / n as f64;
                mean += c * dw.pdf_cos(c) * 2.0 / n as f64;
            }
            assert!((integral - 1.0).abs() < 1e-6, "alpha {alpha}: {integral}");
            let mut rng = PhotonRng::new(3, 0);
            let (mut s, mut s2) = (0.0, 0.0);
            for _ in 0..n {
                let c = dw.v - (dw.v + 1.0) * (-rng.uniform() * dw.log).exp();
                s += c;
                s2 += c * c;
            }
            let m1 = s / n as f64;
            let se = ((s2 / n as f64 - m1 * m1) / n as f64).sqrt();
            assert!((m1 - mean).abs() < 4.0 * se, "alpha {alpha}: {m1} vs {mean} ± {se}");
        }
    }

    /// χ² of (cos θ, φ) of [`classic`]'s new directions about the arrival direction against
    /// the phase function (`crate::stats`, as the phase samplers' tests in `optics::phase`):
    /// Marsaglia's disc directions (isotropic) and the disc-point azimuth about d (HG g = 0.8).
    /// Power: the same isotropic directions tested against HG g = 0.3 must fail (N = 2·10⁵ on
    /// ≈ 320 cells: λ = N Σ(δp)²/p ≫ the X² of p = 10⁻¹⁰).
    #[test]
    fn classic_directions_match_the_phase_function() {
        use crate::stats::{chi2_test_cos_phi, graded_cos_edges, sidak_alpha, uniform_edges};
        let chi2 = |m: &Translucent, pdf: &dyn Fn(f64) -> f64, seed: u64| {
            let d = [0.3, -0.5, (1.0f64 - 0.34).sqrt()];
            let f = Frame::new(d);
            let mut rng = PhotonRng::new(seed, 0);
            let samples: Vec<(f64, f64)> = (0..200_000)
                .map(|_| {
                    let e = f.to_local(classic(m, d, &mut rng));
                    (e[2].clamp(-1.0, 1.0), e[1].atan2(e[0]).rem_euclid(2.0 * PI))
                })
                .collect();
            let edges = graded_cos_edges(12, 16, 1e-5).unwrap();
            chi2_test_cos_phi(&samples, &|c, _| pdf(c), &edges, &uniform_edges(0.0, 2.0 * PI, 8)).unwrap()
        };
        let alpha = sidak_alpha(0.01, 2).unwrap();
        for (g, seed) in [(0.0, 11), (0.8, 12)] {
            let m = Translucent::new("m", [0.1; 3], [1.0; 3], g, 1.4, None, false).unwrap();
            let r = chi2(&m, &|c| m.phase.pdf(c), seed);
            assert!(r.p_value > alpha, "g = {g}: {r:?}");
        }
        let iso = Translucent::new("m", [0.1; 3], [1.0; 3], 0.0, 1.4, None, false).unwrap();
        let wrong = crate::optics::Phase::hg(0.3).unwrap();
        let r = chi2(&iso, &|c| wrong.pdf(c), 13);
        assert!(r.p_value < 1e-10, "isotropic directions accepted as HG g = 0.3: {r:?}");
    }
}
