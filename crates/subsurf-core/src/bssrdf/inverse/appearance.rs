//! A material from its appearance: one semi-infinite [`Layer`] per channel whose total diffuse
//! reflectance under a normally incident beam (the "surface colour" of Jensen & Buhler 2002 and
//! pbrt's `SubsurfaceFromDiffuse`) is the requested one, with mean free path ℓ = 1/σt per channel.
//!
//! Per model, the single-scattering albedo α (σs = α/ℓ, σa = (1 − α)/ℓ) is found from the
//! model's own total reflectance:
//! - `dipole`, `better_dipole`, `multipole` (a semi-infinite multipole is the dipole): the
//!   closed-form total is inverted for α' ([`crate::diffusion::alpha_prime_from_rd`]), then
//!   α = α'/(1 − g + gα') (from α' = α(1 − g)/(1 − αg));
//! - `photon_beam_diffusion`: bisection on α of its numerically integrated total;
//! - `normalized_diffusion`: the profile's total *is* A; the albedo is Chiang, Kutz & Burley's
//!   fit for a random walk ("Practical and Controllable Subsurface Scattering for Production
//!   Path Tracing", SIGGRAPH 2016 talk, eq. 1): α = 1 − e^{A(−5.09406 + A(2.61188 − 4.31805A))}
//!   (fitted for an index-matched, isotropic medium);
//! - `monte_carlo`: ρ_eff(α) of a [`ProfileTable`] for the same g and η, inverted (the only model
//!   whose material reproduces the colour when simulated by the engine).

use crate::bssrdf::photon_beam_diffusion;
use crate::bssrdf::table::ProfileTable;
use crate::bssrdf::{Medium, Model, RadialProfile};
use crate::diffusion::{self, alpha_prime_from_rd};
use crate::error::{check_g, check_index, Error, Result};
use crate::medium::Layer;

/// The single-scattering albedo whose total reflectance under `model` is `rd`.
pub fn albedo_from_reflectance(
    model: Model,
    rd: f64,
    g: f64,
    eta: f64,
    table: Option<&ProfileTable>,
    field: &str,
) -> Result<f64> {
    if !(rd.is_finite() && (0.0..=1.0).contains(&rd)) {
        return Err(Error::param(field, rd, "a finite number in [0, 1] (a total diffuse reflectance)"));
    }
    check_g("g", g)?;
    check_index("eta", eta)?;
    let from_ap = |ap: f64| ap / (1.0 - g + g * ap);
    match model {
        Model::Dipole | Model::Multipole => Ok(from_ap(alpha_prime_from_rd(rd, eta, diffusion::Model::Dipole)?)),
        Model::BetterDipole => Ok(from_ap(alpha_prime_from_rd(rd, eta, diffusion::Model::BetterDipole)?)),
        Model::NormalizedDiffusion => Ok(-(rd * (-5.09406 + rd * (2.61188 - 4.31805 * rd))).exp_m1()),
        Model::PhotonBeamDiffusion => {
            let total = |a: f64| -> Result<f64> {
                Ok(photon_beam_diffusion::profile(&Medium::new(1.0 - a, a, g, eta)?)?.total())
            };
            let hi_total = total(1.0 - 1e-9)?;
            if rd > hi_total {
                return Err(Error::Invalid(format!(
                    "{field} = {rd} is out of range: photon beam diffusion reaches at most {hi_total:.6} (g = {g}, eta = {eta})"
                )));
            }
            let (mut lo, mut hi) = (0.0f64, 1.0 - 1e-9);
            while hi - lo > 1e-11 {
                let m = 0.5 * (lo + hi);
                if total(m)? < rd {
                    lo = m;
                } else {
                    hi = m;
                }
            }
            Ok(0.5 * (lo + hi))
        }
        Model::MonteCarlo => {
            let t = table.ok_or_else(|| {
                Error::Invalid("model \"monte_carlo\" needs a ProfileTable built for the same g and eta".into())
            })?;
            let s = t.settings();
            if (s.g - g).abs() > 1e-12 || (s.eta - eta).abs() > 1e-12 {
                return Err(Error::Invalid(format!(
                    "the ProfileTable was built for g = {}, eta = {}, not g = {g}, eta = {eta}",
                    s.g, s.eta
                )));
            }
            t.albedo_for(rd, field)
        }
    }
}

/// One semi-infinite layer (index η, HG g) per channel with the given total diffuse
/// reflectance `albedo[i]` and mean free path `mfp[i]` = 1/σt (mm).
pub fn material_from_appearance(
    albedo: &[f64],
    mfp: &[f64],
    eta: f64,
    g: f64,
    model: Model,
    table: Option<&ProfileTable>,
) -> Result<Vec<Layer>> {
    if albedo.is_empty() || albedo.len() != mfp.len() {
        return Err(Error::Invalid(format!(
            "albedo and mfp need one value per channel each (got {} and {})",
            albedo.len(),
            mfp.len()
        )));
    }
    albedo
        .iter()
        .zip(mfp)
        .enumerate()
        .map(|(i, (&c, &l))| {
            if !(l.is_finite() && l > 0.0) {
                return Err(Error::param(format!("mfp[{i}]"), l, "a finite number > 0 (mm)"));
            }
            let a = albedo_from_reflectance(model, c, g, eta, table, &format!("albedo[{i}]"))?;
            Layer::new(eta, (1.0 - a) / l, a / l, g, f64::INFINITY)
        })
        .collect()
}
