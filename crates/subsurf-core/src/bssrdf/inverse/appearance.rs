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
            if total == 0.0 {
                return Ok(0.0); // no scattering: no reflectance
            }
            let f = |a: f64| Ok(photon_beam_diffusion::profile(&Medium::new(1.0 - a, a, g, eta)?)?.total() - total);
            // The better dipole's albedo for the same total (closed form) starts the search: the
            // two models' totals are close, so the root is a few steps from it.
            let guess = alpha_prime_from_rd(total, eta, diffusion::Model::BetterDipole).ok().map(from_ap);
            match bracket(&f, guess, -total, 1.0 - 1e-9)? {
                Bracket::Root(a) => Ok(a),
                Bracket::Found(lo, hi, f_lo, f_hi) => illinois(f, lo, hi, f_lo, f_hi),
                Bracket::Above(f_top) => Err(out_of_range(f_top + total)),
            }
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

/// Where the root of an increasing `f` on [0, `top`] lies, searched from `guess`.
enum Bracket {
    /// `f` is 0 there.
    Root(f64),
    /// lo, hi, f(lo) < 0 < f(hi).
    Found(f64, f64, f64, f64),
    /// f(top) < 0 (given): no root.
    Above(f64),
}

/// A bracket of the root of the increasing `f` on [0, `top`] (f(0) = `f_zero` < 0): from
/// `guess`, steps of 2 %, 8 %, 32 %, … of the way to the end on the root's side; without a
/// guess, [0, `top`]. Photon beam diffusion's albedo from the better dipole's guess: 13–14
/// totals per channel from [0, 1] before, 9–10 now (each integrates a tabulated profile, ≈ 0.05 s).
fn bracket(f: &impl Fn(f64) -> Result<f64>, guess: Option<f64>, f_zero: f64, top: f64) -> Result<Bracket> {
    let Some(a) = guess.filter(|a| *a > 0.0 && *a < top) else {
        let f_top = f(top)?;
        return Ok(if f_top < 0.0 { Bracket::Above(f_top) } else { Bracket::Found(0.0, top, f_zero, f_top) });
    };
    let f_a = f(a)?;
    if f_a == 0.0 {
        return Ok(Bracket::Root(a));
    }
    let up = f_a < 0.0;
    let (mut near, mut f_near, mut step) = (a, f_a, 0.02);
    loop {
        let end = if up { top } else { 0.0 };
        let b = if step >= 1.0 { end } else { a + step * (end - a) };
        let f_b = if b == 0.0 { f_zero } else { f(b)? };
        match (up, f_b >= 0.0) {
            (true, true) => return Ok(Bracket::Found(near, b, f_near, f_b)),
            (false, false) => return Ok(Bracket::Found(b, near, f_b, f_near)),
            (true, false) if b >= top => return Ok(Bracket::Above(f_b)),
            _ => (near, f_near, step) = (b, f_b, 4.0 * step),
        }
    }
}

/// The root of the increasing `f` in [lo, hi] (f(lo) = f_lo < 0 < f_hi = f(hi)) to 1e-11:
/// regula falsi with the Illinois modification (each photon beam diffusion total integrates
/// the profile, ≈ 0.05 s; bisection to 1e-11 took ~37 of them).
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The bracket search on a line with its root at 0.3: from a guess on either side, without
    /// one, at the root itself, and with no root below `top`.
    #[test]
    fn bracket_finds_the_root_from_any_guess() {
        let f = |a: f64| Ok(a - 0.3);
        for guess in [Some(0.29), Some(0.31), Some(0.9), Some(0.01), None] {
            match bracket(&f, guess, -0.3, 1.0).unwrap() {
                Bracket::Found(lo, hi, f_lo, f_hi) => {
                    assert!(lo < 0.3 && 0.3 < hi && f_lo < 0.0 && f_hi > 0.0, "{guess:?}: [{lo}, {hi}]");
                    assert!((illinois(f, lo, hi, f_lo, f_hi).unwrap() - 0.3).abs() < 1e-11);
                }
                _ => panic!("{guess:?}: no bracket"),
            }
        }
        assert!(matches!(bracket(&f, Some(0.3), -0.3, 1.0).unwrap(), Bracket::Root(a) if a == 0.3));
        assert!(matches!(bracket(&f, Some(0.1), -0.3, 0.25).unwrap(), Bracket::Above(v) if (v + 0.05).abs() < 1e-15));
        assert!(matches!(bracket(&f, None, -0.3, 0.25).unwrap(), Bracket::Above(_)));
    }

    /// Photon beam diffusion from a reflectance: none gives no scattering, and one above what a
    /// non-absorbing medium reflects is refused with that maximum.
    #[test]
    fn photon_beam_diffusion_ends_of_the_range() {
        let conv = Conventions { power: Power::Entering, mfp_kind: MeanFreePath::Extinction };
        let pbd = Model::PhotonBeamDiffusion;
        let l = material_from_reflectance(&[0.0], &[1.0], 1.3, 0.0, pbd, conv, None).unwrap()[0];
        assert_eq!(l.mus, 0.0);
        let e = material_from_reflectance(&[1.0], &[1.0], 1.3, 0.0, pbd, conv, None).unwrap_err().to_string();
        assert!(
            e.starts_with("reflectance[0] = 1 is out of range: model \"photon_beam_diffusion\" reaches at most"),
            "{e}"
        );
    }
}
