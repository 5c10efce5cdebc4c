"""BSSRDF profile benchmarks (`make bench`): evaluation and sampling throughput (calls/s) of every
model, the time to build a Monte Carlo profile of 3-layer skin (RGB) and a ProfileTable.

A benchmark, not a test: the numbers depend on the machine and its load (2 shared cores here).
Usage: python benches/bench_profiles.py [--table-photons N] [--skip-table]
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np
from subsurf import Layer, Stack, bssrdf

# 3-layer skin per channel (R, G, B): epidermis 0.1 mm, dermis 2 mm, subcutis; mm^-1.
SKIN = [
    Stack(
        [Layer(1.4, ea, 40.0, 0.8, 0.1), Layer(1.4, da, 20.0, 0.85, 2.0), Layer(1.44, 0.01, 12.0, 0.9)],
        n_above=1.0,
    )
    for ea, da in ((0.3, 0.02), (0.8, 0.06), (1.5, 0.12))
]


def rate(f, x):
    t0 = time.perf_counter()
    f(x)
    return len(x) / (time.perf_counter() - t0)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--table-photons", type=int, default=200_000)
    ap.add_argument("--skip-table", action="store_true")
    args = ap.parse_args(argv)
    print(f"bssrdf benchmarks; {os.cpu_count()} cores; load {os.getloadavg()[0]:.2f}")
    print(f"{'model':<24} {'build s':>8} {'rd calls/s':>12} {'sample calls/s':>15}")
    rng = np.random.default_rng(0)
    for m in bssrdf.MODELS:
        t0 = time.perf_counter()
        if m == "monte_carlo":
            p = bssrdf.Profile.from_monte_carlo(Layer(1.4, 0.05, 10.0, 0.9), photons=100_000)
        else:
            p = bssrdf.Profile.from_model(m, 0.05, 10.0, 0.9, 1.4)
        build = time.perf_counter() - t0
        r = np.ascontiguousarray(p.sample_r(rng.random(200_000)))
        u = rng.random(200_000)
        ev = rate(p.rd, r)
        sa = rate(p.sample_r, u)
        print(f"{m:<24} {build:>8.3f} {ev:>12.3e} {sa:>15.3e}")
    t0 = time.perf_counter()
    chans = bssrdf.profiles(SKIN, photons=200_000, seed=1)
    print(
        f"monte_carlo profile, 3-layer skin RGB, 2e5 photons/channel: {time.perf_counter() - t0:.1f} s "
        f"(totals {', '.join(f'{c.total():.4f}' for c in chans)})"
    )
    if not args.skip_table:
        t0 = time.perf_counter()
        t = bssrdf.ProfileTable.build(0.0, 1.4, photons=args.table_photons)
        print(
            f"ProfileTable (24 albedos x {args.table_photons} photons, g = 0, eta = 1.4): "
            f"{time.perf_counter() - t0:.1f} s; rho_eff(0.99) = {t.rho_eff(0.99):.4f}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
