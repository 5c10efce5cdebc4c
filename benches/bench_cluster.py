"""Cluster benchmarks (`make bench`): a 2-worker Dask LocalCluster against a local run of the same
photons on the same machine (A/B back to back, alternating, so both see the same load), and the
per-task cost of Dask and of a photon-range task.

A benchmark, not a test: the numbers depend on the machine and its load (2 shared cores here;
the load average is printed before and after). Usage:
python benches/bench_cluster.py [--photons N] [--repeats K] [--tasks N]
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import dask
from distributed import Client, LocalCluster
from subsurf import Layer, PencilBeam, Stack, Tallies, simulate
from subsurf.cluster import DEFAULT_TASK_SECONDS, run_ranges

# A 1 mm tissue slab (mm, mm^-1) scored with R(r), T(r), A(z), A(r, z) and exit angles.
SLAB = Stack([Layer(1.4, 0.1, 10.0, 0.9, 1.0)], n_above=1.0, n_below=1.0)
TALLIES = Tallies(nr=100, dr=0.05, nz=100, dz=0.01, na=15)


def _nothing(x):
    return x


def timed(f):
    t0 = time.perf_counter()
    out = f()
    return time.perf_counter() - t0, out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--photons", type=int, default=2_000_000, help="photons of each A/B run")
    ap.add_argument("--repeats", type=int, default=3, help="A/B pairs")
    ap.add_argument("--tasks", type=int, default=400, help="trivial tasks for the scheduling cost")
    args = ap.parse_args(argv)
    print(f"cluster benchmarks; {os.cpu_count()} cores; load before {os.getloadavg()[0]:.2f}")
    with (
        LocalCluster(
            n_workers=2,
            threads_per_worker=1,
            processes=True,
            host="127.0.0.1",
            dashboard_address=None,
            worker_dashboard_address=None,
        ) as lc,
        Client(lc, set_as_default=False) as client,
    ):
        client.submit(_nothing, 0, pure=False).result()  # workers warm
        kw = dict(photons=args.photons, seed=1, tallies=TALLIES)
        ratios, local_s, cluster_s = [], [], []
        for _ in range(args.repeats):
            a, ra = timed(lambda: simulate(SLAB, threads=2, **kw))
            b, rb = timed(lambda: simulate(SLAB, client=client, **kw))
            assert ra.state == rb.state, "cluster and local runs differ"
            local_s.append(a)
            cluster_s.append(b)
            ratios.append(b / a)
        r = statistics.median(ratios)
        print(
            f"1 mm slab, {args.photons:,} photons, tallies R(r), A(z), A(r,z), angles ({TALLIES.nr}x{TALLIES.nz}):"
            f"\n  local, 2 threads: {statistics.median(local_s):.2f} s; 2-worker LocalCluster (1 thread each): "
            f"{statistics.median(cluster_s):.2f} s; median ratio {r:.3f} -> overhead {100 * (r - 1):+.1f} % "
            f"(ratios {', '.join(f'{x:.3f}' for x in ratios)}; identical bits)"
        )
        n = args.tasks
        dt, _ = timed(lambda: client.gather([client.submit(_nothing, i, pure=False) for i in range(n)]))
        print(f"Dask round trip of a trivial task: {1e3 * dt / n:.2f} ms per task ({n} tasks, 2 workers)")
        # The same 64 chunks as 64 tasks or as one, on one worker: the difference is the cost of
        # 63 tasks (scheduling, shipping and merging a state, starting a run).
        small, src = 64 * 4096, PencilBeam()
        with dask.annotate(workers=[sorted(client.nthreads())[0]], allow_other_workers=False):
            pairs = []
            for _ in range(args.repeats):
                one, _ = timed(
                    lambda: run_ranges(client, SLAB, small, 1, None, src, TALLIES, None, None, task_photons=small)
                )
                many, _ = timed(
                    lambda: run_ranges(client, SLAB, small, 1, None, src, TALLIES, None, None, task_photons=4096)
                )
                pairs.append((one, many))
        per = statistics.median((m - o) / 63 for o, m in pairs)
        o, m = (statistics.median(x) for x in zip(*pairs))
        print(
            f"photon-range task (state of {_bins():,} bins, 72 B/bin = {72 * _bins() / 1e6:.1f} MB): "
            f"{1e3 * per:.1f} ms per task beyond its photons (one worker: 64 one-chunk tasks {m:.2f} s, "
            f"one task of the same photons {o:.2f} s); at the default {DEFAULT_TASK_SECONDS:g} s per task "
            f"that is {100 * per / DEFAULT_TASK_SECONDS:.2f} %"
        )
    print(f"load after {os.getloadavg()[0]:.2f}")


def _bins() -> int:
    """Bins of the state of a run with the benchmark's tallies (totals and histograms)."""
    return sum(n for _, n in simulate(SLAB, photons=1, seed=0, tallies=TALLIES).state.layout)


if __name__ == "__main__":
    main()
