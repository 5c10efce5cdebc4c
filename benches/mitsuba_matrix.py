"""Mitsuba 3 on the validation matrix's scenes (docs/render.md, "Mitsuba 3 on the matrix's scenes"):
is the matrix's reference, the mean of four 128-spp ``random_walk`` images, right?

Per row ``shape:material:scale`` the scene is built exactly as docs/scripts/adaptive_validation.py
builds it (``SHAPES[shape](library(material, scale, "monte_carlo", 10000))``, ``scene(objs, extent,
backlit = shape == "slab", size)``), converted with benches/render_compare.py's
``mitsuba_description`` (the same triangles as a PLY with flat facets, ``to_mitsuba``'s dielectric
and homogeneous medium, the rectangle's ``to_world`` and radiance, the constant environment, the
pinhole camera and a box pixel filter) and rendered ``--seeds`` times with Mitsuba 3's
``volpathmis`` (Russian roulette off, ``rr_depth`` 10⁹, as the bench: see "Against Mitsuba 3")
by benches/mitsuba_worker.py on 2 threads. ``--lambertian A`` swaps the material for an opaque
Lambertian of albedo A in both renderers (a check of the conversion alone: the walk renders the
scene itself then, ``--walk-spp`` × ``--walk-seeds``).

Compared over the matrix's object pixels (``adaptive_validation.object_mask``): per channel the
object mean of the mean of the K Mitsuba images against that of the walk's images (the matrix's
references, read from ``--refs``: ``{shape}_{material}_{scale}_{size}_128_{seed}.npz``, key
``img``), each with σ² = Σᵢ sᵢ²/(K n²) (sᵢ² the sample variance of pixel i over the K images:
the pixels of an image are independent), and ratio − 1 = Mitsuba/walk − 1 with σ by propagation.

Usage: DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM-19.so nice -n 5 .venv/bin/python
benches/mitsuba_matrix.py --cases slab:marble:1 --spp 256 --seeds 1,2,3,4 [--out /tmp/mtref]
Mitsuba's images are kept in ``OUT/mitsuba`` (a rerun reuses them); the numbers are merged into
``OUT/mitsuba_matrix.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import sys

import numpy as np
import subsurf.render as R

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, "..", "docs", "scripts"))

import adaptive_validation as av  # noqa: E402
import render_compare as rc  # noqa: E402

RR_DEPTH = 10**9


def build(case: str, size: int, lambertian: float | None):
    """(scene, mask) of a matrix row; the material an opaque Lambertian of albedo ``lambertian``
    if given (the mask is the matrix's either way)."""
    shape, material, scale = case.split(":")
    objs, extent = av.SHAPES[shape](av.library(material, float(scale), "monte_carlo", 10000))
    mask = av.object_mask(objs, extent, size)
    if lambertian is not None:
        objs = [R.Object(o.positions, o.triangles, R.Lambertian(lambertian)) for o in objs]
    return av.scene(objs, extent, shape == "slab", size), mask


def description(sc, ply: str, lambertian: float | None) -> dict:
    """render_compare's description of ``sc``; a Lambertian object gets a ``diffuse`` BSDF and no medium."""
    if lambertian is None:
        return rc.mitsuba_description(sc, ply, RR_DEPTH)
    (o,) = sc.objects
    mat = o.material
    o.material = R.Translucent.library("marble")  # to_mitsuba needs a Translucent; replaced below
    d = rc.mitsuba_description(sc, ply, RR_DEPTH)
    o.material = mat
    d["material"] = {"bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [lambertian] * 3}}}
    return d


def mean_sigma(images, mask):
    """Object mean per channel of the mean of ``images`` and its σ (independent pixels)."""
    return rc.mean_and_sigma(images, mask)


def spread_sigma(images, mask):
    """σ of the object mean from the spread of the K images' own object means (K − 1 degrees of
    freedom: a cross-check of :func:`mean_sigma`, which assumes independent pixels)."""
    m = np.stack([im[mask].mean(axis=0) for im in images])
    return m.std(axis=0, ddof=1) / np.sqrt(len(images))


def ratio(m, sm, w, sw):
    """m/w − 1 and its σ (independent estimates)."""
    r = m / w
    return r - 1, r * np.sqrt((sm / m) ** 2 + (sw / w) ** 2)


def walk_images(case, a, sc):
    shape, material, scale = case.split(":")
    if a.lambertian is None:
        name = f"{shape}_{material}_{float(scale)}_{a.size}_128_{{}}.npz"
        return [np.load(os.path.join(a.refs, name.format(s)))["img"] for s in (1, 7, 11, 13)]
    out = []
    for s in a.walk_seeds:
        path = os.path.join(a.out, "walk", f"{case.replace(':', '_')}_lamb{a.lambertian}_{a.walk_spp}_{s}.npy")
        if not os.path.exists(path):
            os.makedirs(os.path.dirname(path), exist_ok=True)
            np.save(path, R.render(sc, "random_walk", spp=a.walk_spp, seed=s, threads=2).array)
        out.append(np.load(path))
    return out


def run(case, a, mit):
    sc, mask = build(case, a.size, a.lambertian)
    tag = case.replace(":", "_") + ("" if a.lambertian is None else f"_lamb{a.lambertian}")
    d = os.path.join(a.out, "mitsuba")
    os.makedirs(d, exist_ok=True)
    paths = [os.path.join(d, f"{tag}_{a.size}_{a.spp}_{s}.npy") for s in a.seeds]
    loaded = False
    for s, p in zip(a.seeds, paths):
        if os.path.exists(p):
            continue
        if not loaded:
            mit.load(description(sc, os.path.join(a.out, f"{tag}.ply"), a.lambertian))
            loaded = True
        _, wall, cpu = mit.render(a.spp, s, p)
        print(f"  {tag} seed {s}: {wall:.0f} s wall, {cpu:.0f} s CPU", flush=True)
    mits = [np.load(p) for p in paths]
    walks = walk_images(case, a, sc)
    (mm, sm), (mw, sw) = mean_sigma(mits, mask), mean_sigma(walks, mask)
    r, sr = ratio(mm, sm, mw, sw)
    _, sr_spread = ratio(mm, spread_sigma(mits, mask), mw, spread_sigma(walks, mask))
    return {
        "pixels": int(mask.sum()),
        "mitsuba": {"mean": mm.tolist(), "sigma": sm.tolist(), "spp": a.spp, "seeds": list(a.seeds)},
        "walk": {"mean": mw.tolist(), "sigma": sw.tolist()},
        "ratio_minus_1": r.tolist(),
        "sigma": sr.tolist(),
        "z": (r / sr).tolist(),
        "sigma_spread": sr_spread.tolist(),
    }


def table(results):
    lines = [
        "| row | px | walk R, G, B (±σ) | Mitsuba R, G, B (±σ) | Mitsuba/walk − 1 (%) ± σ | z | σ from spread (%) |",
        "|---|---|---|---|---|---|---|",
    ]
    for key, r in results.items():

        def f3(x):
            return ", ".join(f"{m:.4f}±{s:.4f}" for m, s in zip(x["mean"], x["sigma"]))

        pct = ", ".join(f"{100 * v:+.2f}±{100 * s:.2f}" for v, s in zip(r["ratio_minus_1"], r["sigma"]))
        z = ", ".join(f"{v:+.1f}" for v in r["z"])
        spread = ", ".join(f"{100 * v:.2f}" for v in r.get("sigma_spread", []))
        lines.append(f"| {key} | {r['pixels']} | {f3(r['walk'])} | {f3(r['mitsuba'])} | {pct} | {z} | {spread} |")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--cases", default="slab:marble:1")
    ap.add_argument("--size", type=int, default=64)
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--seeds", type=lambda x: [int(v) for v in x.split(",")], default=[1, 2, 3, 4])
    ap.add_argument("--refs", default="/work/wt/vm/refs", help="the matrix's random_walk references")
    ap.add_argument("--out", default="/tmp/mtref")
    ap.add_argument("--lambertian", type=float, help="an opaque Lambertian of this albedo instead")
    ap.add_argument("--walk-spp", type=int, default=64)
    ap.add_argument("--walk-seeds", type=lambda x: [int(v) for v in x.split(",")], default=[1, 2, 3, 4])
    ap.add_argument("--table-only", action="store_true")
    a = ap.parse_args(argv)
    path = os.path.join(a.out, "mitsuba_matrix.json")
    results = json.load(open(path)) if os.path.exists(path) else {}
    if not a.table_only:
        mit = rc.Mitsuba(sys.executable, rc.THREADS, allow_install=False)
        if not mit.ok:
            sys.exit(mit.why)
        try:
            for case in a.cases.split(","):
                key = case + ("" if a.lambertian is None else f" lambertian {a.lambertian}")
                results[key] = run(case, a, mit)
                os.makedirs(a.out, exist_ok=True)
                with open(path, "w") as f:
                    json.dump(results, f, indent=1)
                print(table({key: results[key]}), flush=True)
        finally:
            mit.close()
    print(table(results))


if __name__ == "__main__":
    main()
