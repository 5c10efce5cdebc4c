//! Normalized diffusion: P. H. Christensen & B. Burley, "Approximate Reflectance Profiles for
//! Efficient Subsurface Scattering", Pixar Technical Memo 15-04 (2015) — the profile of
//! RenderMan, Arnold and Cycles.
//!
//! - eq. (2)/(3): R(r) = A s (e^{−sr/ℓ} + e^{−sr/(3ℓ)}) / (8π ℓ r) = A (e^{−r/d} + e^{−r/(3d)})/(8π d r),
//!   d = ℓ/s, with ∫₀^∞ R 2πr dr = A exactly (the surface albedo);
//! - shape parameter s(A) fitted by the authors to Monte Carlo:
//!   eq. (5) searchlight (normally incident beam), ℓ the mean free path 1/σt:
//!   s = 1.85 − A + 7|A − 0.8|³;
//!   eq. (6) diffuse surface transmission, ℓ the mean free path: s = 1.9 − A + 3.5 (A − 0.8)²;
//!   eq. (8) searchlight with ℓ the diffuse mean free path: s = 3.5 + 100 (A − 0.33)⁴.
//!
//! From a medium ([`from_medium`], [`with_albedo`]) d is set by the median radius of the medium's
//! photon beam diffusion profile, not by a fit of s(A) (see [`with_albedo`]).
//!
//! CDF C(r) = 1 − ¼e^{−r/d} − ¾e^{−r/(3d)} in closed form; it is inverted exactly: with
//! y = e^{−r/(3d)} and v = 1 − u, y³ + 3y = 4v (Cardano), y = a − 1/a, a = ∛(2v + √(4v² + 1)),
//! written without cancellation (see [`NormalizedDiffusion::sample_r`]).

use super::{Medium, RadialProfile};
use crate::error::{Error, Result};
use std::f64::consts::PI;

/// Which published fit of the shape parameter s(A) (and which length ℓ it expects).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShapeFit {
    /// Eq. (5): searchlight configuration, ℓ = mean free path 1/σt.
    Searchlight,
    /// Eq. (6): diffuse surface transmission, ℓ = mean free path 1/σt.
    DiffuseSurface,
    /// Eq. (8): searchlight configuration, ℓ = diffuse mean free path.
    SearchlightDmfp,
}

impl ShapeFit {
    /// Names: `"searchlight"`, `"diffuse_surface"`, `"searchlight_dmfp"`.
    pub fn from_name(name: &str) -> Result<ShapeFit> {
        match name {
            "searchlight" => Ok(ShapeFit::Searchlight),
            "diffuse_surface" => Ok(ShapeFit::DiffuseSurface),
            "searchlight_dmfp" => Ok(ShapeFit::SearchlightDmfp),
            o => Err(Error::Invalid(format!(
                "variant = {o:?} is not a shape fit: must be one of [\"searchlight\", \"diffuse_surface\", \"searchlight_dmfp\"]"
            ))),
        }
    }

    /// s(A) of this fit.
    pub fn s(self, a: f64) -> f64 {
        match self {
            ShapeFit::Searchlight => 1.85 - a + 7.0 * (a - 0.8).abs().powi(3),
            ShapeFit::DiffuseSurface => 1.9 - a + 3.5 * (a - 0.8) * (a - 0.8),
            ShapeFit::SearchlightDmfp => 3.5 + 100.0 * (a - 0.33).powi(4),
        }
    }
}

/// Christensen–Burley profile with surface albedo `a` and scale `d` = ℓ/s (mm).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NormalizedDiffusion {
    /// Surface albedo A = total diffuse reflectance, in [0, 1].
    pub a: f64,
    /// d = ℓ/s, mm.
    pub d: f64,
}

impl NormalizedDiffusion {
    /// From the surface albedo A ∈ [0, 1], the length ℓ > 0 (mm) and the fit giving s(A).
    pub fn new(albedo: f64, length: f64, fit: ShapeFit) -> Result<Self> {
        if !(albedo.is_finite() && (0.0..=1.0).contains(&albedo)) {
            return Err(Error::param("albedo", albedo, "a finite number in [0, 1] (the surface albedo A)"));
        }
        if !(length.is_finite() && length > 0.0) {
            return Err(Error::param("mfp", length, "a finite number > 0 (mm)"));
        }
        Ok(NormalizedDiffusion { a: albedo, d: length / fit.s(albedo) })
    }
}

impl RadialProfile for NormalizedDiffusion {
    fn rd(&self, r: f64) -> f64 {
        if !(r > 0.0) {
            return if r == 0.0 { f64::INFINITY } else { 0.0 };
        }
        let e3 = (-r / (3.0 * self.d)).exp();
        self.a * (e3 * e3 * e3 + e3) / (8.0 * PI * self.d * r)
    }
    fn total(&self) -> f64 {
        self.a
    }
    fn pdf(&self, r: f64) -> f64 {
        if !(r >= 0.0) || self.a == 0.0 {
            return 0.0;
        }
        let e3 = (-r / (3.0 * self.d)).exp();
        (e3 * e3 * e3 + e3) / (4.0 * self.d)
    }
    fn cdf(&self, r: f64) -> f64 {
        if !(r > 0.0) {
            return 0.0;
        }
        let e3 = (-r / (3.0 * self.d)).exp();
        1.0 - 0.25 * e3 * e3 * e3 - 0.75 * e3
    }
    fn sample_r(&self, u: f64) -> f64 {
        if !(u > 0.0) {
            return 0.0;
        }
        if u >= 1.0 {
            return f64::INFINITY;
        }
        let v = 1.0 - u;
        let s = (4.0 * v * v + 1.0).sqrt();
        let a = (2.0 * v + s).cbrt();
        // y = a − 1/a = (a³ − 1)(a + 1)/((a² + a + 1) a), a³ − 1 = 2v + 4v²/(s + 1).
        let y = (2.0 * v + 4.0 * v * v / (s + 1.0)) * (a + 1.0) / ((a * a + a + 1.0) * a);
        -3.0 * self.d * y.ln()
    }
}

/// From physical parameters: A = the total of photon beam diffusion for the same medium (the
/// best analytic total available here; [`with_albedo`] takes A given) and d from its median
/// radius, as [`with_albedo`].
pub fn from_medium(m: &Medium) -> Result<NormalizedDiffusion> {
    let p = super::photon_beam_diffusion::profile(m)?;
    with_median(p.total().clamp(0.0, 1.0), p.radius_for_fraction(0.5))
}

/// The profile a renderer uses for a material made from a `reflectance` per unit *incident*
/// power ([`crate::bssrdf::inverse::material_from_reflectance`]): A = reflectance/(1 − R_sp),
/// per unit power entering the medium like the other closed-form profiles.
pub fn from_reflectance(m: &Medium, reflectance: f64) -> Result<NormalizedDiffusion> {
    let a = reflectance / crate::bssrdf::inverse::appearance::entering_fraction(m.eta);
    if !(reflectance.is_finite() && reflectance >= 0.0 && a <= 1.0) {
        return Err(Error::param(
            "reflectance",
            reflectance,
            "a finite number in [0, 1 − R_sp] (a reflectance per incident power)",
        ));
    }
    with_albedo(m, a)
}

/// The median radius of the profile in units of d: C(r) = ½ at r = 3d·(−ln y), y³ + 3y = 2
/// (1.5522…).
pub fn median_over_d() -> f64 {
    NormalizedDiffusion { a: 1.0, d: 1.0 }.sample_r(0.5)
}

/// The profile of surface albedo `a` whose median radius is `median` (mm): d = median/1.5522….
pub fn with_median(a: f64, median: f64) -> Result<NormalizedDiffusion> {
    if !(a.is_finite() && (0.0..=1.0).contains(&a)) {
        return Err(Error::param("albedo", a, "a finite number in [0, 1] (the surface albedo A)"));
    }
    if !(median.is_finite() && median > 0.0) {
        return Err(Error::param("median radius", median, "a finite number > 0 (mm)"));
    }
    Ok(NormalizedDiffusion { a, d: median / median_over_d() })
}

/// The profile of medium `m` with surface albedo `a` (its total reflectance, e.g. the colour a
/// material was made from): Christensen & Burley's shape with its scale d set so that the
/// median radius is that of the medium's photon beam diffusion profile
/// ([`super::photon_beam_diffusion::profile`]: Habel et al.'s single + multiple scattering,
/// energy-conserving; its median is continuous as σa → 0 and within 5 % of the engine's).
///
/// Why not the paper's fits of s(A): they take a length ℓ and were fitted to Monte Carlo
/// profiles of index-matched, isotropic media. Median radii model/engine (20k photons, same
/// A): eq. (8) with ℓ = 1/σtr (used here before) 0.68 on Jensen's marble (η 1.5), 0.64 at
/// σa 10⁻³, σs 1, η 1.3, 1.14 at σa 10⁻⁴, then 10.2 at 10⁻⁶ and infinite as σa → 0 (1/σtr → ∞
/// while s(A) stays finite; at σa = 0 it switched to eq. (5) with 1/σt': a median of 1.71 mm
/// at σa = 0, 1,200 mm at 10⁻⁹; a sphere of σa 10⁻⁹ rendered black). Eq. (5) with ℓ = 1/σt:
/// 0.41 on marble (the fits ignore a refractive boundary and anisotropy, `docs/profiles.md`).
/// Photon beam diffusion's median: 0.94–1.04 of the engine's on those media and at g = 0.9,
/// η = 1 (the table in `docs/profiles.md`).
pub fn with_albedo(m: &Medium, a: f64) -> Result<NormalizedDiffusion> {
    with_median(a, super::photon_beam_diffusion::profile(m)?.radius_for_fraction(0.5))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The published formulas' own values: s(A) at A = 0.8 and A = 0.5 by eqs. (5), (6), (8)
    /// (worked by hand from the paper's formulas: 1.85 − 0.8 = 1.05; 1.85 − 0.5 + 7·0.3³ =
    /// 1.539; 1.9 − 0.8 = 1.1; 1.9 − 0.5 + 3.5·0.09 = 1.715; 3.5 + 100·0.47⁴ = 8.37968...),
    /// and the normalisation ∫R 2πr dr = A, CDF(d·3 ln 2)… checked numerically.
    #[test]
    fn published_formulas() {
        assert!((ShapeFit::Searchlight.s(0.8) - 1.05).abs() < 1e-15);
        assert!((ShapeFit::Searchlight.s(0.5) - 1.539).abs() < 1e-14);
        assert!((ShapeFit::DiffuseSurface.s(0.8) - 1.1).abs() < 1e-15);
        assert!((ShapeFit::DiffuseSurface.s(0.5) - 1.715).abs() < 1e-14);
        assert!((ShapeFit::SearchlightDmfp.s(0.33) - 3.5).abs() < 1e-15);
        assert!((ShapeFit::SearchlightDmfp.s(0.8) - (3.5 + 100.0 * 0.47f64.powi(4))).abs() < 1e-13);
        // eq. (3) at A = 0.5, ℓ = 1 mm, s = 1.539, r = 1 mm:
        // 0.5·1.539·(e^{−1.539} + e^{−0.513})/(8π) = 0.0249009...
        let p = NormalizedDiffusion::new(0.5, 1.0, ShapeFit::Searchlight).unwrap();
        let want = 0.5 * 1.539 * ((-1.539f64).exp() + (-0.513f64).exp()) / (8.0 * PI);
        assert!((p.rd(1.0) - want).abs() < 1e-15 && (want - 0.0249009).abs() < 1e-6, "{want}");
        for i in 1..2000 {
            let u = i as f64 / 2000.0;
            let r = p.sample_r(u);
            assert!((p.cdf(r) - u).abs() < 1e-13, "{u}");
        }
        assert!((p.cdf(p.sample_r(1.0 - 1e-12)) - (1.0 - 1e-12)).abs() < 1e-15);
        assert!(NormalizedDiffusion::new(1.2, 1.0, ShapeFit::Searchlight).is_err());
    }

    /// The median radius is 1.5522… d: y = e^{−r/(3d)} solves y³ + 3y = 2, y = a − 1/a with
    /// a = ∛(1 + √2) (Cardano), so r = −3d ln y.
    #[test]
    fn median_in_units_of_d() {
        let a = (1.0 + 2f64.sqrt()).cbrt();
        let want = -3.0 * (a - 1.0 / a).ln();
        assert!((median_over_d() - want).abs() < 1e-13 && (want - 1.55218).abs() < 1e-5, "{want}");
        let p = with_median(0.7, 2.0).unwrap();
        assert!((p.cdf(2.0) - 0.5).abs() < 1e-13 && p.total() == 0.7);
        assert!(with_median(0.7, 0.0).is_err() && with_median(1.1, 1.0).is_err());
    }

    /// Continuous as σa → 0 (issue 20: median 1.71 mm at σa = 0, 1,200 mm at 10⁻⁹, 37.9 mm at
    /// 10⁻⁶ before): the median radius and the total at σa/σs' = 10⁻¹², 10⁻⁹, 10⁻⁶ move from
    /// σa = 0's by at most 10 √(σa/σs') relative — diffusion theory's rate (Jensen et al.
    /// 2001's total R_d = (α'/2)(1 + e^{−(4/3)A√(3(1 − α'))}) e^{−√(3(1 − α'))} falls as
    /// √(3σa/σt') when α' → 1; constant ≈ 3 measured here: 2.6 % at g = 0.9, σa/σs' = 10⁻⁵) —
    /// the same through `with_albedo`.
    #[test]
    fn continuous_as_absorption_vanishes() {
        for &(g, eta) in &[(0.0, 1.3), (0.9, 1.4), (0.0, 1.0)] {
            let ssp = 1.0 - g;
            let at = |sa: f64| from_medium(&Medium::new(sa, 1.0, g, eta).unwrap()).unwrap();
            let p0 = at(0.0);
            let m0 = p0.radius_for_fraction(0.5);
            assert!((p0.total() - 1.0).abs() < 1e-9, "{}", p0.total());
            for &x in &[1e-12, 1e-9, 1e-6] {
                let (sa, tol) = (x * ssp, 10.0 * x.sqrt());
                let p = at(sa);
                let m = p.radius_for_fraction(0.5);
                println!("g {g} eta {eta} sigma_a {sa:e}: median {m:.4} mm vs {m0:.4}, A {:.6}", p.a);
                assert!((m / m0 - 1.0).abs() < tol && (p.a - p0.a).abs() < tol, "sigma_a {sa}: {m} vs {m0}");
                let q = with_albedo(&Medium::new(sa, 1.0, g, eta).unwrap(), 0.8).unwrap();
                assert!((q.radius_for_fraction(0.5) / m0 - 1.0).abs() < tol && q.a == 0.8);
            }
        }
    }
}
