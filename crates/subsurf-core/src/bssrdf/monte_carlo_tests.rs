//! Tests of the Monte Carlo profile against independent references (fixed seeds, tolerances
//! from the runs' standard errors).

use super::*;
use crate::bssrdf::chandrasekhar::semi_infinite_reflectance;
use crate::mc::tally::totals::{Total, Totals};
use crate::mc::tally::{TallyConfig, TallySet};
use crate::medium::Layer;

fn semi(a: f64) -> Stack {
    Stack::new(vec![Layer::new(1.0, 1.0 - a, a, 0.0, f64::INFINITY).unwrap()], 1.0, 1.0).unwrap()
}

/// Semi-infinite, index-matched, isotropic: the profile's total (= the run's total, energy-
/// exact) matches Chandrasekhar's exact 1 − H(1)√(1 − a) within 0.5 % and within 4σ, over
/// albedo 0.3–0.999. Photons per albedo chosen so that 4σ < 0.5 % of the value.
#[test]
fn total_matches_chandrasekhar_slow() {
    for &(a, photons) in &[(0.3, 3_000_000u64), (0.6, 1_600_000), (0.9, 500_000), (0.99, 150_000), (0.999, 50_000)] {
        let s = McSettings { photons, seed: 7, ..McSettings::default() };
        let edges = default_edges(&semi(a), &s).unwrap();
        let cfg = RunConfig { photons, seed: 7, threads: None, source: Source::default(), isa: None };
        let out = run(
            &semi(a),
            &cfg,
            || (Totals::new(1), RadialTally::new(edges.clone())),
            &AtomicBool::new(false),
            &AtomicU64::new(0),
        )
        .unwrap();
        let (tot, radial) = out.tally;
        let p = MonteCarloProfile::from_data(radial.data(), 0.2).unwrap();
        let (rd, se) = tot.get(Total::Diffuse);
        assert!((p.total() - rd).abs() < 1e-12, "energy-exact: {} vs {rd}", p.total());
        let exact = semi_infinite_reflectance(a).unwrap();
        assert!(4.0 * se < 0.005 * exact, "a = {a}: not enough photons ({se})");
        assert!((rd - exact).abs() < 4.0 * se, "a = {a}: MC {rd} ± {se} vs H-function {exact}");
        assert!((p.total_stderr() - se).abs() < 1e-12);
    }
}

/// Layered, mismatched stack: the profile integrated over the engine's own linear rings (the
/// `rd_r` tally of the same photons) matches the engine's R(r) within 4 of its standard errors
/// from 0.05 to 3 mm, and the profile is positive and sampled consistently.
#[test]
fn layered_profile_matches_engine_slow() {
    let stack = Stack::new(
        vec![
            Layer::new(1.4, 0.3, 10.0, 0.8, 0.1).unwrap(),
            Layer::new(1.4, 0.05, 15.0, 0.85, 0.5).unwrap(),
            Layer::new(1.45, 0.02, 12.0, 0.9, f64::INFINITY).unwrap(),
        ],
        1.0,
        1.0,
    )
    .unwrap();
    let s = McSettings { photons: 60_000, seed: 3, ..McSettings::default() };
    let edges = default_edges(&stack, &s).unwrap();
    let tc = TallyConfig { nr: 60, dr: 0.05, nz: 1, dz: 1.0, na: 1, ..TallyConfig::default() };
    let set = TallySet::new(&tc, &stack).unwrap();
    let cfg = RunConfig { photons: s.photons, seed: s.seed, threads: None, source: Source::default(), isa: None };
    let out = run(
        &stack,
        &cfg,
        || (set.clone(), RadialTally::new(edges.clone())),
        &AtomicBool::new(false),
        &AtomicU64::new(0),
    )
    .unwrap();
    let (set, radial) = out.tally;
    let p = MonteCarloProfile::from_data(radial.data(), 0.2).unwrap();
    let h = set.finalize(out.photons).into_iter().find(|h| h.name == "rd_r").unwrap();
    let mut worst: f64 = 0.0;
    for i in 1..59 {
        let (a, b) = (0.05 * i as f64, 0.05 * (i + 1) as f64);
        let ring = p.total() * (p.cdf(b) - p.cdf(a)) / (PI * (b * b - a * a));
        let (v, se) = (h.values[i], h.stderr[i]);
        let z = (ring - v) / se;
        worst = worst.max(z.abs());
        assert!(z.abs() < 4.0, "ring [{a}, {b}]: profile {ring} vs engine {v} ± {se} ({z:.2}σ)");
        assert!(p.rd(0.5 * (a + b)) > 0.0);
    }
    assert!(worst > 0.0);
    for i in 1..200 {
        let u = i as f64 / 200.0;
        assert!((p.cdf(p.sample_r(u)) - u).abs() < 1e-12, "{u}");
    }
    assert!(p.single_scattering().unwrap().total() > 0.0);
}

/// The tail: past r_t the profile decays like the fitted asymptote, has no cut-off, and its
/// energy beyond r_t is the Monte Carlo weight there.
#[test]
fn tail_is_energy_exact_and_unbounded() {
    let s = McSettings { photons: 20_000, seed: 1, ..McSettings::default() };
    let p = MonteCarloProfile::simulate(&semi(0.99), &s).unwrap();
    let (r_t, sigma) = p.tail();
    let d = p.data();
    let k = d.edges.iter().position(|&e| e == r_t).unwrap();
    let beyond: f64 = d.weight[k..].iter().sum();
    assert!(((1.0 - p.cdf(r_t)) * p.total() - beyond).abs() < 1e-12);
    assert!(sigma >= 0.0 && p.rd(10.0 * r_t) > 0.0 && p.sample_r(1.0 - 1e-9).is_finite());
    assert!(p.sample_r(1.0 - 1e-9) > r_t);
}
