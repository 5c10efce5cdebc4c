//! A material from its appearance — the one colour → material inversion of the package: one
//! semi-infinite [`Layer`] per channel whose total diffuse reflectance under a normally incident
//! beam (specular reflection excluded) is the requested `reflectance` under a chosen profile
//! [`Model`], and whose mean free path of a chosen kind is `mfp` (mm). The spelling follows
//! pbrt's `SubsurfaceMaterial` (`reflectance`, `mfp`) and its `SubsurfaceFromDiffuse`
//! (Pharr, Jakob & Humphreys, PBR 3rd ed. §15.5).
//!
//! Two choices are explicit ([`Conventions`]):
//! - [`Power`]: the reflectance is per unit power *incident* on the surface (what the engine
//!   and a rendered surface show; Jensen & Buhler 2002's "diffuse reflectance") or per unit
//!   power *entering* the medium (the closed-form totals R_d = ∫R_d(r) 2πr dr of the diffusion
//!   literature and pbrt's ρ_eff). Under a normal beam incident = (1 − R_sp) × entering
//!   ([`entering_fraction`]; ignoring it made materials 2.8 % dark at η = 1.4, 4 % at 1.5);
//! - [`MeanFreePath`]: which length `mfp` is — 1/σt (pbrt), 1/σt' (transport), 1/σtr (Jensen &
//!   Buhler 2002, §4) or Christensen & Burley's d (2015; the renderer's normalized diffusion).
//!
//! The single-scattering albedo α (σs = ασt, σa = (1 − α)σt) comes from each model's total,
//! an exhaustive `match` on the model (`single_scattering_albedo`):
//! - `dipole`, `multipole` (a semi-infinite multipole is the dipole), `better_dipole`: the
//!   closed-form total is inverted for α' ([`crate::diffusion::alpha_prime_from_rd`]), then
//!   α = α'/(1 − g + gα') (from α' = α(1 − g)/(1 − αg));
//! - `photon_beam_diffusion`: its numerically integrated total, inverted on α (regula falsi);
//! - `monte_carlo`: ρ_eff(α) of a [`ProfileTable`] for the same g and η (the engine's total);
//! - `normalized_diffusion`: its total is its surface albedo A for *every* medium, so it cannot
//!   say which medium has the reflectance; the medium is the physical one, from the engine's
//!   [`ProfileTable`] as for `monte_carlo`, and a renderer gives the profile A = the entering
//!   reflectance ([`crate::bssrdf::normalized_diffusion::from_reflectance`]). (Chiang, Kutz &
//!   Burley's 2016 fit α(A), used here before, assumes an index-matched isotropic medium: at
//!   g = 0.8, η = 1.4 the engine gave that material 0.020 for a requested 0.30.)
//!
//! The models' materials reproduce the reflectance under the model; the engine's reflectance
//! of them differs by the model's error (`docs/profiles.md`).

use crate::bssrdf::normalized_diffusion;
use crate::bssrdf::photon_beam_diffusion;
use crate::bssrdf::table::ProfileTable;
use crate::bssrdf::{Medium, Model, RadialProfile};
use crate::diffusion::{self, alpha_prime_from_rd};
use crate::error::{check_g, check_index, Error, Result};
use crate::medium::Layer;
use crate::optics::fr_dielectric;

/// The fraction of a normally incident beam that enters a medium of relative index `eta`:
/// 1 − R_sp (R_sp the Fresnel reflectance at normal incidence).
pub fn entering_fraction(eta: f64) -> f64 {
    1.0 - fr_dielectric(1.0, 1.0, eta)
}

/// Per unit of which power a reflectance is given.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Power {
    /// Per unit power incident on the surface, specular reflection excluded (the engine's
    /// `Diffuse` total, the colour a render shows).
    Incident,
    /// Per unit power entering the medium (the diffusion models' closed-form totals, pbrt's
    /// ρ_eff): incident / (1 − R_sp).
    Entering,
}

/// Which length a mean free path `mfp` (mm) is. σt' = σa + σs(1 − g).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MeanFreePath {
    /// ℓ = 1/σt (pbrt's `mfp`, `SubsurfaceFromDiffuse`).
    Extinction,
    /// ℓ = 1/σt' (the transport mean free path).
    Transport,
    /// ℓ_d = 1/σtr, σtr = √(σa/D) with the model's diffusion coefficient (Jensen & Buhler
    /// 2002, §4): D = 1/(3σt') (Jensen et al. 2001) for `dipole`, `multipole`,
    /// `normalized_diffusion` (its profile's σtr) and `monte_carlo`; Grosjean's
    /// D = (2σa + σs')/(3σt'²) (d'Eon 2012) for `better_dipole` and `photon_beam_diffusion`
    /// (whose kernel is the better dipole).
    Diffuse,
    /// Christensen & Burley's (2015) scale d — the d of the `normalized_diffusion` profile a
    /// renderer builds for the material: its median radius (1.5522 d) is that of the medium's
    /// photon beam diffusion profile ([`normalized_diffusion::with_albedo`]); finite without
    /// absorption.
    BurleyD,
}

impl Power {
    /// The names, in the order of [`Power::from_name`].
    pub const NAMES: [&'static str; 2] = ["incident", "entering"];
    /// `"incident"` or `"entering"`.
    pub fn from_name(name: &str) -> Result<Power> {
        match name {
            "incident" => Ok(Power::Incident),
            "entering" => Ok(Power::Entering),
            o => Err(Error::Invalid(format!("power = {o:?} is unknown: must be one of {:?}", Power::NAMES))),
        }
    }
    /// The name [`Power::from_name`] takes.
    pub fn name(self) -> &'static str {
        match self {
            Power::Incident => "incident",
            Power::Entering => "entering",
        }
    }
}

impl MeanFreePath {
    /// The names, in the order of [`MeanFreePath::from_name`].
    pub const NAMES: [&'static str; 4] = ["extinction", "transport", "diffuse", "burley_d"];
    /// `"extinction"`, `"transport"`, `"diffuse"` or `"burley_d"`.
    pub fn from_name(name: &str) -> Result<MeanFreePath> {
        match name {
            "extinction" => Ok(MeanFreePath::Extinction),
            "transport" => Ok(MeanFreePath::Transport),
            "diffuse" => Ok(MeanFreePath::Diffuse),
            "burley_d" => Ok(MeanFreePath::BurleyD),
            o => Err(Error::Invalid(format!("mfp_kind = {o:?} is unknown: must be one of {:?}", MeanFreePath::NAMES))),
        }
    }

    /// This length × σt for a medium of single-scattering albedo `alpha`, HG `g`, relative
    /// index `eta`, whose reflectance per entering power is `a_enter`, under `model` (see the
    /// variants): k with ℓ = 1/(k σt). 0 where the length is infinite (no absorption for the
    /// diffuse length).
    pub fn sigma_ratio(self, model: Model, alpha: f64, g: f64, eta: f64, a_enter: f64) -> Result<f64> {
        let (sa, sp) = (1.0 - alpha, alpha * (1.0 - g)); // σa/σt, σs'/σt
        let stp = sa + sp; // σt'/σt = 1 − αg
        let classical = (3.0 * sa * stp).sqrt();
        Ok(match self {
            MeanFreePath::Extinction => 1.0,
            MeanFreePath::Transport => stp,
            MeanFreePath::Diffuse => match model {
                Model::Dipole | Model::Multipole | Model::NormalizedDiffusion | Model::MonteCarlo | Model::Adaptive => {
                    classical
                }
                Model::BetterDipole | Model::PhotonBeamDiffusion => (3.0 * sa * stp * stp / (2.0 * sa + sp)).sqrt(),
            },
            MeanFreePath::BurleyD => {
                // d of the medium with σt = 1 (lengths scale as 1/σt).
                1.0 / normalized_diffusion::with_albedo(&Medium::new(sa, alpha, g, eta)?, a_enter.clamp(0.0, 1.0))?.d
            }
        })
    }
}

/// The two conventions of a reflectance and a mean free path.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Conventions {
    /// Per unit of which power the reflectance is.
    pub power: Power,
    /// Which length the mean free path is.
    pub mfp_kind: MeanFreePath,
}

/// The single-scattering albedo α of a semi-infinite medium (HG `g`, relative index `eta`)
/// whose total diffuse reflectance under a normally incident beam, per unit power *entering*
/// the medium, is `total` under `model` (see the module docs). `field` names the reflectance
/// in errors; `enter` = [`entering_fraction`]`(eta)` converts ranges to the user's `power`.
fn single_scattering_albedo(
    model: Model,
    total: f64,
    (g, eta): (f64, f64),
    table: Option<&ProfileTable>,
    (field, rd, power): (&str, f64, Power),
) -> Result<f64> {
    let shown = |t: f64| match power {
        Power::Incident => t * entering_fraction(eta),
        Power::Entering => t,
    };
    let out_of_range = |most: f64| {
        Error::Invalid(format!(
            "{field} = {rd} is out of range: model {:?} reaches at most {:.6} per {} power (g = {g}, eta = {eta})",
            model.name(),
            shown(most),
            power.name(),
        ))
    };
    if total > 1.0 {
        return Err(out_of_range(1.0));
    }
    let from_ap = |ap: f64| ap / (1.0 - g + g * ap);
    match model {
        Model::Dipole | Model::Multipole => Ok(from_ap(alpha_prime_from_rd(total, eta, diffusion::Model::Dipole)?)),
        Model::BetterDipole => Ok(from_ap(alpha_prime_from_rd(total, eta, diffusion::Model::BetterDipole)?)),
        Model::PhotonBeamDiffusion => {
            let pbd = |a: f64| Ok(photon_beam_diffusion::profile(&Medium::new(1.0 - a, a, g, eta)?)?.total());
            let hi = 1.0 - 1e-9;
            let hi_total = pbd(hi)?;
            if total > hi_total {
                return Err(out_of_range(hi_total));
            }
            illinois(|a| Ok(pbd(a)? - total), 0.0, hi, -total, hi_total - total)
        }
        Model::MonteCarlo | Model::Adaptive | Model::NormalizedDiffusion => {
            let t = table.ok_or_else(|| {
                Error::Invalid(format!(
                    "model {:?} needs a ProfileTable built for the same g and eta (the engine's total)",
                    model.name()
                ))
            })?;
            let s = t.settings();
            if (s.g - g).abs() > 1e-12 || (s.eta - eta).abs() > 1e-12 {
                return Err(Error::Invalid(format!(
                    "the ProfileTable was built for g = {}, eta = {}, not g = {g}, eta = {eta}",
                    s.g, s.eta
                )));
            }
            // The table holds the engine's total per incident power.
            t.albedo_for(total * entering_fraction(eta), field).map_err(|e| match power {
                Power::Incident => e,
                Power::Entering => {
                    Error::Invalid(format!("{e} (per incident power = entering × {:.6})", entering_fraction(eta)))
                }
            })
        }
    }
}

/// The root of the increasing `f` in [lo, hi] (f(lo) = f_lo < 0 < f_hi = f(hi)) to 1e-11:
/// regula falsi with the Illinois modification (each photon beam diffusion total integrates
/// the profile, ≈ 0.1 s; bisection to 1e-11 took ~37 of them).
fn illinois(f: impl Fn(f64) -> Result<f64>, mut lo: f64, mut hi: f64, mut f_lo: f64, mut f_hi: f64) -> Result<f64> {
    let mut side = 0;
    for _ in 0..200 {
        if hi - lo <= 1e-11 {
            break;
        }
        let m = (lo - f_lo * (hi - lo) / (f_hi - f_lo)).clamp(lo, hi);
        let m = if m <= lo || m >= hi { 0.5 * (lo + hi) } else { m };
        let v = f(m)?;
        if v == 0.0 || v.abs() < 1e-13 {
            return Ok(m);
        }
        if v < 0.0 {
            (lo, f_lo) = (m, v);
            if side == -1 {
                f_hi *= 0.5;
            }
            side = -1;
        } else {
            (hi, f_hi) = (m, v);
            if side == 1 {
                f_lo *= 0.5;
            }
            side = 1;
        }
    }
    Ok(0.5 * (lo + hi))
}

/// One semi-infinite layer (index η, HG g) per channel whose total diffuse reflectance under a
/// normally incident beam is `reflectance[i]` (per unit power of `conv.power`, in [0, 1]) under
/// `model`, and whose mean free path of kind `conv.mfp_kind` is `mfp[i]` (mm). `table`: the
/// engine's [`ProfileTable`] for (g, η), needed by `monte_carlo` and `normalized_diffusion`.
pub fn material_from_reflectance(
    reflectance: &[f64],
    mfp: &[f64],
    eta: f64,
    g: f64,
    model: Model,
    conv: Conventions,
    table: Option<&ProfileTable>,
) -> Result<Vec<Layer>> {
    if reflectance.is_empty() || reflectance.len() != mfp.len() {
        return Err(Error::Invalid(format!(
            "reflectance and mfp need one value per channel each (got {} and {})",
            reflectance.len(),
            mfp.len()
        )));
    }
    check_g("g", g)?;
    check_index("eta", eta)?;
    let enter = entering_fraction(eta);
    reflectance
        .iter()
        .zip(mfp)
        .enumerate()
        .map(|(i, (&rd, &l))| {
            let field = format!("reflectance[{i}]");
            if !(rd.is_finite() && (0.0..=1.0).contains(&rd)) {
                return Err(Error::param(&field, rd, "a finite number in [0, 1] (a total diffuse reflectance)"));
            }
            if !(l.is_finite() && l > 0.0) {
                return Err(Error::param(format!("mfp[{i}]"), l, "a finite number > 0 (mm)"));
            }
            let total = match conv.power {
                Power::Incident => rd / enter,
                Power::Entering => rd,
            };
            let a = single_scattering_albedo(model, total, (g, eta), table, (&field, rd, conv.power))?;
            let k = conv.mfp_kind.sigma_ratio(model, a, g, eta, total)?;
            if !(k > 0.0) {
                return Err(Error::param(
                    &field,
                    rd,
                    "a reflectance below that of a non-absorbing medium when mfp is the diffuse length \
                     (mfp_kind \"diffuse\": no absorption makes it infinite)",
                ));
            }
            let st = 1.0 / (l * k);
            Layer::new(eta, (1.0 - a) * st, a * st, g, f64::INFINITY)
        })
        .collect()
}
