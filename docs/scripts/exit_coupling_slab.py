"""The exit direction's coupling to the light on a flat surface: a thick slab (400 × 400 × 100 mm)
under a sun at 50° from the normal, seen at 50° from the sun's side (back towards the sun), from
the mirror side and from 90° in azimuth: ``hierarchical`` + ``adaptive`` against ``random_walk``
(docs/render.md, "The exit coupling"). Prints adaptive / random_walk − 1 per channel and view, with
the coupling (as rendered) and without it (the same image divided by its factor 1 + A sin² 50°
(sun side) or 1 − A sin² 50° (mirror side); 1 at 90°).

    python docs/scripts/exit_coupling_slab.py [--material skin_layered|ketchup] [--spp-ref 256] [--size 8]
"""

from __future__ import annotations

import argparse
import os
import sys

import numpy as np
import subsurf.render as R

sys.path.insert(0, os.path.dirname(__file__))
import adaptive_validation  # noqa: E402

THETA = 50.0


def slab(m, method):
    """The slab's objects: one box, or for the layered skin under ``random_walk`` the epidermis as a
    box around the dermis (the walk takes layers as nested closed meshes)."""
    if m == "skin_layered" and method == "random_walk":
        epi, der = (o.material for o in adaptive_validation.skin_walk(1))
        d = adaptive_validation.EPI_D
        return [
            R.Object.box(epi, lo=(-200, -200, -100), hi=(200, 200, 0)),
            R.Object.box(der, lo=(-200 + d, -200 + d, -100 + d), hi=(200 - d, 200 - d, -d)),
        ]
    if m == "skin_layered":
        m = adaptive_validation.skin_layered(1, "adaptive", 10000)
    return [R.Object.box(m, lo=(-200, -200, -100), hi=(200, 200, 0))]


def image(m, view, method, spp, size, seed):
    a = np.radians(THETA)
    sun = (np.sin(a), 0.0, np.cos(a))
    cams = {"sun side": (sun[0], 0.0, sun[2]), "mirror": (-sun[0], 0.0, sun[2]), "90° azimuth": (0.0, sun[0], sun[2])}
    cam = tuple(200.0 * c for c in cams[view])
    scene = R.Scene(
        slab(m, method),
        [R.DirectionalLight(sun, 1.0)],
        (0, 0, 0),
        R.Camera(cam, look_at=(0, 0, 0), up=(0, 1, 0), fov=2.0, width=size, height=size),
    )
    return R.render(scene, method, spp=spp, seed=seed).array


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--material", default="skin_layered")
    ap.add_argument("--spp-ref", type=int, default=256)
    ap.add_argument("--spp", type=int, default=4)
    ap.add_argument("--size", type=int, default=8)
    a = ap.parse_args()
    if a.material == "skin_layered":
        m = "skin_layered"
        table = adaptive_validation.skin_layered(1, "adaptive", 10000).adaptive_table()
    else:
        m = R.Translucent.library(a.material, model="adaptive", mc_photons=10000, mc_seed=3)
        table = m.adaptive_table()
    amp = np.array([cd["coupling_a"] for cd in table.curvature()])
    s2 = np.sin(np.radians(THETA)) ** 2
    print(f"{a.material}: A = " + ", ".join(f"{x:+.3f}" for x in amp))
    for view, sign in (("sun side", 1.0), ("mirror", -1.0), ("90° azimuth", 0.0)):
        ref = image(m, view, "random_walk", a.spp_ref, a.size, 5)
        got = image(m, view, "hierarchical", a.spp, a.size, 5)
        mean = ref.mean(axis=(0, 1))
        se = ref.std(axis=(0, 1)) / np.sqrt(ref.shape[0] * ref.shape[1]) / mean
        rel = got.mean(axis=(0, 1)) / mean - 1
        before = (1 + rel) / (1 + sign * amp * s2) - 1
        cols, prev, noise = (
            ", ".join(f"{100 * r:.1f}" if x is se else f"{100 * r:+.1f}" for r in x) for x in (rel, before, se)
        )
        print(f"{view:>12}: {cols} % (without the coupling {prev} %; ± {noise})", flush=True)


if __name__ == "__main__":
    main()
