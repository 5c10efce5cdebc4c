"""Rendering benchmark (`make bench`): BVH rays/s; 512×512 marble sphere of ~10⁵ triangles
(icosphere level 6: 81,920) under an area light and the environment: hierarchical time,
random_walk seconds per spp, and the error of each against a long random_walk reference at
(about) equal time, over the sphere's pixels. A benchmark, not a test: numbers depend on the
machine and its load (printed). Usage: python benches/render_bench.py [--size 512] [--ref-spp 64]"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np
import subsurf.render as R
from subsurf import _core


def scene(size, level=6):
    m = R.Translucent.library("marble", model="dipole")
    return R.Scene(
        [R.Object.sphere(m, radius=10, subdivisions=level)],
        [R.RectLight((-20, -30, 40), (8, 0, 0), (0, -5, 5), 4e4)],
        (0.05, 0.05, 0.06),
        R.Camera((0, -60, 10), fov=24, width=size, height=size),
    )


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--ref-spp", type=int, default=64)
    a = ap.parse_args()
    print(f"render benchmark; {os.cpu_count()} cores; load average {os.getloadavg()[0]:.2f}")
    sc = scene(a.size)
    inside, cam = _core.render_bvh_benchmark(sc._to_core(), 200_000)
    print(
        f"BVH (obvhs CWBVH, {len(sc.objects[0].triangles):,} triangles), one thread: "
        f"{inside:.3g} incoherent rays/s, {cam:.3g} camera rays/s"
    )
    t0 = time.monotonic()
    h = R.render(sc, "hierarchical", spp=1, seed=1)
    th = time.monotonic() - t0
    print(f"hierarchical {a.size}x{a.size}, 1 spp: {th:.1f} s (target <= 30 s)")
    t0 = time.monotonic()
    w1 = R.render(sc, "random_walk", spp=1, seed=2)
    tw = time.monotonic() - t0
    print(f"random_walk: {tw:.1f} s per spp")
    eq = max(1, int(round(th / tw)))
    w_eq = R.render(sc, "random_walk", spp=eq, seed=3)
    ref = R.render(sc, "random_walk", spp=a.ref_spp, seed=4)
    m = ref.array.mean(axis=-1) > 0.2 * np.percentile(ref.array.mean(axis=-1), 99)
    for name, img in (("hierarchical", h), (f"random_walk {eq} spp (equal time)", w_eq)):
        d = img.array[m] - ref.array[m]
        print(
            f"{name}: RMSE vs random_walk {a.ref_spp} spp = {np.sqrt(np.mean(d**2)):.3e}, "
            f"mean rel. error {np.mean(np.abs(d) / np.maximum(ref.array[m], 1e-12)):.3%}"
        )
    del w1


if __name__ == "__main__":
    main()
