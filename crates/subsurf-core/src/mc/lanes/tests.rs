//! Tests of the lane kernel: the same bits on every instruction set, agreement with the
//! scalar reference kernel, and the benchmark of the kernel alone.

use super::*;
use crate::mc::kernel::Kernel;
use crate::mc::source::Source;
use crate::mc::tally::totals::Totals;
use crate::medium::{Layer, Stack};
use std::sync::atomic::AtomicBool;

fn layer(n: f64, mua: f64, mus: f64, g: f64, d: f64) -> Layer {
    Layer::new(n, mua, mus, g, d).unwrap()
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
            ev += k.trace::<Totals, false, false>(1, i, &mut t);
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
