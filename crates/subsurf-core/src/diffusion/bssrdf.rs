//! The diffusion term of the BSSRDF and its surface integral (a BRDF).
//!
//! Jensen et al. (2001, §2.4): S_d(x_i, ω_i; x_o, ω_o) = (1/π) F_t(η, ω_i) R_d(‖x_i − x_o‖) F_t(η, ω_o),
//! with F_t = 1 − F_r the Fresnel transmittance of the smooth boundary for light crossing it
//! from outside (index 1) into the medium (index η), evaluated at the outside angle.
//! Directions are unit vectors pointing away from the surface, normal +z (pbrt's BSDF
//! convention); a direction with ω_z ≤ 0 (below the surface) gives S_d = 0.
//!
//! Note on normalisation: with this form the outgoing radiant exitance is
//! F_t(ω_i) R_d(r) (1 − F_dr,ext), i.e. R_d is multiplied once more by the external hemispherical
//! transmittance; d'Eon (2012) divides the exit factor by 1 − 2C₁(1/η) to remove it. We keep
//! Jensen's form for both profiles, as the paper defines S_d.

use super::Model;
use crate::error::{Error, Result};
use crate::optics::fr_dielectric;
use std::f64::consts::FRAC_1_PI;

/// Validate a unit direction (finite, |ω| = 1 within 1e-6); returns cos θ = ω_z.
pub fn check_direction(field: &str, w: [f64; 3]) -> Result<f64> {
    let n2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
    if !(n2.is_finite() && (n2.sqrt() - 1.0).abs() <= 1e-6) {
        return Err(Error::param(field, n2.sqrt(), "a unit vector (|w| = 1 within 1e-6) given as its length here"));
    }
    Ok(w[2])
}

/// Check that a point has finite coordinates.
pub fn check_point(field: &str, p: [f64; 3]) -> Result<()> {
    for (k, v) in p.iter().enumerate() {
        if !v.is_finite() {
            return Err(Error::param(format!("{field}[{k}]"), *v, "a finite coordinate (mm)"));
        }
    }
    Ok(())
}

/// F_t(η, cos θ) = 1 − F_r(cos θ; 1 → η), the transmittance into the medium (0 for cos θ ≤ 0).
#[inline]
pub fn ft(eta: f64, cos_theta: f64) -> f64 {
    if cos_theta <= 0.0 {
        0.0
    } else {
        1.0 - fr_dielectric(cos_theta, 1.0, eta)
    }
}

/// [`ft`] with checked arguments: η ∈ [1, 2.5] (the diffusion models' range) and cos θ ∈ [−1, 1].
pub fn ft_checked(eta: f64, cos_theta: f64) -> Result<f64> {
    let eta = super::check_eta(eta)?;
    if !(cos_theta.is_finite() && cos_theta.abs() <= 1.0) {
        return Err(Error::param("cos_theta", cos_theta, "a finite number in [-1, 1]"));
    }
    Ok(ft(eta, cos_theta))
}

/// S_d(x_i, ω_i; x_o, ω_o) in mm⁻² sr⁻¹ (Jensen et al. 2001), with R_d from `model`.
#[allow(clippy::too_many_arguments)]
pub fn sd(
    xi: [f64; 3],
    wi: [f64; 3],
    xo: [f64; 3],
    wo: [f64; 3],
    model: Model,
    sigma_a: f64,
    sigma_s_prime: f64,
    eta: f64,
) -> Result<f64> {
    check_point("xi", xi)?;
    check_point("xo", xo)?;
    let ci = check_direction("wi", wi)?;
    let co = check_direction("wo", wo)?;
    let dx = [xi[0] - xo[0], xi[1] - xo[1], xi[2] - xo[2]];
    let r = (dx[0] * dx[0] + dx[1] * dx[1] + dx[2] * dx[2]).sqrt();
    let rd = model.rd(r, sigma_a, sigma_s_prime, eta)?;
    Ok(FRAC_1_PI * ft(eta, ci) * rd * ft(eta, co))
}

/// The diffusion BRDF ∫ S_d dA(x_i) = (1/π) F_t(η, ω_i) R_d,total(α', η) F_t(η, ω_o), sr⁻¹:
/// the reflectance of a uniformly lit semi-infinite medium from multiple scattering.
pub fn diffusion_brdf(
    wi: [f64; 3],
    wo: [f64; 3],
    model: Model,
    sigma_a: f64,
    sigma_s_prime: f64,
    eta: f64,
) -> Result<f64> {
    let ci = check_direction("wi", wi)?;
    let co = check_direction("wo", wo)?;
    let st = super::check_properties(sigma_a, sigma_s_prime, eta)?;
    let total = model.total_rd(sigma_s_prime / st, eta)?;
    Ok(FRAC_1_PI * ft(eta, ci) * total * ft(eta, co))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sd_factorises() {
        let th = 0.6f64;
        let wi = [th.sin(), 0.0, th.cos()];
        let wo = [0.0, 0.0, 1.0];
        let s = sd([0.0; 3], wi, [0.3, 0.4, 0.0], wo, Model::Dipole, 0.1, 1.0, 1.3).unwrap();
        let rd = super::super::dipole_rd(0.5, 0.1, 1.0, 1.3).unwrap();
        let fi = 1.0 - fr_dielectric(th.cos(), 1.0, 1.3);
        let fo = 1.0 - (0.3f64 / 2.3).powi(2);
        assert!((s - FRAC_1_PI * fi * rd * fo).abs() < 1e-15 * s.abs().max(1.0));
        assert_eq!(sd([0.0; 3], [0.0, 0.0, -1.0], [0.0; 3], wo, Model::Dipole, 0.1, 1.0, 1.3).unwrap(), 0.0);
        assert!(sd([0.0; 3], [0.0, 0.0, 2.0], [0.0; 3], wo, Model::Dipole, 0.1, 1.0, 1.3).is_err());
        assert!(sd([f64::NAN, 0.0, 0.0], wo, [0.0; 3], wo, Model::Dipole, 0.1, 1.0, 1.3).is_err());
    }
}
