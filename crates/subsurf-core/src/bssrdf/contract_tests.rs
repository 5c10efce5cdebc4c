//! The [`RadialProfile`] contract, checked for every model: ∫ pdf = 1 and ∫ R_d 2πr dr = total
//! to 1e-6 (independent adaptive quadrature), cdf(sample_r(u)) = u, and a χ² test of sample_r
//! against pdf (Šidák-corrected over the models, overall level 0.01); the values at the ends of
//! the domain (r = 0, r = ∞) and the checked queries ([`Query`]) of the API.

use super::*;
use crate::stats::{chi2_pooled, chi2_sf, integrate_adaptive, sidak_alpha, SplitMix64};
use std::f64::consts::PI;

/// pbrt-v4 `BeamDiffusionMS`/`BeamDiffusionSS` (src/pbrt/bssrdf.cpp) with its 100-sample rule,
/// evaluated by docs/scripts/pbrt_beam_diffusion.py: (ρ, g, η, r, MS, SS) for σs = ρ, σa = 1 − ρ.
pub(crate) const PBRT_BEAM_DIFFUSION: &[(f64, f64, f64, f64, f64, f64)] = &[
    (0.5, 0.0, 1.0, 0.5, 1.033802e-02, 1.512435e-02),
    (0.8, 0.0, 1.33, 1.0, 7.934186e-03, 9.814408e-04),
    (0.95, 0.5, 1.33, 0.3, 2.208512e-02, 9.746085e-03),
    (0.99, 0.0, 1.5, 2.0, 7.139566e-03, 1.305309e-05),
    (0.99, 0.9, 1.33, 5.0, 3.299264e-04, 2.792241e-10),
    (0.9, 0.5, 1.5, 0.1, 2.810729e-02, 5.057437e-02),
];

/// ∫₀^∞ f(r) dr by adaptive Gauss–Legendre on doubling panels from 1e-8·s to 1e10·s.
fn integral(f: &dyn Fn(f64) -> f64, s: f64) -> f64 {
    let mut g = |r: f64| f(r);
    let mut sum = integrate_adaptive(&mut g, 0.0, 1e-8 * s, 1e-16);
    let mut a = 1e-8 * s;
    while a < 1e10 * s {
        sum += integrate_adaptive(&mut g, a, 2.0 * a, 1e-14);
        a *= 2.0;
    }
    sum
}

/// The contract cases of one model (exhaustive: a new model must say how it is tested).
fn cases(model: Model) -> Vec<(String, Box<dyn RadialProfile>, f64)> {
    let m = Medium::new(0.05, 1.2, 0.3, 1.33).unwrap();
    let layered = Stack::new(
        vec![Layer::new(1.4, 0.2, 8.0, 0.8, 0.6).unwrap(), Layer::new(1.4, 0.02, 10.0, 0.8, f64::INFINITY).unwrap()],
        1.0,
        1.0,
    )
    .unwrap();
    let name = |what: &str| format!("{}{what}", model.name());
    match model {
        Model::Dipole | Model::BetterDipole | Model::PhotonBeamDiffusion | Model::NormalizedDiffusion => {
            vec![(name(""), medium_profile(model, &m).unwrap(), 1.0)]
        }
        Model::Multipole => vec![
            (
                name(" slab"),
                multipole::profile(
                    &Stack::new(vec![Layer::new(1.33, 0.05, 1.2, 0.3, 3.0).unwrap()], 1.0, 1.0).unwrap(),
                )
                .unwrap(),
                1.0,
            ),
            (name(" layered"), multipole::profile(&layered).unwrap(), 0.5),
        ],
        Model::MonteCarlo | Model::Adaptive => {
            vec![(name(""), profile(model, &layered, &McSettingsForTests::settings()).unwrap(), 0.1)]
        }
    }
}

/// Every model's cases, in [`Model::ALL`] order.
fn models() -> Vec<(String, Box<dyn RadialProfile>, f64)> {
    Model::ALL.iter().copied().flat_map(cases).collect()
}

struct McSettingsForTests;
impl McSettingsForTests {
    fn settings() -> monte_carlo::McSettings {
        monte_carlo::McSettings { photons: 20_000, seed: 11, ..Default::default() }
    }
}

#[test]
fn integrals_and_inverse() {
    for (name, p, s) in models() {
        let t = p.total();
        assert!(t > 0.0 && t < 1.0, "{name}: total {t}");
        let ipdf = integral(&|r| p.pdf(r), s);
        let ird = integral(&|r| 2.0 * PI * r * p.rd(r), s);
        assert!((ipdf - 1.0).abs() < 1e-6, "{name}: ∫pdf = {ipdf}");
        assert!((ird - t).abs() < 1e-6 * t, "{name}: ∫rd 2πr = {ird} vs total {t}");
        for i in 1..400 {
            let u = i as f64 / 400.0;
            let r = p.sample_r(u);
            assert!(r.is_finite() && r >= 0.0, "{name}: sample_r({u}) = {r}");
            assert!((p.cdf(r) - u).abs() < 1e-10, "{name}: cdf(sample_r({u})) = {}", p.cdf(r));
        }
        assert!(p.radius_for_fraction(0.999) > p.radius_for_fraction(0.5));
        if let Some(ss) = p.single_scattering() {
            assert!(ss.total() > 0.0 && ss.total() < t, "{name}: single {}", ss.total());
        }
    }
}

/// `sample_r` against `pdf`: χ² of 10⁵ samples in 40 equiprobable bins (by the model's own
/// inverse cdf, up to its 0.999 quantile) plus the tail, overall α = 0.01 over all cases (Šidák).
/// Power: a relative deviation ±δ of the bins holding a fraction f of the probability adds
/// λ = N Σ(δp)²/p ≈ N f δ² to X²; at α_i ≈ 1.4·10⁻³ (7 cases) on ≈ 40 degrees of freedom the
/// test fails with probability 0.9 once λ ≳ 53 (non-central χ²): δ ≈ 2.3 % spread over the
/// whole profile, ≈ 7 % over a tenth of it (4 bins), ≈ 15 % in a single bin.
#[test]
fn sampling_chi2() {
    let all = models();
    let alpha = sidak_alpha(0.01, all.len()).unwrap();
    for (k, (name, p, s)) in all.into_iter().enumerate() {
        let n = 100_000usize;
        let nb = 40;
        let edges: Vec<f64> =
            (0..=nb).map(|i| if i == 0 { 0.0 } else { p.sample_r(0.999 * i as f64 / nb as f64) }).collect();
        let mut rng = SplitMix64::new(100 + k as u64);
        let mut obs = vec![0.0; nb + 1];
        for _ in 0..n {
            let r = p.sample_r(rng.next_f64());
            let b = edges.partition_point(|&e| e <= r);
            obs[(b.max(1) - 1).min(nb)] += 1.0;
        }
        let mut exp: Vec<f64> = edges
            .windows(2)
            .map(|w| {
                let mut f = |r: f64| p.pdf(r);
                n as f64 * integrate_adaptive(&mut f, w[0], w[1], 1e-12)
            })
            .collect();
        let inside: f64 = exp.iter().sum();
        exp.push(n as f64 - inside);
        let _ = s;
        let c = chi2_pooled(&obs, &exp, 5.0).unwrap();
        assert!(c.p_value > alpha, "{name}: χ² = {} dof {} p = {} (α = {alpha})", c.statistic, c.dof, c.p_value);
        assert!(chi2_sf(c.statistic, c.dof as f64).unwrap() == c.p_value);
    }
}

/// Every model (and a profile-table profile) at the ends of its domain, and the API's checked
/// queries refusing what is outside it with the argument's name (before: `rd(nan)`
/// was 0, `sample_r(nan)` 0 or ∞, `sample_r(1.5)` clamped, `rd(∞)` NaN for the dipoles, `pdf(0)`
/// NaN for Monte Carlo).
#[test]
fn ends_of_the_domain_and_checked_queries() {
    let mut all = models();
    let s = table::TableSettings { albedos: vec![0.9, 0.99], photons: 2000, ..table::TableSettings::new(0.0, 1.3) };
    let (never, progress) = (std::sync::atomic::AtomicBool::new(false), std::sync::atomic::AtomicU64::new(0));
    let table = table::ProfileTable::build(s, &never, &progress).unwrap();
    all.push(("table".to_string(), Box::new(table.profile(0.02, 1.0).unwrap()), 1.0));
    for (name, p, _) in all {
        assert_eq!(p.rd(f64::INFINITY), 0.0, "{name}: rd(inf)");
        assert_eq!(p.pdf(f64::INFINITY), 0.0, "{name}: pdf(inf)");
        assert_eq!(p.cdf(f64::INFINITY), 1.0, "{name}: cdf(inf)");
        assert_eq!(p.cdf(0.0), 0.0, "{name}: cdf(0)");
        let (rd0, pdf0) = (p.rd(0.0), p.pdf(0.0));
        assert!(rd0 >= 0.0, "{name}: rd(0) = {rd0}");
        assert!(pdf0.is_finite() && pdf0 >= 0.0, "{name}: pdf(0) = {pdf0}");
        for u in [0.0, 0.5, 1.0 - f64::EPSILON] {
            let r = Query::SampleR.eval(p.as_ref(), u).unwrap();
            assert!(r.is_finite() && r >= 0.0, "{name}: sample_r({u}) = {r}");
        }
        for (q, x, arg) in [
            (Query::Rd, f64::NAN, "r = nan"),
            (Query::Pdf, -1.0, "r = -1.0"),
            (Query::Cdf, f64::NEG_INFINITY, "r = -inf"),
            (Query::SampleR, f64::NAN, "u = nan"),
            (Query::SampleR, 1.5, "u = 1.5"),
            (Query::SampleR, 1.0, "u = 1.0"),
            (Query::SampleR, -0.1, "u = -0.1"),
            (Query::RadiusForFraction, 1.0, "q = 1.0"),
        ] {
            let e = q.eval(p.as_ref(), x).unwrap_err().to_string();
            assert!(e.starts_with(arg) && e.contains(if arg.starts_with('r') { "[0, inf]" } else { "[0, 1)" }), "{e}");
        }
        assert_eq!(Query::Rd.eval(p.as_ref(), 1.0).unwrap(), p.rd(1.0));
        assert_eq!(Query::Rd.eval(p.as_ref(), f64::INFINITY).unwrap(), 0.0);
    }
}

#[test]
fn names_and_bad_input() {
    for &m in Model::ALL {
        assert_eq!(Model::from_name("model", m.name()).unwrap(), m);
    }
    assert!(Model::from_name("model", "quadrupole").unwrap_err().to_string().contains("monte_carlo"));
    let e = Medium::new(-1.0, 1.0, 0.0, 1.3).unwrap_err().to_string();
    assert!(e.starts_with("sigma_a"), "{e}");
    let layered = Stack::new(vec![Layer::new(1.4, 0.1, 1.0, 0.0, 1.0).unwrap()], 1.0, 1.0).unwrap();
    assert!(profile(Model::Dipole, &layered, &Default::default()).err().unwrap().to_string().contains("multipole"));
    let chans = channel_profiles(Model::Dipole, std::slice::from_ref(&layered), &Default::default());
    assert!(chans.err().unwrap().to_string().starts_with("channels[0]"));
}
