//! Tests of the lane kernel: its sampling (χ²), the same bits on every instruction set,
//! agreement with the scalar reference kernel, coverage of the standard errors, and the
//! benchmarks of the kernel alone and of whole runs.

use super::*;
use crate::mc::kernel::Kernel;
use crate::mc::source::Source;
use crate::mc::tally::totals::Totals;
use crate::medium::{Layer, Stack};
use std::sync::atomic::AtomicBool;

fn layer(n: f64, mua: f64, mus: f64, g: f64, d: f64) -> Layer {
    Layer::new(n, mua, mus, g, d).unwrap()
}

use crate::mc::tally::totals::Total;
use crate::mc::tally::{HistogramOut, TallyConfig, TallySet};
use crate::mc::{run, RunConfig};
use crate::optics::Phase;
use crate::rng::PhotonRng;
use crate::stats::{chi2_test_cos_phi, graded_cos_edges, sidak_alpha, uniform_edges};
use std::f64::consts::PI;
use std::sync::atomic::AtomicU64;

/// The lane kernel's scattering (HG 1 − cos θ by [`hg_one_minus_cos`] and the azimuth and
/// MCML's update by [`spin_word`], in f32: the code the kernel's loop inlines) against the HG
/// pdf × uniform φ, in the frame of the incident direction: χ² on a graded (cos θ, φ) grid
/// (cells down to 10⁻⁵ in cos θ at both ends), 5 HG values × 3 incident directions (normal
/// incidence, which takes the special form; a generic one; one 10⁻⁴ rad from the pole, where
/// 1 − uz² has lost its precision in f32) at overall α = 0.01 (Šidák), 2·10⁵ samples each.
/// Power: a relative deviation ±δ of the cell probabilities over cells holding a fraction f of
/// the probability adds λ = N Σ(δp)²/p ≈ N f δ² to X²; at α_i = 6.7·10⁻⁴ (15 tests) on ≈ 320
/// cells the test fails with probability 0.9 once λ ≳ 130 (non-central χ²), so with N = 2·10⁵
/// δ ≈ 2.6 % spread over the whole pdf, or ≈ 8 % confined to a tenth of it, fails.
#[test]
fn lane_scattering_chi2() {
    let dirs = [[0.0, 0.0, -1.0], [1.0, -1.0, 1.0], [6e-5, 8e-5, 1.0]];
    let gs = [0.0, 0.75, 0.9, 0.95, -0.5];
    let alpha = sidak_alpha(0.01, gs.len() * dirs.len()).unwrap();
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let unit = |v: [f64; 3]| {
        let l = dot(v, v).sqrt();
        [v[0] / l, v[1] / l, v[2] / l]
    };
    for (k, g) in gs.into_iter().enumerate() {
        let phase = Phase::hg(g).unwrap();
        let kc = [(1.0 - g) as f32, (2.0 * g) as f32, ((1.0 - g) * (1.0 + g)) as f32];
        for (j, d) in dirs.into_iter().enumerate() {
            let d = unit(d);
            let df = [d[0] as f32, d[1] as f32, d[2] as f32];
            // An orthonormal frame (t1, t2, d) of the f32 direction.
            let d = [df[0] as f64, df[1] as f64, df[2] as f64];
            let d = unit(d);
            let t1 = if d[2].abs() > 0.9 { [1.0, 0.0, 0.0] } else { [0.0, 0.0, 1.0] };
            let p = dot(t1, d);
            let t1 = unit([t1[0] - p * d[0], t1[1] - p * d[1], t1[2] - p * d[2]]);
            let t2 = [d[1] * t1[2] - d[2] * t1[1], d[2] * t1[0] - d[0] * t1[2], d[0] * t1[1] - d[1] * t1[0]];
            let mut rng = PhotonRng::new(40 + k as u64, j as u64);
            let samples: Vec<(f64, f64)> = (0..200_000)
                .map(|_| {
                    let m = hg_one_minus_cos(kc, super::math::open01_f32(rng.next_u32()));
                    let e = spin_word(df[0], df[1], df[2], m, rng.next_u32());
                    let e = unit([e.0 as f64, e.1 as f64, e.2 as f64]);
                    let p = dot(e, t2).atan2(dot(e, t1));
                    (dot(e, d).clamp(-1.0, 1.0), if p < 0.0 { p + 2.0 * PI } else { p })
                })
                .collect();
            let edges = graded_cos_edges(12, 16, 1e-5).unwrap();
            let r =
                chi2_test_cos_phi(&samples, &|c, _| phase.pdf(c), &edges, &uniform_edges(0.0, 2.0 * PI, 8)).unwrap();
            println!("g = {g}, direction {j}: p = {:.3}", r.p_value);
            assert!(r.p_value > alpha, "g = {g}, direction {d:?}: {r:?}");
        }
    }
}

/// 1 − cos θ keeps its relative precision at the forward peak: against the f64 formula
/// 1 − cos θ = (t² − (1 − g)²)/(2g) evaluated in exact-enough f64 at the same f32 ξ, within
/// 6·10⁻⁷ relative (10 roundings of 2⁻²⁴: the formula has 7 correctly rounded operations,
/// the denominator's error entering twice) over 10⁶ words and the words nearest ξ = 1, for
/// g = 0.9, 0.99, 10⁻³, −0.7; and 2(1 − ξ) exactly for g = 0. The rearranged form itself is
/// checked in f64 against the textbook 1 − cos θ = 1 − (1 + g² − t²)/(2g) (MCML eq. 3.28) on a
/// grid of ξ, within that form's own rounding: 8 ε (1 + g² + t²)/(2|g|) absolute.
#[test]
fn hg_one_minus_cos_is_relatively_precise() {
    for g in [0.9f64, 0.99, 1e-3, -0.7] {
        for i in 0..=1000 {
            let u = i as f64 / 1000.0;
            let d = 1.0 - g + 2.0 * g * u;
            let t = (1.0 - g * g) / d;
            let rearranged = (1.0 - g) * (1.0 - u) * (t + 1.0 - g) / d;
            let textbook = 1.0 - (1.0 + g * g - t * t) / (2.0 * g);
            let tol = 8.0 * f64::EPSILON * (1.0 + g * g + t * t) / (2.0 * g.abs());
            assert!((rearranged - textbook).abs() <= tol, "g = {g}, ξ = {u}: {rearranged} vs {textbook}");
        }
    }
    let mut rng = PhotonRng::new(9, 10);
    for g in [0.9f64, 0.99, 1e-3, -0.7, 0.0] {
        let k = [(1.0 - g) as f32, (2.0 * g) as f32, ((1.0 - g) * (1.0 + g)) as f32];
        let (gf, omg) = (k[1] as f64 / 2.0, k[0] as f64);
        let mut worst = 0.0f64;
        let top = (0..4096u32).map(|i| u32::MAX - (i << 9));
        for w in top.chain((0..1_000_000).map(|_| rng.next_u32())) {
            let u = super::math::open01_f32(w);
            let m = hg_one_minus_cos(k, u) as f64;
            let uf = u as f64;
            // reference from the f32-rounded constants (the sampler's own g), in f64
            let d = omg + 2.0 * gf * uf;
            let exact = omg * (1.0 - uf) * ((k[2] as f64) / d + omg) / d;
            if g == 0.0 {
                assert_eq!(m, 2.0 * (1.0 - uf));
            }
            worst = worst.max(((m - exact) / exact).abs());
        }
        println!("g = {g}: 1 − cos θ within {worst:.2e} relative");
        assert!(worst < 6e-7, "g = {g}: {worst}");
    }
}

/// The f32 direction update against the same update in f64 (on the same f32 inputs, std's
/// f64 cos/sin of the same azimuth and f64's 1 − cos θ) at polar distances 10⁻¹…10⁻⁵ rad
/// from ±z and generic directions: within 6·10⁻⁷ (Euclidean) over 10⁵ draws each; with
/// ρ² = 1 − uz² instead of ux² + uy² the error near the pole is ~ρ; prints the worst. Where
/// 1 − uz² keeps 10⁻¹² relative in f64 (ρ ≥ 10⁻²), also against the engine's own f64 update
/// [`crate::optics::spin`], within the same bound.
#[test]
fn spin_word_matches_f64_near_the_pole() {
    let mut rng = PhotonRng::new(15, 16);
    let k = [0.1f32, 1.8, 0.19];
    let mut worst = 0.0f64;
    for rho in [0.5, 1e-1, 1e-2, 1e-3, 1e-4, 1e-5] {
        for _ in 0..100_000 {
            let phi = 2.0 * PI * super::math::open01_f32(rng.next_u32()) as f64;
            let sgn = if rng.next_u32() & 1 == 1 { 1.0 } else { -1.0 };
            let (sx, sy): (f64, f64) = (rho * phi.cos(), rho * phi.sin());
            let d = [sx as f32, sy as f32, (sgn * (1.0 - rho * rho).sqrt()) as f32];
            let m = hg_one_minus_cos(k, super::math::open01_f32(rng.next_u32()));
            let word = rng.next_u32();
            let e = spin_word(d[0], d[1], d[2], m, word);
            // f64 reference: the same formula on the unit vector of the f32 inputs
            let (ux, uy, uz) = (d[0] as f64, d[1] as f64, d[2] as f64);
            let n = (ux * ux + uy * uy + uz * uz).sqrt();
            let (ux, uy, uz) = (ux / n, uy / n, uz / n);
            let t = 2.0 * PI * crate::rng::u32_to_open01(word);
            let (cp, sp) = (t.cos(), t.sin());
            let (m, t2) = (m as f64, ux * ux + uy * uy);
            let (cth, q) = (1.0 - m, (m * (2.0 - m) / t2).sqrt());
            let r = [
                q * (ux * uz * cp - uy * sp) + ux * cth,
                q * (uy * uz * cp + ux * sp) + uy * cth,
                -q * cp * t2 + uz * cth,
            ];
            let err = ((e.0 as f64 - r[0]).powi(2) + (e.1 as f64 - r[1]).powi(2) + (e.2 as f64 - r[2]).powi(2)).sqrt();
            worst = worst.max(err);
            if rho >= 1e-2 {
                let o = crate::optics::spin([ux, uy, uz], cth, cp, sp);
                let err =
                    ((e.0 as f64 - o[0]).powi(2) + (e.1 as f64 - o[1]).powi(2) + (e.2 as f64 - o[2]).powi(2)).sqrt();
                worst = worst.max(err);
            }
        }
    }
    println!("spin_word: within {worst:.2e} of the f64 update");
    assert!(worst < 6e-7, "{worst}");
}

/// A long f32 history keeps |u| = 1: 10⁶ successive scatterings (g = 0.9) of one direction
/// by [`spin_word`] stay within 2.5·10⁻⁷ of unit length (without the Newton step f32
/// rounding would random-walk |u| by ~10⁻⁴); prints the worst.
#[test]
fn spin_word_keeps_unit_length() {
    let mut rng = PhotonRng::new(11, 12);
    let k = [0.1f32, 1.8, 0.19];
    let (mut ux, mut uy, mut uz) = (0.0f32, 0.0f32, 1.0f32);
    let mut worst = 0.0f64;
    for _ in 0..1_000_000 {
        let m = hg_one_minus_cos(k, super::math::open01_f32(rng.next_u32()));
        (ux, uy, uz) = spin_word(ux, uy, uz, m, rng.next_u32());
        let n = ((ux as f64).powi(2) + (uy as f64).powi(2) + (uz as f64).powi(2)).sqrt();
        worst = worst.max((n - 1.0).abs());
    }
    println!("spin_word: ||u| − 1| ≤ {worst:.2e} over 10⁶ scatterings");
    assert!(worst < 2.5e-7, "{worst}");
}

/// A stack with every feature the kernel branches on: a clear layer, mismatched indices,
/// a phase-function mixture, a semi-infinite bottom.
fn hard_stack() -> Stack {
    let mix = Phase::mixture(&[(0.7, 0.9), (0.3, -0.3)]).unwrap();
    Stack::new(
        vec![
            layer(1.5, 0.0, 0.0, 0.0, 0.1),
            layer(1.4, 0.5, 20.0, 0.8, 0.3),
            Layer::with_phase(1.33, 0.2, 10.0, mix, 0.5).unwrap(),
            layer(1.45, 0.05, 5.0, 0.0, f64::INFINITY),
        ],
        1.0,
        1.2,
    )
    .unwrap()
}

fn every_tally() -> TallyConfig {
    TallyConfig {
        nr: 20,
        dr: 0.1,
        nz: 20,
        dz: 0.05,
        na: 6,
        nt: 10,
        dt: 2.0,
        brdf: Some((4, 3)),
        max_order: Some(3),
        ..TallyConfig::default()
    }
}

fn run_all(s: &Stack, cfg: &RunConfig, tc: &TallyConfig) -> (Totals, Vec<HistogramOut>, u64) {
    let nl = s.layers.len();
    let set = TallySet::new(tc, s).unwrap();
    let out = run(s, cfg, || (Totals::new(nl), set.clone()), &AtomicBool::new(false), &AtomicU64::new(0)).unwrap();
    let h = out.tally.1.finalize(out.photons);
    (out.tally.0, h, out.events)
}

/// Every instruction set this machine has gives the same bits (totals, every histogram and
/// its errors, events) for every source, and so does any thread count.
#[test]
fn same_bits_on_every_instruction_set_and_thread_count_slow() {
    let s = hard_stack();
    for source in [Source::default(), Source::Pencil { theta: 1.2, phi: 0.4 }, Source::Diffuse] {
        let mut cfg = RunConfig::new(6_000, 3);
        cfg.source = source;
        cfg.threads = Some(1);
        let reference = run_all(&s, &cfg, &every_tally());
        assert!((reference.0.energy_balance() - 1.0).abs() < 1e-12);
        for isa in Isa::available() {
            for threads in [1, 2] {
                cfg.isa = Some(isa);
                cfg.threads = Some(threads);
                let other = run_all(&s, &cfg, &every_tally());
                assert_eq!(other.0, reference.0, "{isa:?}, {threads} threads: totals");
                assert_eq!(other.2, reference.2, "{isa:?}: events");
                for (a, b) in other.1.iter().zip(&reference.1) {
                    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                    assert_eq!(bits(&a.values), bits(&b.values), "{isa:?}: {}", a.name);
                    assert_eq!(bits(&a.stderr), bits(&b.stderr), "{isa:?}: {} stderr", a.name);
                }
            }
        }
    }
}

/// The lane kernel and the scalar reference kernel (`mc::kernel`, the same physics with the
/// azimuth drawn from a disc point) agree on every total and per-layer absorption of the hard
/// stack within 4 combined standard errors (independent runs: different seeds); the
/// transmittance is exactly 0 for both (semi-infinite bottom). Power: Rd ≈ 0.27, A ≈ 0.68 with
/// 6·10⁴ photons a side, so the 4 combined σ band (√2 · 4σ, σ ≈ 1.1·10⁻³ each) is ≈ 2.3 % of Rd
/// and ≈ 0.9 % of A; for the layers (A ≈ 0.44, 0.16, 0.08, binomial σ ≈ √(A(1−A)/N)) it is
/// ≈ 2.6 %, 5 % and 8 %: a 3 % bias of a total, or 8 % of the deepest layer's absorption, fails.
#[test]
fn lanes_agree_with_scalar_reference_slow() {
    let s = hard_stack();
    let nl = s.layers.len();
    let n = 60_000;
    let mut cfg = RunConfig::new(n, 21);
    cfg.source = Source::Pencil { theta: 0.5, phi: 0.0 };
    let lanes = run(&s, &cfg, || Totals::new(nl), &AtomicBool::new(false), &AtomicU64::new(0)).unwrap().tally;
    let k = Kernel::new(&s, cfg.source);
    let mut scalar = Totals::new(nl);
    for i in 0..n {
        k.trace::<Totals, true, true>(22, i, &mut scalar, &AtomicBool::new(false)).unwrap();
    }
    let check = |name: &str, (a, sa): (f64, f64), (b, sb): (f64, f64)| {
        let se = (sa * sa + sb * sb).sqrt();
        assert!((a == b && se == 0.0) || (a - b).abs() < 4.0 * se, "{name}: lanes {a} ± {sa}, scalar {b} ± {sb}");
    };
    for (name, q) in [("Rd", Total::Diffuse), ("Tt", Total::Transmittance), ("A", Total::Absorbed)] {
        check(name, lanes.get(q), scalar.get(q));
    }
    for (j, (a, b)) in lanes.absorbed_per_layer().into_iter().zip(scalar.absorbed_per_layer()).enumerate() {
        if j > 0 {
            check(&format!("A layer {j}"), a, b);
        }
    }
}

/// Coverage of the standard errors: 200 independent runs (seeds) of the van de Hulst slab
/// (Rd = 0.09739, Tt = 0.66096, A = 1 − Rd − Tt, MCML paper Table 2) with 16384 photons each;
/// the fraction of runs whose estimate lies within 1 (2) reported standard errors of the exact
/// value must match 68.3 % (95.4 %) within 3 binomial standard errors (3 × 3.3 % and 3 × 1.5 %
/// points for 200 runs). Checked for the per-photon errors of the totals and of an escape histogram
/// (rd_r, one bin over the whole surface), and for the batch-means errors of an absorption
/// histogram (a_z, one bin over the whole slab: its
/// physical deposits, whose mean is A since roulette's term has mean 0; 64 batches of 256
/// photons, so the t-distribution of the estimate, 67.9 % and 95.0 % for 63 degrees of
/// freedom, is within the tolerance of the normal one). Power: the coverage bands are ±9.9 and
/// ±4.4 % points, so (90 % power: band + 1.28 binomial σ) reported errors below ≈ 0.75× the true
/// ones (1 σ: 2Φ(0.74) − 1 = 54 %; 2 σ: 0.80×) or above ≈ 1.35× (1 σ coverage 82 %) fail; a
/// 10 % error in the reported σ usually passes. The exact values hold to 5·10⁻⁶, below 1 % of
/// σ ≥ 2·10⁻³ at 16384 photons.
#[test]
fn standard_errors_cover_the_exact_values() {
    let s = Stack::new(vec![layer(1.0, 1.0, 9.0, 0.75, 0.2)], 1.0, 1.0).unwrap();
    let (rd, tt) = (0.09739, 0.66096);
    let tc =
        TallyConfig { nr: 1, dr: 1e3, nz: 1, dz: 1.0, na: 1, spatial: true, angular: true, ..TallyConfig::default() };
    let area = PI * 1e6;
    let runs = 200;
    let mut inside = [[0u32; 2]; 4];
    for seed in 0..runs {
        let mut cfg = RunConfig::new(16_384, 1000 + seed);
        cfg.threads = Some(1);
        let (t, h, _) = run_all(&s, &cfg, &tc);
        let get = |name: &str| h.iter().find(|x| x.name == name).unwrap();
        let (r, a) = (get("rd_r"), get("a_z"));
        let est = [
            (t.get(Total::Diffuse), rd),
            (t.get(Total::Transmittance), tt),
            ((r.values[0] * area, r.stderr[0] * area), rd),
            ((a.values[0], a.stderr[0]), 1.0 - rd - tt),
        ];
        for (k, ((m, se), exact)) in est.into_iter().enumerate() {
            for (j, z) in [1.0, 2.0].into_iter().enumerate() {
                inside[k][j] += ((m - exact).abs() < z * se) as u32;
            }
        }
    }
    let names = ["Rd (per photon)", "Tt (per photon)", "rd_r (per photon)", "a_z (batch means)"];
    for (k, name) in names.iter().enumerate() {
        for (j, p) in [0.6827, 0.9545].into_iter().enumerate() {
            let f = inside[k][j] as f64 / runs as f64;
            println!("{name}: {f:.3} of the runs within {} σ (expected {p})", j + 1);
            let tol = 3.0 * (p * (1.0 - p) / runs as f64).sqrt();
            assert!((f - p).abs() < tol, "{name}: {f} of the runs within {} σ (expected {p} ± {tol})", j + 1);
        }
    }
}

/// The benchmark cases (a), (c), (d) of `make bench`.
pub(crate) fn bench_cases() -> Vec<(&'static str, Stack, u64)> {
    vec![
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
    ]
}

/// CPU time of the calling thread in ns, from /proc/thread-self/schedstat (Linux; 0 elsewhere).
fn cpu_ns() -> u64 {
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()
        .and_then(|s| s.split_whitespace().next().and_then(|x| x.parse().ok()))
        .unwrap_or(0)
}

/// Not a test: `cargo test -p subsurf-core bench_lanes -- --ignored --nocapture` prints the
/// single-thread speed of the lane kernel on each instruction set and of the scalar reference
/// (Totals tally), per second of this thread's CPU time.
#[test]
#[ignore]
fn bench_lanes() {
    let filter = std::env::var("BENCH_CASE").unwrap_or_default();
    for (name, s, n) in bench_cases() {
        if !filter.is_empty() && !filter.contains(name) {
            continue;
        }
        let k = Kernel::new(&s, Source::default());
        let nl = s.layers.len();
        let mut line = format!("case {name}:");
        let isa_filter = std::env::var("BENCH_ISA").unwrap_or_default();
        for isa in Isa::available() {
            if !isa_filter.is_empty() && isa.name() != isa_filter {
                continue;
            }
            let mut t = Totals::new(nl);
            let c0 = cpu_ns();
            let ev = trace_range(isa, &k, 1, 0..n, &mut t, &AtomicBool::new(false)).unwrap();
            let cpu = (cpu_ns() - c0) as f64 * 1e-9;
            line +=
                &format!(" {} {:.3e} ev/s ({:.3e} ph/s, {ev} events);", isa.name(), ev as f64 / cpu, n as f64 / cpu);
        }
        if !isa_filter.is_empty() {
            println!("{line}");
            continue;
        }
        let mut t = Totals::new(nl);
        let c0 = cpu_ns();
        let mut ev = 0;
        for i in 0..n {
            ev += k.trace::<Totals, false, false>(1, i, &mut t, &AtomicBool::new(false)).unwrap();
        }
        let cpu = (cpu_ns() - c0) as f64 * 1e-9;
        line += &format!(" scalar reference {:.3e} ev/s", ev as f64 / cpu);
        println!("{line}");
    }
}

/// CPU time of the whole process (all threads), s, from /proc/self/stat (Linux; 0 elsewhere).
fn process_cpu_s() -> f64 {
    std::fs::read_to_string("/proc/self/stat")
        .ok()
        .and_then(|s| {
            let f: Vec<&str> = s.rsplit(')').next()?.split_whitespace().collect();
            Some((f[11].parse::<f64>().ok()? + f[12].parse::<f64>().ok()?) / 100.0)
        })
        .unwrap_or(0.0)
}

/// Not a test: `cargo test --release -p subsurf-core bench_runs -- --ignored --nocapture` prints
/// events per CPU-second of whole runs (`mc::run`, 1 thread) with the totals and with MCML's
/// tally set (100 × 0.01 mm in r and z, 30 angles), with and without errors.
#[test]
#[ignore]
fn bench_runs() {
    use crate::mc::tally::{TallyConfig, TallySet};
    use crate::mc::{run, RunConfig};
    use std::sync::atomic::AtomicU64;
    let filter = std::env::var("BENCH_CASE").unwrap_or_default();
    for (name, s, n) in bench_cases() {
        if !filter.is_empty() && !filter.contains(name) {
            continue;
        }
        let nl = s.layers.len();
        let mut cfg = RunConfig::new(n * 4, 1);
        cfg.threads = Some(1);
        let (stop, done) = (AtomicBool::new(false), AtomicU64::new(0));
        let mut line = format!("case {name}:");
        let c0 = process_cpu_s();
        let ev = run(&s, &cfg, || Totals::new(nl), &stop, &done).unwrap().events;
        line += &format!(" totals {:.3e} ev/CPU-s;", ev as f64 / (process_cpu_s() - c0));
        for errors in [true, false] {
            let set = TallySet::new(&TallyConfig { errors, ..TallyConfig::default() }, &s).unwrap();
            let c0 = process_cpu_s();
            let ev = run(&s, &cfg, || (Totals::new(nl), set.clone()), &stop, &done).unwrap().events;
            line += &format!(" mcml set (errors {errors}) {:.3e} ev/CPU-s;", ev as f64 / (process_cpu_s() - c0));
        }
        println!("{line}");
    }
}

/// `SUBSURF_ISA`'s values: every name this machine runs is taken (case and spaces aside, empty
/// = no choice, `baseline` = `scalar`); an unknown name, and a known one this CPU lacks, are
/// refused with a message naming the variable, the value and what the CPU runs.
#[test]
fn forced_instruction_set_is_parsed_and_checked() {
    assert_eq!(Isa::parse_forced("").unwrap(), None);
    assert_eq!(Isa::parse_forced("  ").unwrap(), None);
    assert_eq!(Isa::parse_forced("baseline").unwrap(), Some(Isa::Scalar));
    for isa in Isa::available() {
        assert_eq!(Isa::parse_forced(&format!(" {} ", isa.name().to_uppercase())).unwrap(), Some(isa));
    }
    let here = Isa::available().iter().map(|i| i.name()).collect::<Vec<_>>().join(", ");
    let err = Isa::parse_forced("avx1024").unwrap_err().to_string();
    assert!(err.contains("SUBSURF_ISA") && err.contains("avx1024") && err.contains(&here), "{err}");
    for isa in Isa::ALL.into_iter().filter(|i| !i.runs_here()) {
        let err = Isa::parse_forced(isa.name()).unwrap_err().to_string();
        assert!(err.contains("not supported by this CPU") && err.contains(&here), "{err}");
    }
    #[cfg(target_arch = "x86_64")]
    assert!(Isa::available().contains(&Isa::Sse4) == std::arch::is_x86_feature_detected!("sse4.2"));
}
