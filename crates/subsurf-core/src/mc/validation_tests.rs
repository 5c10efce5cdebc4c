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
/// d = 0.2 mm: Rd = 0.09739, Tt = 0.66096 (Tt includes the unscattered e⁻²). Power: with 10⁵
/// photons σ ≈ √(p(1−p)/N), so the 4σ band is ≈ 3.8 % of Rd, 0.9 % of Tt and 3.2 % of the
/// unscattered e⁻²: a 4 % bias of Rd or a 1 % bias of Tt fails.
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
/// Power: only the diffuse part (≈ 0.037) is random; with 2·10⁵ photons its 4σ band
/// (≈ 4√(p(1−p)/N) = 1.7·10⁻³) is 2.2 % of R = 0.077 (4.6 % of the diffuse part), so a 2.5 %
/// error in R fails.
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
        // absorbed = physical deposits (per layer) + the roulette term, exactly; the physical
        // part is never negative and the roulette term is zero-mean (4σ)
        let per_layer: f64 = a.tally.absorbed_per_layer().iter().map(|x| x.0).sum();
        let roulette = a.tally.get(Total::Roulette);
        assert!((per_layer + roulette.0 - a.tally.get(Total::Absorbed).0).abs() < 1e-12);
        assert!(a.tally.absorbed_per_layer().iter().all(|x| x.0 >= 0.0));
        assert_eq!(a.tally.absorbed_per_layer()[0].0, 0.0, "a clear layer absorbs nothing");
        assert!(roulette.0.abs() <= 4.0 * roulette.1, "{roulette:?}");
    }
}

/// Exact semi-infinite, index-matched, isotropic, normal incidence (van de Hulst's tables):
/// Rd = 0.28525 at albedo 0.8. Power: with 10⁵ photons the 4σ band (σ ≈ √(p(1−p)/N)) is
/// ≈ 5.7·10⁻³, 2.0 % of Rd, so a 2.5 % bias fails.
#[test]
fn semi_infinite_isotropic() {
    let s = Stack::new(vec![Layer::new(1.0, 0.2, 0.8, 0.0, f64::INFINITY).unwrap()], 1.0, 1.0).unwrap();
    let out = go(&s, RunConfig::new(100_000, 2));
    within("Rd", out.tally.get(Total::Diffuse), 0.28525, 4.0);
    assert_eq!(out.tally.get(Total::Transmittance).0, 0.0);
}

/// Specular reflectance of a pencil beam is deterministic: exactly the Fresnel value, stderr 0.
#[test]
fn deterministic_total_has_zero_stderr() {
    let s = Stack::new(vec![Layer::new(1.4, 0.1, 10.0, 0.9, 1.0).unwrap()], 1.0, 1.0).unwrap();
    let mut cfg = RunConfig::new(5_000, 3);
    cfg.source = Source::Pencil { theta: 1.0, phi: 0.5 };
    let out = go(&s, cfg);
    let want = crate::optics::fr_dielectric(1.0f64.cos(), 1.0, 1.4);
    assert_eq!(out.tally.get(Total::Specular), (want, 0.0));
    assert!(out.tally.get(Total::Diffuse).1 > 0.0);
}

#[test]
fn cancel_and_bad_input() {
    let s = Stack::new(vec![Layer::new(1.0, 1.0, 9.0, 0.75, 0.2).unwrap()], 1.0, 1.0).unwrap();
    let cancel = AtomicBool::new(true);
    let progress = AtomicU64::new(0);
    let out = run(&s, &RunConfig::new(10_000, 0), || Totals::new(1), &cancel, &progress).unwrap();
    assert!(out.cancelled && out.photons == 0 && out.tally.photons() == 0);
    let mut cfg = RunConfig::new(1, 0);
    cfg.threads = Some(super::config::MAX_THREADS + 1);
    let e = run(&s, &cfg, || (), &cancel, &progress).unwrap_err().to_string();
    assert!(e.starts_with("threads = 1025 is out of range"), "{e}");
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

/// Inputs from the fuzz campaign that hung a run or gave a wrong answer: each is now refused
/// (naming the field) or traced correctly, and none takes long.
#[test]
fn hostile_inputs_are_refused_or_answered() {
    let layer = |n, mua, mus, d| Layer::new(n, mua, mus, 0.0, d);
    assert!(layer(1.4, 1e308, 1e308, 1.0).unwrap_err().to_string().starts_with("mua + mus = inf"));
    assert!(layer(1.0, 0.0, 1e-320, f64::INFINITY).unwrap_err().to_string().starts_with("mus = 1e-320"));
    assert!(layer(1.0, 1e-310, 1e-310, f64::INFINITY).unwrap_err().to_string().starts_with("mua = 1e-310"));
    let grazing = Source::Pencil { theta: 89.9999999f64.to_radians(), phi: 0.0 };
    assert!(grazing.validate().unwrap_err().to_string().starts_with("source.theta"));
    let e = Stack::new(vec![layer(1.0, 0.0, 0.0, 1e308).unwrap(), layer(1.0, 10.0, 0.0, 1.0).unwrap()], 1.0, 1.0);
    assert!(e.unwrap_err().to_string().starts_with("layers[1].thickness"));
    // the same physics at a normal scale: thin turbid layers under the steepest allowed beam end
    let steep = Source::Pencil { theta: super::source::MAX_PENCIL_THETA, phi: 0.0 };
    for l in [layer(1.5, 0.1, 1.0, 1e-9), layer(1.5, 0.0, 1e-12, 1.0)] {
        let s = Stack::new(vec![l.unwrap()], 1.0, 1.0).unwrap();
        let mut cfg = RunConfig::new(40, 1);
        cfg.source = steep;
        let out = go(&s, cfg);
        assert!((out.tally.energy_balance() - 1.0).abs() < 1e-12);
        assert!(out.tally.get(Total::Transmittance).0 > 0.0);
    }
    // a non-absorbing semi-infinite medium is refused with the explanation
    let white = Stack::new(vec![layer(1.0, 0.0, 1.0, f64::INFINITY).unwrap()], 1.0, 1.0).unwrap();
    let e = run(&white, &RunConfig::new(10, 0), || (), &AtomicBool::new(false), &AtomicU64::new(0));
    assert!(e.unwrap_err().to_string().starts_with("layers[0].mua = 0.0 is out of range"));
}

/// The same photons give the same bits however they are split: one run with 1, 2 or 3 threads,
/// or uneven chunk-aligned ranges traced separately and appended in range order — totals and
/// every histogram. Also: a run cancelled by a tally hook holds a prefix of whole chunks, and
/// continuing it gives the bits of the uninterrupted run.
#[test]
fn exact_merge_is_partition_and_thread_independent() {
    use super::state::{fingerprint, TallyState};
    use super::tally::{TallyConfig, TallySet};
    let s = Stack::new(
        vec![Layer::new(1.4, 0.3, 8.0, 0.8, 0.2).unwrap(), Layer::new(1.33, 1.0, 4.0, 0.0, f64::INFINITY).unwrap()],
        1.0,
        1.0,
    )
    .unwrap();
    let tc = TallyConfig {
        nr: 7,
        dr: 0.1,
        nz: 6,
        dz: 0.05,
        na: 4,
        nt: 5,
        dt: 1.0,
        brdf: Some((3, 2)),
        max_order: Some(2),
        ..Default::default()
    };
    let proto = TallySet::new(&tc, &s).unwrap();
    let make = || (Totals::new(2), proto.clone());
    let mut layout = Vec::new();
    make().channels(&mut layout);
    let n = 4 * CHUNK + 123; // the last chunk is cut
    let fp = fingerprint(&s, &Source::default(), 4, Some(&tc));
    let range = |start: u64, end: u64, threads: usize| {
        let mut st = TallyState::new(layout.clone(), fp, start).unwrap();
        let mut cfg = RunConfig::new(end, 4);
        cfg.threads = Some(threads);
        let cancelled = extend(&s, &cfg, &mut st, make, &AtomicBool::new(false), &AtomicU64::new(0)).unwrap();
        assert!(!cancelled);
        st
    };
    let whole = range(0, n, 1);
    for threads in [2, 3] {
        assert_eq!(range(0, n, threads), whole, "threads = {threads}");
    }
    for cuts in [vec![CHUNK, 3 * CHUNK], vec![CHUNK, 2 * CHUNK, 3 * CHUNK, 4 * CHUNK]] {
        let mut bounds = vec![0];
        bounds.extend(cuts);
        bounds.push(n);
        let mut merged = range(bounds[0], bounds[1], 2);
        for w in bounds.windows(2).skip(1) {
            merged.append(&range(w[0], w[1], 1)).unwrap();
        }
        assert_eq!(merged, whole, "ranges {bounds:?}");
        let (a, b) = (finish(&merged, make), finish(&whole, make));
        assert_eq!(a.0, b.0);
        assert!(a.1.finalize(n).iter().zip(&b.1.finalize(n)).all(|(x, y)| x.same_bits(y)));
    }
    // cancelled by a hook at photon 2.5 chunks: a prefix of whole chunks, resumable to the same bits
    let cancel = AtomicBool::new(false);
    let hook = || (make(), StopAt { at: 2 * CHUNK + CHUNK / 2, flag: &cancel, panic: false });
    let mut hooked_layout = Vec::new();
    hook().channels(&mut hooked_layout);
    let mut st = TallyState::new(hooked_layout, fp, 0).unwrap();
    let mut cfg = RunConfig::new(n, 4);
    cfg.threads = Some(2);
    assert!(extend(&s, &cfg, &mut st, hook, &cancel, &AtomicU64::new(0)).unwrap());
    assert!(st.end.is_multiple_of(CHUNK) && st.end <= 3 * CHUNK, "{}", st.end);
    let mut part = TallyState::new(layout.clone(), fp, 0).unwrap();
    part.end = st.end;
    part.events = st.events;
    part.channels = st.channels.clone();
    // (on a busy machine the chunks before the hook may still be in flight when it fires: then
    // the prefix is empty)
    let prefix = if st.end == 0 { TallyState::new(layout.clone(), fp, 0).unwrap() } else { range(0, st.end, 1) };
    assert_eq!(part, prefix, "the partial state is the state of its prefix");
    assert!(!extend(&s, &cfg, &mut part, make, &AtomicBool::new(false), &AtomicU64::new(0)).unwrap());
    assert_eq!(part, whole);
}

const CHUNK: u64 = super::config::CHUNK_PHOTONS;

/// A panic in one worker (a bug in a tally) reaches the caller; the other workers, waiting for
/// that worker's chunk, do not hang.
#[test]
fn a_panicking_worker_does_not_hang_the_run() {
    let s = Stack::new(vec![Layer::new(1.0, 1.0, 9.0, 0.75, 0.2).unwrap()], 1.0, 1.0).unwrap();
    let mut cfg = RunConfig::new(12 * CHUNK, 1);
    cfg.threads = Some(3);
    let flag = AtomicBool::new(false);
    let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        run(
            &s,
            &cfg,
            || StopAt { at: CHUNK + 5, flag: &flag, panic: true },
            &AtomicBool::new(false),
            &AtomicU64::new(0),
        )
    }));
    assert!(r.is_err());
}

/// A tally that raises `flag` when photon `at` begins (a deterministic Ctrl-C), or panics.
struct StopAt<'a> {
    at: u64,
    flag: &'a AtomicBool,
    panic: bool,
}

impl Tally for StopAt<'_> {
    fn begin_photon(&mut self, _lane: usize, photon: u64) {
        if photon == self.at {
            assert!(!self.panic, "a bug in a tally");
            self.flag.store(true, std::sync::atomic::Ordering::Relaxed);
        }
    }
    fn specular(&mut self, _lane: usize, _w: f64) {}
    fn absorb(&mut self, _lane: usize, _p: &Packet, _dw: f64) {}
    fn roulette(&mut self, _lane: usize, _p: &Packet, _dw: f64) {}
    fn escape(&mut self, _lane: usize, _p: &Packet, _side: Side, _dir_out: [f64; 3], _w: f64) {}
    fn end_photon(&mut self, _lane: usize) {}
    fn channels(&self, _out: &mut Vec<super::tally::Channel>) {}
    fn drain_into(&mut self, _state: &mut [super::tally::ChannelState]) -> Option<usize> {
        Some(0)
    }
    fn load_from(&mut self, _state: &[super::tally::ChannelState], _photons: u64) -> usize {
        0
    }
}
