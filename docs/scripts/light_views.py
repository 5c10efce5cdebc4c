"""Where the adaptive model's error under the validation matrix's area light sits, on a sphere of the
matrix (docs/render.md, "The matrix's area light: where the excess sits"): the sphere under one light
at a time (the matrix's rectangle alone, the same rectangle turned to face the sphere, a sun from its
direction, the environment alone) and the rectangle alone seen from four cameras (the matrix's, from
the light, from the side, from the far side), ``hierarchical`` + ``adaptive`` 4 spp against two
``random_walk`` images; object means per channel and red by bins of the rectangle's own irradiance
(E/E_max, from the rectangle's radiance and both cosines, no occlusion: the sphere is convex).

    python docs/scripts/light_views.py [--case sphere:ketchup:1] [--spp-ref 512] [--out DIR]

The random_walk images are cached in DIR (default /tmp/light_views).
"""

from __future__ import annotations

import argparse
import os
import sys

import numpy as np
import subsurf.render as R

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import adaptive_validation as V  # noqa: E402

C, U, W = np.array([-20.0, -30, 40]), np.array([15.0, 0, 0]), np.array([0, -10.6, 10.6])  # the matrix's rect
CAMERAS = {
    "matrix": ((0, -60, 9.0), 24),
    "light": (tuple(40 * C / np.linalg.norm(C)), 36),
    "side": ((42.0, -42, 9), 36),
    "far": ((40.0, -30, -30), 36),
}


def lights(which):
    if which == "rect":
        return [R.RectLight(tuple(C), tuple(U), tuple(W), 2.25e5)]
    n = -C / np.linalg.norm(C)
    if which == "facing":  # the same centre and size, facing the sphere
        u = np.cross(n, [0, 0, 1.0])
        u /= np.linalg.norm(u)
        return [R.RectLight(tuple(C), tuple(15 * u), tuple(15 * np.cross(n, u)), 2.25e5)]
    return [R.DirectionalLight(tuple(-n), 1e-3)] if which == "sun" else []


def irradiance(p, n, k=24):
    """The rectangle's irradiance at points p (normals n) over its largest, by a k × k midpoint rule."""
    nl = np.cross(U, W) / np.linalg.norm(np.cross(U, W))
    e = np.zeros(p.shape[:-1])
    for a in (np.arange(k) + 0.5) / k * 2 - 1:
        for b in (np.arange(k) + 0.5) / k * 2 - 1:
            d = C + a * U + b * W - p
            r2 = (d * d).sum(-1)
            d /= np.sqrt(r2)[..., None]
            e += np.maximum((n * d).sum(-1), 0) * np.maximum(-(d @ nl), 0) / r2
    return e / e.max()


def sphere_hits(cam, fov, size, radius):
    """Per pixel: whether the ray hits the sphere well inside its outline, the point and the normal."""
    pos = np.array(cam, float)
    f = -pos / np.linalg.norm(pos)
    r = np.cross(f, [0, 0, 1.0])
    r /= np.linalg.norm(r)
    u, t = np.cross(r, f), np.tan(np.radians(fov / 2))
    ys, xs = np.mgrid[0:size, 0:size] + 0.5
    d = f + ((2 * xs / size - 1) * t)[..., None] * r + ((1 - 2 * ys / size) * t)[..., None] * u
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    b = d @ pos
    disc = b * b - (pos @ pos - radius * radius)
    p = pos + (-b - np.sqrt(np.maximum(disc, 0)))[..., None] * d
    return disc > 0.3 * radius, p, p / radius


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", default="sphere:ketchup:1")
    ap.add_argument("--spp-ref", type=int, default=512)
    ap.add_argument("--size", type=int, default=64)
    ap.add_argument("--out", default="/tmp/light_views")
    a = ap.parse_args()
    shape, material, scale = a.case.split(":")
    os.makedirs(a.out, exist_ok=True)

    def objects(model):
        return V.SHAPES[shape](V.library(material, float(scale), model, 10000))[0]

    walk, model = objects("monte_carlo"), objects("adaptive")
    runs = [(w, "matrix") for w in ("rect", "facing", "sun", "env")] + [("rect", v) for v in CAMERAS if v != "matrix"]
    for which, view in runs:
        cam, fov = CAMERAS[view]

        def scene(objs, which=which, cam=cam, fov=fov):
            env = (0.2, 0.2, 0.22) if which == "env" else (0, 0, 0)
            return R.Scene(objs, lights(which), env, R.Camera(cam, fov=fov, width=a.size, height=a.size))

        refs = []
        for seed in (1, 7):
            path = f"{a.out}/{a.case.replace(':', '_')}_{which}_{view}_{a.spp_ref}_{seed}.npz"
            refs.append(V.cached_walk(path, scene(walk), a.spp_ref, seed)[0])
        img = R.render(scene(model), "hierarchical", spp=4, seed=2).array
        ref = 0.5 * (refs[0] + refs[1])
        hit, p, n = sphere_hits(cam, fov, a.size, 10.0)
        err = 100 * (img[hit].sum(0) / ref[hit].sum(0) - 1)
        floor = 100 * (refs[1][hit].sum(0) / refs[0][hit].sum(0) - 1)
        print(f"{which:6s} seen from {view:6s}: R, G, B {np.round(err, 1)} (floor {np.round(floor, 1)})")
        if which == "rect":
            e = irradiance(p, n)
            for lo, hi in ((0, 1e-9), (1e-9, 0.2), (0.2, 0.5), (0.5, 0.8), (0.8, 1.01)):
                mk = hit & (e >= lo) & (e < hi)
                if mk.sum() >= 5:
                    red = 100 * (img[mk, 0].sum() / ref[mk, 0].sum() - 1)
                    print(f"    E/E_max [{lo:.1f}, {hi:.1f}): {mk.sum():4d} pixels, red {red:+.1f} %")


if __name__ == "__main__":
    main()
