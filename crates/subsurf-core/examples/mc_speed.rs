//! Profiling harness for the Monte Carlo engine (a fixed amount of work, for `perf` or
//! `valgrind --tool=callgrind`; `make bench` is the benchmark): traces the `make bench` cases
//! with the totals only or with MCML's tally set and prints photons, events, wall and CPU time.
//!
//! Usage: `cargo run --release --example mc_speed -- CASE TALLIES PHOTONS THREADS`, CASE one of
//! a, c, d (benches/bench.py), TALLIES one of totals, mcml, mcml-noerr. With `MC_SPEED_BITS`
//! set, a run also prints the bits of each total and, with tallies, a hash of the bits of every
//! histogram value and standard error (to check that a speed-up keeps them); `SUBSURF_ISA`
//! (avx512, avx2, sse, neon, baseline) forces the lane kernel's instruction set, as for every run.

use std::sync::atomic::{AtomicBool, AtomicU64};
use std::time::Instant;
use subsurf_core::mc::lanes::Isa;
use subsurf_core::mc::tally::totals::{Total, Totals};
use subsurf_core::mc::tally::{TallyConfig, TallySet};
use subsurf_core::mc::{run, RunConfig};
use subsurf_core::medium::{Layer, Stack};

fn case(key: &str) -> Stack {
    let l = |n, mua, mus, g, d| Layer::new(n, mua, mus, g, d).expect("valid layer");
    let layers = match key {
        "a" => vec![l(1.0, 1.0, 9.0, 0.75, 0.2)],
        "c" => vec![l(1.4, 0.1, 10.0, 0.9, 0.1), l(1.4, 0.05, 15.0, 0.85, 2.0), l(1.4, 0.02, 12.0, 0.9, 10.0)],
        "d" => vec![l(1.4, 0.01, 10.0, 0.9, 100.0)],
        _ => panic!("case: one of a, c, d"),
    };
    Stack::new(layers, 1.0, 1.0).expect("valid stack")
}

fn cpu_seconds() -> f64 {
    let text = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let f: Vec<&str> = text.rsplit(')').next().unwrap_or("").split_whitespace().collect();
    let ticks: f64 = f.get(11).and_then(|u| u.parse().ok()).unwrap_or(0.0)
        + f.get(12).and_then(|s| s.parse::<f64>().ok()).unwrap_or(0.0);
    ticks / 100.0
}

/// The bits of each total, to compare two builds.
fn print_bits(t: &Totals) {
    for q in Total::ALL {
        let (m, se) = t.get(q);
        println!("{q:?} {:016x} {:016x}", m.to_bits(), se.to_bits());
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let arg = |i: usize, d: &str| args.get(i).cloned().unwrap_or_else(|| d.to_string());
    let stack = case(&arg(1, "a"));
    let tallies = arg(2, "mcml");
    let photons: u64 = arg(3, "1000000").parse().expect("photons");
    let mut cfg = RunConfig::new(photons, 1);
    cfg.threads = Some(arg(4, "1").parse().expect("threads"));
    cfg.isa = Some(Isa::selected().unwrap_or_else(|e| panic!("{e}")));
    eprintln!("lane kernel on {}", cfg.isa.map_or("?", |i| i.name()));
    let (cancel, progress) = (AtomicBool::new(false), AtomicU64::new(0));
    let nl = stack.layers.len();
    let (t0, c0) = (Instant::now(), cpu_seconds());
    let (photons, events) = if tallies == "totals" {
        let r = run(&stack, &cfg, || Totals::new(nl), &cancel, &progress).expect("run");
        if std::env::var_os("MC_SPEED_BITS").is_some() {
            print_bits(&r.tally);
        }
        (r.photons, r.events)
    } else {
        let tc = TallyConfig { errors: tallies == "mcml", ..TallyConfig::default() };
        let proto = TallySet::new(&tc, &stack).expect("tallies");
        let r = run(&stack, &cfg, || (Totals::new(nl), proto.clone()), &cancel, &progress).expect("run");
        if std::env::var_os("MC_SPEED_BITS").is_some() {
            print_bits(&r.tally.0);
            // FNV-1a over the bits of every value and standard error, histogram by histogram
            for h in r.tally.1.finalize(r.photons) {
                let mut hash = 0xcbf2_9ce4_8422_2325u64;
                for x in h.values.iter().chain(&h.stderr) {
                    hash = (hash ^ x.to_bits()).wrapping_mul(0x0100_0000_01b3);
                }
                println!("{} {hash:016x}", h.name);
            }
        }
        (r.photons, r.events)
    };
    let (wall, cpu) = (t0.elapsed().as_secs_f64(), cpu_seconds() - c0);
    println!(
        "photons {photons} events {events} wall {wall:.3} s cpu {cpu:.2} s: {:.3e} events/s, {:.3e} events/CPU-s",
        events as f64 / wall,
        events as f64 / cpu.max(1e-9)
    );
}
