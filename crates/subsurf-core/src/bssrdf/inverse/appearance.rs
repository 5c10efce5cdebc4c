//! A material from its appearance: one semi-infinite [`Layer`] per channel whose total diffuse
//! reflectance under a normally incident beam, per unit incident power with the specular
//! reflection excluded (the "surface colour" of Jensen & Buhler 2002 and pbrt's
//! `SubsurfaceFromDiffuse`; what the engine measures), is the requested one, with mean free path
//! ℓ = 1/σt per channel.
//!
//! Per model, the single-scattering albedo α (σs = α/ℓ, σa = (1 − α)/ℓ) is found from the
//! model's own prediction of the colour:
//! - `dipole`, `better_dipole`, `multipole` (a semi-infinite multipole is the dipole),
//!   `photon_beam_diffusion`: their totals are per unit power *entering* the medium, so the
//!   colour is (1 − R_sp) × total ([`entering_fraction`]; without that factor the materials
//!   came out 2.8 % dark at η = 1.4, 4 % at 1.5). The closed-form total is inverted for α'
//!   ([`crate::diffusion::alpha_prime_from_rd`]), then α = α'/(1 − g + gα') (from
//!   α' = α(1 − g)/(1 − αg)); photon beam diffusion's numerically integrated total by bisection
//!   on α. Their materials reproduce the colour under the model; the engine's reflectance of
//!   them differs by the model's error (`docs/profiles.md`);
//! - `monte_carlo` and `normalized_diffusion`: ρ_eff(α) of a [`ProfileTable`] for the same g and η,
//!   inverted: the material simulated by the engine reproduces the colour. Normalized diffusion
//!   takes its surface albedo A as a parameter (its total *is* A for any medium), so its
//!   material is the physical one and a renderer builds its profile with A = colour/(1 − R_sp)
//!   ([`crate::bssrdf::normalized_diffusion::from_colour`]). (Chiang, Kutz & Burley's 2016 fit
//!   α(A), used here before, assumes an index-matched isotropic medium: at g = 0.8, η = 1.4 the
//!   engine gave that material 0.020 for a requested 0.30, and the profile rebuilt from it with
//!   photon beam diffusion's total 0.018: the −74 to −88 % of the render reference.)

use crate::bssrdf::photon_beam_diffusion;
use crate::bssrdf::table::ProfileTable;
use crate::bssrdf::{Medium, Model, RadialProfile};
use crate::diffusion::{self, alpha_prime_from_rd};
use crate::error::{check_g, check_index, Error, Result};
use crate::medium::Layer;
use crate::optics::fr_dielectric;

/// The fraction of a normally incident beam that enters a medium of relative index `eta`:
/// 1 − R_sp. The closed-form models' totals are per unit power *entering* the medium, a colour
/// (and the engine's reflectance) per unit *incident* power: colour = (1 − R_sp) × total.
pub fn entering_fraction(eta: f64) -> f64 {
    1.0 - fr_dielectric(1.0, 1.0, eta)
}

/// The single-scattering albedo of a semi-infinite medium (HG `g`, relative index `eta`)
/// whose total diffuse reflectance under a normally incident beam, per unit incident power
/// (specular excluded), is `rd` under `model` (see the module docs).
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
    if matches!(model, Model::MonteCarlo | Model::NormalizedDiffusion) {
        let t = table.ok_or_else(|| {
            Error::Invalid(format!("model {:?} needs a ProfileTable built for the same g and eta", model.name()))
        })?;
        let s = t.settings();
        if (s.g - g).abs() > 1e-12 || (s.eta - eta).abs() > 1e-12 {
            return Err(Error::Invalid(format!(
                "the ProfileTable was built for g = {}, eta = {}, not g = {g}, eta = {eta}",
                s.g, s.eta
            )));
        }
        return t.albedo_for(rd, field);
    }
    let total = rd / entering_fraction(eta);
    let from_ap = |ap: f64| ap / (1.0 - g + g * ap);
    let out_of_range = |most: f64| {
        Error::Invalid(format!(
            "{field} = {rd} is out of range: model {:?} reaches at most {:.6} (g = {g}, eta = {eta}; \
             colour = (1 − R_sp) × the model's total)",
            model.name(),
            most * entering_fraction(eta)
        ))
    };
    if total > 1.0 {
        return Err(out_of_range(1.0));
    }
    match model {
        Model::Dipole | Model::Multipole => Ok(from_ap(alpha_prime_from_rd(total, eta, diffusion::Model::Dipole)?)),
        Model::BetterDipole => Ok(from_ap(alpha_prime_from_rd(total, eta, diffusion::Model::BetterDipole)?)),
        _ => {
            let pbd = |a: f64| -> Result<f64> {
                Ok(photon_beam_diffusion::profile(&Medium::new(1.0 - a, a, g, eta)?)?.total())
            };
            let hi_total = pbd(1.0 - 1e-9)?;
            if total > hi_total {
                return Err(out_of_range(hi_total));
            }
            // Regula falsi with the Illinois modification on the increasing total(α): each
            // total integrates the profile (≈ 0.1 s), bisection to 1e-11 took ~37 of them.
            let (mut lo, mut hi, mut f_lo, mut f_hi) = (0.0f64, 1.0 - 1e-9, -total, hi_total - total);
            let mut side = 0;
            for _ in 0..200 {
                if hi - lo <= 1e-11 {
                    break;
                }
                let m = (lo - f_lo * (hi - lo) / (f_hi - f_lo)).clamp(lo, hi);
                let m = if m <= lo || m >= hi { 0.5 * (lo + hi) } else { m };
                let f = pbd(m)? - total;
                if f == 0.0 {
                    return Ok(m);
                }
                if f < 0.0 {
                    (lo, f_lo) = (m, f);
                    if side == -1 {
                        f_hi *= 0.5;
                    }
                    side = -1;
                } else {
                    (hi, f_hi) = (m, f);
                    if side == 1 {
                        f_lo *= 0.5;
                    }
                    side = 1;
                }
                if f.abs() < 1e-13 {
                    return Ok(m);
                }
            }
            Ok(0.5 * (lo + hi))
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
