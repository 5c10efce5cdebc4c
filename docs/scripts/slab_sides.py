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

Then the unscattered (ballistic) image of the light through the slab, per pixel from its centre ray
(:func:`ballistic`): the ray refracted into the front face (y = −1) leaves the back face parallel to
itself; where it meets the rectangle it carries L (1 − F_in)(1 − F_out) e^{−σt · 2 mm / cos θt}, else
the environment's radiance so attenuated. Printed: its share of the walk's image per region (light
alone) and of the matrix row's reference (``--refs``, with the environment), the model's bias
against the walk less it, and the step of walk − model in bands of x across the line x ≈ 9.9 mm
beyond which the rays pass beside the light (|z| < 9 mm), against the predicted step.

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


def fresnel(ci, n1, n2):
    """Unpolarised Fresnel reflectance at incidence cosine ``ci`` from n1 into n2, and cos θt."""
    si = n1 / n2 * np.sqrt(np.maximum(0.0, 1 - ci**2))
    ct = np.sqrt(np.maximum(0.0, 1 - si**2))
    rs = ((n1 * ci - n2 * ct) / (n1 * ci + n2 * ct)) ** 2
    rp = ((n1 * ct - n2 * ci) / (n1 * ct + n2 * ci)) ** 2
    return 0.5 * (rs + rp), ct


def ballistic(sc, material):
    """(image of the unscattered light through the slab (H, W, 3), the rectangle seen through it
    (H, W) bool, the front-face point of each pixel's centre ray (H, W, 3))."""
    cam, (light,) = sc.camera, sc.lights
    pos, d = np.asarray(cam.position, float), rc.camera_rays(cam)
    f_in, ct = fresnel(d[..., 1], 1.0, material.eta)  # the front face's outward normal is −y
    f_out, _ = fresnel(ct, material.eta, 1.0)
    p0 = pos + ((-1 - pos[1]) / d[..., 1])[..., None] * d
    inside = d / material.eta
    inside[..., 1] = ct
    p1 = p0 + (2 / ct)[..., None] * inside
    c, u, v = (np.asarray(x, float) for x in (light.position, light.u, light.v))
    q = p1 + ((c[1] - p1[..., 1]) / d[..., 1])[..., None] * d - c  # on the light's plane y = c_y
    sees = (np.abs(q @ u) <= u @ u) & (np.abs(q @ v) <= v @ v)
    radiance = np.asarray(light.power, float) / (np.pi * 4 * np.linalg.norm(np.cross(u, v)))
    seen = np.where(sees[..., None], radiance, np.asarray(sc.environment, float))
    st = np.asarray(material.sigma_a) + np.asarray(material.sigma_s)
    img = ((1 - f_in) * (1 - f_out))[..., None] * seen * np.exp(-st * (2 / ct)[..., None])
    return img, sees, p0


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
    ap.add_argument("--refs", default="/work/wt/vm/refs", help="the matrix's random_walk references")
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
    unscattered(objs, extent, a, regions)


def unscattered(objs, extent, a, regions):
    """The ballistic image's shares and the step of walk − model across the edge of the light's view."""
    sc = av.scene(objs, extent, True, a.size)
    dark = av.scene(objs, extent, True, a.size)
    dark.environment = (0.0, 0.0, 0.0)
    ball, sees, p0 = ballistic(dark, objs[0].material)
    w, h = images(objs, extent, a, False, a.out)
    wm, hm = np.mean(w, axis=0), np.mean(h, axis=0)
    print("\nthe light's unscattered image through the slab (light alone), R, G, B:")
    for name, mk in regions:
        b = ball[mk].mean(axis=0)
        share = ", ".join(f"{100 * x:.1f}" for x in b / wm[mk].mean(axis=0))
        less = ", ".join(f"{100 * x:+.1f}" for x in hm[mk].mean(axis=0) / (wm - ball)[mk].mean(axis=0) - 1)
        vals = ", ".join(f"{x:.3f}" for x in b)
        print(f"  {name}: {vals} = {share} % of the walk; model / (walk − it) − 1: {less} %")
    # The table's T at d = 2 mm counts the unscattered photons of its normal-incidence runs:
    # e^{−σt d}(1 − F(0)) of it. Emulated: the model's image less that share, plus the term.
    m = av.library("marble", 1.0, "adaptive", 10000)
    st = np.asarray(m.sigma_a) + np.asarray(m.sigma_s)
    t = np.array([m.adaptive_table().totals(c, 2.0)[1] for c in range(3)])
    u = np.exp(-2 * st) * (1 - fresnel(np.ones(1), 1.0, m.eta)[0]) / t
    print(
        "  the table's T at 2 mm "
        + ", ".join(f"{x:.4f}" for x in t)
        + "; its unscattered share "
        + ", ".join(f"{100 * x:.2f}" for x in u)
        + " %"
    )
    for name, mk in regions:
        e = (hm * (1 - u) + ball)[mk].mean(axis=0) / wm[mk].mean(axis=0) - 1
        print(
            f"  {name}: model × (1 − share) + the term against the walk: "
            + ", ".join(f"{100 * x:+.1f}" for x in e)
            + " %"
        )
    names = [f"slab_marble_1.0_{a.size}_128_{s}.npz" for s in (1, 7, 11, 13)]
    if all(os.path.exists(os.path.join(a.refs, n)) for n in names):
        ref = np.mean([np.load(os.path.join(a.refs, n))["img"] for n in names], axis=0)
        full, _, _ = ballistic(sc, objs[0].material)
        mk = regions[-1][1]
        share = full[mk].sum(axis=0) / ref[mk].sum(axis=0)
        pct = ", ".join(f"{100 * x:.2f}" for x in share)
        print(f"  of the matrix row's reference (with the environment): {pct} %")
    x, z, (_, mask) = p0[..., 0], p0[..., 2], regions[-1]
    edge = x[sees & mask & (np.abs(z) < 9)].max()
    print(f"walk − model in bands of x (|z| < 9 mm; the rays pass beside the light beyond x = {edge:.1f} mm):")
    for lo, hi in ((edge - 3.6, edge - 1.8), (edge - 1.8, edge), (edge, edge + 1.8), (edge + 1.8, edge + 3.6)):
        mk = mask & (x > lo + 1e-9) & (x <= hi + 1e-9) & (np.abs(z) < 9)
        d = (wm - hm)[mk].mean(axis=0)
        s = np.sqrt(np.stack([im[mk] for im in w]).var(axis=0, ddof=1).sum(axis=0) / (len(w) * mk.sum() ** 2))
        print(
            f"  x ∈ ({lo:.1f}, {hi:.1f}] mm, {int(mk.sum())} px: "
            + ", ".join(f"{m:+.3f}±{e:.3f}" for m, e in zip(d, s))
            + "; unscattered image "
            + ", ".join(f"{m:.3f}" for m in ball[mk].mean(axis=0))
        )


if __name__ == "__main__":
    main()
