"""Rendering benchmark (`make bench`): BVH rays/s; 512×512 marble sphere of ~10⁵ triangles
(icosphere level 6: 81,920) under an area light and the environment: hierarchical time,
random_walk at 16 spp against the 30 s target; at a smaller resolution (--error-size, default 64,
so the long reference is affordable on 2 cores), the error of hierarchical and of random_walk at
equal time against a long random_walk reference, over the sphere's pixels; and subsurf's
random_walk side by side with Mitsuba 3's volpathmis on the same scenes and threads
(benches/render_compare.py: parity of the object means, equal-spp and equal-time efficiency).
Mitsuba 3 is installed when it can be (``pip install mitsuba`` into this Python, ``apt-get install
libllvm19`` as root; --no-install forbids it); otherwise the reason is printed and subsurf's part
runs alone. A benchmark, not a test: numbers depend on the machine and its load (printed).
Usage: python benches/render_bench.py [--quick] [--size 512] [--error-size 64] [--ref-spp 128]
       [--compare-size 64] [--budget 120] [--spp N] [--cases marble,skin,ear] [--no-mitsuba] [--no-install]
       [--parts big,error,mitsuba] [--mitsuba-rr-depth 1000000000]"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time

import numpy as np
import render_compare as C
import subsurf.render as R
from subsurf import _core

#: The 512² random_walk target at 16 spp, seconds on 2 cores.
TARGET_16SPP = 30.0


def scene(size, level=6):
    m = R.Translucent.library("marble", model="dipole")
    return R.Scene(
        [R.Object.sphere(m, radius=10, subdivisions=level)],
        [R.RectLight((-20, -30, 40), (8, 0, 0), (0, -5, 5), 4e4)],
        (0.05, 0.05, 0.06),
        R.Camera((0, -60, 10), fov=24, width=size, height=size),
    )


def load():
    return f"load average {os.getloadavg()[0]:.2f}"


def timed(sc, method, spp, seed, threads=None):
    t0 = time.monotonic()
    img = R.render(sc, method, spp=spp, seed=seed, threads=threads)
    return img, time.monotonic() - t0


def big_sphere(a):
    sc = scene(a.size)
    inside, cam = _core.render_bvh_benchmark(sc._to_core(), 200_000)
    print(
        f"BVH (obvhs CWBVH, {len(sc.objects[0].triangles):,} triangles), one thread: "
        f"{inside:.3g} incoherent rays/s, {cam:.3g} camera rays/s"
    )
    _, th = timed(sc, "hierarchical", 1, 1)
    print(f"hierarchical {a.size}x{a.size}, 1 spp: {th:.1f} s (target <= 30 s)")
    _, t1 = timed(sc, "random_walk", 1, 2)
    if t1 * 16 <= 4 * TARGET_16SPP:  # affordable: render the 16 spp the target names
        _, t16 = timed(sc, "random_walk", 16, 2)
        how = "measured"
    else:
        t16, how = 16 * t1, "16 x the 1-spp time"
    print(
        f"random_walk {a.size}x{a.size}: {t1:.1f} s at 1 spp; 16 spp: {t16:.1f} s ({how}; "
        f"target <= {TARGET_16SPP:.0f} s on 2 cores; {load()})"
    )


def equal_time_error(a):
    small = scene(a.error_size)
    h, th = timed(small, "hierarchical", 1, 1)
    _, tw = timed(small, "random_walk", 1, 2)
    eq = max(1, int(round(th / tw)))
    w_eq = R.render(small, "random_walk", spp=eq, seed=3)
    ref = R.render(small, "random_walk", spp=a.ref_spp, seed=4)
    m = ref.array.mean(axis=-1) > 0.2 * np.percentile(ref.array.mean(axis=-1), 99)
    print(f"at {a.error_size}x{a.error_size}, against random_walk {a.ref_spp} spp ({m.sum()} object pixels):")
    for name, img, t in (("hierarchical 1 spp", h, th), (f"random_walk {eq} spp", w_eq, eq * tw)):
        d = img.array[m] - ref.array[m]
        print(
            f"  {name} ({t:.1f} s): RMSE {np.sqrt(np.mean(d**2)):.3e}, "
            f"mean rel. error {np.mean(np.abs(d) / np.maximum(ref.array[m], 1e-12)):.2%}, "
            f"object mean {img.array[m].sum() / ref.array[m].sum() - 1:+.2%}"
        )


def mitsuba_comparison(a):
    print(
        f"\nsubsurf random_walk vs Mitsuba 3 volpathmis, {a.compare_size}x{a.compare_size}, {C.THREADS} threads "
        f"each; {C.K} renders per setting and renderer; {load()}"
    )
    mit = None
    if not a.no_mitsuba:
        mit = C.Mitsuba(sys.executable, C.THREADS, not a.no_install)
        if mit.ok:
            i = mit.info
            print(
                f"Mitsuba {i['mitsuba']} (Dr.Jit {i['drjit']}), variant {i['variant']}, libLLVM {i['libllvm']}; "
                f"volpathmis max_depth -1, rr_depth {a.mitsuba_rr_depth}"
            )
        else:
            print(f"Mitsuba 3 unavailable: {mit.why}; subsurf's part only")
            mit = None
    results = []
    try:
        with tempfile.TemporaryDirectory() as tmp:
            for obj in a.cases:
                for light in C.LIGHTS:
                    t0 = time.monotonic()
                    try:
                        results.append(C.run_case(obj, light, a, mit, tmp))
                    except RuntimeError as e:  # Mitsuba failed on this scene: say so, go on
                        print(f"  {obj} {light}: Mitsuba failed ({e}); subsurf's part only")
                        results.append(C.run_case(obj, light, a, None, tmp))
                    r = results[-1]
                    print(f"  {obj} {light}: N = {r['spp']} spp, {time.monotonic() - t0:.0f} s in all; {load()}")
    finally:
        if mit is not None:
            mit.close()
    C.print_parity(results)
    C.print_efficiency(results)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="small sizes and budgets (about a minute)")
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--ref-spp", type=int, default=128)
    ap.add_argument("--error-size", type=int, default=64)
    ap.add_argument("--compare-size", type=int, default=64, help="image size of the Mitsuba comparison")
    ap.add_argument("--budget", type=float, default=120.0, help="CPU seconds per comparison scene (sets N)")
    ap.add_argument("--spp", type=int, default=0, help="the comparison's equal-spp N (default: from --budget)")
    ap.add_argument("--cases", default="marble,skin,ear", help="comparison objects (of marble, skin, ear)")
    ap.add_argument("--no-mitsuba", action="store_true", help="subsurf's part of the comparison only")
    ap.add_argument("--no-install", action="store_true", help="never install Mitsuba 3 or libLLVM")
    ap.add_argument("--parts", default="big,error,mitsuba", help="which parts to run (of big, error, mitsuba)")
    ap.add_argument("--mitsuba-rr-depth", type=int, default=10**9, help="Mitsuba's rr_depth (see docs/render.md)")
    a = ap.parse_args()
    if a.quick:
        a.size, a.error_size, a.ref_spp, a.compare_size, a.budget = 128, 32, 32, 32, 6.0
    a.cases = [c for c in a.cases.split(",") if c]
    bad = [c for c in a.cases if c not in C.OBJECTS]
    if bad:
        ap.error(f"--cases: {bad} unknown (allowed: {list(C.OBJECTS)})")
    print(f"render benchmark; {os.cpu_count()} cores; {load()} (other processes slow these figures)")
    parts = a.parts.split(",")
    for name, part in (("big", big_sphere), ("error", equal_time_error), ("mitsuba", mitsuba_comparison)):
        if name in parts:
            part(a)
    print(f"{load()} now")


if __name__ == "__main__":
    main()
