"""The exit term on a flat surface: a thick ketchup slab (400 × 400 × 100 mm) under a normal sun,
seen at 5, 45 and 75° from the normal: ``hierarchical`` + ``adaptive`` against ``random_walk``
(docs/render.md, "The exit term"). Prints adaptive / random_walk − 1 per channel and angle.

    python docs/scripts/exit_slab.py [--material ketchup|skin_layered] [--angles 5,45,75] [--spp-ref 1024] [--size 16]

``skin_layered`` is the validation matrix's two-layer skin (the random walk's epidermis a box
around the dermis, as ``exit_coupling_slab.py``).
"""

from __future__ import annotations

import argparse
import os
import sys

import numpy as np
import subsurf.render as R

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import exit_coupling_slab  # noqa: E402


def image(m, angle, method, spp, size):
    a = np.radians(angle)
    cam = (200.0 * np.sin(a), 0.0, 200.0 * np.cos(a))
    scene = R.Scene(
        exit_coupling_slab.slab(m, method),
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
    ap.add_argument("--material", default="ketchup")
    ap.add_argument("--angles", default="5,45,75")
    a = ap.parse_args()
    m = a.material
    if m != "skin_layered":
        m = R.Translucent.library(m, model="adaptive", mc_photons=10000, mc_seed=3)
    for angle in map(float, a.angles.split(",")):
        ref = image(m, angle, "random_walk", a.spp_ref, a.size)
        got = image(m, angle, "hierarchical", a.spp, a.size)
        err = ref.std(axis=(0, 1)) / np.sqrt(ref.shape[0] * ref.shape[1])
        rel = got.mean(axis=(0, 1)) / ref.mean(axis=(0, 1)) - 1
        se = err / ref.mean(axis=(0, 1))
        cells = ", ".join(f"{100 * r:+.1f} % (± {100 * s:.1f})" for r, s in zip(rel, se))
        print(f"{angle:2.0f}°: {cells}", flush=True)


if __name__ == "__main__":
    main()
