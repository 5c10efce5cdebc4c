"""The BSSRDF methods against random_walk on examples/render/marble_sphere.toml with its floor
(albedo 0.5, as shipped), a white floor (albedo 1) and no floor (docs/render.md): the
object-mean ratio per channel over the sphere's pixels (pixels whose four corners see the sphere),
and the noise floor (two random_walk images of different seeds).
Usage: python docs/scripts/floor_bounce.py [--spp-ref 32] [--spp 4] [--model dipole] [--scale 1]
[--methods hierarchical,probe]."""

from __future__ import annotations

import argparse
import copy
import os
import time

import numpy as np
import subsurf.render as R
from subsurf.render.toml_scene import load_scene

HERE = os.path.dirname(os.path.abspath(__file__))
EXAMPLE = os.path.join(HERE, "..", "..", "examples", "render", "marble_sphere.toml")


def mask(cam, center=(0.0, 0.0, 10.0), radius=9.9):
    """Pixels whose four corners' camera rays meet the sphere (radius just inside the icosphere's)."""
    pos, look, up = (np.asarray(v, float) for v in (cam.position, cam.look_at, cam.up))
    fwd = (look - pos) / np.linalg.norm(look - pos)
    right = np.cross(fwd, up)
    right /= np.linalg.norm(right)
    upv = np.cross(right, fwd)
    t, w, h = np.tan(np.radians(cam.fov) / 2), cam.width, cam.height
    oc = pos - np.asarray(center)

    def hits(x, y):
        sx = (2 * x / w - 1) * t * w / h
        sy = (1 - 2 * y / h) * t
        d = fwd[None, None] + sx[..., None] * right + sy[..., None] * upv
        d /= np.linalg.norm(d, axis=-1, keepdims=True)
        b = d @ oc
        return b * b - (oc @ oc - radius * radius) > 0

    ys, xs = np.mgrid[0:h, 0:w].astype(float)
    return hits(xs, ys) & hits(xs + 1, ys) & hits(xs, ys + 1) & hits(xs + 1, ys + 1)


def variant(scene, floor):
    """The example with the floor's albedo `floor` (None: no floor)."""
    s = copy.copy(scene)
    objs = []
    for o in scene.objects:
        if isinstance(o.material, R.Lambertian):
            if floor is None:
                continue
            o = copy.copy(o)
            o.material = R.Lambertian([floor] * 3, name="floor")
        objs.append(o)
    s.objects = objs
    return s


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--spp-ref", type=int, default=32)
    ap.add_argument("--spp", type=int, default=4)
    ap.add_argument("--model", default=None, help="profile model of the marble (default: the example's)")
    ap.add_argument("--methods", default="hierarchical,probe")
    ap.add_argument("--probe-spp", type=int, default=64)
    ap.add_argument("--floors", default="none,0.5,1")
    a = ap.parse_args()
    scene, _ = load_scene(EXAMPLE)
    if a.model:
        for o in scene.objects:
            if isinstance(o.material, R.Translucent):
                o.material = copy.copy(o.material)
                o.material.model = a.model
    mk = mask(scene.camera)
    print(f"{mk.sum()} object pixels; random_walk {a.spp_ref} spp × 2 seeds")
    for fl in a.floors.split(","):
        floor = None if fl == "none" else float(fl)
        s = variant(scene, floor)
        t0 = time.time()
        ref = [np.asarray(R.render(s, "random_walk", spp=a.spp_ref // 2, seed=sd))[mk].mean(0) for sd in (11, 12)]
        t_ref = time.time() - t0
        mean_ref = 0.5 * (ref[0] + ref[1])
        noise = ref[0] / ref[1] - 1
        row = f"floor {fl}: random_walk {np.round(mean_ref, 5)} ({t_ref:.0f} s; "
        row += f"seed-to-seed {np.round(100 * noise, 1)} %)"
        for m in a.methods.split(","):
            spp = a.probe_spp if m == "probe" else a.spp
            t0 = time.time()
            img = np.asarray(R.render(s, m, spp=spp, seed=3))[mk].mean(0)
            row += f"; {m} {spp} spp ratio {np.round(img / mean_ref, 3)} ({time.time() - t0:.0f} s)"
        print(row, flush=True)


if __name__ == "__main__":
    main()
