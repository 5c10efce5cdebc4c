"""The exit term on a flat surface: a thick ketchup slab (400 × 400 × 100 mm) under a normal sun,
seen at 5, 45 and 75° from the normal: ``hierarchical`` + ``adaptive`` against ``random_walk``
(docs/render.md, "The exit term"). Prints adaptive / random_walk − 1 per channel and angle.

    python docs/scripts/exit_slab.py [--spp-ref 1024] [--size 16]
"""

from __future__ import annotations

import argparse

import numpy as np
import subsurf.render as R


def image(m, angle, method, spp, size):
    a = np.radians(angle)
    cam = (200.0 * np.sin(a), 0.0, 200.0 * np.cos(a))
    scene = R.Scene(
        [R.Object.box(m, lo=(-200, -200, -100), hi=(200, 200, 0))],
        [R.DirectionalLight((0, 0, 1), 1.0)],
        (0, 0, 0),
        R.Camera(cam, look_at=(0, 0, 0), up=(0, 1, 0), fov=2.0, width=size, height=size),
    )
    return R.render(scene, method, spp=spp, seed=5).array


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--spp-ref", type=int, default=1024)
    ap.add_argument("--spp", type=int, default=4)
    ap.add_argument("--size", type=int, default=16)
    a = ap.parse_args()
    m = R.Translucent.library("ketchup", model="adaptive", mc_photons=10000, mc_seed=3)
    for angle in (5, 45, 75):
        ref = image(m, angle, "random_walk", a.spp_ref, a.size)
        got = image(m, angle, "hierarchical", a.spp, a.size)
        err = ref.std(axis=(0, 1)) / np.sqrt(ref.shape[0] * ref.shape[1])
        rel = got.mean(axis=(0, 1)) / ref.mean(axis=(0, 1)) - 1
        se = err / ref.mean(axis=(0, 1))
        print(f"{angle:2d}°: " + ", ".join(f"{100 * r:+.1f} % (± {100 * s:.1f})" for r, s in zip(rel, se)), flush=True)


if __name__ == "__main__":
    main()
