"""The backlit slab's red deficit (docs/render.md, "The backlit slab"; "Mitsuba 3 on the matrix's
scenes"): does light entering the slab's 2 mm sides explain it?

The validation matrix's area light (docs/scripts/adaptive_validation.py, ``scene(..., backlit=True)``)
spans x, z ∈ [−45, 15] mm at y = 45, so it reaches past the slab's −x and −z sides and lights them
(a sun from straight behind lights no side). Here the matrix's slab is rendered under that light alone
(no environment) twice: as is, and with a black frame hugging its four sides (opaque Lambertian
albedo 0, 0.05 mm from the side, 0.5 mm thick, the slab's 2 mm deep: it stops the light that would
enter the sides, and absorbs what leaves them, without shading the back face or hiding the front
face from the camera). Each with ``random_walk`` (``--walk-spp`` × ``--walk-seeds``) and
``hierarchical`` + ``adaptive`` (the matrix's 4 spp × 4 seeds, its 10 000-photon table from
``$SUBSURF_CACHE``). Printed per region of the front face (by distance from its rim, as the docs'
table) and for the whole object (the matrix's mask): the model's object mean against the walk's,
R, G, B, with the walk's σ (per-pixel variance over its images); and the sides' share of the walk's
image (1 − framed/unframed).

Usage: SUBSURF_CACHE=... nice -n 5 .venv/bin/python docs/scripts/slab_sides.py [--out /tmp/mtref/sides]
"""

from __future__ import annotations

import argparse
import os
import sys

import numpy as np
import subsurf.render as R

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, "..", "..", "benches"))
import adaptive_validation as av  # noqa: E402
import render_compare as rc  # noqa: E402

GAP, THICK = 0.05, 0.5  # mm: the frame's distance from the sides and its thickness
REGIONS = (("> 6 mm", 6, 99), ("3–6 mm", 3, 6), ("1–3 mm", 1, 3), ("< 1 mm", -1, 1))


def frame():
    """Four black boxes around the slab's sides (x, z = ±15 mm), y ∈ [−1, 1]."""
    black = R.Lambertian(0.0)
    a, b = 15 + GAP, 15 + GAP + THICK
    boxes = [
        ((-b, -1, -b), (-a, 1, b)),
        ((a, -1, -b), (b, 1, b)),
        ((-a, -1, -b), (a, 1, -a)),
        ((-a, -1, a), (a, 1, b)),
    ]
    return [R.Object.box(black, lo=lo, hi=hi) for lo, hi in boxes]


def rim_distance(cam):
    """Per pixel, 15 − max(|x|, |z|) where the centre ray meets the front face's plane y = −1."""
    pos = np.asarray(cam.position, float)
    d = rc.camera_rays(cam)
    t = (-1 - pos[1]) / d[..., 1]
    p = pos + t[..., None] * d
    return 15 - np.maximum(np.abs(p[..., 0]), np.abs(p[..., 2]))


def images(objs, extent, a, framed, out):
    """(walk images, model images) of the slab under the light alone, cached in ``out``."""
    res = {}
    for method, spp, seeds in (("random_walk", a.walk_spp, a.walk_seeds), ("hierarchical", 4, (2, 4, 6, 8))):
        imgs = []
        for s in seeds:
            path = os.path.join(out, f"{'framed' if framed else 'bare'}_{method}_{spp}_{s}.npy")
            if not os.path.exists(path):
                model = "monte_carlo" if method == "random_walk" else "adaptive"
                m = av.library("marble", 1.0, model, 10000)
                if model == "adaptive":
                    m.adaptive_table()
                slab, _ = av.SHAPES["slab"](m)
                sc = av.scene(slab + (frame() if framed else []), extent, True, a.size)
                sc.environment = (0.0, 0.0, 0.0)
                np.save(path, R.render(sc, method, spp=spp, seed=s, threads=2).array)
                print(f"  {path}", flush=True)
            imgs.append(np.load(path))
        res[method] = imgs
    return res["random_walk"], res["hierarchical"]


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--size", type=int, default=64)
    ap.add_argument("--walk-spp", type=int, default=128)
    ap.add_argument("--walk-seeds", type=lambda x: [int(v) for v in x.split(",")], default=[1, 2])
    ap.add_argument("--out", default="/tmp/mtref/sides")
    a = ap.parse_args(argv)
    os.makedirs(a.out, exist_ok=True)
    objs, extent = av.SHAPES["slab"](av.library("marble", 1.0, "monte_carlo", 10000))
    mask = av.object_mask(objs, extent, a.size)
    rim = rim_distance(av.scene(objs, extent, True, a.size).camera)
    regions = [(name, mask & (rim > lo) & (rim <= hi)) for name, lo, hi in REGIONS] + [("object", mask)]
    walks = {}
    print("| slab, area light only | region | px | model / walk − 1 (R, G, B) % | walk σ % |")
    print("|---|---|---|---|---|")
    for framed in (False, True):
        w, h = images(objs, extent, a, framed, a.out)
        walks[framed] = np.mean(w, axis=0)
        for name, mk in regions:
            mw, mh = np.mean(w, axis=0)[mk].mean(axis=0), np.mean(h, axis=0)[mk].mean(axis=0)
            sw = np.sqrt(np.stack([x[mk] for x in w]).var(axis=0, ddof=1).sum(axis=0) / (len(w) * mk.sum() ** 2))
            b = ", ".join(f"{100 * (x - 1):+.1f}" for x in mh / mw)
            s = ", ".join(f"{100 * x:.1f}" for x in sw / mw)
            print(f"| {'framed' if framed else 'bare'} | {name} | {int(mk.sum())} | {b} | {s} |")
    print("\nthe sides' share of the walk's image (1 − framed / bare), R, G, B %:")
    for name, mk in regions:
        share = 1 - walks[True][mk].mean(axis=0) / walks[False][mk].mean(axis=0)
        print(f"  {name}: " + ", ".join(f"{100 * x:.1f}" for x in share))


if __name__ == "__main__":
    main()
