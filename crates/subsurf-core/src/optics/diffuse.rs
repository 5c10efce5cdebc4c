//! Hemispherical averages of the Fresnel reflectance: diffuse Fresnel reflectance and the
//! Fresnel moments used by diffusion boundary conditions.
//!
//! Convention: `eta = n_inside / n_outside` (relative index of the scattering medium).
//! *Internal* quantities are for light inside the medium hitting the boundary (total internal
//! reflection beyond the critical angle when η > 1); *external* ones for light arriving from
//! outside. With R(μ; n_i → n_t) the unpolarised Fresnel reflectance ([`fr_dielectric`]):
//!
//! - Fresnel moment  C_i(η) = ∫_0^1 R(μ; η → 1) μ^i dμ  (internal), i = 0, 1, 2, …
//!   This is d'Eon 2012 ("A better dipole", eq. 13 ff., the C_1, C_2 of the boundary condition
//!   A = (1 + 3 C_2)/(1 − 2 C_1)) and pbrt-v3's `FresnelMoment1/2(eta)` (pbrt-v3 §15.5.4,
//!   Eq. 11.7 of the 3rd-edition book; pbrt fits them with polynomials, we integrate).
//! - Diffuse (cosine-weighted hemispherical) reflectance  F_dr = 2 C_1 = 2∫_0^1 R(μ) μ dμ
//!   (Jensen et al. 2001, eq. 5's F_dr; Egan & Hilgeman 1979 fitted it).
//!
//! Quadrature: adaptive 10-point Gauss–Legendre ([`integrate_adaptive`]) to 1e-13. Beyond the
//! critical cosine μ_c = √(1 − 1/x²) (x = n_i/n_t > 1) R = 1 and the integral is closed-form;
//! on [μ_c, 1] R has a square-root kink at μ_c (cos θ_t ∝ √(μ − μ_c)), removed by the
//! substitution μ = μ_c + (1 − μ_c) s², which makes the integrand analytic in s.

use super::fresnel::fr_dielectric;
use crate::error::{Error, Result};
use crate::stats::integrate_adaptive;

/// Tolerance of the adaptive quadrature (absolute, per unit length).
const TOL: f64 = 1e-13;

/// Smallest relative index η the hemispherical averages accept.
pub const ETA_MIN: f64 = 1e-3;
/// Largest relative index η the hemispherical averages accept: beyond it (η² ≥ 10⁶) the
/// critical cosine √(1 − 1/η²) is within 5·10⁻⁷ of 1 and the quadrature of the remaining sliver
/// loses its accuracy (and at η ≈ 10¹⁵⁵, η² overflows); real interfaces have η between ~0.25 and 4.
pub const ETA_MAX: f64 = 1e3;

/// Check a relative index η ∈ [[`ETA_MIN`], [`ETA_MAX`]].
pub fn check_eta(field: &str, eta: f64) -> Result<f64> {
    if (ETA_MIN..=ETA_MAX).contains(&eta) {
        Ok(eta)
    } else {
        Err(Error::param(field, eta, "a number in [0.001, 1000] (eta = n_inside / n_outside)"))
    }
}

/// ∫_0^1 R(μ; x) μ^i dμ for light going from index ratio x = n_i / n_t (x > 0).
fn moment_ratio(x: f64, i: i32) -> f64 {
    let r = |mu: f64| fr_dielectric(mu, x, 1.0) * mu.powi(i);
    if x > 1.0 {
        let mu_c = (1.0 - 1.0 / (x * x)).sqrt();
        // ∫_0^{μc} 1 · μ^i dμ (total internal reflection) + kink-free substitution on [μc, 1].
        let tir = mu_c.powi(i + 1) / (i + 1) as f64;
        let h = 1.0 - mu_c;
        let rest = integrate_adaptive(&mut |s: f64| r(mu_c + h * s * s) * 2.0 * h * s, 0.0, 1.0, TOL);
        tir + rest
    } else {
        // No TIR; near x → 1⁻ R(μ) varies fast close to μ = 0, the adaptive rule refines there.
        integrate_adaptive(&mut |mu: f64| r(mu), 0.0, 1.0, TOL)
    }
}

/// The i-th Fresnel moment C_i(η) = ∫_0^1 R(μ; η → 1) μ^i dμ for light *inside* a medium of
/// relative index η = n_inside/n_outside (d'Eon 2012; pbrt-v3 `FresnelMoment{1,2}`).
/// Errors: η outside [[`ETA_MIN`], [`ETA_MAX`]], or `i` > 16.
pub fn fresnel_moment(eta: f64, i: u32) -> Result<f64> {
    check_eta("eta", eta)?;
    if i > 16 {
        return Err(Error::param_int("i", i, "an integer in [0, 16]"));
    }
    Ok(moment_ratio(eta, i as i32))
}

/// C_1(η) = ∫_0^1 R μ dμ (internal); 2 C_1 is the internal diffuse reflectance.
pub fn fresnel_moment1(eta: f64) -> Result<f64> {
    fresnel_moment(eta, 1)
}

/// C_2(η) = ∫_0^1 R μ² dμ (internal).
pub fn fresnel_moment2(eta: f64) -> Result<f64> {
    fresnel_moment(eta, 2)
}

/// Diffuse Fresnel reflectance F_dr: the cosine-weighted hemispherical average
/// 2∫_0^1 R(μ) μ dμ of the unpolarised Fresnel reflectance, by quadrature (accuracy ~1e-12).
///
/// `eta = n_inside / n_outside`; `internal = true` for light inside the medium reaching the
/// boundary (the F_dr of Jensen et al. 2001), `false` for diffuse light arriving from outside.
/// Reciprocity gives F_dr,int = 1 − (1 − F_dr,ext)/η² (tested, not used).
/// Reference values: η = 1.3 → 0.44446 (int), 0.06113 (ext); 1.4 → 0.52899, 0.07681;
/// 1.5 → 0.59635, 0.09178. Errors: η outside [[`ETA_MIN`], [`ETA_MAX`]].
pub fn diffuse_fresnel_reflectance(eta: f64, internal: bool) -> Result<f64> {
    check_eta("eta", eta)?;
    let x = if internal { eta } else { 1.0 / eta };
    Ok(2.0 * moment_ratio(x, 1))
}

/// Egan & Hilgeman (1979) polynomial fit of the internal diffuse Fresnel reflectance, as
/// quoted by Jensen et al. 2001 (eq. 5 context): F_dr ≈ −1.440/η² + 0.710/η + 0.668 + 0.0636 η.
/// Valid for η ≥ 1; against the quadrature its absolute error is below 2e-3 for
/// 1 ≤ η ≤ 1.6 (measured max 1.6e-3, at η = 1 where the fit gives 0.0016 instead of 0).
/// Errors: η not finite and ≥ 1.
pub fn diffuse_fresnel_reflectance_fit(eta: f64) -> Result<f64> {
    if !(eta.is_finite() && eta >= 1.0) {
        return Err(Error::param("eta", eta, "a finite number >= 1 (the fit is for internal reflection)"));
    }
    Ok(-1.440 / (eta * eta) + 0.710 / eta + 0.668 + 0.0636 * eta)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Published/reference values (issue 2): (η, internal, external), 5 decimals.
    const TABLE: [(f64, f64, f64); 3] = [(1.3, 0.44446, 0.06113), (1.4, 0.52899, 0.07681), (1.5, 0.59635, 0.09178)];

    #[test]
    fn diffuse_matches_reference_table() {
        for (eta, int, ext) in TABLE {
            let fi = diffuse_fresnel_reflectance(eta, true).unwrap();
            let fe = diffuse_fresnel_reflectance(eta, false).unwrap();
            println!("eta {eta}: internal {fi:.8} (err {:.2e}), external {fe:.8} (err {:.2e})", fi - int, fe - ext);
            assert!((fi - int).abs() <= 5e-6, "eta {eta}: internal {fi}");
            assert!((fe - ext).abs() <= 5e-6, "eta {eta}: external {fe}");
        }
    }

    #[test]
    fn reciprocity_identity() {
        // Internal and external are integrated independently (TIR split + substitution vs plain
        // adaptive rule); reciprocity of R links them: F_int = 1 − (1 − F_ext)/η².
        for eta in [1.01, 1.1, 1.33, 1.5, 2.0, 3.0, 0.75] {
            let fi = diffuse_fresnel_reflectance(eta, true).unwrap();
            let fe = diffuse_fresnel_reflectance(eta, false).unwrap();
            let err = (fi - (1.0 - (1.0 - fe) / (eta * eta))).abs();
            assert!(err < 1e-10, "eta {eta}: identity error {err:e}");
        }
        // η = 1: no interface, R ≡ 0.
        assert!(diffuse_fresnel_reflectance(1.0, true).unwrap().abs() < 1e-15);
    }

    #[test]
    fn egan_hilgeman_fit_accuracy() {
        let mut worst: f64 = 0.0;
        for k in 0..=60 {
            let eta = 1.0 + 0.01 * k as f64;
            let q = diffuse_fresnel_reflectance(eta, true).unwrap();
            let f = diffuse_fresnel_reflectance_fit(eta).unwrap();
            worst = worst.max((q - f).abs());
        }
        println!("Egan–Hilgeman fit: max |error| on [1, 1.6] = {worst:.3e}");
        assert!(worst < 2e-3); // the largest error is at η = 1 (fit 0.0016 vs exact 0)
        assert!(diffuse_fresnel_reflectance_fit(0.9).is_err());
    }

    /// pbrt-v3 `FresnelMoment1/2` polynomial fits (bssrdf.cpp), used as an independent check of
    /// the convention (internal, η = n_inside/n_outside).
    fn pbrt_fm1(e: f64) -> f64 {
        if e < 1.0 {
            0.45966 - 1.73965 * e + 3.37668 * e * e - 3.904945 * e.powi(3) + 2.49277 * e.powi(4) - 0.68441 * e.powi(5)
        } else {
            -4.61686 + 11.1136 * e - 10.4646 * e * e + 5.11455 * e.powi(3) - 1.27198 * e.powi(4) + 0.12746 * e.powi(5)
        }
    }
    fn pbrt_fm2(e: f64) -> f64 {
        if e < 1.0 {
            0.27614 - 0.87350 * e + 1.12077 * e * e - 0.65095 * e.powi(3) + 0.07883 * e.powi(4) + 0.04860 * e.powi(5)
        } else {
            let r = 1.0 / e;
            -547.033 + 45.3087 * r.powi(3) - 218.725 * r * r + 458.843 * r + 404.557 * e - 189.519 * e * e
                + 54.9327 * e.powi(3)
                - 9.00603 * e.powi(4)
                + 0.63942 * e.powi(5)
        }
    }

    #[test]
    fn moments_match_pbrt_fits_and_definitions() {
        let (mut w1, mut w2): (f64, f64) = (0.0, 0.0);
        for eta in [0.7, 0.8, 0.9, 1.1, 1.2, 1.3, 1.33, 1.4, 1.5, 1.6] {
            let c1 = fresnel_moment1(eta).unwrap();
            let c2 = fresnel_moment2(eta).unwrap();
            w1 = w1.max((c1 - pbrt_fm1(eta)).abs());
            w2 = w2.max((c2 - pbrt_fm2(eta)).abs());
            assert!((2.0 * c1 - diffuse_fresnel_reflectance(eta, true).unwrap()).abs() < 1e-14);
            // C_0 ≥ C_1 ≥ C_2 since R ≥ 0 and μ ≤ 1.
            let c0 = fresnel_moment(eta, 0).unwrap();
            assert!(c0 >= c1 && c1 >= c2 && c2 > 0.0);
        }
        println!("pbrt-v3 fits: max |C1 − fit| = {w1:.2e}, max |C2 − fit| = {w2:.2e}");
        assert!(w1 < 2e-3 && w2 < 2e-3);
        // Closed-form check past the critical angle: for large η, C_i → 1/(i+1) (R = 1 nearly
        // everywhere): with η = 1e3 the TIR part alone is (1 − 1e-6)^{(i+1)/2}/(i+1).
        assert!((fresnel_moment(1e3, 2).unwrap() - 1.0 / 3.0).abs() < 1e-5);
    }

    #[test]
    fn bad_eta_is_an_error() {
        // out of range values that used to hang the quadrature (η² overflows) are refused
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY, 1e155, 1e308, 1e-200, 1.001e3, 0.999e-3] {
            assert!(diffuse_fresnel_reflectance(bad, true).is_err());
            assert!(fresnel_moment1(bad).is_err());
        }
        assert!(fresnel_moment(1.3, 17).is_err());
        assert!(fresnel_moment2(1e155).unwrap_err().to_string().starts_with("eta = 1e+155 is out of range"));
        assert!(diffuse_fresnel_reflectance(1e-200, false).is_err());
        // both ends of the range are computed (and bounded by the TIR-only limits)
        for eta in [ETA_MIN, ETA_MAX] {
            for internal in [true, false] {
                let f = diffuse_fresnel_reflectance(eta, internal).unwrap();
                assert!(f.is_finite() && (0.0..=1.0).contains(&f), "{eta} {internal}: {f}");
            }
            assert!(fresnel_moment1(eta).unwrap().is_finite());
        }
    }
}
