//! Validated entry points of the optics functions, for callers with untrusted input (the Python
//! binding, user code): each checks its arguments — naming each in the error with its allowed
//! range — then calls the unchecked function the Monte Carlo kernels use. The rules live here
//! once; bindings only map arrays over these functions.

use super::{fresnel, phase, sampling, Phase, Polarization};
use crate::error::{check_g, Error, Result};

/// Allowed range of a cosine argument.
const COSINE: &str = "a number in [-1, 1]";
/// Allowed range of a uniform random number.
const UNIT: &str = "a number in [0, 1]";
/// Allowed range of a refractive index or an attenuation coefficient that must be positive.
const POSITIVE: &str = "a finite number > 0";

/// Check a cosine in [−1, 1].
pub fn check_cosine(field: &str, x: f64) -> Result<f64> {
    if (-1.0..=1.0).contains(&x) {
        Ok(x)
    } else {
        Err(Error::param(field, x, COSINE))
    }
}

/// Check a uniform number in [0, 1].
pub fn check_unit(field: &str, u: f64) -> Result<f64> {
    if (0.0..=1.0).contains(&u) {
        Ok(u)
    } else {
        Err(Error::param(field, u, UNIT))
    }
}

/// Check a finite number > 0.
pub fn check_positive(field: &str, x: f64) -> Result<f64> {
    if x.is_finite() && x > 0.0 {
        Ok(x)
    } else {
        Err(Error::param(field, x, POSITIVE))
    }
}

fn check_vector(field: &str, v: [f64; 3]) -> Result<[f64; 3]> {
    for (k, &x) in v.iter().enumerate() {
        if !x.is_finite() {
            return Err(Error::param(format!("{field}[{k}]"), x, "finite"));
        }
    }
    Ok(v)
}

/// A polarisation by name: `"unpolarized"` (or `"unpolarised"`), `"s"` or `"p"`.
pub fn polarization(name: &str) -> Result<Polarization> {
    match name.to_ascii_lowercase().as_str() {
        "unpolarized" | "unpolarised" => Ok(Polarization::Unpolarized),
        "s" => Ok(Polarization::S),
        "p" => Ok(Polarization::P),
        _ => Err(Error::Invalid(format!(
            "polarization = {name:?} is not allowed: must be \"unpolarized\", \"s\" or \"p\""
        ))),
    }
}

/// [`fresnel::fresnel_reflectance`] (or, with `transmit`, 1 − R) with checked arguments.
pub fn fresnel_rt(cos_theta_i: f64, eta_i: f64, eta_t: f64, pol: Polarization, transmit: bool) -> Result<f64> {
    check_cosine("cos_theta_i", cos_theta_i)?;
    check_positive("eta_i", eta_i)?;
    check_positive("eta_t", eta_t)?;
    let r = fresnel::fresnel_reflectance(cos_theta_i, eta_i, eta_t, pol);
    Ok(if transmit { 1.0 - r } else { r })
}

/// [`fresnel::refract`] with checked arguments (`None` on total internal reflection).
pub fn refract(d: [f64; 3], normal: [f64; 3], eta_i: f64, eta_t: f64) -> Result<Option<[f64; 3]>> {
    check_vector("d", d)?;
    check_vector("normal", normal)?;
    check_positive("eta_i", eta_i)?;
    check_positive("eta_t", eta_t)?;
    check_positive("eta_i / eta_t", eta_i / eta_t)?;
    Ok(fresnel::refract(d, normal, eta_i, eta_t))
}

/// [`fresnel::reflect`] with checked (finite) arguments.
pub fn reflect(d: [f64; 3], normal: [f64; 3]) -> Result<[f64; 3]> {
    Ok(fresnel::reflect(check_vector("d", d)?, check_vector("normal", normal)?))
}

/// [`phase::hg_phase`] with checked arguments.
pub fn hg_phase(cos_theta: f64, g: f64) -> Result<f64> {
    Ok(phase::hg_phase(check_cosine("cos_theta", cos_theta)?, check_g("g", g)?))
}

/// [`phase::sample_hg`] with checked arguments.
pub fn sample_hg(u: f64, g: f64) -> Result<f64> {
    Ok(phase::sample_hg(check_unit("u", u)?, check_g("g", g)?))
}

/// The isotropic phase function 1/(4π) at a checked `cos_theta`.
pub fn isotropic_phase(cos_theta: f64) -> Result<f64> {
    check_cosine("cos_theta", cos_theta)?;
    Ok(phase::isotropic_phase())
}

/// [`Phase::eval`] at a checked `cos_theta`.
pub fn phase_eval(p: &Phase, cos_theta: f64) -> Result<f64> {
    Ok(p.eval(check_cosine("cos_theta", cos_theta)?))
}

/// [`Phase::sample`] with a checked `u` (u = 1 is taken as the largest number below 1).
pub fn phase_sample(p: &Phase, u: f64) -> Result<f64> {
    Ok(p.sample(check_unit("u", u)?.min(1.0 - f64::EPSILON)))
}

/// [`sampling::beer_lambert`] with checked arguments (`distance` may be +∞).
pub fn beer_lambert(mu_t: f64, distance: f64) -> Result<f64> {
    crate::error::check_nonneg("mu_t", mu_t)?;
    if !(distance >= 0.0) {
        return Err(Error::param("distance", distance, "a number >= 0 (inf allowed)"));
    }
    Ok(sampling::beer_lambert(mu_t, distance))
}

/// [`sampling::sample_free_path`] with checked arguments.
pub fn sample_free_path(u: f64, sigma_t: f64) -> Result<f64> {
    Ok(sampling::sample_free_path(check_unit("u", u)?, check_positive("sigma_t", sigma_t)?))
}

/// [`sampling::free_path_pdf`] with checked arguments (`s` any number; 0 for s < 0).
pub fn free_path_pdf(s: f64, sigma_t: f64) -> Result<f64> {
    if s.is_nan() {
        return Err(Error::param("s", s, "a number (mm)"));
    }
    Ok(sampling::free_path_pdf(s, check_positive("sigma_t", sigma_t)?))
}

/// [`sampling::sample_cosine_hemisphere`] with checked arguments.
pub fn sample_cosine_hemisphere(u1: f64, u2: f64) -> Result<[f64; 3]> {
    Ok(sampling::sample_cosine_hemisphere(check_unit("u1", u1)?, check_unit("u2", u2)?))
}

/// [`sampling::cosine_hemisphere_pdf`] at a checked `cos_theta`.
pub fn cosine_hemisphere_pdf(cos_theta: f64) -> Result<f64> {
    Ok(sampling::cosine_hemisphere_pdf(check_cosine("cos_theta", cos_theta)?))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arguments_are_checked_and_named() {
        let msg = |r: Result<f64>| r.unwrap_err().to_string();
        assert!(msg(fresnel_rt(1.5, 1.0, 1.5, Polarization::S, false)).starts_with("cos_theta_i = 1.5"));
        assert!(msg(fresnel_rt(0.5, 0.0, 1.5, Polarization::S, false)).starts_with("eta_i = 0"));
        assert!(msg(hg_phase(0.0, 1.0)).starts_with("g = 1"));
        assert!(msg(sample_hg(f64::NAN, 0.0)).starts_with("u = nan"));
        assert!(msg(isotropic_phase(-1.1)).starts_with("cos_theta"));
        assert!(msg(free_path_pdf(1.0, f64::INFINITY)).starts_with("sigma_t = inf"));
        assert!(msg(beer_lambert(1.0, -1.0)).starts_with("distance"));
        assert!(refract([f64::NAN, 0.0, 1.0], [0.0, 0.0, 1.0], 1.0, 1.5).unwrap_err().to_string().starts_with("d[0]"));
        assert!(polarization("x").is_err());
        assert_eq!(polarization("P").unwrap(), Polarization::P);
        assert_eq!(fresnel_rt(1.0, 1.0, 1.5, Polarization::Unpolarized, true).unwrap(), 1.0 - 0.04);
        assert_eq!(beer_lambert(1.0, f64::INFINITY).unwrap(), 0.0);
        assert!((free_path_pdf(0.5, 2.0).unwrap() - 2.0 * (-1.0f64).exp()).abs() < 1e-15);
        assert_eq!(free_path_pdf(-0.5, 2.0).unwrap(), 0.0);
    }
}
