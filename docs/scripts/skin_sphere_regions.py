"""Where the `adaptive` model's error sits on the validation matrix's two-layer skin sphere
(docs/render.md, "The two-layer skin sphere: where the error sits"): hierarchical + adaptive
against random_walk per band of the exit cosine μ_o and of the angle between the surface normal
and the direction to the area light's centre, each pixel's band from its camera ray's hit on the
analytic sphere (r = 10 mm), under the matrix's lighting split into its parts.

Usage: python docs/scripts/skin_sphere_regions.py [--light both|env|rect] [--spp-ref 128]
[--seeds 1,7] [--spp 4] [--out DIR]. ``both`` is the matrix's scene (its cached references are
read from ``DIR/refs``); ``env`` its constant environment alone; ``rect`` its area light alone.
The references' seeds are averaged; their spread gives the references' own noise per band.
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

RADIUS = 10.0
MU_EDGES = (0.0, 0.2, 0.4, 0.6, 0.8, 1.01)
LIGHT_EDGES = (-1.01, 0.0, 0.25, 0.5, 0.75, 1.01)


def geometry(camera, light):
    """Per pixel μ_o and the cosine between the normal and the direction to the light's centre
    (NaN off the sphere)."""
    pos = np.array(camera.position, float)
    d = C.camera_rays(camera).reshape(-1, 3)
    b = d @ pos
    disc = b * b - (pos @ pos - RADIUS**2)
    t = -b - np.sqrt(np.where(disc > 0, disc, np.nan))
    p = pos + t[:, None] * d
    n = p / RADIUS
    mu = -(n * d).sum(1)
    centre = np.asarray(light.position, float) + 0.5 * (np.asarray(light.u, float) + np.asarray(light.v, float))
    to = centre - p
    cl = (n * to).sum(1) / np.linalg.norm(to, axis=1)
    return mu.reshape(camera.height, camera.width), cl.reshape(camera.height, camera.width)


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--light", choices=("both", "env", "rect"), default="both")
    ap.add_argument("--size", type=int, default=64)
    ap.add_argument("--spp", type=int, default=4)
    ap.add_argument("--spp-ref", type=int, default=128)
    ap.add_argument("--seeds", default="1,7")
    cache = os.environ.get("SUBSURF_CACHE", os.path.expanduser("~/.cache/subsurf"))
    ap.add_argument("--out", default=os.path.join(cache, "validation_matrix"))
    a = ap.parse_args(argv)
    size = a.size

    def scene(objs):
        s = V.scene(objs, 10.0, False, size)
        if a.light == "env":
            return R.Scene(objs, [], s.environment, s.camera)
        if a.light == "rect":
            return R.Scene(objs, s.lights, (0, 0, 0), s.camera)
        return s

    walk_objs = V.skin_walk(1.0)
    objs, extent = V.sphere(10)(V.skin_layered(1.0, "monte_carlo", 10000))
    mask = V.object_mask(objs, extent, size)
    refs = []
    for seed in map(int, a.seeds.split(",")):
        name = f"sphere_skin_layered_1.0_{size}_{a.spp_ref}_{seed}.npz"
        sub = "refs" if a.light == "both" else f"refs_{a.light}"
        refs.append(V.cached_walk(os.path.join(a.out, sub, name), scene(walk_objs), a.spp_ref, seed)[0])
    ref = np.mean(refs, axis=0)
    m = V.skin_layered(1.0, "adaptive", 10000)
    m.adaptive_table()
    sc = scene(V.sphere(10)(m)[0])
    img = R.render(sc, "hierarchical", spp=a.spp, seed=2).array
    mu, cl = geometry(sc.camera, V.scene(objs, extent, False, size).lights[0])
    pct = lambda v: ", ".join(f"{100 * x:+.1f}" for x in v)  # noqa: E731
    k = len(refs)
    print(f"two-layer skin sphere, {a.light}: hierarchical adaptive {a.spp} spp vs random_walk {k} × {a.spp_ref} spp")
    print("| band | pixels | adaptive / reference − 1 (%) | share of the object's excess (%) | reference noise σ (%) |")
    print("|---|---|---|---|---|")
    excess = img[mask].sum(0) - ref[mask].sum(0)

    def band(name, x, edges, i):
        lo, hi = max(edges[i], -1), min(edges[i + 1], 1)
        return f"{name} {lo:.2f}–{hi:.2f}", (x >= edges[i]) & (x < edges[i + 1])

    bands = [band("μ_o", mu, MU_EDGES, i) for i in range(5)]
    bands += [band("cos to light", cl, LIGHT_EDGES, i) for i in range(5)]
    for name, sel in [*bands, ("object", np.ones_like(mask))]:
        sel = sel & mask
        total = ref[sel].sum(0)
        var = np.var([r[sel].sum(0) for r in refs], axis=0, ddof=1) / k if k > 1 else np.zeros(3)
        noise = ", ".join(f"{100 * x:.2f}" for x in np.sqrt(var) / total)
        share = ", ".join(f"{100 * x:.0f}" for x in (img[sel].sum(0) - total) / excess)
        print(f"| {name} | {sel.sum()} | {pct(img[sel].sum(0) / total - 1)} | {share} | {noise} |")
    return 0


if __name__ == "__main__":
    main()
