//! Property-based tests of the public API with hostile input (proptest): random layers —
//! including extreme, subnormal, infinite and NaN values — stacks, sources and tally
//! configurations must give either a clean [`Error`] or a result whose energy balance holds to
//! 1e-12, with no NaN where none is documented, a prefix state, and never a panic or a hang.
//!
//! Each case traces few photons under a watchdog: after [`CASE_SECONDS`] it raises the run's
//! cancel flag (a legitimately slow case then returns a shorter prefix, which must satisfy the
//! same properties); if the run does not return within [`HANG_SECONDS`] after that, the process
//! aborts — a loop that does not poll the flag is a hang.
//!
//! Cases: 48 by default (CI); `SUBSURF_PROPTEST_CASES=100000 cargo test -p subsurf-core --test
//! proptest_mc -- --nocapture` runs a long campaign and prints its tally of outcomes.
//!
//! proptest is built without `std` (its `std` feature compiles regex-syntax and an OS random
//! source: about 10 of the ~170 CPU seconds of `make test`'s Rust test build): its cases come from one fixed
//! stream, the same in every run (a longer campaign draws further along it), and a panic is
//! turned into a failing case here ([`no_panic`]) so that it is shrunk and its input printed.

use proptest::prelude::*;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::mpsc::{self, RecvTimeoutError};
use std::sync::Mutex;
use std::time::Duration;
use subsurf_core::mc::tally::totals::{Total, Totals};
use subsurf_core::mc::tally::{Channel, TallyConfig, TallySet};
use subsurf_core::mc::{extend, finish, RunConfig, Source, TallyState};
use subsurf_core::medium::{Layer, Stack};
use subsurf_core::optics::{checked, Phase, Polarization};
use subsurf_core::{diffusion, optics, Error};

/// Seconds a case may trace before its run is cancelled.
const CASE_SECONDS: u64 = 2;
/// Seconds a cancelled run may take to return before the test declares a hang.
const HANG_SECONDS: u64 = 20;

fn cases() -> u32 {
    std::env::var("SUBSURF_PROPTEST_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(48)
}

/// Numbers a hostile user might type for a coefficient or thickness.
fn wild() -> impl Strategy<Value = f64> {
    prop_oneof![
        12 => Just(0.0),
        40 => (-3.0f64..3.0).prop_map(|e| 10f64.powf(e)),
        4 => (-320.0f64..-10.0).prop_map(|e| 10f64.powf(e)),
        4 => (10.0f64..308.0).prop_map(|e| 10f64.powf(e)),
        1 => prop_oneof![Just(f64::NAN), Just(f64::INFINITY), Just(f64::NEG_INFINITY), Just(-1.0), Just(f64::MAX)],
        1 => any::<f64>(),
    ]
}

fn index() -> impl Strategy<Value = f64> {
    prop_oneof![30 => 1.0f64..3.0, 3 => Just(1.0), 1 => prop_oneof![Just(0.5), Just(f64::NAN), Just(1e300)]]
}

fn g() -> impl Strategy<Value = f64> {
    prop_oneof![
        80 => -0.999f64..0.999,
        4 => prop_oneof![Just(0.999999), Just(-0.9999999), Just(0.0), Just(1e-7)],
        1 => prop_oneof![Just(1.0), Just(f64::NAN)]
    ]
}

fn thickness() -> impl Strategy<Value = f64> {
    prop_oneof![24 => (-9.0f64..3.0).prop_map(|e| 10f64.powf(e)), 8 => Just(f64::INFINITY), 1 => wild()]
}

type LayerArgs = (f64, f64, f64, Vec<(f64, f64)>, f64);

fn layer(thickness: impl Strategy<Value = f64>) -> impl Strategy<Value = LayerArgs> {
    let lobes =
        prop_oneof![4 => g().prop_map(|g| vec![(1.0, g)]), 1 => prop::collection::vec((0.0f64..1.0, g()), 1..=4)];
    (index(), wild(), wild(), lobes, thickness)
}

/// Upper layers (mostly finite) and a last layer (often semi-infinite).
fn layers() -> impl Strategy<Value = Vec<LayerArgs>> {
    let upper = prop_oneof![30 => (-9.0f64..1.0).prop_map(|e| 10f64.powf(e)), 1 => wild()];
    (prop::collection::vec(layer(upper), 0..=3), layer(thickness())).prop_map(|(mut v, last)| {
        v.push(last);
        v
    })
}

fn source() -> impl Strategy<Value = Source> {
    prop_oneof![
        16 => (0.0f64..std::f64::consts::FRAC_PI_2, -10.0f64..10.0).prop_map(|(theta, phi)| Source::Pencil { theta, phi }),
        1 => Just(Source::Pencil { theta: std::f64::consts::FRAC_PI_2 - 1e-6, phi: 0.0 }),
        1 => prop_oneof![Just(Source::Pencil { theta: f64::NAN, phi: 0.0 }), Just(Source::Pencil { theta: 1.6, phi: 0.0 })],
        8 => Just(Source::Diffuse),
    ]
}

fn width() -> impl Strategy<Value = f64> {
    prop_oneof![30 => (-3.0f64..1.0).prop_map(|e| 10f64.powf(e)), 1 => wild()]
}

/// A bin count: mostly valid, sometimes 0.
fn count(max: usize) -> impl Strategy<Value = usize> {
    prop_oneof![60 => 1..max, 1 => Just(0)]
}

fn tallies() -> impl Strategy<Value = Option<TallyConfig>> {
    let cfg = (
        (count(12), width(), count(12), width(), count(8)),
        (0usize..6, width(), prop::option::of((count(5), count(5))), prop::option::of(0u32..4), any::<(bool, bool)>()),
    )
        .prop_map(|((nr, dr, nz, dz, na), (nt, dt, brdf, max_order, (spatial, angular)))| TallyConfig {
            nr,
            dr,
            nz,
            dz,
            na,
            nt,
            dt,
            brdf,
            max_order,
            spatial,
            angular,
            errors: nr % 2 == 1,
        });
    prop_oneof![1 => Just(None), 3 => cfg.prop_map(Some)]
}

/// Outcomes of the cases run so far (printed by the long campaign).
static OUTCOMES: Mutex<[usize; 4]> = Mutex::new([0; 4]);
const REFUSED: usize = 0;
const TRACED: usize = 1;
const STOPPED: usize = 2;
const EVENTS: usize = 3;
static CASE: AtomicUsize = AtomicUsize::new(0);
/// Refusal messages by their first words (printed by the campaign's report).
static REASONS: Mutex<Vec<(String, usize)>> = Mutex::new(Vec::new());

fn refused(e: &Error) {
    let msg = e.to_string();
    let head =
        if std::env::var("SUBSURF_PROPTEST_FULL").is_ok() { &msg } else { msg.split(" = ").next().unwrap_or(&msg) };
    let key: String = head.chars().take(60).map(|c| if c.is_ascii_digit() { '#' } else { c }).collect();
    let mut r = REASONS.lock().unwrap();
    match r.iter_mut().find(|(k, _)| *k == key) {
        Some(x) => x.1 += 1,
        None => r.push((key, 1)),
    }
    tally(REFUSED, 1);
}

fn tally(k: usize, n: usize) {
    OUTCOMES.lock().unwrap()[k] += n;
}

/// A case's panic as a failure of that case (shrunk and printed like any other).
fn no_panic(f: impl FnOnce() -> Result<(), TestCaseError>) -> Result<(), TestCaseError> {
    catch_unwind(AssertUnwindSafe(f)).unwrap_or_else(|p| {
        let msg = p.downcast_ref::<&str>().map(|s| s.to_string()).or_else(|| p.downcast_ref::<String>().cloned());
        Err(TestCaseError::fail(format!("panic: {}", msg.unwrap_or_default())))
    })
}

/// Run `f` on a thread while a watchdog cancels it after CASE_SECONDS and aborts on a hang (a
/// panic of `f` drops the sender: the watchdog then returns at once).
fn guarded<R: Send>(cancel: &AtomicBool, f: impl FnOnce() -> R + Send) -> R {
    let (tx, rx) = mpsc::channel::<()>();
    std::thread::scope(|s| {
        s.spawn(move || {
            if rx.recv_timeout(Duration::from_secs(CASE_SECONDS)) == Err(RecvTimeoutError::Timeout) {
                cancel.store(true, Ordering::Relaxed);
                if rx.recv_timeout(Duration::from_secs(HANG_SECONDS)) == Err(RecvTimeoutError::Timeout) {
                    eprintln!("hang: a cancelled run did not return within {HANG_SECONDS} s");
                    std::process::abort();
                }
            }
        });
        let r = f();
        let _ = tx.send(());
        r
    })
}

fn make_layer(t: &LayerArgs) -> Result<Layer, Error> {
    let (n, mua, mus, lobes, d) = t;
    let phase = if lobes.len() == 1 { Phase::hg(lobes[0].1)? } else { Phase::mixture(lobes)? };
    Layer::with_phase(*n, *mua, *mus, phase, *d)
}

fn check_case(
    layers: &[LayerArgs],
    n_above: f64,
    n_below: f64,
    source: Source,
    tallies: Option<TallyConfig>,
    photons: u64,
    threads: usize,
) -> Result<(), TestCaseError> {
    CASE.fetch_add(1, Ordering::Relaxed);
    let stack = match layers
        .iter()
        .map(make_layer)
        .collect::<Result<Vec<_>, _>>()
        .and_then(|l| Stack::new(l, n_above, n_below))
    {
        Ok(s) => s,
        Err(e) => {
            prop_assert!(!e.to_string().is_empty());
            refused(&e);
            return Ok(());
        }
    };
    let nl = stack.layers.len();
    let set = match tallies.map(|t| TallySet::new(&t, &stack)).transpose() {
        Ok(s) => s,
        Err(e) => {
            prop_assert!(!e.to_string().is_empty());
            refused(&e);
            return Ok(());
        }
    };
    let cfg = RunConfig { photons, seed: photons ^ 0x5eed, threads: Some(threads), source, isa: None };
    let mut layout: Vec<Channel> = Totals::layout(nl);
    if let Some(t) = &tallies {
        layout.extend(TallySet::layout(t).map_err(|e| TestCaseError::fail(e.to_string()))?);
    }
    let mut state = TallyState::new(layout, 0, 0).map_err(|e| TestCaseError::fail(e.to_string()))?;
    let cancel = AtomicBool::new(false);
    let progress = AtomicU64::new(0);
    let proto = set.clone();
    let out = guarded(&cancel, || match &proto {
        None => extend(&stack, &cfg, &mut state, || (Totals::new(nl), ()), &cancel, &progress),
        Some(p) => extend(&stack, &cfg, &mut state, || (Totals::new(nl), p.clone()), &cancel, &progress),
    });
    let cancelled = match out {
        Err(e) => {
            prop_assert!(!e.to_string().is_empty());
            refused(&e);
            return Ok(());
        }
        Ok(c) => c,
    };
    // a prefix of whole chunks (or all photons)
    prop_assert!(state.start == 0 && state.end <= photons);
    prop_assert!(state.end == photons || (cancelled && state.end % 4096 == 0));
    tally(if cancelled { STOPPED } else { TRACED }, 1);
    tally(EVENTS, state.events as usize);
    let n = state.photons();
    if n == 0 {
        return Ok(());
    }
    let (t, hists) = match &set {
        None => (finish(&state, || Totals::new(nl)), Vec::new()),
        Some(p) => {
            let (t, s) = finish(&state, || (Totals::new(nl), p.clone()));
            (t, s.finalize(n))
        }
    };
    let balance = t.energy_balance();
    prop_assert!((balance - 1.0).abs() <= 1e-12, "energy balance {balance}");
    for q in Total::ALL {
        let (m, se) = t.get(q);
        prop_assert!(m.is_finite(), "{q:?} = {m}");
        prop_assert!(se.is_finite() || n < 2, "{q:?} stderr = {se}");
    }
    prop_assert!(t.get(Total::Absorbed).0 >= -1e-12, "absorbed {}", t.get(Total::Absorbed).0);
    for (i, (a, _)) in t.absorbed_per_layer().into_iter().enumerate() {
        prop_assert!(a >= 0.0, "layer {i} absorbed {a}");
    }
    // Histogram errors are batch means: none without errors or with fewer than two batches.
    let errors = tallies.is_some_and(|c| c.errors) && n > subsurf_core::mc::config::BATCH_PHOTONS;
    for h in &hists {
        let documented_nan = h.name.starts_with("fluence");
        for (k, (&v, &se)) in h.values.iter().zip(&h.stderr).enumerate() {
            prop_assert!(v.is_finite() || (documented_nan && v.is_nan()), "{} bin {k} = {v}", h.name);
            prop_assert!(se.is_finite() || !errors || (documented_nan && se.is_nan()), "{} stderr {k} = {se}", h.name);
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(), failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn any_input_gives_an_error_or_a_balanced_result(
        layers in layers(),
        n_above in index(),
        n_below in index(),
        source in source(),
        tallies in tallies(),
        photons in 1u64..60,
        threads in 1usize..=3,
    ) {
        no_panic(|| check_case(&layers, n_above, n_below, source, tallies, photons, threads))?;
    }

    /// The validated optics and diffusion entry points with any numbers: a finite answer or a
    /// clean error, never a panic or a hang.
    #[test]
    fn optics_and_diffusion_functions_answer_or_refuse(
        a in wild(), b in wild(), c in wild(), u in prop_oneof![0.0f64..=1.0, wild()], i in 0u32..20,
    ) {
        no_panic(|| optics_and_diffusion_case(a, b, c, u, i))?;
    }
}

fn optics_and_diffusion_case(a: f64, b: f64, c: f64, u: f64, i: u32) -> Result<(), TestCaseError> {
    let finite = |r: Result<f64, Error>| r.map_or(true, |v| v.is_finite());
    prop_assert!(finite(checked::fresnel_rt(u, a, b, Polarization::Unpolarized, false)));
    prop_assert!(finite(checked::sample_hg(u, c.min(2.0) - 1.0)));
    prop_assert!(finite(checked::free_path_pdf(a, b)));
    prop_assert!(finite(checked::beer_lambert(a, b)));
    prop_assert!(finite(optics::diffuse_fresnel_reflectance(a, true)));
    prop_assert!(finite(optics::diffuse_fresnel_reflectance(a, false)));
    prop_assert!(finite(optics::fresnel_moment(a, i)));
    for m in [diffusion::Model::Dipole, diffusion::Model::BetterDipole] {
        prop_assert!(finite(m.rd(u, a, b, c)));
        prop_assert!(finite(m.total_rd(u, c)));
        prop_assert!(finite(diffusion::alpha_prime_from_rd(u, c, m)));
    }
    Ok(())
}

#[test]
fn a_panic_is_a_failing_case() {
    let r = no_panic(|| panic!("boom"));
    assert!(matches!(r, Err(TestCaseError::Fail(m)) if m.message().contains("panic: boom")));
}

/// The long campaign's tally (printed with `--nocapture`, after the other tests of this file).
#[test]
fn zz_report() {
    let o = *OUTCOMES.lock().unwrap();
    println!(
        "proptest campaign: {} MC cases: {} refused with an error, {} traced, {} stopped by the time guard; {} events",
        CASE.load(Ordering::Relaxed),
        o[REFUSED],
        o[TRACED],
        o[STOPPED],
        o[EVENTS]
    );
    let mut r = REASONS.lock().unwrap().clone();
    r.sort_by_key(|x| std::cmp::Reverse(x.1));
    for (k, n) in r.iter().take(12) {
        println!("  refused {n:6}: {k}");
    }
}
