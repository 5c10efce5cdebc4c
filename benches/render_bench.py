"""Rendering benchmark (`make bench`): BVH rays/s; 512×512 marble sphere of ~10⁵ triangles
(icosphere level 6: 81,920) under an area light and the environment: hierarchical time,
random_walk seconds per spp; and, at a smaller resolution (--error-size, default 64, so the long
reference is affordable on 2 cores), the error of hierarchical and of random_walk at equal time
against a long random_walk reference, over the sphere's pixels. A benchmark, not a test: numbers
depend on the machine and its load (printed).
Usage: python benches/render_bench.py [--size 512] [--error-size 64] [--ref-spp 128]"""

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
    ap.add_argument("--ref-spp", type=int, default=128)
    ap.add_argument("--error-size", type=int, default=64)
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
    R.render(sc, "random_walk", spp=1, seed=2)
    tw = time.monotonic() - t0
    print(f"random_walk {a.size}x{a.size}: {tw:.1f} s per spp")
    small = scene(a.error_size)
    t0 = time.monotonic()
    h = R.render(small, "hierarchical", spp=1, seed=1)
    th = time.monotonic() - t0
    t0 = time.monotonic()
    R.render(small, "random_walk", spp=1, seed=2)
    tw = time.monotonic() - t0
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
    print(f"load average now {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
