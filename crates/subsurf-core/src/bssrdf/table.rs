//! [`ProfileTable`]: Monte Carlo profiles of homogeneous semi-infinite media in optical units
//! (σt = 1, r in mean free paths 1/σt) on a grid of single-scattering albedos, for one g and η —
//! the role of pbrt-v4's `BSSRDFTable`, computed with the engine instead of photon beam diffusion.
//!
//! Built as "one function per albedo point + assembly" ([`build_point`], [`ProfileTable::assemble`])
//! so a sweep layer can map the points over workers; point i uses seed `seed + i`, so a table
//! is the same whoever computes which point.
//!
//! Interpolation in α (see [`ProfileTable::profile`]): ρ_eff(α) (the total diffuse reflectance,
//! ∫R 2πr dr) by a monotone cubic (PCHIP) in u = −ln(1 − α); the shape as the mixture of the two
//! neighbouring normalised profiles, weighted linearly in u. The interpolated profile's total is
//! therefore exactly the interpolated ρ_eff, and equals the Monte Carlo total at the nodes. A
//! medium (σa, σs) scales as R(r) = σt² R̃(α, σt r).

use super::cdf::{hermite, pchip_slopes};
use super::monte_carlo::{log_edges, MonteCarloProfile, RadialData, RadialTally};
use super::RadialProfile;
use crate::error::{check_g, check_index, Error, Result};
use crate::mc::{run, RunConfig, Source};
use crate::medium::{Layer, Stack};
use std::sync::atomic::{AtomicBool, AtomicU64};
use std::sync::Arc;

/// Largest albedo of the default grid (α → 1 has unbounded path lengths in Monte Carlo).
pub const ALBEDO_MAX: f64 = 0.9999;

/// What a table is computed from.
#[derive(Clone, Debug, PartialEq)]
pub struct TableSettings {
    /// HG mean cosine.
    pub g: f64,
    /// Relative index η = n_medium / n_outside.
    pub eta: f64,
    /// Increasing single-scattering albedos in [0, 1).
    pub albedos: Vec<f64>,
    /// Photons per albedo.
    pub photons: u64,
    /// Seed of albedo 0 (albedo i uses seed + i).
    pub seed: u64,
    /// Log grid in mean free paths: inner, outer edge and bins per decade.
    pub r_min: f64,
    /// Outer edge of the log grid (mean free paths).
    pub r_max: f64,
    /// Bins per decade.
    pub per_decade: usize,
    /// Relative error beyond which the Monte Carlo tail is replaced by the asymptote.
    pub max_rel_err: f64,
    /// Threads per point (`None`: all).
    pub threads: Option<usize>,
}

/// `n` albedos from 0 to [`ALBEDO_MAX`], equally spaced in −ln(1 − α).
pub fn default_albedos(n: usize) -> Vec<f64> {
    let n = n.max(2);
    let umax = -(1.0 - ALBEDO_MAX).ln();
    (0..n).map(|i| -(-umax * i as f64 / (n - 1) as f64).exp_m1()).collect()
}

impl TableSettings {
    /// Defaults: 24 albedos, 2·10⁵ photons each, r from 10⁻³ to 10⁴ mean free paths, 10 bins per
    /// decade, tail beyond 20 % relative error.
    pub fn new(g: f64, eta: f64) -> TableSettings {
        TableSettings {
            g,
            eta,
            albedos: default_albedos(24),
            photons: 200_000,
            seed: 0,
            r_min: 1e-3,
            r_max: 1e4,
            per_decade: 10,
            max_rel_err: 0.2,
            threads: None,
        }
    }

    /// Check every field.
    pub fn validate(&self) -> Result<()> {
        check_g("g", self.g)?;
        check_index("eta", self.eta)?;
        if self.albedos.is_empty() {
            return Err(Error::Invalid("albedos: the table is empty; give at least two albedos".into()));
        }
        if self.albedos.len() < 2 {
            return Err(Error::param("albedos", self.albedos.len() as f64, "at least 2 albedos"));
        }
        for (i, &a) in self.albedos.iter().enumerate() {
            if !(a.is_finite() && (0.0..1.0).contains(&a)) {
                return Err(Error::param(format!("albedos[{i}]"), a, "a number in [0, 1)"));
            }
            if i > 0 && !(a > self.albedos[i - 1]) {
                return Err(Error::param(format!("albedos[{i}]"), a, "larger than the previous albedo"));
            }
        }
        if self.photons < 2 {
            return Err(Error::param("photons", self.photons as f64, "an integer >= 2"));
        }
        log_edges(self.r_min, self.r_max, self.per_decade)?;
        Ok(())
    }

    fn stack(&self, albedo: f64) -> Result<Stack> {
        Stack::new(vec![Layer::new(self.eta, 1.0 - albedo, albedo, self.g, f64::INFINITY)?], 1.0, 1.0)
    }
}

/// Trace albedo point `i` of the table (σt = 1 mm⁻¹, so mm are mean free paths).
pub fn build_point(s: &TableSettings, i: usize, cancel: &AtomicBool, progress: &AtomicU64) -> Result<RadialData> {
    s.validate()?;
    let a = *s.albedos.get(i).ok_or_else(|| Error::param("index", i as f64, "an index into albedos"))?;
    let edges = log_edges(s.r_min, s.r_max, s.per_decade)?;
    let cfg = RunConfig {
        photons: s.photons,
        seed: s.seed.wrapping_add(i as u64),
        threads: s.threads,
        source: Source::default(),
        isa: None,
    };
    let out = run(&s.stack(a)?, &cfg, || RadialTally::new(edges.clone()), cancel, progress)?;
    if out.cancelled {
        return Err(Error::Invalid(format!("table point {i} (albedo {a}) was interrupted")));
    }
    Ok(out.tally.data())
}

/// Profiles on an albedo grid (see the module docs).
#[derive(Clone, Debug)]
pub struct ProfileTable {
    settings: TableSettings,
    profiles: Vec<Arc<MonteCarloProfile>>,
    u: Vec<f64>,
    rho: Vec<f64>,
    rho_slopes: Vec<f64>,
}

fn u_of(a: f64) -> f64 {
    -(-a).ln_1p()
}

impl ProfileTable {
    /// Assemble a table from its points (one [`RadialData`] per albedo, in order).
    pub fn assemble(settings: TableSettings, points: Vec<RadialData>) -> Result<ProfileTable> {
        settings.validate()?;
        if points.len() != settings.albedos.len() {
            return Err(Error::Invalid(format!(
                "table: {} points for {} albedos (one point per albedo)",
                points.len(),
                settings.albedos.len()
            )));
        }
        let profiles = points
            .into_iter()
            .map(|d| MonteCarloProfile::from_data(d, settings.max_rel_err).map(Arc::new))
            .collect::<Result<Vec<_>>>()?;
        let u: Vec<f64> = settings.albedos.iter().map(|&a| u_of(a)).collect();
        let rho: Vec<f64> = profiles.iter().map(|p| p.total()).collect();
        let rho_slopes = pchip_slopes(&u, &rho);
        Ok(ProfileTable { settings, profiles, u, rho, rho_slopes })
    }

    /// Build every point here (sequentially; each point uses all threads of its run).
    pub fn build(settings: TableSettings, cancel: &AtomicBool, progress: &AtomicU64) -> Result<ProfileTable> {
        let pts = (0..settings.albedos.len())
            .map(|i| build_point(&settings, i, cancel, progress))
            .collect::<Result<Vec<_>>>()?;
        Self::assemble(settings, pts)
    }

    /// The settings.
    pub fn settings(&self) -> &TableSettings {
        &self.settings
    }
    /// The node profiles (optical units).
    pub fn nodes(&self) -> &[Arc<MonteCarloProfile>] {
        &self.profiles
    }

    /// ρ_eff(α): total diffuse reflectance at albedo α ∈ [α₀, α_last].
    pub fn rho_eff(&self, albedo: f64) -> Result<f64> {
        self.check_albedo(albedo)?;
        Ok(hermite(&self.u, &self.rho, &self.rho_slopes, u_of(albedo)))
    }

    fn check_albedo(&self, a: f64) -> Result<()> {
        let (lo, hi) = (self.settings.albedos[0], *self.settings.albedos.last().unwrap());
        if !(a.is_finite() && a >= lo && a <= hi) {
            return Err(Error::Invalid(format!(
                "albedo = {a} is out of range: this table covers single-scattering albedos [{lo}, {hi}]"
            )));
        }
        Ok(())
    }

    /// The albedo α with ρ_eff(α) = `rho` (bisection on the monotone interpolant to 1e-14);
    /// a reflectance the table cannot reach is an error naming `field`.
    pub fn albedo_for(&self, rho: f64, field: &str) -> Result<f64> {
        let (lo, hi) = (self.rho[0], *self.rho.last().unwrap());
        if !(rho.is_finite() && rho >= lo && rho <= hi) {
            return Err(Error::Invalid(format!(
                "{field} = {rho} is out of range: this table reaches total reflectances [{lo:.6}, {hi:.6}] \
                 (g = {}, eta = {}); build it with albedos that reach the colour",
                self.settings.g, self.settings.eta
            )));
        }
        let (mut a, mut b) = (self.u[0], *self.u.last().unwrap());
        for _ in 0..200 {
            let m = 0.5 * (a + b);
            if hermite(&self.u, &self.rho, &self.rho_slopes, m) < rho {
                a = m;
            } else {
                b = m;
            }
            if b - a < 1e-14 {
                break;
            }
        }
        Ok(-(-0.5 * (a + b)).exp_m1())
    }

    /// The profile of a medium with σa, σs (mm⁻¹) of this table's g and η.
    pub fn profile(&self, sigma_a: f64, sigma_s: f64) -> Result<TableProfile> {
        crate::error::check_nonneg("sigma_a", sigma_a)?;
        crate::error::check_nonneg("sigma_s", sigma_s)?;
        let st = sigma_a + sigma_s;
        if !(st > 0.0 && st.is_finite()) {
            return Err(Error::param("sigma_a + sigma_s", st, "a finite number > 0"));
        }
        let a = sigma_s / st;
        let total = self.rho_eff(a)?;
        let ua = u_of(a);
        let k = self.u.partition_point(|&x| x <= ua).saturating_sub(1).min(self.u.len() - 2);
        let t = ((ua - self.u[k]) / (self.u[k + 1] - self.u[k])).clamp(0.0, 1.0);
        Ok(TableProfile { a: self.profiles[k].clone(), b: self.profiles[k + 1].clone(), t, sigma_t: st, total })
    }
}

/// A profile interpolated from a [`ProfileTable`]: mixture (1 − t)·a + t·b of two normalised
/// node profiles, scaled to total ρ_eff and to σt.
#[derive(Clone, Debug)]
pub struct TableProfile {
    a: Arc<MonteCarloProfile>,
    b: Arc<MonteCarloProfile>,
    t: f64,
    sigma_t: f64,
    total: f64,
}

impl TableProfile {
    fn shape_pdf(&self, x: f64) -> f64 {
        (1.0 - self.t) * self.a.pdf(x) + self.t * self.b.pdf(x)
    }
}

impl RadialProfile for TableProfile {
    fn rd(&self, r: f64) -> f64 {
        let x = self.sigma_t * r;
        if !(x > 0.0) {
            return 0.0;
        }
        self.total * self.sigma_t * self.sigma_t * self.shape_pdf(x) / (2.0 * std::f64::consts::PI * x)
    }
    fn total(&self) -> f64 {
        self.total
    }
    fn pdf(&self, r: f64) -> f64 {
        if self.total > 0.0 {
            self.sigma_t * self.shape_pdf(self.sigma_t * r)
        } else {
            0.0
        }
    }
    fn cdf(&self, r: f64) -> f64 {
        let x = self.sigma_t * r;
        (1.0 - self.t) * self.a.cdf(x) + self.t * self.b.cdf(x)
    }
    fn sample_r(&self, u: f64) -> f64 {
        if self.t == 0.0 || self.t == 1.0 {
            let p = if self.t == 0.0 { &self.a } else { &self.b };
            return p.sample_r(u) / self.sigma_t;
        }
        // The mixture CDF lies between the two components' inverses: bisect in ln r.
        let (ra, rb) = (self.a.sample_r(u), self.b.sample_r(u));
        let (mut lo, mut hi) = (ra.min(rb), ra.max(rb));
        if !(hi > lo) || !hi.is_finite() {
            return lo / self.sigma_t;
        }
        let mix = |x: f64| (1.0 - self.t) * self.a.cdf(x) + self.t * self.b.cdf(x) - u;
        for _ in 0..200 {
            let m = if lo > 0.0 { (lo * hi).sqrt() } else { 0.5 * hi };
            if mix(m) < 0.0 {
                lo = m;
            } else {
                hi = m;
            }
            if hi - lo <= 1e-14 * hi {
                break;
            }
        }
        0.5 * (lo + hi) / self.sigma_t
    }
}
