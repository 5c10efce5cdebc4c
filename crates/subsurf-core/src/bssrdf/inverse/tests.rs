//! Round trips of the inverse problems (fixed seeds).

use super::*;
use crate::bssrdf::monte_carlo::{McSettings, MonteCarloProfile};
use crate::bssrdf::table::{build_point, ProfileTable, TableSettings};
use crate::bssrdf::{medium_profile, Medium, Model, RadialProfile};
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

/// A material built from an RGB colour with the Monte Carlo model (and normalized diffusion,
/// which shares its material), simulated by the engine, reproduces the colour within 0.5 % per
/// channel (table: 8 albedos in [0.9, 0.9995], 10⁵
/// photons each; check: 3·10⁵ (0.6/colour)² photons per channel, whose 4σ is < 0.5 %).
#[test]
fn monte_carlo_appearance_reproduces_colour_slow() {
    let (g, eta) = (0.0, 1.33);
    let albedos: Vec<f64> = (0..8).map(|i| 1.0 - 0.1 * (0.005f64).powf(i as f64 / 7.0)).collect();
    let table = small_table(g, eta, albedos, 100_000);
    let colour = [0.6, 0.5, 0.4];
    let mfp = [0.5, 1.0, 2.0];
    let layers = material_from_appearance(&colour, &mfp, eta, g, Model::MonteCarlo, Some(&table)).unwrap();
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
    // Every model's own prediction of the colour is the colour: (1 − R_sp) × the closed-form
    // totals (per unit power entering); normalized diffusion's material is the Monte Carlo one
    // (so the engine reproduces it, above) and its renderer profile has total colour/(1 − R_sp)
    // (before: Chiang et al.'s α(A) and photon beam diffusion's total: 0.018 for 0.30 at g = 0.8,
    // η = 1.4).
    let enter = appearance::entering_fraction(eta);
    let nd = material_from_appearance(&colour, &mfp, eta, g, Model::NormalizedDiffusion, Some(&table)).unwrap();
    assert_eq!(nd, layers);
    for (k, l) in nd.iter().enumerate() {
        let m = Medium::new(l.mua, l.mus, g, eta).unwrap();
        let t = crate::bssrdf::normalized_diffusion::from_colour(&m, colour[k]).unwrap().total();
        assert!((enter * t - colour[k]).abs() < 1e-12, "normalized_diffusion: {t}");
    }
    for model in [Model::Dipole, Model::BetterDipole, Model::Multipole, Model::PhotonBeamDiffusion] {
        let l = material_from_appearance(&[0.4], &[1.0], eta, 0.5, model, None).unwrap()[0];
        let m = Medium::new(l.mua, l.mus, 0.5, eta).unwrap();
        let t = medium_profile(model, &m).unwrap().total();
        assert!((enter * t - 0.4).abs() < 1e-6, "{model:?}: {t}");
    }
    let e = material_from_appearance(&[0.99], &[1.0], eta, g, Model::Dipole, None).unwrap_err().to_string();
    assert!(e.starts_with("albedo[0] = 0.99 is out of range: model \"dipole\" reaches at most 0.97"), "{e}");
    let e = material_from_appearance(&[0.99], &[1.0], eta, g, Model::MonteCarlo, Some(&table)).unwrap_err();
    assert!(e.to_string().starts_with("albedo[0] = 0.99 is out of range"), "{e}");
    let e = material_from_appearance(&[1.2], &[1.0], eta, g, Model::Dipole, None).unwrap_err();
    assert!(e.to_string().starts_with("albedo[0] = 1.2"), "{e}");
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
