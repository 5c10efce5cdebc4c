"""Validation matrix of the BSSRDF models for docs/render.md: shapes × materials rendered with
``hierarchical`` (models ``dipole``, ``better_dipole``, ``photon_beam_diffusion``, ``monte_carlo``,
``adaptive``; ``probe`` on request) against ``random_walk`` (the reference, which agrees with
Mitsuba 3), under a constant environment and an area light.

Per case and model: the object-mean bias per channel against the reference (the mean of four
random_walk images of different seeds; the "floor" column: ±σ of that mean, and the per-pixel
mean relative error of one of those images against it) averaged over the model's images of
``--model-seeds`` (default four: one image's object mean carries its irradiance samples' noise
whole; the σ of that mean is printed beside the efficiency), and the efficiency 1/(MSE × seconds) of
hierarchical + adaptive against random_walk at a low spp, both errors against the truth: the
model's squared error against the reference less the reference's own variance (`truth_mse`),
random_walk's variance scaled from the references' (`reference_variance`). Object pixels: those
whose every sample hits the object (an image of the object as a black Lambertian surface in a
white environment is 0 there).

Cases are ``shape:material:scale``; the material's σa, σs are multiplied by ``scale`` (the mesh
is not), so a sphere of 10 mm is 1.2 marble diffusion lengths (red) at scale 1 and 100 at 85.

Usage: python docs/scripts/adaptive_validation.py [--size 64] [--spp-ref 128] [--ref-seeds 1,7,11,13]
[--cases a,b,…] [--models method:model,…] [--out DIR] [--figure PNG] [--table-only]. The random_walk images
(which do not depend on the BSSRDF code) are cached in ``DIR/refs``, so a rerun only renders the
BSSRDF images; the numbers are merged into ``DIR/results.json`` (a rerun of some models replaces
only their rows) and the images kept in ``DIR/images``; the matrix table is printed from there.
Adaptive tables are cached too (``$SUBSURF_CACHE/adaptive``). ``--quick`` is a smoke run.
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

MODELS = ("dipole", "better_dipole", "photon_beam_diffusion", "monte_carlo", "adaptive")
DEFAULT_CASES = (
    "sphere:marble:0.25,sphere:marble:1,sphere:marble:2.5,sphere:marble:8.5,sphere:marble:85,"
    "cylinder:marble:1,slab:marble:1,box:marble:1,torus:marble:1,bowl:marble:1,organic:skin1:1,"
    "sphere:wholemilk:1,sphere:ketchup:1,sphere:skin_layered:1"
)


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


# --- shapes: (objects for a material, extent in mm) ----------------------------------------------


def revolve(profile, segments=64):
    """A closed surface of revolution about z from a profile [(r, z), …] (mm) that starts and ends
    on the axis (r = 0): rings of ``segments`` vertices, one vertex per pole, outward-wound when the
    profile runs from the bottom pole up the outside."""
    rings = profile[1:-1]
    phi = 2 * np.pi * np.arange(segments) / segments
    pts = [(0.0, 0.0, profile[0][1])]
    pts += [(r * np.cos(f), r * np.sin(f), z) for r, z in rings for f in phi]
    pts.append((0.0, 0.0, profile[-1][1]))
    last, tris = len(pts) - 1, []
    ring = lambda i, j: 1 + i * segments + j % segments  # noqa: E731
    for j in range(segments):
        tris.append((0, ring(0, j + 1), ring(0, j)))
        tris.append((last, ring(len(rings) - 1, j), ring(len(rings) - 1, j + 1)))
        for i in range(len(rings) - 1):
            tris += [(ring(i, j), ring(i, j + 1), ring(i + 1, j + 1)), (ring(i, j), ring(i + 1, j + 1), ring(i + 1, j))]
    return np.array(pts), np.array(tris)


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


def cylinder(mat):
    # a capped cylinder, radius 5 mm, 20 mm long, its axis tilted 60° from the view axis (one cap seen)
    r, h = 5.0, 10.0
    cap = [(r * k / 6, -h) for k in range(1, 7)]
    side = [(r, z) for z in np.linspace(-h, h, 25)[1:-1]]
    prof = [(0.0, -h), *cap, *side, *[(r, h) for r, _ in cap[::-1]], (0.0, h)]
    p, t = revolve(prof)
    return [R.Object(p, t, mat, rotate=(-60, 0, 25))], 10


def bowl(mat):
    # a hemispherical shell (outer radius 10, inner 8 mm, a flat rim), opening tilted towards the
    # camera so the inside (concave) and the outside (convex) are both seen
    ro, ri, n = 10.0, 8.0, 24
    th = np.linspace(0, np.pi / 2, n + 1)  # from the bottom pole to the rim
    outer = [(ro * np.sin(a), -ro * np.cos(a)) for a in th]
    rim = [(ro - (ro - ri) * k / 4, 0.0) for k in range(1, 4)]
    inner = [(ri * np.sin(a), -ri * np.cos(a)) for a in th[::-1]]
    p, t = revolve(outer + rim + inner)
    # the inner pole comes last: the profile turns back on the axis, so its triangles face inwards
    # (into the cavity), i.e. out of the shell's material: the orientation is consistent
    return [R.Object(p, t, mat, rotate=(50, 0, 0), translate=(0, 0, 3))], 10


def organic(mat):
    # a scanned-looking blob: an icosphere of radius 10 mm displaced radially by a smooth random
    # field (sum of 12 plane waves of 1–2.5 cycles over the sphere, fixed seed): closed, manifold
    # (star-shaped), radius 7.25–12.75 mm before a 1.1 × 0.9 × 1 stretch: bumps, ridges and hollows
    base = R.Object.sphere(mat, radius=1, subdivisions=5)
    u = base.positions / np.linalg.norm(base.positions, axis=1, keepdims=True)
    rng = np.random.default_rng(20)
    k = rng.normal(size=(12, 3))
    k *= (rng.uniform(1, 2.5, 12) * np.pi / np.linalg.norm(k, axis=1))[:, None]
    field = np.sin(u @ k.T + rng.uniform(0, 2 * np.pi, 12)) @ (rng.uniform(0.5, 1, 12) / 12)
    r = 10 * (1 + 0.275 * field / np.abs(field).max())
    return [R.Object(u * r[:, None] * (1.1, 0.9, 1.0), base.triangles, mat, rotate=(10, 0, 35))], 11


# Hierarchical settings other than the defaults, per shape: none since the default gathering went
# from 64 rays to 16 (the bowl had 16 here before: a third of the time at the same RMSE).
HIERARCHICAL: dict = {}

SHAPES = {
    "sphere": sphere(10),
    "lens": lens,
    "slab": slab,
    "box": box,
    "torus": torus,
    "cylinder": cylinder,
    "bowl": bowl,
    "organic": organic,
}


def scene(objects, extent, backlit, size):
    d = 6 * extent
    light = (
        R.RectLight((-15, 3 * extent, -15), (30, 0, 0), (0, 0, 30), 2.25e5)  # behind, facing the camera
        if backlit
        else R.RectLight((-20, -30, 40), (15, 0, 0), (0, -10.6, 10.6), 2.25e5)
    )
    cam = R.Camera((0, -d, 0.15 * d), fov=24, width=size, height=size)
    return R.Scene(objects, [light], (0.2, 0.2, 0.22), cam)


def object_mask(objects, extent, size):
    black = [R.Object(o.positions, o.triangles, R.Lambertian(0.0)) for o in objects]  # positions already transformed
    s = R.Scene(black, [], (1, 1, 1), scene(objects, extent, False, size).camera)
    img = R.render(s, "hierarchical", spp=16, seed=0).array
    return np.all(img == 0, axis=-1)


def stats(arr, ref, mk):
    d = arr[mk] - ref[mk]
    rel = np.mean(np.abs(d) / np.maximum(ref[mk], 1e-12), axis=0)
    rmse = float(np.sqrt(np.mean(d**2)))
    bias = arr[mk].sum(axis=0) / ref[mk].sum(axis=0) - 1
    return rel, rmse, bias


def cached_walk(path, sc, spp, seed):
    """A random_walk image of scene `sc` and its seconds, read from `path` (.npz) if it is there,
    else rendered and saved there (the references do not depend on the BSSRDF code)."""
    if os.path.exists(path):
        z = np.load(path)
        return z["img"], float(z["s"])
    t0 = time.monotonic()
    img = R.render(sc, "random_walk", spp=spp, seed=seed).array
    dt = time.monotonic() - t0
    os.makedirs(os.path.dirname(path) or ".", exist_ok=True)
    np.savez(path, img=img, s=dt)
    return img, dt


def skin_walk(scale):
    def layer(p, name):
        sa, ss = [scale * x for x in p[0]], [scale * x / (1 - SKIN_G) for x in p[1]]
        return R.Translucent(sa, ss, g=SKIN_G, eta=SKIN_N, name=name)

    epi, der = layer(EPI, "epidermis"), layer(DERMIS, "dermis")
    return [
        R.Object.sphere(epi, radius=10, subdivisions=5),
        R.Object.sphere(der, radius=10 - EPI_D / scale, subdivisions=5),
    ]


# --- one case ---------------------------------------------------------------------------------------


def row(stat, seconds, mse=None):
    rel, rmse, bias = stat
    r = {"rel": list(map(float, rel)), "rmse": rmse, "bias": list(map(float, bias)), "s": seconds}
    return r if mse is None else {**r, "mse": mse}


def seeds_row(per_seed):
    """One model's row from its images of several seeds (`--model-seeds`), each (stats, seconds,
    truth_mse): the means over the seeds, and per channel the standard error of the mean object-mean
    bias over them ("bias_sigma"). Every pixel of a `hierarchical` image shares its irradiance
    samples, so one image's object mean carries their noise whole (0.4–1.2 points on the small
    spheres, the torus and the bowl); the reference's ±σ does not include it."""
    n = len(per_seed)
    r = row(
        tuple(np.mean([p[0][i] for p in per_seed], axis=0) for i in range(3)),
        float(np.mean([p[1] for p in per_seed])),
        [float(np.mean([p[2][0] for p in per_seed])), float(np.sqrt(sum(p[2][1] ** 2 for p in per_seed)) / n)],
    )
    r["rmse"] = float(np.mean([p[0][1] for p in per_seed]))
    if n > 1:
        b = np.array([p[0][2] for p in per_seed])
        r["bias_sigma"] = list(map(float, b.std(axis=0, ddof=1) / np.sqrt(n)))
        r["seeds"] = n
    return r


def truth_mse(arr, refs, mk):
    """The mean squared error against the truth, not against the reference, with its standard
    error: per object pixel and channel q = (arr − ref)² − s²/N, with ref the mean of N
    independent references `refs` of the same spp and s² their sample variance. An image
    independent of them has E(arr − ref)² = E(arr − truth)² + var ref, and E s²/N = var ref, so
    E q is its error against the truth. (The references' own variance is most of the raw RMSE of
    a low-noise BSSRDF image, which made the raw efficiency a floor.)"""
    r = np.stack([x[mk] for x in refs])
    q = ((arr[mk] - r.mean(axis=0)) ** 2 - r.var(axis=0, ddof=1) / len(refs)).ravel()
    return [float(q.mean()), float(q.std(ddof=1) / np.sqrt(q.size))]


def reference_variance(refs, mk):
    """The per-pixel variance of one reference image (mean over object pixels and channels) with
    its standard error: the sample variance of N ≥ 2 independent references of the same spp."""
    q = np.stack([x[mk] for x in refs]).var(axis=0, ddof=1).ravel()
    return [float(q.mean()), float(q.std(ddof=1) / np.sqrt(q.size))]


def reference_sigma(refs, mk):
    """Per channel, the standard error of the reference's object mean relative to it (the
    spread of the N references' object means / √N)."""
    m = np.stack([x[mk].sum(axis=0) for x in refs])
    return list(map(float, m.std(axis=0, ddof=1) / np.sqrt(len(refs)) / m.mean(axis=0)))


def efficiency(res, hi):
    """1/(MSE × seconds) of hierarchical + `hi`'s model over random_walk's at low spp: the raw
    ratio (RMSEs against the reference), the ratio of the errors against the truth, and its 2σ
    lower bound. The model's error is `truth_mse` (floored at its 2σ where it is not resolved);
    random_walk's is its variance, spp_ref/spp_low times the references' (`reference_variance`:
    the walk is unbiased and its pixels are means of independent samples, so its variance goes
    as 1/spp; measured from the two 128-spp references, not from one 16-spp image, whose error
    misses the rare bright samples more often than not)."""
    rw = res["rows"]["random_walk_low"]
    out = {"efficiency_raw": (rw["rmse"] ** 2 * rw["s"]) / (hi["rmse"] ** 2 * hi["s"])}
    if "var" in res["rows"]["floor"] and "mse" in hi:
        ratio = res["spp_ref"] / res["spp_low"]
        (v, e_v), (m_hi, e_hi) = res["rows"]["floor"]["var"], hi["mse"]
        out["efficiency"] = (ratio * v * rw["s"]) / (max(m_hi, 2 * e_hi) * hi["s"])
        out["efficiency_low"] = (ratio * (v - 2 * e_v) * rw["s"]) / ((max(m_hi, 0) + 2 * e_hi) * hi["s"])
    return out


def run_case(case, a):
    shape, material, scale = case.split(":")
    scale = float(scale)

    def mat(model):
        if material == "skin_layered":
            return skin_layered(scale, model, a.table_photons)
        return library(material, scale, model, a.table_photons)

    backlit = shape == "slab"
    objs, extent = SHAPES[shape](mat("monte_carlo"))
    mk = object_mask(objs, extent, a.size)
    walk_objs = objs
    if material == "skin_layered":  # random_walk: the epidermis as a shell around the dermis
        if shape != "sphere":
            return None
        walk_objs = skin_walk(scale)
    cache = os.path.join(a.out, "refs")

    def walk(spp, seed):
        """A random_walk image and its time, from the cache if it holds it."""
        path = f"{cache}/{shape}_{material}_{scale}_{a.size}_{spp}_{seed}.npz"
        return cached_walk(path, scene(walk_objs, extent, backlit, a.size), spp, seed)

    # The reference: the mean of random_walk images of spp_ref with the seeds `ref_seeds`; the
    # "floor" row is the second of them against it (an independent image of the same spp), with
    # the reference's own object-mean error beside it ("sigma").
    walks = [walk(a.spp_ref, seed) for seed in a.ref_seeds]
    refs, t_ref, dt = [w[0] for w in walks], walks[0][1], walks[1][1]
    ref = np.mean(refs, axis=0)
    rows, images = {}, {"reference": ref}
    rows["floor"] = {
        **row(stats(refs[1], ref, mk), dt),
        "var": reference_variance(refs, mk),
        "sigma": reference_sigma(refs, mk),
    }
    low, dt = walk(a.spp_low, 9)
    rows["random_walk_low"] = row(stats(low, ref, mk), dt, truth_mse(low, refs, mk))
    for spec in filter(None, a.models.split(",")):
        method, model = spec.split(":") if ":" in spec else ("hierarchical", spec)
        name = model if method == "hierarchical" else f"{method} {model}"
        try:
            m = mat(model)
            if model == "adaptive":
                m.adaptive_table()  # build or load the table outside the timing (cached on disk)
            o2, _ = SHAPES[shape](m)
            spp = a.spp if method == "hierarchical" else a.spp_probe
            hp = HIERARCHICAL.get(shape) if method == "hierarchical" else None
            renders = []
            for seed in a.model_seeds:
                t0 = time.monotonic()
                img = R.render(scene(o2, extent, backlit, a.size), method, spp=spp, seed=seed, hierarchical=hp).array
                renders.append((img, time.monotonic() - t0))
        except ValueError as e:  # a model that refuses the material (named in the table)
            rows[name] = {"refused": str(e).splitlines()[0][:120]}
            continue
        rows[name] = seeds_row([(stats(x, ref, mk), s, truth_mse(x, refs, mk)) for x, s in renders])
        images[name] = renders[0][0]
    res = {"pixels": int(mk.sum()), "t_ref": t_ref, "spp_ref": a.spp_ref, "spp_low": a.spp_low, "rows": rows}
    res["ref_seeds"] = list(a.ref_seeds)
    if "adaptive" in rows and "rmse" in rows["adaptive"]:
        rows["adaptive"].update(efficiency(res, rows["adaptive"]))
    return res, images


# --- results, tables, figure -------------------------------------------------------------------------


def label(case):
    """'sphere:marble:8.5' → 'sphere 10 L, marble' (the radius in red diffusion lengths)."""
    shape, material, scale = case.split(":")
    if shape != "sphere" or material == "skin_layered":
        return f"{shape}, {material.replace('_', ' ')}" + ("" if float(scale) == 1 else f" ×{scale}")
    m = subsurf.materials.get(material)  # σa, σs' in mm⁻¹
    sa, sp = float(scale) * m.sigma_a[0], float(scale) * m.sigma_s_prime[0]
    n = 10 * np.sqrt(3 * sa * (sa + sp))
    return f"sphere {n:.2g} L, {material}" if n < 10 else f"sphere {n:.0f} L, {material}"


def fmt_row(r, pixel=True):
    if "refused" in r:
        return "refused"
    if "sigma" in r:  # the floor: the reference's own error (±σ of its object mean)
        b = ", ".join(f"±{100 * x:.1f}" for x in r["sigma"])
    else:
        b = ", ".join(f"{100 * x:+.1f}".replace("-", "−") for x in r["bias"])
    return f"{b} % ({100 * np.mean(r['rel']):.0f} %)" if pixel else f"{b} %"


def case_table(case, res):
    lines = [
        f"\n{case}: {res['pixels']} object pixels",
        "| method model | object mean vs reference R, G, B | mean rel. error R, G, B | RMSE | time (s) |",
        "|---|---|---|---|---|",
    ]
    for name, r in res["rows"].items():
        if "refused" in r:
            lines.append(f"| {name} | refused: {r['refused']} | | | |")
            continue
        rel = ", ".join(f"{100 * x:.0f}" for x in r["rel"])
        lines.append(f"| {name} | {fmt_row(r, False)} | {rel} % | {r['rmse']:.3e} | {r['s']:.1f} |")
    if "efficiency" in res["rows"].get("adaptive", {}):
        lines.append(f"efficiency hierarchical+adaptive / random_walk: {fmt_efficiency(res['rows']['adaptive'])}")
    return "\n".join(lines)


def fmt_efficiency(r):
    """'12.3× (≥ 8.1×, raw 4.0×)': against the truth, its 2σ lower bound, against the reference."""
    if "efficiency_low" not in r:
        return f"{r['efficiency']:.1f}× (raw)"
    return f"{r['efficiency']:.1f}× (≥ {r['efficiency_low']:.1f}×, raw {r['efficiency_raw']:.1f}×)"


def within(r, tol=0.03):
    return "bias" in r and max(abs(x) for x in r["bias"]) <= tol


def matrix_table(results, models):
    """The docs' table: per case, each model's object-mean bias R, G, B and (mean per-pixel error)."""
    head = ["case", "floor", *models]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for case, res in results.items():
        cells = [label(case), fmt_row(res["rows"]["floor"])]
        for m in models:
            r = res["rows"].get(m)
            cells.append("—" if r is None else ("**" + fmt_row(r) + "**" if within(r) else fmt_row(r)))
        lines.append("| " + " | ".join(cells) + " |")
    eff = [(c, r["rows"]["adaptive"]) for c, r in results.items() if "efficiency" in r["rows"].get("adaptive", {})]
    if eff:
        lines += [
            "",
            "| case | adaptive: σ of its mean over seeds | adaptive s | random_walk s | efficiency vs random_walk |",
            "|---|---|---|---|---|",
        ]
        for c, r in eff:
            t_rw = results[c]["rows"]["random_walk_low"]["s"]
            sig = "—"
            if "bias_sigma" in r:
                sig = ", ".join(f"±{100 * x:.1f}" for x in r["bias_sigma"]) + f" % ({r['seeds']} seeds)"
            lines.append(f"| {label(c)} | {sig} | {r['s']:.1f} | {t_rw:.1f} | {fmt_efficiency(r)} |")
    lines += ["", "| model | within 3 % per channel | cases |", "|---|---|---|"]
    for m in models:
        ok = [label(c) for c, res in results.items() if within(res["rows"].get(m, {}))]
        n = sum(m in res["rows"] for res in results.values())
        lines.append(f"| {m} | {len(ok)} of {n} | {'; '.join(ok) or '—'} |")
    return "\n".join(lines)


def tonemap(img, exposure):
    x = 1 - np.exp(-exposure * img)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(np.maximum(x, 0), 1 / 2.4) - 0.055).clip(0, 1)


def figure(out, results, models, path):
    """Rows: cases; columns: the random_walk reference and each model (same exposure per row)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cols = ["reference", *models]
    fig, axes = plt.subplots(len(results), len(cols), figsize=(0.8 * len(cols), 0.8 * len(results)), squeeze=False)
    for i, case in enumerate(results):
        z = np.load(os.path.join(out, "images", case.replace(":", "_") + ".npz"))
        exposure = 1.0 / max(np.percentile(z["reference"], 99), 1e-9)
        for j, name in enumerate(cols):
            ax = axes[i, j]
            ax.set_xticks([]), ax.set_yticks([])
            if name in z.files:
                ax.imshow(tonemap(z[name], exposure), interpolation="nearest")
            if i == 0:
                ax.set_title(name.replace("photon_beam_diffusion", "PBD").replace("_", " "), fontsize=5)
            if j == 0:
                ax.set_ylabel(label(case).replace(", ", "\n"), fontsize=4)
    fig.subplots_adjust(0.06, 0.0, 1.0, 0.97, 0.02, 0.02)
    fig.savefig(path, dpi=100)
    from PIL import Image  # a palette PNG: a third of the size

    Image.open(path).convert("RGB").quantize(256).save(path, optimize=True)
    print(f"figure: {path}")


def save_images(out, case, images):
    path = os.path.join(out, "images", case.replace(":", "_") + ".npz")
    os.makedirs(os.path.dirname(path), exist_ok=True)
    old = dict(np.load(path)) if os.path.exists(path) else {}
    np.savez_compressed(path, **{**old, **images})


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--size", type=int, default=64)
    ap.add_argument("--spp-ref", type=int, default=128)
    ap.add_argument(
        "--ref-seeds",
        type=lambda x: [int(v) for v in x.split(",")],
        default=[1, 7, 11, 13],
        help="seeds of the random_walk references (at least 2), whose mean is the reference",
    )
    ap.add_argument("--spp-low", type=int, default=16)
    # hierarchical's spp: 16, one tree walk per pixel (its default samples_per_exitance); 4 before session g
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--spp-probe", type=int, default=64)
    ap.add_argument(
        "--model-seeds",
        type=lambda x: [int(v) for v in x.split(",")],
        default=[2, 4, 6, 8],
        help="seeds of each BSSRDF image (the row is their mean; one parity: the set-up keys streams by seed ^ 1)",
    )
    ap.add_argument("--table-photons", type=int, default=10000)
    shapes = ", ".join(SHAPES)
    ap.add_argument("--cases", default=DEFAULT_CASES, help=f"shape:material:scale, comma-separated (shapes: {shapes})")
    ap.add_argument(
        "--models",
        default=",".join(MODELS),
        help="models (hierarchical) or method:model pairs (e.g. probe:adaptive), comma-separated",
    )
    cache = os.environ.get("SUBSURF_CACHE", os.path.expanduser("~/.cache/subsurf"))
    ap.add_argument("--out", default=os.path.join(cache, "validation_matrix"), help="references, images, results")
    ap.add_argument("--figure", help="write the image matrix (PNG) of the cases in results.json")
    ap.add_argument("--table-only", action="store_true", help="print the table of results.json only")
    ap.add_argument("--quick", action="store_true", help="smoke run: 16², few spp, one case, into --out")
    a = ap.parse_args(argv)
    if a.quick:
        a.size, a.spp_ref, a.spp_low, a.spp, a.table_photons = 16, 4, 2, 1, 2000
        a.ref_seeds, a.model_seeds = a.ref_seeds[:2], a.model_seeds[:1]
        a.cases = "sphere:marble:1" if a.cases == DEFAULT_CASES else a.cases
    path = os.path.join(a.out, "results.json")
    results = {}
    if os.path.exists(path):
        with open(path) as f:
            results = json.load(f)
    if not a.table_only:
        for case in a.cases.split(","):
            t0 = time.monotonic()
            res = run_case(case, a)
            if res is None:
                print(f"{case}: skipped (the layered random_walk reference is built for spheres only)")
                continue
            res, images = res
            old = results.get(case, {}).get("rows", {}) if results.get(case, {}).get("spp_ref") == a.spp_ref else {}
            results[case] = {**res, "rows": {**old, **res["rows"]}}
            save_images(a.out, case, images)
            print(case_table(case, results[case]), f"\n({time.monotonic() - t0:.0f} s)", flush=True)
            os.makedirs(a.out, exist_ok=True)
            with open(path, "w") as f:
                json.dump(results, f, indent=1)
    models = [m for m in MODELS if any(m in r["rows"] for r in results.values())]
    print("\n" + matrix_table(results, models))
    if a.figure:
        figure(a.out, results, models, a.figure)
    return 0


if __name__ == "__main__":
    main()
