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

use super::fastmath;
use super::grid::MediumGrid;
use super::math::Rgb;
use super::texture::{SurfaceTexture, TextureSpec, UnitProfiles};
use crate::bssrdf::adaptive::{AdaptiveSettings, AdaptiveTable};
use crate::bssrdf::{Model, RadialProfile};
use crate::error::{check_g, check_index, check_nonneg, Error, Result};
use crate::medium::{Layer, Stack};
use crate::optics::{diffuse_fresnel_reflectance, Phase};
use std::sync::atomic::{AtomicBool, AtomicU64};
use std::sync::Arc;

/// One radial profile per RGB channel.
pub type Profiles = [Arc<dyn RadialProfile>; 3];

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
    /// R_d(r) per channel (any model behind [`RadialProfile`]); `None` for a material built
    /// for a method that uses no profile ([`super::Method::uses_profiles`]).
    pub bssrdf: Option<Profiles>,
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
    /// σa, σs on a voxel grid ([`super::grid`]; the values above apply outside its box), for
    /// the random walk; `None` for a homogeneous medium.
    pub grid: Option<Arc<MediumGrid>>,
    /// The majorant of delta tracking per channel: σt, or for a grid the largest σt of its
    /// voxels and of the material (the walk samples free paths with it).
    pub sigma_bar: Rgb,
    /// A surface colour / mean-free-path map ([`super::texture`]): a palette of texel
    /// materials, the one at the walk's entry point (random walk) or at the shading point (BSSRDF
    /// methods) used there; `None` for an untextured material.
    pub texture: Option<Arc<SurfaceTexture>>,
    /// The finite-slab tables of `model = "adaptive"` (`render::adaptive`); `None` otherwise.
    pub adaptive: Option<Arc<AdaptiveTable>>,
}

impl Translucent {
    /// Validate and build. `field` names the material in errors (`materials.marble`).
    pub fn new(
        field: &str,
        sigma_a: Rgb,
        sigma_s: Rgb,
        g: f64,
        eta: f64,
        profiles: Option<Profiles>,
        single_scattering: bool,
    ) -> Result<Translucent> {
        for k in 0..3 {
            check_nonneg(&format!("{field}.sigma_a[{k}]"), sigma_a[k])?;
            check_nonneg(&format!("{field}.sigma_s[{k}]"), sigma_s[k])?;
            let Some(p) = &profiles else { continue };
            let t = p[k].total();
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
            bssrdf: profiles,
            single_scattering,
            c_norm: 1.0 - diffuse_fresnel_reflectance(eta, false)?,
            phase: Phase::hg(g)?,
            sigma_t: std::array::from_fn(|k| sigma_a[k] + sigma_s[k]),
            stacks,
            grid: None,
            sigma_bar: std::array::from_fn(|k| sigma_a[k] + sigma_s[k]),
            texture: None,
            adaptive: None,
        })
    }

    /// The material with σa, σs from `grid` inside its box (the majorant becomes the largest
    /// σt of the voxels and of the material).
    pub fn with_grid(mut self, grid: Arc<MediumGrid>) -> Translucent {
        self.sigma_bar = std::array::from_fn(|k| self.sigma_t[k].max(grid.max_t[k]));
        self.grid = Some(grid);
        self
    }

    /// The least σt (mm⁻¹) anywhere in the material: over the channels and, with a grid, its
    /// voxels (a lower bound for the optical depth of any path through it).
    pub fn sigma_t_floor(&self) -> f64 {
        let st = self.sigma_t[0].min(self.sigma_t[1]).min(self.sigma_t[2]);
        let st = self.grid.as_ref().map_or(st, |g| st.min(g.min_t));
        self.texture.as_ref().map_or(st, |t| t.media().iter().map(Translucent::sigma_t_floor).fold(st, f64::min))
    }

    /// Every homogeneous material a point of an object of this material may have: the texel
    /// materials of a textured one, else the material itself.
    pub fn variants(&self) -> &[Translucent] {
        match &self.texture {
            Some(t) => t.media(),
            None => std::slice::from_ref(self),
        }
    }
}

impl Translucent {
    /// The profiles per channel; only for materials built with them (the renderer checks
    /// [`super::Method::uses_profiles`] methods get them).
    pub fn profiles(&self) -> &Profiles {
        self.bssrdf.as_ref().expect("a BSSRDF method's materials have profiles (checked by Renderer::new)")
    }
}

/// A translucent material as the user gives it, before its profiles are computed: what the
/// binding and scene files hand to the core; [`build`](Self::build) makes the [`Translucent`].
#[derive(Clone, Debug)]
pub struct TranslucentSpec {
    /// Name used in errors (`materials.marble`).
    pub field: String,
    /// σa per channel, mm⁻¹.
    pub sigma_a: Rgb,
    /// σs per channel, mm⁻¹.
    pub sigma_s: Rgb,
    /// HG mean cosine.
    pub g: f64,
    /// Refractive index of the medium (outside: 1).
    pub eta: f64,
    /// The profile model, a [`crate::bssrdf::Model`] name.
    pub model: String,
    /// One stack per channel: the medium the profile models see.
    pub stacks: [Stack; 3],
    /// Settings of a `monte_carlo` profile.
    pub mc: crate::bssrdf::monte_carlo::McSettings,
    /// The reflectance the material was made from, if any (see [`channel_profiles`]).
    pub reflectance: Option<Rgb>,
    /// Whether the BSSRDF methods add S⁽¹⁾ (`None`: the model's default, see [`channel_profiles`]).
    pub single_scattering: Option<bool>,
    /// σa, σs on a voxel grid (random walk only; the BSSRDF methods refuse it).
    pub grid: Option<Arc<MediumGrid>>,
    /// A surface colour / mean-free-path map (σa, σs per texel, [`super::texture`]).
    pub texture: Option<Arc<TextureSpec>>,
    /// A prebuilt table of `model = "adaptive"` for `stacks` (e.g. from the on-disk cache);
    /// `None`: [`build`](Self::build) traces it with the `mc` photons and seed.
    pub adaptive: Option<Arc<AdaptiveTable>>,
}

impl TranslucentSpec {
    /// Photons its profiles trace: 3 × `mc.photons` for `monte_carlo`, else 0 (the progress
    /// total of [`build`](Self::build)).
    pub fn photons(&self) -> u64 {
        match Model::from_name("model", &self.model) {
            Ok(Model::MonteCarlo) => match &self.texture {
                Some(t) => self.mc.photons.saturating_mul(t.unit_keys(false).len() as u64),
                None => self.mc.photons.saturating_mul(3),
            },
            Ok(Model::Adaptive) if self.adaptive.is_none() => {
                AdaptiveTable::photons(&self.stacks, &AdaptiveSettings::from_mc(&self.mc))
            }
            _ => 0,
        }
    }

    /// The material. With `profiles` false (the `random_walk` method uses none) no profile is
    /// computed, so a costly `monte_carlo` run is skipped. A Monte Carlo profile polls `cancel`
    /// and counts its photons in `progress`; `None` when `cancel` stopped it.
    pub fn build(&self, profiles: bool, cancel: &AtomicBool, progress: &AtomicU64) -> Result<Option<Translucent>> {
        let within = |e: Error| Error::Invalid(format!("{}: {e}", self.field));
        if profiles && self.grid.is_some() {
            return Err(Error::Invalid(format!(
                "{}.grid: only the random walk (method random_walk, simulate_walk) takes a medium grid; \
                 the BSSRDF methods need a homogeneous material",
                self.field
            )));
        }
        let model = Model::from_name(&format!("{}.model", self.field), &self.model)?;
        if profiles && self.texture.is_some() && model == Model::Adaptive {
            return Err(Error::Invalid(format!(
                "{}.texture: model \"adaptive\" takes no surface texture (its tables are built per \
                 material); use another profile model or the random walk",
                self.field
            )));
        }
        if profiles && Model::from_name("model", &self.model).ok() == Some(Model::Adaptive) {
            return self.build_adaptive(cancel, progress).map_err(within);
        }
        let (profs, ss_default) = if profiles && self.texture.is_some() {
            (None, model.adds_single_scattering()) // the texels have profiles, the mean material none
        } else if profiles {
            match channel_profiles(&self.model, &self.stacks, &self.mc, self.reflectance.as_ref(), cancel, progress)
                .map_err(within)?
            {
                Some((p, ss)) => (Some(p), ss),
                None => return Ok(None),
            }
        } else {
            let m = crate::bssrdf::Model::from_name(&format!("{}.model", self.field), &self.model)?;
            (None, m.adds_single_scattering())
        };
        let ss = self.single_scattering.unwrap_or(ss_default);
        let m = Translucent::new(&self.field, self.sigma_a, self.sigma_s, self.g, self.eta, profs, ss)?;
        if self.grid.is_some() && self.texture.is_some() {
            return Err(Error::Invalid(format!("{}: give a medium grid or a surface texture, not both", self.field)));
        }
        let mut m = match &self.grid {
            Some(g) => m.with_grid(g.clone()),
            None => m,
        };
        if let Some(spec) = &self.texture {
            let field = format!("{}.texture", self.field);
            let by_r = model == Model::NormalizedDiffusion && spec.reflectance.is_some();
            let units = if profiles {
                match self.unit_profiles(spec, by_r, cancel, progress).map_err(|e| e.within(&format!("{field}: ")))? {
                    Some(u) => Some(u),
                    None => return Ok(None),
                }
            } else {
                None
            };
            let tex = SurfaceTexture::build(&field, spec, &m, units.as_ref().map(|u| (u, by_r)))?;
            m.texture = Some(Arc::new(tex));
        }
        Ok(Some(m))
    }

    /// The unit-σt profiles of a texture's distinct albedos ([`super::texture`]), built as the
    /// material's own ([`profiles_for`]: the same model, tables and normalisation); Monte Carlo
    /// profile j (in key order) uses the seed `mc.seed` + j. `None` when cancelled.
    fn unit_profiles(
        &self,
        spec: &TextureSpec,
        by_reflectance: bool,
        cancel: &AtomicBool,
        progress: &AtomicU64,
    ) -> Result<Option<UnitProfiles>> {
        use rayon::prelude::*;
        let top = &self.stacks[0];
        let (n, n_above, n_below) = (top.layers[0].n, top.n_above, top.n_below);
        let keys = spec.unit_keys(by_reflectance);
        let one = |j: usize| -> Result<Option<Arc<dyn RadialProfile>>> {
            let (a, r) = (TextureSpec::key_albedo(keys[j]), f64::from_bits(keys[j].1));
            let layer = Layer::new(n, 1.0 - a, a, self.g, f64::INFINITY)?;
            let stack = Stack::new(vec![layer], n_above, n_below)?;
            let mc = crate::bssrdf::monte_carlo::McSettings { seed: self.mc.seed.wrapping_add(j as u64), ..self.mc };
            let refl = by_reflectance.then_some(r);
            let p = profiles_for(
                &self.model,
                std::slice::from_ref(&stack),
                &mc,
                refl.as_ref().map(std::slice::from_ref),
                cancel,
                progress,
            )
            .map_err(|e| Error::Invalid(format!("texel albedo {a}: {e}")))?;
            Ok(p.map(|(mut v, _)| v.remove(0)))
        };
        let built: Vec<Result<Option<Arc<dyn RadialProfile>>>> = if self.model == "monte_carlo" {
            (0..keys.len()).map(one).collect() // each profile runs the engine on every thread
        } else {
            (0..keys.len()).into_par_iter().with_max_len(1).map(one).collect()
        };
        let mut out = UnitProfiles::new();
        for (k, p) in keys.iter().zip(built) {
            match p? {
                Some(p) => out.insert(*k, p),
                None => return Ok(None),
            };
        }
        Ok(Some(out))
    }
}

impl TranslucentSpec {
    /// The `adaptive` material: its table (given or traced here) and, as the profiles every
    /// method's set-up uses (sample spacing, probe radii, importance sampling), the table's
    /// semi-infinite node.
    fn build_adaptive(&self, cancel: &AtomicBool, progress: &AtomicU64) -> Result<Option<Translucent>> {
        let table = match &self.adaptive {
            Some(t) if t.channels() == 3 => t.clone(),
            Some(t) => return Err(Error::Invalid(format!("the adaptive table has {} channels, not 3", t.channels()))),
            None => match AdaptiveTable::build(&self.stacks, &AdaptiveSettings::from_mc(&self.mc), cancel, progress)? {
                Some(t) => Arc::new(t),
                None => return Ok(None),
            },
        };
        let profs: Vec<Arc<dyn RadialProfile>> = (0..3)
            .map(|k| {
                let semi = table.reflection(k, table.local(k, f64::INFINITY));
                Arc::new(RdTable::new(Box::new(semi), 1.0)) as Arc<dyn RadialProfile>
            })
            .collect();
        let profs: Profiles = [profs[0].clone(), profs[1].clone(), profs[2].clone()];
        let ss = self.single_scattering.unwrap_or(false);
        let mut t = Translucent::new(&self.field, self.sigma_a, self.sigma_s, self.g, self.eta, Some(profs), ss)?;
        t.adaptive = Some(table);
        Ok(Some(t))
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

/// A profile whose R_d is looked up in a log–log table (256 points per decade between the radii
/// holding 10⁻⁶ and 1 − 10⁻⁶ of the energy; exact outside), for models whose R_d is costly to
/// evaluate (photon beam diffusion integrates along the beam at every call). Linear
/// interpolation of ln R_d in ln r: relative error ≲ 1.1·10⁻⁴ for smooth profiles (tested on the
/// dipole). The table can also scale the profile by a constant `k` (R_d → k R_d, total →
/// k total); `cdf` and `sample_r` are the wrapped profile's.
pub struct RdTable {
    pub inner: Box<dyn RadialProfile>,
    pub k: f64,
    ln_r0: f64,
    inv_step: f64,
    ln_rd: Vec<f64>,
    /// The radius holding 1 − 10⁻⁶ of the energy (∞ if not found).
    reach: f64,
}

impl RdTable {
    const PER_DECADE: f64 = 256.0;

    /// Tabulate `k` × `inner`.
    pub fn new(inner: Box<dyn RadialProfile>, k: f64) -> RdTable {
        let (lo, hi) = (inner.radius_for_fraction(1e-6), inner.radius_for_fraction(1.0 - 1e-6));
        if !(inner.total() > 0.0 && lo > 0.0 && hi > lo && hi.is_finite()) {
            return RdTable { inner, k, ln_r0: 0.0, inv_step: 0.0, ln_rd: vec![], reach: f64::INFINITY };
        }
        let step = std::f64::consts::LN_10 / Self::PER_DECADE;
        let n = ((hi / lo).ln() / step).ceil() as usize + 2;
        let ln_rd: Vec<f64> = (0..n).map(|i| inner.rd(lo * (i as f64 * step).exp()).max(1e-300).ln()).collect();
        RdTable { inner, k, ln_r0: lo.ln(), inv_step: 1.0 / step, ln_rd, reach: hi }
    }

    /// The table's value at ln r (inlined e^x, [`fastmath`]; within 2 ulp of libm's): what
    /// [`RadialProfile::rd_ln`] gives, callable without the trait object (the adaptive kernel's
    /// tree walk inlines it, `render::adaptive`).
    #[inline(always)]
    pub fn value_ln(&self, r: f64, ln_r: f64) -> f64 {
        let x = (ln_r - self.ln_r0) * self.inv_step;
        let n = self.ln_rd.len();
        if n < 2 || !(r > 0.0 && x >= 0.0 && x < (n - 1) as f64) {
            return self.outside(r);
        }
        // 0 ≤ x < n − 1: the truncation is the floor, and i + 1 < n
        let xi = x as i64;
        let (i, f) = (xi as usize, x - xi as f64);
        let [a, b] = [self.ln_rd[i], self.ln_rd[i + 1]];
        self.k * fastmath::exp((1.0 - f) * a + f * b)
    }

    /// k R_d(r) of the wrapped profile, outside the table.
    #[cold]
    #[inline(never)]
    fn outside(&self, r: f64) -> f64 {
        self.k * self.inner.rd(r)
    }
}

impl RadialProfile for RdTable {
    fn rd(&self, r: f64) -> f64 {
        self.value_ln(r, fastmath::ln(r))
    }
    /// [`RdTable::value_ln`].
    fn rd_ln(&self, r: f64, ln_r: f64) -> f64 {
        self.value_ln(r, ln_r)
    }
    fn total(&self) -> f64 {
        self.k * self.inner.total()
    }
    fn reach(&self) -> f64 {
        self.reach
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
/// - R_d is looked up in an [`RdTable`] (which also applies the scale below);
/// - profiles are per unit power *entering* the medium (the renderer applies F_t at entry):
///   `monte_carlo` profiles, simulated for a pencil beam of unit *incident* power, are divided
///   by the normal-incidence transmittance 1 − R_sp of the top interface;
/// - S⁽¹⁾ is added where [`crate::bssrdf::Model::adds_single_scattering`] says so;
/// - a material made from a `reflectance` (per channel and unit incident power,
///   [`crate::bssrdf::inverse`]) gives normalized diffusion that reflectance as its surface
///   albedo ([`crate::bssrdf::normalized_diffusion::from_reflectance`]); the other models'
///   materials were inverted under their own totals, which already give the reflectance.
///
/// `None` when `cancel` stopped a Monte Carlo profile (which counts its photons in `progress`).
pub fn channel_profiles(
    model: &str,
    stacks: &[Stack; 3],
    mc: &crate::bssrdf::monte_carlo::McSettings,
    reflectance: Option<&Rgb>,
    cancel: &AtomicBool,
    progress: &AtomicU64,
) -> Result<Option<(Profiles, bool)>> {
    let Some((p, ss)) = profiles_for(model, stacks, mc, reflectance.map(|r| &r[..]), cancel, progress)? else {
        return Ok(None);
    };
    Ok(Some(([p[0].clone(), p[1].clone(), p[2].clone()], ss)))
}

/// One profile per stack.
pub type ProfileList = Vec<Arc<dyn RadialProfile>>;

/// [`channel_profiles`] for any number of stacks (one profile each; `reflectance` one per stack).
pub fn profiles_for(
    model: &str,
    stacks: &[Stack],
    mc: &crate::bssrdf::monte_carlo::McSettings,
    reflectance: Option<&[f64]>,
    cancel: &AtomicBool,
    progress: &AtomicU64,
) -> Result<Option<(ProfileList, bool)>> {
    use crate::bssrdf::{normalized_diffusion, Medium, Model};
    let m = Model::from_name("model", model)?;
    let profs: Vec<Box<dyn RadialProfile>> = match (m, reflectance) {
        (Model::NormalizedDiffusion, Some(c)) => stacks
            .iter()
            .zip(c)
            .enumerate()
            .map(|(k, (s, &a))| -> Result<Box<dyn RadialProfile>> {
                let med = Medium::from_stack(s, model).map_err(|e| e.within(&format!("channels[{k}].")))?;
                Ok(Box::new(
                    normalized_diffusion::from_reflectance(&med, a)
                        .map_err(|e| e.within(&format!("channels[{k}].")))?,
                ))
            })
            .collect::<Result<_>>()?,
        _ => match crate::bssrdf::channel_profiles_with(m, stacks, mc, cancel, progress)? {
            Some(p) => p,
            None => return Ok(None),
        },
    };
    let mut out: Vec<Arc<dyn RadialProfile>> = Vec::with_capacity(stacks.len());
    for (p, s) in profs.into_iter().zip(stacks) {
        let k = if m.per_incident_power() {
            1.0 / (1.0 - crate::optics::fr_dielectric(1.0, s.n_above, s.layers[0].n))
        } else {
            1.0
        };
        out.push(Arc::new(RdTable::new(p, k)));
    }
    Ok(Some((out, m.adds_single_scattering())))
}

#[cfg(test)]
mod table_tests {
    use super::*;

    /// The log–log table against the dipole's closed form: within 3·10⁻⁴ from 10⁻³ to 10³ mm.
    #[test]
    fn rd_table_matches_the_dipole() {
        let m = crate::bssrdf::Medium::new(0.01, 2.0, 0.0, 1.3).unwrap();
        let exact = crate::bssrdf::medium_profile(crate::bssrdf::Model::Dipole, &m).unwrap();
        let t = RdTable::new(crate::bssrdf::medium_profile(crate::bssrdf::Model::Dipole, &m).unwrap(), 1.0);
        let mut worst: f64 = 0.0;
        for i in 0..6000 {
            let r = 1e-3 * 10f64.powf(i as f64 / 1000.0);
            worst = worst.max((t.rd(r) / exact.rd(r) - 1.0).abs());
        }
        assert!(worst < 3e-4, "{worst}");
        assert_eq!(t.total(), exact.total());
    }
}
