"""Monte Carlo engine benchmark (`make bench`): scattering events/s and photons/s on one thread
and on all cores for three MCML test cases, compared with MCML's 1.1e7 events/s per core.

Cases (quoted in cm as MCML takes them; converted here: μ in cm⁻¹ × 0.1 → mm⁻¹, d in cm × 10 → mm):
  (a) slab n=1 in n=1, μa=10, μs=90 /cm, g=0.75, d=0.02 cm;
  (c) three layers n=1.4 in air: (μa, μs, g, d) = (1, 100, 0.9, 0.01), (0.5, 150, 0.85, 0.2),
      (0.2, 120, 0.9, 1.0);
  (d) n=1.4 in air, μa=0.1, μs=100 /cm, g=0.9, d=10 cm.
A benchmark, not a test: the numbers depend on the machine and its load.

Usage: python benches/bench.py [--seconds S]   (target duration of each measurement)
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import subsurf
from subsurf import Layer, Stack

MCML_EVENTS_PER_S = 1.1e7  # per core: the MCML figure of the project's performance goal
TARGET_PER_CORE = 3.3e7

CASES = {
    "(a) slab g=0.75 tau=2": Stack([Layer(1.0, 1.0, 9.0, 0.75, 0.2)], 1.0, 1.0),
    "(c) 3 layers n=1.4": Stack(
        [Layer(1.4, 0.1, 10.0, 0.9, 0.1), Layer(1.4, 0.05, 15.0, 0.85, 2.0), Layer(1.4, 0.02, 12.0, 0.9, 10.0)],
        1.0,
        1.0,
    ),
    "(d) thick n=1.4 g=0.9": Stack([Layer(1.4, 0.01, 10.0, 0.9, 100.0)], 1.0, 1.0),
}


def measure(stack, threads, seconds):
    """Run long enough to last about `seconds` (after pilot runs to size it); returns the
    result and the CPU time of this process (all threads) during the run."""
    n = 2000
    while True:
        c0 = time.process_time()
        r = subsurf.simulate(stack, photons=n, seed=1, threads=threads)
        cpu = time.process_time() - c0
        if r.elapsed_s >= seconds or r.elapsed_s >= 0.25 and n * seconds / r.elapsed_s < n * 1.5:
            return r, cpu
        n = int(n * min(100.0, 1.2 * seconds / max(r.elapsed_s, 1e-3)))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=2.0, help="duration of each measurement (s)")
    args = ap.parse_args(argv)
    cores = os.cpu_count() or 1
    print(
        f"subsurf {subsurf.__version__} Monte Carlo benchmark; {cores} cores; "
        f"load average {os.getloadavg()[0]:.2f} (other processes slow these figures)"
    )
    print(
        "events/s and photons/s are wall-clock; 'per CPU-s' = events per second of CPU time used "
        "(what a core delivers when it is not shared); 'x MCML' = per CPU-s / 1.1e7"
    )
    print(
        f"{'case':<24} {'threads':>7} {'photons':>9} {'events/s':>10} {'photons/s':>10} "
        f"{'per core':>10} {'per CPU-s':>10} {'x MCML':>7} {'scaling':>7}"
    )
    for name, stack in CASES.items():
        one = None
        for threads in (1, None):
            r, cpu = measure(stack, threads, args.seconds)
            t = 1 if threads == 1 else cores
            ev = r.events / r.elapsed_s
            if threads == 1:
                one = ev
            per_core = ev / t
            scale = ev / one
            per_cpu = r.events / cpu if cpu > 0 else float("nan")
            print(
                f"{name:<24} {t:>7} {r.photons:>9} {ev:>10.3e} {r.photons / r.elapsed_s:>10.3e} "
                f"{per_core:>10.3e} {per_cpu:>10.3e} {per_cpu / MCML_EVENTS_PER_S:>7.2f} {scale:>7.2f}"
            )
    print(f"targets: >= {TARGET_PER_CORE:.1e} events/s per core (3x MCML) and >= 1.8x on 2 cores")
    return 0


if __name__ == "__main__":
    sys.exit(main())
