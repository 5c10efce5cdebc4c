//! Materials: translucent (a homogeneous scattering medium inside a smooth dielectric
//! boundary, with one radial profile per channel for the BSSRDF methods) and opaque Lambertian.
//!
//! The BSSRDF of the `hierarchical` and `probe` methods (Jensen et al. 2001, eq. 4 with the
//! normalisation of d'Eon 2012 / pbrt-v4's `NormalizedFresnelBxDF`):
//!
//! S(x_i, ω_i; x_o, ω_o) = F_t(η, ω_i) R_d(‖x_i − x_o‖) F_t(η, ω_o) / (π c(η)),
//! c(η) = 1 − F_dr,ext(η) = (1/π) ∫ F_t(η, ω) cos θ dω,
//!
//! so a flat surface under transmitted irradiance E_t = ∫ F_t L_i cos dω has radiant exitance
//! exactly `profile.total() × E_t` (Jensen's un-normalised form would multiply it by c(η)
//! once more; see `diffusion::bssrdf`).

use super::math::Rgb;
use crate::bssrdf::RadialProfile;
use crate::error::{check_g, check_index, check_nonneg, Error, Result};
use crate::medium::{Layer, Stack};
use crate::optics::{diffuse_fresnel_reflectance, Phase};
use std::sync::Arc;

/// A translucent material: the medium (per channel σa, σs; one phase function; index η
/// relative to the outside) and its radial profiles.
#[derive(Clone)]
pub struct Translucent {
    /// Absorption coefficient σa per channel, mm⁻¹.
    pub sigma_a: Rgb,
    /// Scattering coefficient σs per channel, mm⁻¹.
    pub sigma_s: Rgb,
    /// HG mean cosine.
    pub g: f64,
    /// Refractive index of the medium (the outside is vacuum, index 1).
    pub eta: f64,
    /// R_d(r) per channel (any model behind [`RadialProfile`]).
    pub profiles: [Arc<dyn RadialProfile>; 3],
    /// Whether the BSSRDF methods add the single-scattering term S⁽¹⁾ (off for profiles that
    /// already contain every scattering order, e.g. Monte Carlo ones).
    pub single_scattering: bool,
    /// c(η) = 1 − F_dr,ext(η).
    pub c_norm: f64,
    /// The phase function.
    pub phase: Phase,
    /// σt = σa + σs per channel.
    pub sigma_t: Rgb,
    /// One semi-infinite [`Stack`] per channel for the single-scattering BRDF.
    pub stacks: [Stack; 3],
}

impl Translucent {
    /// Validate and build. `field` names the material in errors (`materials.marble`).
    pub fn new(
        field: &str,
        sigma_a: Rgb,
        sigma_s: Rgb,
        g: f64,
        eta: f64,
        profiles: [Arc<dyn RadialProfile>; 3],
        single_scattering: bool,
    ) -> Result<Translucent> {
        for k in 0..3 {
            check_nonneg(&format!("{field}.sigma_a[{k}]"), sigma_a[k])?;
            check_nonneg(&format!("{field}.sigma_s[{k}]"), sigma_s[k])?;
            let t = profiles[k].total();
            if !(t.is_finite() && (0.0..=1.0 + 1e-9).contains(&t)) {
                return Err(Error::param(format!("{field}.profile[{k}].total"), t, "in [0, 1]"));
            }
        }
        check_g(&format!("{field}.g"), g)?;
        check_index(&format!("{field}.eta"), eta)?;
        let stacks = std::array::from_fn(|k| {
            Stack::new(vec![Layer::new(eta, sigma_a[k], sigma_s[k], g, f64::INFINITY).expect("validated")], 1.0, 1.0)
                .expect("a one-layer stack is valid")
        });
        Ok(Translucent {
            sigma_a,
            sigma_s,
            g,
            eta,
            profiles,
            single_scattering,
            c_norm: 1.0 - diffuse_fresnel_reflectance(eta, false)?,
            phase: Phase::hg(g)?,
            sigma_t: std::array::from_fn(|k| sigma_a[k] + sigma_s[k]),
            stacks,
        })
    }
}

/// A material.
#[derive(Clone)]
pub enum Material {
    Translucent(Box<Translucent>),
    /// Opaque Lambertian reflector of the given albedo per channel (in [0, 1]).
    Lambertian(Rgb),
}

impl Material {
    /// An opaque Lambertian material; errors name `field`.
    pub fn lambertian(field: &str, albedo: Rgb) -> Result<Material> {
        for (k, &a) in albedo.iter().enumerate() {
            if !(a.is_finite() && (0.0..=1.0).contains(&a)) {
                return Err(Error::param(format!("{field}.albedo[{k}]"), a, "in [0, 1]"));
            }
        }
        Ok(Material::Lambertian(albedo))
    }

    /// The translucent material, if this is one.
    pub fn translucent(&self) -> Option<&Translucent> {
        match self {
            Material::Translucent(t) => Some(t),
            Material::Lambertian(_) => None,
        }
    }
}

/// A closed-form profile for tests: R_d(r) = T s² e^{−s r}/(2π) (total T, pdf Gamma(2, 1/s)).
#[cfg(test)]
#[derive(Clone, Copy, Debug)]
pub struct TestProfile {
    pub total: f64,
    pub s: f64,
}

#[cfg(test)]
impl RadialProfile for TestProfile {
    fn rd(&self, r: f64) -> f64 {
        self.total * self.s * self.s * (-self.s * r).exp() / (2.0 * std::f64::consts::PI)
    }
    fn total(&self) -> f64 {
        self.total
    }
    fn cdf(&self, r: f64) -> f64 {
        let x = self.s * r;
        1.0 - (1.0 + x) * (-x).exp()
    }
    fn sample_r(&self, u: f64) -> f64 {
        // Newton on the CDF of Gamma(2): monotone and convex beyond the mode, start at the mean.
        let mut x: f64 = 2.0;
        for _ in 0..60 {
            let f = 1.0 - (1.0 + x) * (-x).exp() - u;
            let fp = x * (-x).exp();
            let nx = (x - f / fp.max(1e-300)).clamp(x / 10.0, x * 10.0 + 1.0);
            if (nx - x).abs() < 1e-14 * x {
                x = nx;
                break;
            }
            x = nx;
        }
        x / self.s
    }
}

/// A profile scaled by a constant: R_d → k R_d (total → k total; pdf, cdf and sampling unchanged).
pub struct Scaled {
    pub inner: Box<dyn RadialProfile>,
    pub k: f64,
}

impl RadialProfile for Scaled {
    fn rd(&self, r: f64) -> f64 {
        self.k * self.inner.rd(r)
    }
    fn total(&self) -> f64 {
        self.k * self.inner.total()
    }
    fn cdf(&self, r: f64) -> f64 {
        self.inner.cdf(r)
    }
    fn sample_r(&self, u: f64) -> f64 {
        self.inner.sample_r(u)
    }
    fn radius_for_fraction(&self, q: f64) -> f64 {
        self.inner.radius_for_fraction(q)
    }
}

/// The profiles of `model` (a [`crate::bssrdf::Model`] name) for one stack per channel, as
/// the renderer uses them, and whether the BSSRDF methods must add S⁽¹⁾:
/// - profiles are per unit power *entering* the medium (the renderer applies F_t at entry):
///   `monte_carlo` profiles, simulated for a pencil beam of unit *incident* power, are divided
///   by the normal-incidence transmittance 1 − R_sp of the top interface;
/// - S⁽¹⁾ is added for the pure diffusion models (dipole, better dipole, multipole) only:
///   photon beam diffusion and Monte Carlo include single scattering in R_d, and normalized
///   diffusion is a fit to every order (Christensen & Burley 2015).
pub fn channel_profiles(
    model: &str,
    stacks: &[Stack; 3],
    mc: &crate::bssrdf::monte_carlo::McSettings,
) -> Result<([Arc<dyn RadialProfile>; 3], bool)> {
    use crate::bssrdf::Model;
    let m = Model::from_name(model)?;
    let profs = crate::bssrdf::channel_profiles(m, stacks, mc)?;
    let mut out: Vec<Arc<dyn RadialProfile>> = Vec::with_capacity(3);
    for (p, s) in profs.into_iter().zip(stacks) {
        if m == Model::MonteCarlo {
            let rsp = crate::optics::fr_dielectric(1.0, s.n_above, s.layers[0].n);
            out.push(Arc::new(Scaled { inner: p, k: 1.0 / (1.0 - rsp) }));
        } else {
            out.push(Arc::from(p));
        }
    }
    let ss = matches!(m, Model::Dipole | Model::BetterDipole | Model::Multipole);
    let arr: [Arc<dyn RadialProfile>; 3] = [out[0].clone(), out[1].clone(), out[2].clone()];
    Ok((arr, ss))
}
