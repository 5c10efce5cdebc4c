//! Round trips of the inverse problems (fixed seeds).

use super::*;
use crate::bssrdf::monte_carlo::{McSettings, MonteCarloProfile};
use crate::bssrdf::table::{build_point, ProfileTable, TableSettings};
use crate::bssrdf::{medium_profile, normalized_diffusion, Medium, Model, RadialProfile};
use crate::diffusion;
use crate::mc::tally::totals::{Total, Totals};
use crate::mc::{run, RunConfig, Source};
use crate::medium::Stack;
use crate::stats::SplitMix64;
use std::sync::atomic::{AtomicBool, AtomicU64};

fn gauss(rng: &mut SplitMix64) -> f64 {
    let (u1, u2) = (rng.next_f64().max(1e-300), rng.next_f64());
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

fn small_table(g: f64, eta: f64, albedos: Vec<f64>, photons: u64) -> ProfileTable {
    let mut s = TableSettings::new(g, eta);
    s.albedos = albedos;
    s.photons = photons;
    s.seed = 40;
    let pts = (0..s.albedos.len())
        .map(|i| build_point(&s, i, &AtomicBool::new(false), &AtomicU64::new(0)).unwrap())
        .collect();
    ProfileTable::assemble(s, pts).unwrap()
}

const INCIDENT_EXT: Conventions = Conventions { power: Power::Incident, mfp_kind: MeanFreePath::Extinction };

/// A material built from an RGB reflectance (per incident power, mfp = 1/σt) with the Monte
/// Carlo model, simulated by the engine, reproduces the reflectance within 0.5 % per channel
/// (table: 8 albedos in [0.9, 0.9995], 10⁵ photons each; check: 3·10⁵ (0.6/R)² photons per
/// channel, whose 4σ is < 0.5 %). Normalized diffusion shares its material.
#[test]
fn monte_carlo_reflectance_reproduced_by_the_engine_slow() {
    let (g, eta) = (0.0, 1.33);
    let table = small_table(g, eta, table_albedos(), 100_000);
    let colour = [0.6, 0.5, 0.4];
    let mfp = [0.5, 1.0, 2.0];
    let layers =
        material_from_reflectance(&colour, &mfp, eta, g, Model::MonteCarlo, INCIDENT_EXT, Some(&table)).unwrap();
    for (i, l) in layers.iter().enumerate() {
        assert!((1.0 / l.sigma_t() - mfp[i]).abs() < 1e-12);
        let s = Stack::new(vec![*l], 1.0, 1.0).unwrap();
        let photons = (300_000.0 * (0.6 / colour[i]).powi(2)) as u64;
        let cfg = RunConfig { photons, seed: 900 + i as u64, threads: None, source: Source::default(), isa: None };
        let out = run(&s, &cfg, || Totals::new(1), &AtomicBool::new(false), &AtomicU64::new(0)).unwrap();
        let (rd, se) = out.tally.get(Total::Diffuse);
        assert!(4.0 * se < 0.005 * colour[i], "channel {i}: check too noisy ({se})");
        eprintln!(
            "appearance channel {i}: simulated {rd} ± {se} vs {} ({:+.3} %)",
            colour[i],
            100.0 * (rd / colour[i] - 1.0)
        );
        assert!((rd / colour[i] - 1.0).abs() < 0.005, "channel {i}: simulated {rd} ± {se} vs requested {}", colour[i]);
    }
    let nd = material_from_reflectance(&colour, &mfp, eta, g, Model::NormalizedDiffusion, INCIDENT_EXT, Some(&table));
    assert_eq!(nd.unwrap(), layers);
}

fn table_albedos() -> Vec<f64> {
    (0..8).map(|i| 1.0 - 0.1 * (0.005f64).powf(i as f64 / 7.0)).collect()
}

/// The model's own forward total per unit power *entering* the medium of a layer, and the
/// tolerance of the round trip, from the numerical method (one arm per model: a new model
/// must say how it is checked).
fn forward_total(model: Model, m: &Medium, table: &ProfileTable, refl_incident: f64) -> (f64, f64) {
    let enter = appearance::entering_fraction(m.eta);
    match model {
        // α' by bisection to 1e-15, closed-form total: rounding only.
        Model::Dipole | Model::BetterDipole => {
            let kind = if model == Model::Dipole { diffusion::Model::Dipole } else { diffusion::Model::BetterDipole };
            (kind.total_rd(m.sigma_s_prime() / (m.sigma_a + m.sigma_s_prime()), m.eta).unwrap(), 1e-12)
        }
        // The tabulated quadrature of R_d(r) (agrees with closed forms to ~1e-12, `Tabulated`);
        // photon beam diffusion's root on α stops at |Δtotal| < 1e-13 or a bracket of 1e-11 (its
        // weight k is computed at σs = 1 whatever the material's scale).
        Model::Multipole | Model::PhotonBeamDiffusion => (medium_profile(model, m).unwrap().total(), 1e-10),
        // ρ_eff of the table (per incident power), inverted by bisection to 1e-14 in ln(1 − α)
        // (adaptive inverts a colour as the semi-infinite Monte Carlo profile).
        Model::MonteCarlo | Model::Adaptive => (table.rho_eff(m.sigma_s / m.sigma_t()).unwrap() / enter, 1e-10),
        // The renderer's profile for the material: its total is A = reflectance / (1 − R_sp).
        Model::NormalizedDiffusion => {
            (normalized_diffusion::from_reflectance(m, refl_incident).unwrap().total(), 1e-14)
        }
    }
}

/// The requested length of `kind` recomputed from the layer by independent code: 1/σt, 1/σt',
/// 1/σtr of the model's diffusion object (`diffusion::Dipole` or `BetterDipole`), and the d of
/// the renderer's normalized diffusion profile (`normalized_diffusion::with_albedo`).
fn length(kind: MeanFreePath, model: Model, m: &Medium, a_enter: f64) -> f64 {
    let (sa, ssp) = (m.sigma_a, m.sigma_s_prime());
    let classical = || 1.0 / diffusion::Dipole::new(sa, ssp, m.eta).unwrap().sigma_tr;
    match kind {
        MeanFreePath::Extinction => 1.0 / m.sigma_t(),
        MeanFreePath::Transport => 1.0 / (sa + ssp),
        MeanFreePath::Diffuse => match model {
            Model::Dipole | Model::Multipole | Model::NormalizedDiffusion | Model::MonteCarlo | Model::Adaptive => {
                classical()
            }
            Model::BetterDipole | Model::PhotonBeamDiffusion => {
                1.0 / diffusion::BetterDipole::new(sa, ssp, m.eta).unwrap().sigma_tr
            }
        },
        MeanFreePath::BurleyD => normalized_diffusion::with_albedo(m, a_enter).unwrap().d,
    }
}

/// Round trip reflectance → material → the model's own total, for every model, both power
/// conventions and every kind of mean free path (g = 0.6, η = 1.4, two reflectances, one for
/// photon beam diffusion): the
/// total reproduces the reflectance and the layer has the requested length, within the
/// numerical method's tolerance (see [`forward_total`]; lengths are arithmetic: 1e-12, Burley's d 1e-9).
#[test]
fn reflectance_round_trips_every_model_and_convention_slow() {
    let (g, eta) = (0.6, 1.4);
    let enter = appearance::entering_fraction(eta);
    let table = small_table(g, eta, table_albedos(), 5_000);
    let (lo, hi) = (table.rho_eff(table_albedos()[0]).unwrap(), table.rho_eff(table_albedos()[7]).unwrap());
    let mut worst = [0.0f64; Model::ALL.len()];
    for (mi, &model) in Model::ALL.iter().enumerate() {
        for power in [Power::Incident, Power::Entering] {
            for kind in
                [MeanFreePath::Extinction, MeanFreePath::Transport, MeanFreePath::Diffuse, MeanFreePath::BurleyD]
            {
                // photon beam diffusion's α is a root of its tabulated total (~1 s an inversion):
                // one reflectance, for two of the eight conventions (one per power; the conversions
                // are the same code for every model, checked in full by the others); the others take
                // two reflectances each
                let pbd = model == Model::PhotonBeamDiffusion;
                let kept = [(Power::Incident, MeanFreePath::Transport), (Power::Entering, MeanFreePath::BurleyD)];
                if pbd && !kept.contains(&(power, kind)) {
                    continue;
                }
                let ts: &[f64] = if pbd { &[0.7] } else { &[0.3, 0.7] };
                for &t in ts {
                    // per incident power, inside the table's range for the table models
                    let inc = lo + t * (hi - lo);
                    let r = if power == Power::Incident { inc } else { inc / enter };
                    let conv = Conventions { power, mfp_kind: kind };
                    let l = material_from_reflectance(&[r], &[1.7], eta, g, model, conv, Some(&table)).unwrap()[0];
                    let m = Medium::new(l.mua, l.mus, g, eta).unwrap();
                    let (total, tol) = forward_total(model, &m, &table, inc);
                    let shown = if power == Power::Incident { total * enter } else { total };
                    let err = (shown - r).abs() / r;
                    worst[mi] = worst[mi].max(err);
                    assert!(err < tol, "{model:?} {power:?} {kind:?}: total {shown} vs {r}");
                    let len = length(kind, model, &m, inc / enter);
                    // Burley's d is photon beam diffusion's tabulated median, scale-equivariant
                    // only to the rounding of its quadrature (measured 1.4e-11)
                    let ltol = if kind == MeanFreePath::BurleyD { 1e-9 } else { 1e-12 };
                    assert!((len / 1.7 - 1.0).abs() < ltol, "{model:?} {power:?} {kind:?}: length {len} vs 1.7");
                }
            }
        }
    }
    eprintln!(
        "worst relative round-trip error per model {:?}: {worst:?}",
        Model::ALL.iter().map(|m| m.name()).collect::<Vec<_>>()
    );
}

/// Refusals: out of range per the chosen power, no table, a diffuse length without absorption.
#[test]
fn reflectance_refusals() {
    let (g, eta) = (0.0, 1.33);
    let table = small_table(g, eta, table_albedos(), 2_000);
    let call = |r: f64, model, conv, t: Option<&ProfileTable>| {
        material_from_reflectance(&[r], &[1.0], eta, g, model, conv, t).unwrap_err().to_string()
    };
    let e = call(0.99, Model::Dipole, INCIDENT_EXT, None);
    assert!(e.starts_with("reflectance[0] = 0.99 is out of range: model \"dipole\" reaches at most 0.97"), "{e}");
    assert!(e.contains("per incident power"), "{e}");
    let entering = Conventions { power: Power::Entering, ..INCIDENT_EXT };
    let e = call(1.2, Model::Dipole, entering, None);
    assert!(e.starts_with("reflectance[0] = 1.2"), "{e}");
    let e = call(0.99, Model::MonteCarlo, INCIDENT_EXT, Some(&table));
    assert!(e.starts_with("reflectance[0] = 0.99 is out of range"), "{e}");
    for model in [Model::MonteCarlo, Model::NormalizedDiffusion] {
        assert!(call(0.5, model, INCIDENT_EXT, None).contains("needs a ProfileTable"));
    }
    let e = call(1.0, Model::Dipole, Conventions { power: Power::Entering, mfp_kind: MeanFreePath::Diffuse }, None);
    assert!(e.contains("no absorption"), "{e}");
    let e = material_from_reflectance(&[0.5], &[0.0], eta, g, Model::Dipole, INCIDENT_EXT, None).unwrap_err();
    assert!(e.to_string().starts_with("mfp[0] = 0"), "{e}");
    assert!(Power::from_name("emitted").unwrap_err().to_string().contains("incident"));
    assert!(MeanFreePath::from_name("free").unwrap_err().to_string().contains("burley_d"));
}

/// Fits of a noisy R_d(r) (20 radii, 3 % noise) recover (σa, σs') within the reported 2σ in at
/// least 25 of 30 seeds per parameter (expected 95 %; P(< 25 | 0.95) ≈ 0.016), for the dipole
/// (closed form) and for Monte Carlo through a profile table.
#[test]
fn profile_fit_coverage() {
    let r: Vec<f64> = (0..20).map(|i| 0.1 * 1.25f64.powi(i)).collect();
    let table = small_table(0.0, 1.3, (0..6).map(|i| 0.9 + 0.018 * i as f64).collect(), 20_000);
    for (model, truth, tab) in [(Model::Dipole, [0.02, 1.0], None), (Model::MonteCarlo, [0.04, 1.0], Some(&table))] {
        let prof: Box<dyn RadialProfile> = match tab {
            Some(t) => Box::new(t.profile(truth[0], truth[1]).unwrap()),
            None => medium_profile(model, &Medium::new(truth[0], truth[1], 0.0, 1.3).unwrap()).unwrap(),
        };
        let exact: Vec<f64> = r.iter().map(|&x| prof.rd(x)).collect();
        let mut hits = [0; 2];
        let mut rng = SplitMix64::new(5);
        for _ in 0..30 {
            let sigma: Vec<f64> = exact.iter().map(|v| 0.03 * v).collect();
            let y: Vec<f64> = exact.iter().zip(&sigma).map(|(v, s)| v + s * gauss(&mut rng)).collect();
            let f = fit::fit_profile(model, &r, &y, &sigma, 0.0, 1.3, [0.03, 0.8], tab).unwrap();
            for k in 0..2 {
                if (f.params[k] - truth[k]).abs() < 2.0 * f.stderr()[k] {
                    hits[k] += 1;
                }
            }
        }
        assert!(hits[0] >= 25 && hits[1] >= 25, "{model:?}: coverage {hits:?} of 30");
    }
}

/// Slab Rd/Tt → (μa, μs') with the multipole: 30 noisy pairs, coverage of 2σ ≥ 25/30; and one
/// Monte Carlo round trip through a slab table against an independent engine run.
#[test]
fn slab_fit_round_trips() {
    let (d, g, n) = (1.0, 0.7, 1.4);
    let truth = [0.1, 1.5];
    let fwd = {
        let l = crate::medium::Layer::new(n, truth[0], truth[1] / (1.0 - g), g, d).unwrap();
        let (r, t) = crate::bssrdf::multipole::Slab::new(&l, n, n).unwrap().transforms(0.0);
        let rsp = crate::optics::fr_dielectric(1.0, 1.0, n);
        let ball = (-(truth[0] + truth[1] / (1.0 - g)) * d).exp() * (1.0 - crate::optics::fr_dielectric(1.0, n, 1.0));
        [(1.0 - rsp) * r, (1.0 - rsp) * (t + ball)]
    };
    let mut rng = SplitMix64::new(8);
    let mut hits = [0; 2];
    for _ in 0..30 {
        let s = [0.004, 0.004];
        let (rd, tt) = (fwd[0] + s[0] * gauss(&mut rng), fwd[1] + s[1] * gauss(&mut rng));
        let f = fit::fit_slab_totals(rd, tt, s, d, g, n, 1.0, 1.0, Model::Multipole, None, [0.05, 1.0]).unwrap();
        for k in 0..2 {
            hits[k] += ((f.params[k] - truth[k]).abs() < 2.0 * f.stderr()[k]) as usize;
        }
    }
    assert!(hits[0] >= 25 && hits[1] >= 25, "multipole slab coverage {hits:?}");
    // Monte Carlo: table on a 5 × 5 grid around the truth, data from another seed.
    let (mua, musp) = (0.3, 2.0);
    let (a, tau) = (musp / (1.0 - g) / (mua + musp / (1.0 - g)), (mua + musp / (1.0 - g)) * d);
    let albedos: Vec<f64> = (0..5).map(|i| a - 0.02 + 0.01 * i as f64).collect();
    let taus: Vec<f64> = (0..5).map(|i| tau * (0.8 + 0.1 * i as f64)).collect();
    let table = SlabTable::build(g, n, 1.0, 1.0, albedos, taus, 40_000, 1).unwrap();
    let s = Stack::new(vec![crate::medium::Layer::new(n, mua, musp / (1.0 - g), g, d).unwrap()], 1.0, 1.0).unwrap();
    let cfg = RunConfig { photons: 40_000, seed: 77, threads: None, source: Source::default(), isa: None };
    let out = run(&s, &cfg, || Totals::new(1), &AtomicBool::new(false), &AtomicU64::new(0)).unwrap();
    let (rd, rs) = out.tally.get(Total::Diffuse);
    let (tt, ts) = out.tally.get(Total::Transmittance);
    // Data noise plus the table's own noise (same photon count) in quadrature.
    let sig = [(2.0f64).sqrt() * rs, (2.0f64).sqrt() * ts];
    let f = fit::fit_slab_totals(rd, tt, sig, d, g, n, 1.0, 1.0, Model::MonteCarlo, Some(&table), [0.25, 1.8]).unwrap();
    let se = f.stderr();
    assert!(
        (f.params[0] - mua).abs() < 3.0 * se[0] && (f.params[1] - musp).abs() < 3.0 * se[1],
        "{:?} ± {se:?}",
        f.params
    );
}

#[test]
fn mc_profile_and_table_bad_input() {
    let s = TableSettings { albedos: vec![], ..TableSettings::new(0.0, 1.0) };
    assert!(s.validate().unwrap_err().to_string().contains("empty"));
    let s = TableSettings { albedos: vec![0.5, 1.2], ..TableSettings::new(0.0, 1.0) };
    assert!(s.validate().unwrap_err().to_string().starts_with("albedos[1]"));
    let p = MonteCarloProfile::simulate(
        &Medium::new(0.1, 1.0, 0.0, 1.0).unwrap().to_stack().unwrap(),
        &McSettings { photons: 2000, ..Default::default() },
    )
    .unwrap();
    let mut d = p.data().clone();
    d.weight[3] = f64::NAN;
    assert!(MonteCarloProfile::from_data(d, 0.2).is_err());
}

/// A slab table is its points: `build` equals `from_totals` of `point` runs (any machine may
/// compute any point), a cancelled point is `None`, and bad grids or totals name the field.
#[test]
fn slab_table_points_and_assembly() {
    let (albedos, taus) = (vec![0.5, 0.9], vec![0.5, 2.0]);
    let built = SlabTable::build(0.0, 1.4, 1.0, 1.2, albedos.clone(), taus.clone(), 2000, 5).unwrap();
    let (never, count) = (AtomicBool::new(false), AtomicU64::new(0));
    let mut pts = Vec::new();
    for (k, (&a, &t)) in albedos.iter().flat_map(|a| taus.iter().map(move |t| (a, t))).enumerate() {
        let p = SlabTable::point(0.0, 1.4, 1.0, 1.2, a, t, 2000, 5 + k as u64, Some(1), &never, &count).unwrap();
        pts.push(p.unwrap());
    }
    let assembled = SlabTable::from_totals(0.0, 1.4, 1.0, 1.2, albedos.clone(), taus.clone(), &pts).unwrap();
    assert_eq!(built, assembled);
    let cancelled = AtomicBool::new(true);
    assert_eq!(SlabTable::point(0.0, 1.4, 1.0, 1.0, 0.5, 1.0, 10_000, 0, None, &cancelled, &count).unwrap(), None);
    let err = |r: crate::error::Result<SlabTable>| r.unwrap_err().to_string();
    assert!(
        err(SlabTable::from_totals(0.0, 1.4, 1.0, 1.0, albedos.clone(), taus.clone(), &pts[..3])).contains("3 points")
    );
    assert!(
        err(SlabTable::from_totals(0.0, 1.4, 1.0, 1.0, vec![0.9, 0.5], taus.clone(), &pts)).starts_with("albedos[1]")
    );
    assert!(
        err(SlabTable::from_totals(0.0, 1.4, 1.0, 1.0, albedos.clone(), vec![1.0, -1.0], &pts)).starts_with("taus[1]")
    );
    let mut bad = pts.clone();
    bad[2][0] = f64::NAN;
    assert!(err(SlabTable::from_totals(0.0, 1.4, 1.0, 1.0, albedos, taus, &bad)).contains("point 2"));
}

/// Fits the data do not identify are refused, not reported with the start value "± 0" or
/// uncertainties of 1e85: no signal, χ² overflowing, data out of range,
/// and the covariance rules of [`lm::Fit::identified`].
#[test]
fn unidentifiable_fits_are_refused() {
    let r: Vec<f64> = (1..=10).map(|i| 0.3 * i as f64).collect();
    let fit = |rd: &[f64], s: &[f64]| {
        fit::fit_profile(Model::Dipole, &r, rd, s, 0.0, 1.3, [0.05, 1.0], None).unwrap_err().to_string()
    };
    let e = fit(&[0.0; 10], &[1e-3; 10]);
    assert!(e.contains("no signal") && e.contains("rd"), "{e}");
    let e = fit(&[1e-300; 10], &[1e-302; 10]);
    assert!(e.starts_with("fit: χ² = inf at the initial parameters"), "{e}");
    let e = fit(&[1.0, f64::NAN, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0], &[0.1; 10]);
    assert!(e.starts_with("rd[1] = nan"), "{e}");
    // A signal barely out of the noise at two radii determines neither parameter.
    let prof = medium_profile(Model::Dipole, &Medium::new(0.05, 1.0, 0.0, 1.3).unwrap()).unwrap();
    let y = [prof.rd(1.0), prof.rd(1.1)];
    let e = fit::fit_profile(Model::Dipole, &[1.0, 1.1], &y, &[y[0] / 1.5, y[1] / 1.5], 0.0, 1.3, [0.05, 1.0], None)
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("fit: the data do not determine sigma_"), "{e}");
    let slab = |rd: f64, tt: f64| {
        fit::fit_slab_totals(rd, tt, [0.01, 0.01], 1.0, 0.0, 1.4, 1.0, 1.0, Model::Multipole, None, [0.1, 1.0])
            .unwrap_err()
            .to_string()
    };
    assert!(slab(0.0, 0.0).contains("no signal"), "{}", slab(0.0, 0.0));
    assert!(slab(-0.1, 0.3).starts_with("rd = -0.1"), "{}", slab(-0.1, 0.3));
    assert!(slab(0.7, 0.6).starts_with("rd + tt = 1.2"), "{}", slab(0.7, 0.6));
    // The rules themselves: a zero, a non-finite and a too large variance are refused.
    let base = lm::Fit { params: vec![1.0, 2.0], cov: vec![0.01, 0.0, 0.0, 0.04], chi2: 3.0, dof: 8, iterations: 5 };
    assert!(base.clone().identified(&["a", "b"]).is_ok());
    for (k, v) in [(0, 0.0), (3, f64::INFINITY), (3, 4.0 * 1.0001), (0, f64::NAN)] {
        let mut f = base.clone();
        f.cov[k] = v;
        let e = f.identified(&["a", "b"]).unwrap_err().to_string();
        assert!(e.starts_with(&format!("fit: the data do not determine {}", if k == 0 { "a" } else { "b" })), "{e}");
    }
    let e = lm::Fit { chi2: f64::INFINITY, ..base }.identified(&["a", "b"]).unwrap_err().to_string();
    assert!(e.contains("χ² is not finite"), "{e}");
}
