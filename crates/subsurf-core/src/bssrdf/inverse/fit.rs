//! Optical properties fitted to measurements, with their covariance ([`super::lm`]).
//!
//! - [`fit_profile`]: (σa, σs') of a semi-infinite medium from a spatially resolved R_d(r)
//!   (with per-point noise) under any model; `monte_carlo` evaluates the model by lookup in a
//!   [`ProfileTable`] (exact transport, no diffusion assumption), the others in closed form.
//!   [`fit_profile_layer`] fits one layer of a layered stack with the multipole.
//! - [`fit_slab_totals`]: (μa, μs') of a slab from its total diffuse reflectance Rd and total
//!   transmittance Tt (the inverse adding-doubling task of Prahl et al. 1993), by the multipole
//!   (diffusion, Donner & Jensen 2005, totals in closed form) or by Monte Carlo through a
//!   [`SlabTable`] of engine runs on a grid of (albedo, optical thickness), interpolated — the
//!   choice where diffusion fails (thin or absorbing slabs).
//!
//! Every fit is returned only when the data identify it ([`super::lm`]: data with signal, finite
//! χ², finite covariance, relative uncertainties ≤ [`super::lm::MAX_RELATIVE_STDERR`]); otherwise
//! it is an error naming what is not determined.

use super::lm::{check_signal, levenberg_marquardt, Fit};
use crate::bssrdf::cdf::{hermite, pchip_slopes};
use crate::bssrdf::multipole::{self, Slab};
use crate::bssrdf::table::ProfileTable;
use crate::bssrdf::{medium_profile, Medium, Model, RadialProfile};
use crate::error::{check_g, Error, Result};
use crate::mc::tally::totals::{Total, Totals};
use crate::mc::{run, RunConfig, Source};
use crate::medium::{Layer, Stack};
use crate::optics::fr_dielectric;
use std::sync::atomic::{AtomicBool, AtomicU64};

fn check_r(r: &[f64]) -> Result<()> {
    for (i, &x) in r.iter().enumerate() {
        if !(x > 0.0 && x.is_finite()) {
            return Err(Error::param(format!("r[{i}]"), x, "a finite radius > 0 (mm)"));
        }
    }
    Ok(())
}

/// R_d(r_i) of `model` for σa = p[0], σs' = p[1] (σs = σs'/(1 − g)).
fn profile_values(
    model: Model,
    table: Option<&ProfileTable>,
    g: f64,
    eta: f64,
    r: &[f64],
    p: &[f64],
) -> Result<Vec<f64>> {
    let sigma_s = p[1] / (1.0 - g);
    let prof: Box<dyn RadialProfile> = match model {
        Model::MonteCarlo | Model::Adaptive => {
            let t =
                table.ok_or_else(|| Error::Invalid("model \"monte_carlo\" needs a ProfileTable for the fit".into()))?;
            Box::new(t.profile(p[0], sigma_s)?)
        }
        Model::Dipole
        | Model::BetterDipole
        | Model::Multipole
        | Model::PhotonBeamDiffusion
        | Model::NormalizedDiffusion => medium_profile(model, &Medium::new(p[0], sigma_s, g, eta)?)?,
    };
    Ok(r.iter().map(|&x| prof.rd(x)).collect())
}

/// Fit (σa, σs') (mm⁻¹) of a semi-infinite medium (HG g, relative index η) to R_d(r) data
/// (`rd` in mm⁻² at radii `r` in mm, standard deviations `sigma`), from `initial`.
#[allow(clippy::too_many_arguments)]
pub fn fit_profile(
    model: Model,
    r: &[f64],
    rd: &[f64],
    sigma: &[f64],
    g: f64,
    eta: f64,
    initial: [f64; 2],
    table: Option<&ProfileTable>,
) -> Result<Fit> {
    check_g("g", g)?;
    check_r(r)?;
    if rd.len() != r.len() {
        return Err(Error::Invalid(format!("fit: {} radii but {} R_d values", r.len(), rd.len())));
    }
    check_data(rd, sigma, "rd")?;
    levenberg_marquardt(&|p| profile_values(model, table, g, eta, r, p), rd, sigma, &initial)?
        .identified(&["sigma_a", "sigma_s_prime"])
}

/// Finite data (named `what[i]`) with signal (lengths are checked by the fit).
fn check_data(y: &[f64], sigma: &[f64], what: &str) -> Result<()> {
    for (i, &v) in y.iter().enumerate() {
        if !v.is_finite() {
            return Err(Error::param(format!("{what}[{i}]"), v, "a finite number"));
        }
    }
    if sigma.len() == y.len() && sigma.iter().all(|s| *s > 0.0 && s.is_finite()) {
        check_signal(y, sigma, what)?; // (bad standard deviations are named by the fit)
    }
    Ok(())
}

/// Fit (μa, μs') of layer `layer` of `stack` (the others fixed) to R_d(r) data with the
/// layered multipole.
pub fn fit_profile_layer(
    stack: &Stack,
    layer: usize,
    r: &[f64],
    rd: &[f64],
    sigma: &[f64],
    initial: [f64; 2],
) -> Result<Fit> {
    check_r(r)?;
    let l0 = *stack
        .layers
        .get(layer)
        .ok_or_else(|| Error::param("layer", layer as f64, "an index into the stack's layers"))?;
    let g = l0.g();
    let model = |p: &[f64]| -> Result<Vec<f64>> {
        let mut s = stack.clone();
        s.layers[layer] = Layer::new(l0.n, p[0], p[1] / (1.0 - g), g, l0.thickness)?;
        let prof = multipole::profile(&s)?;
        Ok(r.iter().map(|&x| prof.rd(x)).collect())
    };
    check_data(rd, sigma, "rd")?;
    levenberg_marquardt(&model, rd, sigma, &initial)?.identified(&["mua", "mus_prime"])
}

/// Monte Carlo totals (Rd, Tt) of slabs on a grid of albedos × optical thicknesses, for one g,
/// slab index and ambient indices; interpolated by monotone cubics in −ln(1 − α) and ln τ.
#[derive(Clone, Debug, PartialEq)]
pub struct SlabTable {
    /// HG g, slab index, index above, index below.
    pub g: f64,
    /// Refractive index of the slab.
    pub n: f64,
    /// Index above.
    pub n_above: f64,
    /// Index below.
    pub n_below: f64,
    /// Increasing albedos in [0, 1).
    pub albedos: Vec<f64>,
    /// Increasing optical thicknesses τ = σt d > 0.
    pub taus: Vec<f64>,
    /// Rd and Tt per (albedo, tau), row-major, and their standard errors.
    pub rd: Vec<f64>,
    /// Total transmittance (unscattered included).
    pub tt: Vec<f64>,
    /// Standard errors of rd.
    pub rd_stderr: Vec<f64>,
    /// Standard errors of tt.
    pub tt_stderr: Vec<f64>,
}

impl SlabTable {
    /// Run the engine once per grid point (`photons` each, point (i, j) with seed + i·len(taus) + j).
    #[allow(clippy::too_many_arguments)]
    pub fn build(
        g: f64,
        n: f64,
        n_above: f64,
        n_below: f64,
        albedos: Vec<f64>,
        taus: Vec<f64>,
        photons: u64,
        seed: u64,
    ) -> Result<SlabTable> {
        Self::check_table_grid(&albedos, &taus)?;
        let (never, progress) = (AtomicBool::new(false), AtomicU64::new(0));
        let mut totals = Vec::with_capacity(albedos.len() * taus.len());
        for (i, &a) in albedos.iter().enumerate() {
            for (j, &tau) in taus.iter().enumerate() {
                let k = (i * taus.len() + j) as u64;
                let p = Self::point(
                    g,
                    n,
                    n_above,
                    n_below,
                    a,
                    tau,
                    photons,
                    seed.wrapping_add(k),
                    None,
                    &never,
                    &progress,
                )?;
                totals.push(p.expect("a run that cannot be cancelled completes"));
            }
        }
        Self::from_totals(g, n, n_above, n_below, albedos, taus, &totals)
    }

    /// One grid point: (Rd, its standard error, Tt, its standard error) of the slab of albedo `a`
    /// and optical thickness `tau` (σt = 1 mm⁻¹, thickness τ mm) under a normally incident pencil
    /// beam; `None` when `cancel` stopped the run (`progress` counts photons).
    #[allow(clippy::too_many_arguments)]
    pub fn point(
        g: f64,
        n: f64,
        n_above: f64,
        n_below: f64,
        a: f64,
        tau: f64,
        photons: u64,
        seed: u64,
        threads: Option<usize>,
        cancel: &AtomicBool,
        progress: &AtomicU64,
    ) -> Result<Option<[f64; 4]>> {
        Self::check_grid(&[a], &[tau])?;
        let s = Stack::new(vec![Layer::new(n, 1.0 - a, a, g, tau)?], n_above, n_below)?;
        let cfg = RunConfig { photons, seed, threads, source: Source::default(), isa: None };
        cfg.validate()?;
        let out = run(&s, &cfg, || Totals::new(1), cancel, progress)?;
        if out.cancelled {
            return Ok(None);
        }
        let (r, rs) = out.tally.get(Total::Diffuse);
        let (tr, ts) = out.tally.get(Total::Transmittance);
        Ok(Some([r, rs, tr, ts]))
    }

    /// A table from its grid and one [`point`](Self::point) result per (albedo, tau), row-major.
    #[allow(clippy::too_many_arguments)]
    pub fn from_totals(
        g: f64,
        n: f64,
        n_above: f64,
        n_below: f64,
        albedos: Vec<f64>,
        taus: Vec<f64>,
        totals: &[[f64; 4]],
    ) -> Result<SlabTable> {
        check_g("g", g)?;
        Self::check_table_grid(&albedos, &taus)?;
        if totals.len() != albedos.len() * taus.len() {
            return Err(Error::Invalid(format!(
                "slab table: {} points for {} albedos × {} optical thicknesses",
                totals.len(),
                albedos.len(),
                taus.len()
            )));
        }
        for (k, p) in totals.iter().enumerate() {
            if !p.iter().all(|x| x.is_finite() && *x >= 0.0) || p[0] > 1.0 || p[2] > 1.0 {
                return Err(Error::Invalid(format!("slab table: point {k} holds {p:?}, not reflectances with errors")));
            }
        }
        let col = |c: usize| totals.iter().map(|p| p[c]).collect::<Vec<f64>>();
        Ok(SlabTable {
            g,
            n,
            n_above,
            n_below,
            albedos,
            taus,
            rd: col(0),
            rd_stderr: col(1),
            tt: col(2),
            tt_stderr: col(3),
        })
    }

    /// A grid of at least 2 × 2 points (see [`check_grid`](Self::check_grid)).
    fn check_table_grid(albedos: &[f64], taus: &[f64]) -> Result<()> {
        if albedos.len() < 2 || taus.len() < 2 {
            return Err(Error::Invalid("slab table: give at least 2 albedos and 2 optical thicknesses".into()));
        }
        Self::check_grid(albedos, taus)
    }

    /// Increasing albedos in [0, 1) and increasing finite optical thicknesses > 0.
    fn check_grid(albedos: &[f64], taus: &[f64]) -> Result<()> {
        for (i, &a) in albedos.iter().enumerate() {
            if !((0.0..1.0).contains(&a) && (i == 0 || a > albedos[i - 1])) {
                return Err(Error::param(format!("albedos[{i}]"), a, "increasing numbers in [0, 1)"));
            }
        }
        for (j, &t) in taus.iter().enumerate() {
            if !(t > 0.0 && t.is_finite() && (j == 0 || t > taus[j - 1])) {
                return Err(Error::param(format!("taus[{j}]"), t, "increasing finite numbers > 0"));
            }
        }
        Ok(())
    }

    /// Interpolated (Rd, Tt) at albedo `a` and optical thickness `tau` inside the grid.
    pub fn totals(&self, a: f64, tau: f64) -> Result<(f64, f64)> {
        let (na, nt) = (self.albedos.len(), self.taus.len());
        if !(a >= self.albedos[0] && a <= self.albedos[na - 1]) {
            return Err(Error::Invalid(format!(
                "albedo = {a} is outside the slab table's [{}, {}]",
                self.albedos[0],
                self.albedos[na - 1]
            )));
        }
        if !(tau >= self.taus[0] && tau <= self.taus[nt - 1]) {
            return Err(Error::Invalid(format!(
                "optical thickness = {tau} is outside the slab table's [{}, {}]",
                self.taus[0],
                self.taus[nt - 1]
            )));
        }
        let u: Vec<f64> = self.albedos.iter().map(|&x| -(-x).ln_1p()).collect();
        let lt: Vec<f64> = self.taus.iter().map(|x| x.ln()).collect();
        let interp = |v: &[f64]| -> f64 {
            let col: Vec<f64> = (0..na)
                .map(|i| {
                    let row = &v[i * nt..(i + 1) * nt];
                    hermite(&lt, row, &cubic_slopes(&lt, row), tau.ln())
                })
                .collect();
            hermite(&u, &col, &cubic_slopes(&u, &col), -(-a).ln_1p())
        };
        Ok((interp(&self.rd), interp(&self.tt)))
    }
}

/// PCHIP slopes for data of either monotonicity (shape-preserving, no overshoot).
fn cubic_slopes(x: &[f64], y: &[f64]) -> Vec<f64> {
    let inc = y.last() >= y.first();
    if inc {
        pchip_slopes(x, y)
    } else {
        let neg: Vec<f64> = y.iter().map(|v| -v).collect();
        pchip_slopes(x, &neg).into_iter().map(|v| -v).collect()
    }
}

/// Fit (μa, μs') (mm⁻¹) of a slab (thickness d mm, HG g, index n between n_above and n_below)
/// to its measured total diffuse reflectance `rd` and total transmittance `tt` (unscattered
/// included; specular reflection excluded) with standard deviations `sigma`.
/// `model`: [`Model::Multipole`] (diffusion: Rd = (1 − R_sp) R̂(0), Tt = (1 − R_sp)(T̂(0) +
/// e^{−σt d}(1 − R_bottom)), multiple specular reflections neglected) or [`Model::MonteCarlo`]
/// (through `table`, which must match g and the indices).
#[allow(clippy::too_many_arguments)]
pub fn fit_slab_totals(
    rd: f64,
    tt: f64,
    sigma: [f64; 2],
    thickness: f64,
    g: f64,
    n: f64,
    n_above: f64,
    n_below: f64,
    model: Model,
    table: Option<&SlabTable>,
    initial: [f64; 2],
) -> Result<Fit> {
    check_g("g", g)?;
    if !(thickness > 0.0 && thickness.is_finite()) {
        return Err(Error::param("thickness", thickness, "a finite number > 0 (mm)"));
    }
    check_slab_totals(rd, tt, sigma)?;
    let rsp = fr_dielectric(1.0, n_above, n);
    let forward = |p: &[f64]| -> Result<Vec<f64>> {
        let mus = p[1] / (1.0 - g);
        match model {
            Model::Multipole => {
                let l = Layer::new(n, p[0], mus, g, thickness)?;
                let (r, t) = Slab::new(&l, n / n_above, n / n_below)?.transforms(0.0);
                let ballistic = (-(p[0] + mus) * thickness).exp() * (1.0 - fr_dielectric(1.0, n, n_below));
                Ok(vec![(1.0 - rsp) * r, (1.0 - rsp) * (t + ballistic)])
            }
            Model::MonteCarlo | Model::Adaptive => {
                let t = table.ok_or_else(|| Error::Invalid("model \"monte_carlo\" needs a SlabTable".into()))?;
                if (t.g - g).abs() > 1e-12 || t.n != n || t.n_above != n_above || t.n_below != n_below {
                    return Err(Error::Invalid("the SlabTable was built for other g or indices".into()));
                }
                let st = p[0] + mus;
                let (r, tr) = t.totals(mus / st, st * thickness)?;
                Ok(vec![r, tr])
            }
            m => Err(Error::Invalid(format!(
                "slab totals are fitted with \"multipole\" or \"monte_carlo\", not {:?}",
                m.name()
            ))),
        }
    };
    levenberg_marquardt(&forward, &[rd, tt], &sigma, &initial)?.identified(&["mua", "mus_prime"])
}

/// Measured slab totals: fractions of the incident power, Rd, Tt ∈ [0, 1] with Rd + Tt ≤ 1, and
/// some signal (see [`check_signal`]).
fn check_slab_totals(rd: f64, tt: f64, sigma: [f64; 2]) -> Result<()> {
    for (name, v) in [("rd", rd), ("tt", tt)] {
        if !(0.0..=1.0).contains(&v) {
            return Err(Error::param(name, v, "a fraction of the incident power in [0, 1]"));
        }
    }
    if rd + tt > 1.0 {
        return Err(Error::param("rd + tt", rd + tt, "at most 1 (fractions of the incident power)"));
    }
    if sigma.iter().all(|s| *s > 0.0 && s.is_finite()) {
        check_signal(&[rd, tt], &sigma, "total (rd, tt)")?;
    }
    Ok(())
}
