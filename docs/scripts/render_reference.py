"""Reference comparison for docs/render.md: every BSSRDF profile model (hierarchical method)
against the random_walk image of the same scene; per-channel mean relative error and RMSE over
the object's pixels. Usage: python docs/scripts/render_reference.py [--size 96] [--spp-ref 256]
[--material marble|skin] [--scale S]. ``--scale`` multiplies every σ by S and divides layer
thicknesses by S: the same scene for an object S times larger in mean free paths (S = 10: a
100 mm sphere), where the half-space assumption of every BSSRDF holds better.
Writes docs/render_reference_<material>[_x<S>].png and prints the markdown table."""

from __future__ import annotations

import argparse
import time

import numpy as np
import subsurf
import subsurf.bssrdf
import subsurf.render as R

# Skin-like two-layer material (RGB): an absorbing epidermis (0.25 mm) over Jensen et al.'s
# (2001) skin1 dermis; g = 0.8 and n = 1.4 in both (σs = σs'/(1 − g)). Representative values for
# a comparison, not a tissue model.
SKIN_G, SKIN_N, EPI_D = 0.8, 1.4, 0.25
EPI = ((0.25, 0.5, 1.0), (1.5, 1.7, 2.0))  # σa, σs' (mm⁻¹)
DERMIS = ((0.032, 0.17, 0.48), (0.74, 0.88, 1.01))


def skin_stacks(scale=1.0):
    s = scale
    return [
        subsurf.Stack(
            [
                subsurf.Layer(SKIN_N, s * EPI[0][k], s * EPI[1][k] / (1 - SKIN_G), SKIN_G, EPI_D / s),
                subsurf.Layer(SKIN_N, s * DERMIS[0][k], s * DERMIS[1][k] / (1 - SKIN_G), SKIN_G),
            ]
        )
        for k in range(3)
    ]


def skin_material(model, mc_photons, scale=1.0):
    """Layered models get the stacks; one-layer models the homogeneous medium of the same colour
    (the layered Monte Carlo total per channel) and mean free path (the dermis' 1/σt)."""
    if model in ("multipole", "monte_carlo"):
        return R.Translucent.from_stacks(skin_stacks(scale), model=model, mc_photons=mc_photons)
    color = [
        float(subsurf.bssrdf.Profile.from_monte_carlo(s, photons=mc_photons, seed=9).total())
        for s in skin_stacks(scale)
    ]
    mfp = [(1 - SKIN_G) / (DERMIS[0][k] * (1 - SKIN_G) + DERMIS[1][k]) / scale for k in range(3)]
    return R.Translucent.from_reflectance(color, mfp, eta=SKIN_N, g=SKIN_G, model=model)


def skin_walk_objects(scale=1.0):
    """random_walk: the epidermis as a shell (outer sphere) around the dermis (inner sphere)."""
    s = scale

    def layer(p, name):
        sa, ss = [s * x for x in p[0]], [s * x / (1 - SKIN_G) for x in p[1]]
        return R.Translucent(sa, ss, g=SKIN_G, eta=SKIN_N, name=name)

    epi, der = layer(EPI, "epidermis"), layer(DERMIS, "dermis")
    inner = 10 - EPI_D / s
    return [R.Object.sphere(epi, radius=10, subdivisions=5), R.Object.sphere(der, radius=inner, subdivisions=5)]


def library(name, scale=1.0, **kw):
    """A library material with every σ multiplied by ``scale``."""
    m = R.Translucent.library(name, **kw)
    m.sigma_a, m.sigma_s = [scale * x for x in m.sigma_a], [scale * x for x in m.sigma_s]
    return m


def scene(mat, size, objects=None):
    return R.Scene(
        objects or [R.Object.sphere(mat, radius=10, subdivisions=5)],
        # A large area light and a bright environment: random_walk reaches lights only by the
        # direction its path leaves the object in (smooth boundary), so small lights converge slowly.
        [R.RectLight((-20, -30, 40), (15, 0, 0), (0, -10.6, 10.6), 2.25e5)],
        (0.2, 0.2, 0.22),
        R.Camera((0, -60, 10), fov=24, width=size, height=size),
    )


def mask(size):
    """Pixels whose whole footprint is on the sphere (object pixels): rays from the camera."""
    cam = np.array([0, -60, 10.0])
    fwd = -cam / np.linalg.norm(cam)
    right = np.cross(fwd, [0, 0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, fwd)
    t = np.tan(np.radians(12))
    m = np.zeros((size, size), bool)
    for y in range(size):
        for x in range(size):
            ok = True
            for dx, dy in ((0, 0), (1, 0), (0, 1), (1, 1)):
                sx = (2 * (x + dx) / size - 1) * t
                sy = (1 - 2 * (y + dy) / size) * t
                d = fwd + sx * right + sy * up
                d /= np.linalg.norm(d)
                b = cam @ d
                ok &= b * b - (cam @ cam - 100.0) > 0
            m[y, x] = ok
    return m


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--size", type=int, default=96)
    ap.add_argument("--spp-ref", type=int, default=256)
    ap.add_argument("--spp", type=int, default=4)
    ap.add_argument("--material", default="marble", help="a library name, or 'skin' (two layers)")
    ap.add_argument("--mc-photons", type=int, default=200_000)
    ap.add_argument("--scale", type=float, default=1.0, help="multiply every σ by this (object size in mfp)")
    a = ap.parse_args()
    mk = mask(a.size)
    t0 = time.monotonic()
    if a.material == "skin":
        ref_scene = scene(None, a.size, skin_walk_objects(a.scale))
    else:
        ref_scene = scene(library(a.material, a.scale), a.size)
    ref = R.render(ref_scene, "random_walk", spp=a.spp_ref, seed=1)
    print(f"random_walk reference: {a.spp_ref} spp, {time.monotonic() - t0:.0f} s")
    rows, imgs = [], [("random_walk", ref.array)]

    def stats(arr):
        d = arr[mk] - ref.array[mk]
        rel = np.mean(np.abs(d) / np.maximum(ref.array[mk], 1e-12), axis=0)
        rmse = np.sqrt(np.mean(d**2, axis=0))
        bias = arr[mk].sum(axis=0) / ref.array[mk].sum(axis=0) - 1
        return rel, rmse, bias

    # The noise floor: a second, independent random_walk image against the reference.
    t1 = time.monotonic()
    again = R.render(ref_scene, "random_walk", spp=a.spp_ref, seed=7)
    rows.append(("random_walk, 2nd seed (noise floor)", *stats(again.array), time.monotonic() - t1))
    for model in R.MODELS:
        t1 = time.monotonic()
        try:
            if a.material == "skin":
                mat = skin_material(model, a.mc_photons, a.scale)
            else:
                mat = library(a.material, a.scale, model=model, mc_photons=a.mc_photons)
            img = R.render(scene(mat, a.size), "hierarchical", spp=a.spp, seed=2)
        except subsurf.ParameterError as e:
            print(f"{model}: refused: {e}")
            rows.append((f"{model} (refused)", *([float("nan")] * 3,) * 3, time.monotonic() - t1))
            continue
        rows.append((model, *stats(img.array), time.monotonic() - t1))
        imgs.append((model, img.array))
    print(
        f"{a.material} (scale {a.scale:g}): {a.size}x{a.size}, hierarchical {a.spp} spp vs random_walk "
        f"{a.spp_ref} spp, {mk.sum()} pixels"
    )
    print("| model | mean rel. error R, G, B | RMSE R, G, B | object mean vs reference R, G, B | time (s) |")
    print("|---|---|---|---|---|")
    for m, rel, rmse, bias, dt in rows:
        pct = ", ".join(f"{100 * x:.1f} %" for x in rel)
        rms = ", ".join(f"{x:.2e}" for x in rmse)
        bia = ", ".join(f"{100 * x:+.1f} %" for x in bias)
        print(f"| {m} | {pct} | {rms} | {bia} | {dt:.0f} |")
    from matplotlib.figure import Figure

    fig = Figure(figsize=(2.2 * len(imgs), 2.6), layout="constrained")
    scale = np.percentile(ref.array[mk].mean(axis=-1), 99.5)
    for i, (name, arr) in enumerate(imgs):
        ax = fig.add_subplot(1, len(imgs), i + 1)
        x = np.clip(arr / scale, 0, 1) ** (1 / 2.2)
        ax.imshow(x)
        ax.set_title(name.replace("_", " "), fontsize=8)
        ax.axis("off")
    suffix = "" if a.scale == 1 else f"_x{a.scale:g}"
    fig.savefig(f"docs/render_reference_{a.material}{suffix}.png", dpi=110)


if __name__ == "__main__":
    main()
