"""Validation of the geometry-aware BSSRDF (``model="adaptive"``) for docs/render.md: a matrix of
shapes × materials rendered with ``hierarchical`` (models ``monte_carlo`` and ``adaptive``, and
``probe`` + ``adaptive``) against ``random_walk`` (the reference, which agrees with Mitsuba 3),
under a constant environment and an area light.

Per case and model: the object-mean bias per channel against the reference, the per-pixel mean
relative error next to the noise floor (a second random_walk image of the same spp against the
reference), and the efficiency 1/(RMSE² × seconds) of hierarchical + adaptive against random_walk
at a low spp (both RMSEs against the reference). Object pixels: those whose every sample hits the
object (an image of the object as a black Lambertian surface in a white environment is 0 there).

Usage: python docs/scripts/adaptive_validation.py [--size 64] [--spp-ref 256] [--cases a,b,…]
[--table-photons 20000]. Prints a markdown table (and ``--json`` writes the numbers). Tables are
cached (``$SUBSURF_CACHE/adaptive``), so a second run only renders.
"""

from __future__ import annotations

import argparse
import json
import os
import time

import numpy as np
import subsurf
import subsurf.render as R

# Skin-like two-layer material: a 0.25 mm absorbing epidermis over Jensen et al.'s (2001) skin1
# dermis, g = 0.8, n = 1.4 (as docs/scripts/render_reference.py).
SKIN_G, SKIN_N, EPI_D = 0.8, 1.4, 0.25
EPI = ((0.25, 0.5, 1.0), (1.5, 1.7, 2.0))  # σa, σs' (mm⁻¹)
DERMIS = ((0.032, 0.17, 0.48), (0.74, 0.88, 1.01))


def library(name, scale, model, photons):
    m = R.Translucent.library(name, model=model, mc_photons=photons, mc_seed=3)
    m.sigma_a, m.sigma_s = [scale * x for x in m.sigma_a], [scale * x for x in m.sigma_s]
    return m


def skin_stacks(scale):
    return [
        subsurf.Stack(
            [
                subsurf.Layer(SKIN_N, scale * EPI[0][k], scale * EPI[1][k] / (1 - SKIN_G), SKIN_G, EPI_D / scale),
                subsurf.Layer(SKIN_N, scale * DERMIS[0][k], scale * DERMIS[1][k] / (1 - SKIN_G), SKIN_G),
            ]
        )
        for k in range(3)
    ]


def skin_layered(scale, model, photons):
    return R.Translucent.from_stacks(skin_stacks(scale), model=model, mc_photons=photons, mc_seed=3)


# Shapes: (objects for a material, light, camera). Geometry in mm; the material's scale sets the
# size in diffusion lengths (marble's red diffusion length is 8.5 mm at scale 1).
def sphere(radius):
    def make(mat):
        return [R.Object.sphere(mat, radius=radius, subdivisions=5)], radius

    return make


def lens(mat):
    # an icosphere scaled to 18 × 2.4 × 18 mm (the demo's lens): thin at its rim
    return [R.Object.sphere(mat, radius=1, subdivisions=5, scale=(9, 1.2, 9))], 9


def slab(mat):
    # a thin slab 30 × 2 × 30 mm, lit from behind (its far face)
    return [R.Object.box(mat, lo=(-15, -1, -15), hi=(15, 1, 15))], 15


def box(mat):
    return [R.Object.box(mat, lo=(-6, -6, -6), hi=(6, 6, 6), rotate=(20, 0, 30))], 10


def torus(mat):
    return [R.Object.torus(mat, major=7, minor=2.5, rotate=(70, 0, 0))], 10


SHAPES = {"sphere": sphere(10), "lens": lens, "slab": slab, "box": box, "torus": torus}


def scene(objects, extent, backlit):
    d = 6 * extent
    light = (
        R.RectLight((-15, 3 * extent, -15), (30, 0, 0), (0, 0, 30), 2.25e5)  # behind, facing the camera
        if backlit
        else R.RectLight((-20, -30, 40), (15, 0, 0), (0, -10.6, 10.6), 2.25e5)
    )
    cam = R.Camera((0, -d, 0.15 * d), fov=24, width=SIZE, height=SIZE)
    return R.Scene(objects, [light], (0.2, 0.2, 0.22), cam)


def object_mask(objects, extent):
    black = [R.Object(o.positions, o.triangles, R.Lambertian(0.0)) for o in objects]  # positions already transformed
    s = R.Scene(black, [], (1, 1, 1), scene(objects, extent, False).camera)
    img = R.render(s, "hierarchical", spp=16, seed=0).array
    return np.all(img == 0, axis=-1)


def stats(arr, ref, mk):
    d = arr[mk] - ref[mk]
    rel = np.mean(np.abs(d) / np.maximum(ref[mk], 1e-12), axis=0)
    rmse = float(np.sqrt(np.mean(d**2)))
    bias = arr[mk].sum(axis=0) / ref[mk].sum(axis=0) - 1
    return rel, rmse, bias


def run_case(shape, material, scale, a):
    def mat(model):
        if material == "skin_layered":
            return skin_layered(scale, model, a.table_photons)
        return library(material, scale, model, a.table_photons)

    backlit = shape == "slab"
    objs, extent = SHAPES[shape](mat("monte_carlo"))
    mk = object_mask(objs, extent)
    walk_objs = objs
    if material == "skin_layered":  # random_walk: the epidermis as a shell around the dermis
        if shape != "sphere":
            return None
        walk_objs = skin_walk(scale)

    def walk(spp, seed):
        """A random_walk image and its time, from ``--ref-cache`` if it holds it."""
        path = f"{a.ref_cache}/{shape}_{material}_{scale}_{SIZE}_{spp}_{seed}.npz" if a.ref_cache else None
        if path and os.path.exists(path):
            z = np.load(path)
            return z["img"], float(z["s"])
        t0 = time.monotonic()
        img = R.render(scene(walk_objs, extent, backlit), "random_walk", spp=spp, seed=seed).array
        dt = time.monotonic() - t0
        if path:
            os.makedirs(a.ref_cache, exist_ok=True)
            np.savez(path, img=img, s=dt)
        return img, dt

    ref, t_ref = walk(a.spp_ref, 1)
    rows = {}
    again, dt = walk(a.spp_ref, 7)
    rows["random_walk (noise floor)"] = (*stats(again, ref, mk), dt)
    low, dt = walk(a.spp_low, 9)
    rows[f"random_walk {a.spp_low} spp"] = (*stats(low, ref, mk), dt)
    for spec in a.models.split(","):
        method, model = spec.split(":")
        m = mat(model)
        if model == "adaptive":
            m.adaptive_table()  # build or load the table outside the timing (cached on disk)
        o2, _ = SHAPES[shape](m)
        t0 = time.monotonic()
        spp = a.spp if method == "hierarchical" else a.spp_probe
        img = R.render(scene(o2, extent, backlit), method, spp=spp, seed=2).array
        rows[f"{method} {model}"] = (*stats(img, ref, mk), time.monotonic() - t0)
    return {"pixels": int(mk.sum()), "t_ref": t_ref, "rows": rows}


def skin_walk(scale):
    def layer(p, name):
        sa, ss = [scale * x for x in p[0]], [scale * x / (1 - SKIN_G) for x in p[1]]
        return R.Translucent(sa, ss, g=SKIN_G, eta=SKIN_N, name=name)

    epi, der = layer(EPI, "epidermis"), layer(DERMIS, "dermis")
    return [
        R.Object.sphere(epi, radius=10, subdivisions=5),
        R.Object.sphere(der, radius=10 - EPI_D / scale, subdivisions=5),
    ]


SIZE = 64


def main():
    global SIZE
    ap = argparse.ArgumentParser()
    ap.add_argument("--size", type=int, default=64)
    ap.add_argument("--spp-ref", type=int, default=256)
    ap.add_argument("--spp-low", type=int, default=16)
    ap.add_argument("--spp", type=int, default=4)
    ap.add_argument("--spp-probe", type=int, default=64)
    ap.add_argument("--table-photons", type=int, default=20000)
    ap.add_argument(
        "--cases",
        default="sphere:marble:1,sphere:marble:0.25,sphere:marble:4,slab:marble:1,lens:skin1:1,sphere:skin_layered:1",
        help="shape:material:scale, comma-separated (shapes: " + ", ".join(SHAPES) + ")",
    )
    ap.add_argument("--json", help="write the numbers here")
    ap.add_argument(
        "--models",
        default="hierarchical:monte_carlo,hierarchical:adaptive,probe:adaptive",
        help="method:model pairs to compare, comma-separated",
    )
    ap.add_argument("--ref-cache", help="keep the random_walk images here (re-runs only render the BSSRDFs)")
    a = ap.parse_args()
    SIZE = a.size
    out = {}
    for case in a.cases.split(","):
        shape, material, scale = case.split(":")
        t0 = time.monotonic()
        res = run_case(shape, material, float(scale), a)
        if res is None:
            print(f"{case}: skipped (the layered random_walk reference is built for spheres only)")
            continue
        out[case] = res
        print(f"\n{case}: {res['pixels']} object pixels, {time.monotonic() - t0:.0f} s", flush=True)
        print("| method model | object mean vs reference R, G, B | mean rel. error R, G, B | RMSE | time (s) |")
        print("|---|---|---|---|---|")
        for name, (rel, rmse, bias, dt) in res["rows"].items():
            b = ", ".join(f"{100 * x:+.1f}" for x in bias)
            r = ", ".join(f"{100 * x:.0f}" for x in rel)
            print(f"| {name} | {b} % | {r} % | {rmse:.3e} | {dt:.1f} |", flush=True)
        rw = res["rows"][f"random_walk {a.spp_low} spp"]
        hi = res["rows"].get("hierarchical adaptive")
        if hi is not None:  # --models without it: no efficiency
            eff = (1 / (hi[1] ** 2 * hi[3])) / (1 / (rw[1] ** 2 * rw[3]))
            print(f"efficiency hierarchical+adaptive / random_walk: {eff:.1f}x")
            res["efficiency_ratio"] = eff
    if a.json:
        with open(a.json, "w") as f:
            json.dump(
                {
                    k: {
                        **v,
                        "rows": {
                            n: {"rel": list(map(float, r[0])), "rmse": r[1], "bias": list(map(float, r[2])), "s": r[3]}
                            for n, r in v["rows"].items()
                        },
                    }
                    for k, v in out.items()
                },
                f,
                indent=1,
            )


if __name__ == "__main__":
    main()
