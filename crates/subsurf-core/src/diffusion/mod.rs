//! Diffusion models of subsurface scattering in a semi-infinite, homogeneous medium:
//! the classical dipole of Jensen, Marschner, Levoy & Hanrahan (SIGGRAPH 2001) and the
//! "better dipole" of d'Eon (2012).
//!
//! Conventions (all modules here):
//! - `sigma_a` σa and `sigma_s_prime` σs' = σs(1 − g) in mm⁻¹, distances in mm, R_d(r) in mm⁻².
//! - `eta` η = n_medium / n_outside, the relative refractive index seen by light leaving the
//!   medium. Allowed range [1, [`ETA_MAX`]]: η < 1 (a scattering medium under a denser cover) is
//!   physically possible, but the Egan–Hilgeman fit of F_dr that Jensen uses is only meaningful
//!   for η ≥ 1 (it goes negative below 1, e.g. F_dr(0.8) = −0.64), and both polynomial fits
//!   (F_dr and d'Eon's Fresnel moments) leave their fitted range above η ≈ 2.5 (d'Eon's C₁ fit
//!   is off by 0.03 at η = 2.8 and by 0.12 at η = 3; F_dr(4) > 1 makes A negative).
//!   Out-of-range values are refused with [`Error::Parameter`].
//! - Both models are diffusion approximations: trustworthy for high reduced albedo
//!   (α' ≳ 0.9) and distances of a few transport mean free paths 1/σt' or more; near the
//!   source (r ≲ 1/σt') and at low albedo they are qualitative only. See `docs/` for the
//!   Monte Carlo comparison.
//!
//! Modules: [`dipole`] (Jensen 2001), [`better_dipole`] (d'Eon 2012), [`inversion`]
//! (α' from R_d, optical properties from a colour), [`bssrdf`] (S_d and the diffusion BRDF).

pub mod better_dipole;
pub mod bssrdf;
pub mod dipole;
pub mod inversion;

pub use better_dipole::{better_dipole_rd, better_dipole_total_rd, fresnel_moment1, fresnel_moment2, BetterDipole};
pub use bssrdf::{diffusion_brdf, sd};
pub use dipole::{a_coefficient, dipole_rd, dipole_total_rd, fdr, flux_term, Dipole};
pub use inversion::alpha_prime_from_rd;

use crate::error::{Error, Result};

/// Largest relative index accepted by the diffusion models (end of the polynomial fits' range).
pub const ETA_MAX: f64 = 2.5;

/// A diffusion profile, selectable by name.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Model {
    /// Jensen et al. (2001), classical dipole.
    Dipole,
    /// d'Eon (2012), "A Better Dipole".
    BetterDipole,
}

impl Model {
    /// Names accepted by [`Model::from_name`].
    pub const NAMES: [&'static str; 2] = ["dipole", "better_dipole"];

    /// `"dipole"` or `"better_dipole"`; anything else is an [`Error::Invalid`] listing the names.
    pub fn from_name(name: &str) -> Result<Model> {
        match name {
            "dipole" => Ok(Model::Dipole),
            "better_dipole" => Ok(Model::BetterDipole),
            other => Err(Error::Invalid(format!(
                "model = {other:?} is not a diffusion model: must be one of {:?}",
                Model::NAMES
            ))),
        }
    }

    /// R_d(r) of this model, mm⁻².
    pub fn rd(self, r: f64, sigma_a: f64, sigma_s_prime: f64, eta: f64) -> Result<f64> {
        match self {
            Model::Dipole => dipole_rd(r, sigma_a, sigma_s_prime, eta),
            Model::BetterDipole => better_dipole_rd(r, sigma_a, sigma_s_prime, eta),
        }
    }

    /// Total diffuse reflectance ∫ R_d(r) 2πr dr of this model (closed form).
    pub fn total_rd(self, alpha_prime: f64, eta: f64) -> Result<f64> {
        match self {
            Model::Dipole => dipole_total_rd(alpha_prime, eta),
            Model::BetterDipole => better_dipole_total_rd(alpha_prime, eta),
        }
    }
}

/// Check the relative index η ∈ [1, ETA_MAX].
pub fn check_eta(eta: f64) -> Result<f64> {
    if eta.is_finite() && (1.0..=ETA_MAX).contains(&eta) {
        Ok(eta)
    } else {
        Err(Error::param("eta", eta, "a finite number in [1, 2.5] (eta = n_medium / n_outside)"))
    }
}

/// Check the reduced albedo α' ∈ [0, 1].
pub fn check_alpha_prime(alpha_prime: f64) -> Result<f64> {
    if alpha_prime.is_finite() && (0.0..=1.0).contains(&alpha_prime) {
        Ok(alpha_prime)
    } else {
        Err(Error::param("alpha_prime", alpha_prime, "a finite number in [0, 1]"))
    }
}

/// Range of the reduced extinction coefficient σt' = σa + σs' (mm⁻¹) and of distances r (mm)
/// the models accept: within it every term of the profiles (z³ with z = 1/σt', e^{−σtr d}, d³)
/// is a finite, normal floating-point number.
pub const SIGMA_T_PRIME_RANGE: (f64, f64) = (1e-100, 1e100);
/// Largest source–exit distance r (mm) accepted.
pub const R_MAX: f64 = 1e100;

/// Check (σa, σs', η) and return σt' = σa + σs' (in [`SIGMA_T_PRIME_RANGE`]).
pub fn check_properties(sigma_a: f64, sigma_s_prime: f64, eta: f64) -> Result<f64> {
    crate::error::check_coefficient("sigma_a", sigma_a)?;
    crate::error::check_coefficient("sigma_s_prime", sigma_s_prime)?;
    check_eta(eta)?;
    let st = sigma_a + sigma_s_prime;
    let (lo, hi) = SIGMA_T_PRIME_RANGE;
    if !(lo..=hi).contains(&st) {
        return Err(Error::param(
            "sigma_a + sigma_s_prime",
            st,
            "a number in [1e-100, 1e100] (mm^-1; 0 is an empty medium)",
        ));
    }
    Ok(st)
}

/// Check a source–exit distance r ∈ [0, [`R_MAX`]] (mm).
pub fn check_r(r: f64) -> Result<f64> {
    if (0.0..=R_MAX).contains(&r) {
        Ok(r)
    } else {
        Err(Error::param("r", r, "a number in [0, 1e100] (mm)"))
    }
}
