"""Where the `adaptive` model's error sits on the validation matrix's torus (docs/render.md, "The
torus: where the error sits"): hierarchical + adaptive against random_walk per band of the tube
angle θ (0 the outer equator, 90° the top, 180° the inner equator), each pixel's band from its
camera ray's hit on the analytic torus (sphere tracing its distance function).

Usage: python docs/scripts/torus_regions.py [--light uniform|area] [--spp-ref 512] [--out DIR].
``uniform``: a white environment and no light; ``area``: the matrix's scene (its cached
references are read from ``DIR/refs`` when the spp is the matrix's 128). Two random_walk images
(seeds 1 and 7) give the references' own noise per band.
"""

from __future__ import annotations

import argparse
import os
import sys

import numpy as np
import subsurf.render as R

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import adaptive_validation as V  # noqa: E402

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "benches"))
import render_compare as C  # noqa: E402

MAJOR, MINOR = 7.0, 2.5  # the matrix's torus (mm)
EDGES = (0, 30, 60, 90, 120, 150, 180.1)


def tube_angle(objs, camera, size):
    """Per pixel the tube angle (degrees) of the camera ray's hit on the analytic torus."""
    pos = np.array(camera.position, float)
    d = C.camera_rays(camera).reshape(-1, 3)  # the renderer's pixel-centre rays
    p = objs[0].positions
    c = p.mean(0)
    axis = np.linalg.eigh(np.cov((p - c).T))[1][:, 0]  # the torus' flat direction

    def local(x):
        q = x - c
        z = q @ axis
        return z, np.linalg.norm(q - z[..., None] * axis, axis=-1)

    t = np.zeros(len(d))
    for _ in range(400):  # sphere tracing: the distance function is exact for a torus
        z, rad = local(pos + t[:, None] * d)
        t += np.sqrt((rad - MAJOR) ** 2 + z**2) - MINOR
    z, rad = local(pos + t[:, None] * d)
    return np.degrees(np.abs(np.arctan2(z, rad - MAJOR))).reshape(size, size)


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--light", choices=("uniform", "area"), default="uniform")
    ap.add_argument("--size", type=int, default=64)
    ap.add_argument("--spp", type=int, default=4)
    ap.add_argument("--spp-ref", type=int, default=512)
    cache = os.environ.get("SUBSURF_CACHE", os.path.expanduser("~/.cache/subsurf"))
    ap.add_argument("--out", default=os.path.join(cache, "validation_matrix"))
    a = ap.parse_args(argv)
    size = a.size

    def scene(objs):
        s = V.scene(objs, extent, False, size)
        return s if a.light == "area" else R.Scene(objs, [], (1, 1, 1), s.camera)

    objs, extent = V.torus(V.library("marble", 1.0, "monte_carlo", 10000))
    mask = V.object_mask(objs, extent, size)
    refs = []
    for seed in (1, 7):
        name = f"torus_marble_1.0_{size}_{a.spp_ref}_{seed}.npz"
        path = os.path.join(a.out, "refs" if a.light == "area" else "refs_uniform", name)
        refs.append(V.cached_walk(path, scene(objs), a.spp_ref, seed)[0])
    ref, again = refs
    m = V.library("marble", 1.0, "adaptive", 10000)
    m.adaptive_table()
    img = R.render(scene(V.torus(m)[0]), "hierarchical", spp=a.spp, seed=2).array
    angle = tube_angle(objs, scene(objs).camera, size)
    pct = lambda v: ", ".join(f"{100 * x:+.1f}" for x in v)  # noqa: E731
    print(f"torus, marble, {a.light} light: hierarchical adaptive {a.spp} spp vs random_walk {a.spp_ref} spp")
    print("| θ | pixels | adaptive / reference − 1 (%) | reference noise σ (%) |\n|---|---|---|---|")
    bands = [(f"{EDGES[i]:.0f}–{EDGES[i + 1]:.0f}°", (angle >= EDGES[i]) & (angle < EDGES[i + 1])) for i in range(6)]
    for name, sel in [*bands, ("object", np.ones_like(mask))]:
        sel = sel & mask
        total = ref[sel].sum(0)
        sigma = np.sqrt(((ref[sel] - again[sel]) ** 2 / 2).sum(0)) / total
        noise = ", ".join(f"{100 * x:.2f}" for x in sigma)
        print(f"| {name} | {sel.sum()} | {pct(img[sel].sum(0) / total - 1)} | {noise} |")
    return 0


if __name__ == "__main__":
    main()
