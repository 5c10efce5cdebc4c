//! Radial BSSRDF profiles R_d(r): the diffuse reflectance per unit area (mm⁻²) at distance r
//! (mm) from a normally incident pencil beam of unit power, for one colour channel.
//!
//! Every model implements [`RadialProfile`]; renderers and fits use profiles only through it.
//! One model per file, each citing its paper and equations:
//! - [`dipole`]: Jensen et al. 2001 (the classical dipole);
//! - [`better_dipole`]: d'Eon 2012;
//! - [`multipole`]: Donner & Jensen 2005 (finite slabs, layered stacks by convolution);
//! - [`photon_beam_diffusion`]: Habel, Christensen & Jarosz 2013 (single + multiple scattering);
//! - [`normalized_diffusion`]: Christensen & Burley 2015;
//! - [`monte_carlo`]: the engine's R(r) on a log grid, energy-exact, for any [`Stack`];
//! - [`adaptive`]: the engine's R(r; d) and T(r; d) of finite slabs on a grid of thicknesses (the
//!   renderer's geometry-aware BSSRDF; as a plain profile, the semi-infinite Monte Carlo one),
//!   with [`curvature`] and [`oblique`] (its curvature scales and oblique-incidence gain).
//!
//! Support: [`cdf`] (the monotone radial CDF every model samples from), [`chandrasekhar`] (exact
//! semi-infinite reflectance, the reference of the Monte Carlo tests), [`table`] (Monte Carlo
//! profile tables in optical units), [`inverse`] (material from appearance, fits to measurements).

pub mod adaptive;
pub mod better_dipole;
pub mod cdf;
pub mod chandrasekhar;
pub mod coupling;
pub mod curvature;
pub mod curved;
pub mod dipole;
pub mod exit;
pub mod flow;
pub mod harmonic;
pub mod inverse;
pub mod monte_carlo;
pub mod multipole;
pub mod normalized_diffusion;
pub mod oblique;
pub mod photon_beam_diffusion;
pub mod table;

#[cfg(test)]
mod contract_tests;

use crate::error::{check_g, check_index, check_nonneg, Error, Result};
use crate::medium::{Layer, Stack};
use cdf::RadialCdf;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

/// A radial diffuse-reflectance profile and the sampling routines a renderer needs.
///
/// Contract (tested for every model in `contract_tests.rs`), for radii r ∈ [0, ∞] and fractions
/// u ∈ [0, 1) — the domain [`Query`] checks for the API:
/// - [`rd`](Self::rd) ≥ 0, finite for 0 < r < ∞ (+∞ allowed at r = 0, where some profiles are
///   singular), and 0 at r = ∞;
/// - [`total`](Self::total) = ∫₀^∞ R_d(r) 2πr dr (the total diffuse reflectance, in [0, 1]);
/// - [`pdf`](Self::pdf) = 2πr R_d(r) / total, finite everywhere (its limit at r = 0), 0 at r = ∞,
///   and it integrates to 1 over r ∈ [0, ∞);
/// - [`cdf`](Self::cdf) is its integral from 0 (0 at r = 0, 1 at r = ∞), and
///   [`sample_r`](Self::sample_r) its inverse: `cdf(sample_r(u)) = u`, finite, for u ∈ [0, 1);
/// - a profile with `total() == 0` has `pdf ≡ 0` and is never sampled.
pub trait RadialProfile: Send + Sync {
    /// R_d(r), mm⁻², at radius `r` ≥ 0 (mm).
    fn rd(&self, r: f64) -> f64;
    /// [`rd`](Self::rd) at `r` given `ln_r` = ln r: a caller that evaluates several profiles at
    /// one radius (the hierarchical method's tree walk) takes the logarithm once, and profiles
    /// tabulated in ln r use it.
    fn rd_ln(&self, r: f64, ln_r: f64) -> f64 {
        let _ = ln_r;
        self.rd(r)
    }
    /// A radius (mm) beyond which the profile holds at most about 10⁻⁶ of its energy, where one
    /// is known (∞ otherwise): the hierarchical method's tree walk skips what lies beyond it.
    fn reach(&self) -> f64 {
        f64::INFINITY
    }
    /// ∫₀^∞ R_d(r) 2πr dr, dimensionless.
    fn total(&self) -> f64;
    /// Fraction of [`total`](Self::total) inside radius `r` (mm).
    fn cdf(&self, r: f64) -> f64;
    /// The radius r (mm) with `cdf(r) = u`, u ∈ [0, 1): the inverse-CDF sampler of [`pdf`](Self::pdf).
    fn sample_r(&self, u: f64) -> f64;
    /// 2πr R_d(r) / total, mm⁻¹: the density of [`sample_r`](Self::sample_r).
    fn pdf(&self, r: f64) -> f64 {
        let t = self.total();
        if t > 0.0 && r < f64::INFINITY {
            2.0 * std::f64::consts::PI * r * self.rd(r) / t
        } else {
            0.0
        }
    }
    /// The radius (mm) holding a fraction `q` ∈ [0, 1) of the energy (renderers bound their
    /// searches with it, e.g. q = 0.999).
    fn radius_for_fraction(&self, q: f64) -> f64 {
        self.sample_r(q)
    }
    /// The single-scattering part of the profile as a profile of its own (included in
    /// [`rd`](Self::rd)), for models that separate it (photon beam diffusion, Monte Carlo);
    /// `None` for pure diffusion models.
    fn single_scattering(&self) -> Option<&dyn RadialProfile> {
        None
    }
}

/// One query of a profile as the API takes it (`subsurf.bssrdf.Profile`'s methods): the argument
/// is checked against the domain of the [`RadialProfile`] contract — radii in [0, ∞], fractions in
/// [0, 1) — and refused with an error naming it, instead of a silent 0, NaN or clamped value.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Query {
    /// [`RadialProfile::rd`] at radius `r`.
    Rd,
    /// [`RadialProfile::pdf`] at radius `r`.
    Pdf,
    /// [`RadialProfile::cdf`] at radius `r`.
    Cdf,
    /// [`RadialProfile::sample_r`] of the fraction `u`.
    SampleR,
    /// [`RadialProfile::radius_for_fraction`] of the fraction `q`.
    RadiusForFraction,
}

impl Query {
    /// The query's value at `x` for `p`, or an error naming the argument and its range.
    pub fn eval(self, p: &dyn RadialProfile, x: f64) -> Result<f64> {
        let (name, radius) = match self {
            Query::Rd | Query::Pdf | Query::Cdf => ("r", true),
            Query::SampleR => ("u", false),
            Query::RadiusForFraction => ("q", false),
        };
        if radius && !(x >= 0.0) {
            return Err(Error::param(name, x, "a radius in [0, inf] (mm)"));
        }
        if !radius && !(0.0..1.0).contains(&x) {
            return Err(Error::param(name, x, "a fraction in [0, 1)"));
        }
        Ok(match self {
            Query::Rd => p.rd(x),
            Query::Pdf => p.pdf(x),
            Query::Cdf => p.cdf(x),
            Query::SampleR => p.sample_r(x),
            Query::RadiusForFraction => p.radius_for_fraction(x),
        })
    }
}

/// A closed-form R_d(r) with a characteristic length; [`Tabulated`] adds its CDF and sampler.
pub trait ClosedForm: Send + Sync {
    /// R_d(r), mm⁻².
    fn rd(&self, r: f64) -> f64;
    /// A length (mm) on which the profile varies near the origin (e.g. 1/σt').
    fn scale(&self) -> f64;
    /// The single-scattering part, if the model separates it.
    fn single(&self) -> Option<&dyn RadialProfile> {
        None
    }
}

/// A closed-form profile with its CDF tabulated once ([`RadialCdf::from_rd`]): `rd` and `pdf`
/// are the model's exact values; `total` is the quadrature of rd (agrees with the closed-form
/// totals to ~1e-12 where they exist).
pub struct Tabulated<M: ClosedForm> {
    /// The model.
    pub model: M,
    cdf: RadialCdf,
    total: f64,
}

impl<M: ClosedForm> Tabulated<M> {
    /// Tabulate the CDF of `model`.
    pub fn new(model: M) -> Self {
        let (cdf, total) = RadialCdf::from_rd(&|r| model.rd(r), model.scale());
        Tabulated { model, cdf, total }
    }
}

impl<M: ClosedForm> RadialProfile for Tabulated<M> {
    fn rd(&self, r: f64) -> f64 {
        if (0.0..f64::INFINITY).contains(&r) {
            self.model.rd(r)
        } else {
            0.0
        }
    }
    fn total(&self) -> f64 {
        self.total
    }
    fn cdf(&self, r: f64) -> f64 {
        self.cdf.cdf(r)
    }
    fn sample_r(&self, u: f64) -> f64 {
        self.cdf.sample(u)
    }
    fn single_scattering(&self) -> Option<&dyn RadialProfile> {
        self.model.single()
    }
}

/// A homogeneous semi-infinite medium in air-like surroundings: σa, σs (mm⁻¹), HG mean cosine g
/// and relative index η = n_medium/n_outside.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Medium {
    /// Absorption coefficient σa, mm⁻¹.
    pub sigma_a: f64,
    /// Scattering coefficient σs, mm⁻¹.
    pub sigma_s: f64,
    /// Henyey–Greenstein mean cosine g (|g| < 1).
    pub g: f64,
    /// Relative refractive index η = n_medium / n_outside (≥ 1 for the diffusion models).
    pub eta: f64,
}

impl Medium {
    /// Validated medium.
    pub fn new(sigma_a: f64, sigma_s: f64, g: f64, eta: f64) -> Result<Medium> {
        check_nonneg("sigma_a", sigma_a)?;
        check_nonneg("sigma_s", sigma_s)?;
        check_g("g", g)?;
        check_index("eta", eta)?;
        if !(sigma_a + sigma_s > 0.0) {
            return Err(Error::param(
                "sigma_a + sigma_s",
                sigma_a + sigma_s,
                "a finite number > 0 (a non-empty medium)",
            ));
        }
        Ok(Medium { sigma_a, sigma_s, g, eta })
    }

    /// The medium of a stack made of one semi-infinite layer (η = n / n_above); other stacks
    /// are refused (only `multipole` and `monte_carlo` take layered or finite stacks).
    pub fn from_stack(stack: &Stack, model: &str) -> Result<Medium> {
        match stack.layers.as_slice() {
            [l] if l.thickness.is_infinite() && l.phase.lobes().len() == 1 => {
                Medium::new(l.mua, l.mus, l.g(), l.n / stack.n_above)
            }
            _ => Err(Error::Invalid(format!(
                "model {model:?} needs one semi-infinite layer with an HG phase function; use \"multipole\" \
                 or \"monte_carlo\" for layered, finite or mixture stacks"
            ))),
        }
    }

    /// σs' = σs (1 − g), mm⁻¹.
    pub fn sigma_s_prime(&self) -> f64 {
        self.sigma_s * (1.0 - self.g)
    }
    /// σt = σa + σs, mm⁻¹.
    pub fn sigma_t(&self) -> f64 {
        self.sigma_a + self.sigma_s
    }
    /// Single-scattering albedo σs/σt.
    pub fn albedo(&self) -> f64 {
        self.sigma_s / self.sigma_t()
    }
    /// This medium as a stack: one semi-infinite layer of index η under index 1.
    pub fn to_stack(&self) -> Result<Stack> {
        Stack::new(vec![Layer::new(self.eta, self.sigma_a, self.sigma_s, self.g, f64::INFINITY)?], 1.0, 1.0)
    }
}

crate::named_enum! {
    /// The profile models, selectable by name (in the order the CLI and the docs list them).
    pub enum Model ("a profile model") {
        /// Jensen et al. 2001.
        Dipole = "dipole",
        /// d'Eon 2012.
        BetterDipole = "better_dipole",
        /// Donner & Jensen 2005.
        Multipole = "multipole",
        /// Habel, Christensen & Jarosz 2013.
        PhotonBeamDiffusion = "photon_beam_diffusion",
        /// Christensen & Burley 2015.
        NormalizedDiffusion = "normalized_diffusion",
        /// The Monte Carlo engine.
        MonteCarlo = "monte_carlo",
        /// The Monte Carlo engine's finite-slab reflection and transmission, chosen per shading
        /// point by the local thickness (renderer); as a profile, the semi-infinite one.
        Adaptive = "adaptive",
    }
}

impl Model {
    /// Whether the renderer's BSSRDF methods add the single-scattering term S⁽¹⁾ to this
    /// model's R_d: yes for the pure diffusion models (dipole, better dipole, multipole); photon
    /// beam diffusion and Monte Carlo include single scattering in R_d, and normalized
    /// diffusion is a fit to every order (Christensen & Burley 2015).
    pub fn adds_single_scattering(self) -> bool {
        match self {
            Model::Dipole | Model::BetterDipole | Model::Multipole => true,
            Model::PhotonBeamDiffusion | Model::NormalizedDiffusion | Model::MonteCarlo | Model::Adaptive => false,
        }
    }

    /// Whether the model's R_d is per unit power *incident* on the surface (Monte Carlo profiles,
    /// simulated for a pencil beam) rather than per unit power *entering* the medium (the
    /// diffusion models' sources sit below the interface).
    pub fn per_incident_power(self) -> bool {
        match self {
            Model::MonteCarlo | Model::Adaptive => true,
            Model::Dipole
            | Model::BetterDipole
            | Model::Multipole
            | Model::PhotonBeamDiffusion
            | Model::NormalizedDiffusion => false,
        }
    }
}

/// The profile of `model` for `stack` (Monte Carlo settings from `mc`; ignored by the others).
pub fn profile(model: Model, stack: &Stack, mc: &monte_carlo::McSettings) -> Result<Box<dyn RadialProfile>> {
    let never = AtomicBool::new(false);
    Ok(profile_with(model, stack, mc, &never, &AtomicU64::new(0))?.expect("never cancelled"))
}

/// [`profile`], cancellable: a Monte Carlo profile polls `cancel` (as [`crate::mc::run()`] does)
/// and counts its traced photons in `progress`; `None` when `cancel` stopped it.
pub fn profile_with(
    model: Model,
    stack: &Stack,
    mc: &monte_carlo::McSettings,
    cancel: &AtomicBool,
    progress: &AtomicU64,
) -> Result<Option<Box<dyn RadialProfile>>> {
    Ok(Some(match model {
        Model::MonteCarlo | Model::Adaptive => {
            let run = monte_carlo::MonteCarloProfile::simulate_with(stack, mc, cancel, progress);
            if cancel.load(Ordering::Relaxed) {
                return Ok(None); // also a run stopped before two photons (an error otherwise)
            }
            Box::new(run?.0)
        }
        Model::Multipole => multipole::profile(stack)?,
        Model::Dipole | Model::BetterDipole | Model::PhotonBeamDiffusion | Model::NormalizedDiffusion => {
            medium_profile(model, &Medium::from_stack(stack, model.name())?)?
        }
    }))
}

/// The profile of a closed-form `model` for a homogeneous semi-infinite medium (Monte Carlo
/// needs [`profile`] with its settings).
pub fn medium_profile(model: Model, m: &Medium) -> Result<Box<dyn RadialProfile>> {
    Ok(match model {
        Model::Dipole => Box::new(dipole::profile(m)?),
        Model::BetterDipole => Box::new(better_dipole::profile(m)?),
        Model::Multipole => multipole::profile(&m.to_stack()?)?,
        Model::PhotonBeamDiffusion => Box::new(photon_beam_diffusion::profile(m)?),
        Model::NormalizedDiffusion => Box::new(normalized_diffusion::from_medium(m)?),
        Model::MonteCarlo | Model::Adaptive => {
            return Err(Error::Invalid(format!(
                "model {:?} needs Monte Carlo settings: use bssrdf::profile",
                model.name()
            )))
        }
    })
}

/// One profile per channel (a list of stacks for RGB or a spectrum), in channel order.
pub fn channel_profiles(
    model: Model,
    stacks: &[Stack],
    mc: &monte_carlo::McSettings,
) -> Result<Vec<Box<dyn RadialProfile>>> {
    let never = AtomicBool::new(false);
    Ok(channel_profiles_with(model, stacks, mc, &never, &AtomicU64::new(0))?.expect("never cancelled"))
}

/// [`channel_profiles`], cancellable as [`profile_with`] (channel i's Monte Carlo run uses seed
/// `mc.seed + i`); `None` when `cancel` stopped it.
pub fn channel_profiles_with(
    model: Model,
    stacks: &[Stack],
    mc: &monte_carlo::McSettings,
    cancel: &AtomicBool,
    progress: &AtomicU64,
) -> Result<Option<Vec<Box<dyn RadialProfile>>>> {
    if stacks.is_empty() {
        return Err(Error::Invalid("stacks: give at least one stack (one per channel)".into()));
    }
    let mut out = Vec::with_capacity(stacks.len());
    for (i, s) in stacks.iter().enumerate() {
        let mut cfg = *mc;
        cfg.seed = mc.seed.wrapping_add(i as u64);
        match profile_with(model, s, &cfg, cancel, progress).map_err(|e| channel_error(e, i))? {
            Some(p) => out.push(p),
            None => return Ok(None),
        }
    }
    Ok(Some(out))
}

fn channel_error(e: Error, i: usize) -> Error {
    match e {
        Error::Invalid(m) => Error::Invalid(format!("channels[{i}]: {m}")),
        other => other.within(&format!("channels[{i}].")),
    }
}
