//! Engine tests against independent references (closed forms and published transport results).
//! Tolerances are 4 standard errors as reported by the run (fixed seeds).

use super::tally::totals::{Total, Totals};
use super::*;
use crate::medium::{Layer, Stack};
use crate::optics::Phase;
use std::sync::atomic::{AtomicBool, AtomicU64};

fn go(stack: &Stack, cfg: RunConfig) -> RunOutput<Totals> {
    let nl = stack.layers.len();
    run(stack, &cfg, || Totals::new(nl), &AtomicBool::new(false), &AtomicU64::new(0)).unwrap()
}

fn within(name: &str, (m, se): (f64, f64), want: f64, k: f64) {
    assert!(se.is_finite() && se > 0.0, "{name}: stderr {se}");
    assert!((m - want).abs() <= k * se, "{name}: {m} ± {se}, expected {want} ({:.2}σ)", (m - want) / se);
}

/// van de Hulst slab (MCML paper's Table 2 case): n = 1 in n = 1, μa = 1, μs = 9 /mm, g = 0.75,
/// d = 0.2 mm: Rd = 0.09739, Tt = 0.66096 (Tt includes the unscattered e⁻²).
#[test]
fn van_de_hulst_slab() {
    let s = Stack::new(vec![Layer::new(1.0, 1.0, 9.0, 0.75, 0.2).unwrap()], 1.0, 1.0).unwrap();
    let out = go(&s, RunConfig::new(100_000, 11));
    let t = &out.tally;
    within("Rd", t.get(Total::Diffuse), 0.09739, 4.0);
    within("Tt", t.get(Total::Transmittance), 0.66096, 4.0);
    within("Tu", t.get(Total::Unscattered), (-2.0f64).exp(), 4.0);
    assert_eq!(t.get(Total::Specular).0, 0.0);
    assert!((t.energy_balance() - 1.0).abs() < 1e-12);
    assert_eq!(out.photons, 100_000);
    assert!(!out.cancelled && out.events > 100_000);
}

/// A clear glass slab (σa = σs = 0, n = 1.5 in air) at normal incidence: incoherent multiple
/// reflections give R = R₀ + (1−R₀)² R₀ /(1 − R₀²) = 2R₀/(1+R₀), R₀ = ((n−1)/(n+1))².
#[test]
fn glass_slab() {
    let s = Stack::new(vec![Layer::new(1.5, 0.0, 0.0, 0.0, 1.0).unwrap()], 1.0, 1.0).unwrap();
    let out = go(&s, RunConfig::new(200_000, 3));
    let t = &out.tally;
    let r0 = 0.04;
    assert!((t.get(Total::Specular).0 - r0).abs() < 1e-12);
    let spec_plus_rd = (t.get(Total::Specular).0 + t.get(Total::Diffuse).0, t.get(Total::Diffuse).1);
    within("R", spec_plus_rd, 2.0 * r0 / (1.0 + r0), 4.0);
    assert_eq!(t.get(Total::Absorbed).0, 0.0);
    assert_eq!(t.get(Total::Transmittance).0, t.get(Total::Unscattered).0);
    assert!((t.energy_balance() - 1.0).abs() < 1e-12);
    assert_eq!(out.events, 0);
}

/// Energy balance to rounding for mismatched, multi-layer, clear, mixture and diffuse cases;
/// thread-count invariance (bit-identical) and seed dependence.
#[test]
fn balance_and_reproducibility() {
    let mix = Phase::mixture(&[(0.7, 0.9), (0.3, -0.3)]).unwrap();
    let s = Stack::new(
        vec![
            Layer::new(1.5, 0.0, 0.0, 0.0, 0.1).unwrap(),
            Layer::new(1.4, 0.5, 20.0, 0.8, 0.3).unwrap(),
            Layer::with_phase(1.33, 0.2, 10.0, mix, 0.5).unwrap(),
            Layer::new(1.45, 0.05, 5.0, 0.0, f64::INFINITY).unwrap(),
        ],
        1.0,
        1.2,
    )
    .unwrap();
    for source in [Source::default(), Source::Pencil { theta: 1.2, phi: 0.4 }, Source::Diffuse] {
        let mut cfg = RunConfig::new(10_000, 5);
        cfg.source = source;
        cfg.threads = Some(1);
        let a = go(&s, cfg);
        assert!((a.tally.energy_balance() - 1.0).abs() < 1e-12, "{}", a.tally.energy_balance() - 1.0);
        cfg.threads = Some(2);
        let b = go(&s, cfg);
        assert_eq!(a.tally, b.tally);
        assert_eq!(a.events, b.events);
        cfg.seed = 6;
        let c = go(&s, cfg);
        assert_ne!(a.tally.get(Total::Diffuse).0, c.tally.get(Total::Diffuse).0);
        let per_layer: f64 = a.tally.absorbed_per_layer().iter().map(|x| x.0).sum();
        assert!((per_layer - a.tally.get(Total::Absorbed).0).abs() < 1e-12);
    }
}

/// Exact semi-infinite, index-matched, isotropic, normal incidence (van de Hulst's tables):
/// Rd = 0.28525 at albedo 0.8.
#[test]
fn semi_infinite_isotropic() {
    let s = Stack::new(vec![Layer::new(1.0, 0.2, 0.8, 0.0, f64::INFINITY).unwrap()], 1.0, 1.0).unwrap();
    let out = go(&s, RunConfig::new(100_000, 2));
    within("Rd", out.tally.get(Total::Diffuse), 0.28525, 4.0);
    assert_eq!(out.tally.get(Total::Transmittance).0, 0.0);
}

#[test]
fn cancel_and_bad_input() {
    let s = Stack::new(vec![Layer::new(1.0, 1.0, 9.0, 0.75, 0.2).unwrap()], 1.0, 1.0).unwrap();
    let cancel = AtomicBool::new(true);
    let progress = AtomicU64::new(0);
    let out = run(&s, &RunConfig::new(10_000, 0), || Totals::new(1), &cancel, &progress).unwrap();
    assert!(out.cancelled && out.photons == 0 && out.tally.photons() == 0);
    let progress = AtomicU64::new(0);
    let out = run(&s, &RunConfig::new(10_000, 0), || Totals::new(1), &AtomicBool::new(false), &progress).unwrap();
    assert_eq!(progress.load(std::sync::atomic::Ordering::Relaxed), 10_000);
    assert_eq!(out.tally.photons(), 10_000);
    let mut cfg = RunConfig::new(0, 0);
    assert!(run(&s, &cfg, || (), &cancel, &progress).is_err());
    cfg.photons = 1;
    cfg.threads = Some(0);
    assert!(run(&s, &cfg, || (), &cancel, &progress).is_err());
    cfg.threads = None;
    cfg.source = Source::Pencil { theta: f64::NAN, phi: 0.0 };
    assert!(run(&s, &cfg, || (), &cancel, &progress).is_err());
}

/// Not a test: `cargo test -p subsurf-core bench_kernel -- --ignored --nocapture` prints the
/// single-thread kernel speed (Totals tally) for the cases (a), (c), (d), per second of
/// this thread's CPU time (the machine may be shared) and of wall time.
#[test]
#[ignore]
fn bench_kernel() {
    let layer = |n, mua, mus, g, d| Layer::new(n, mua, mus, g, d).unwrap();
    let cases = [
        ("a", Stack::new(vec![layer(1.0, 1.0, 9.0, 0.75, 0.2)], 1.0, 1.0).unwrap(), 400_000),
        (
            "c",
            Stack::new(
                vec![
                    layer(1.4, 0.1, 10.0, 0.9, 0.1),
                    layer(1.4, 0.05, 15.0, 0.85, 2.0),
                    layer(1.4, 0.02, 12.0, 0.9, 10.0),
                ],
                1.0,
                1.0,
            )
            .unwrap(),
            8_000,
        ),
        ("d", Stack::new(vec![layer(1.4, 0.01, 10.0, 0.9, 100.0)], 1.0, 1.0).unwrap(), 3_000),
    ];
    for (name, s, n) in cases {
        // Traced on this thread, to read its own CPU time.
        let k = super::kernel::Kernel::new(&s, Source::default());
        let mut t = Totals::new(s.layers.len());
        let (t0, c0) = (std::time::Instant::now(), cpu_ns());
        let mut events = 0;
        for i in 0..n {
            events += k.trace::<Totals, false, false>(1, i, &mut t);
        }
        let (dt, cpu) = (t0.elapsed().as_secs_f64(), (cpu_ns() - c0) as f64 * 1e-9);
        println!(
            "case {name}: {:.3e} events/s of CPU time ({:.3e} wall), {:.3e} photons/s of CPU time ({events} events)",
            events as f64 / cpu,
            events as f64 / dt,
            n as f64 / cpu,
        );
    }
}

/// CPU time of the calling thread in ns, from /proc/thread-self/schedstat (Linux; 0 elsewhere).
fn cpu_ns() -> u64 {
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()
        .and_then(|s| s.split_whitespace().next().and_then(|x| x.parse().ok()))
        .unwrap_or(0)
}
