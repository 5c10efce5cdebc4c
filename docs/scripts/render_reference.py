"""Reference comparison for docs/render.md: every BSSRDF profile model (hierarchical method)
against the random_walk image of the same scene; per-channel mean relative error and RMSE over
the object's pixels. Usage: python docs/scripts/render_reference.py [--size 96] [--spp-ref 256]
Writes docs/render_reference.png and prints the markdown table."""

from __future__ import annotations

import argparse
import time

import numpy as np
import subsurf.render as R


def scene(mat, size):
    return R.Scene(
        [R.Object.sphere(mat, radius=10, subdivisions=5)],
        [R.RectLight((-20, -30, 40), (8, 0, 0), (0, -5, 5), 4e4)],
        (0.05, 0.05, 0.06),
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
    ap.add_argument("--material", default="marble")
    a = ap.parse_args()
    mk = mask(a.size)
    t0 = time.monotonic()
    ref = R.render(scene(R.Translucent.library(a.material), a.size), "random_walk", spp=a.spp_ref, seed=1)
    print(f"random_walk reference: {a.spp_ref} spp, {time.monotonic() - t0:.0f} s")
    rows, imgs = [], [("random_walk", ref.array)]
    for model in R.MODELS:
        t1 = time.monotonic()
        mat = R.Translucent.library(a.material, model=model, mc_photons=200_000)
        img = R.render(scene(mat, a.size), "hierarchical", spp=a.spp, seed=2)
        d = img.array[mk] - ref.array[mk]
        rel = np.mean(np.abs(d) / np.maximum(ref.array[mk], 1e-12), axis=0)
        rmse = np.sqrt(np.mean(d**2, axis=0))
        rows.append((model, rel, rmse, time.monotonic() - t1))
        imgs.append((model, img.array))
    print("| model | mean rel. error R, G, B | RMSE R, G, B | time (s) |")
    print("|---|---|---|---|")
    for m, rel, rmse, dt in rows:
        print(
            f"| {m} | {', '.join(f'{100 * x:.1f} %' for x in rel)} | {', '.join(f'{x:.2e}' for x in rmse)} | {dt:.0f} |"
        )
    from matplotlib.figure import Figure

    fig = Figure(figsize=(2.2 * len(imgs), 2.6), layout="constrained")
    scale = np.percentile(ref.array[mk].mean(axis=-1), 99.5)
    for i, (name, arr) in enumerate(imgs):
        ax = fig.add_subplot(1, len(imgs), i + 1)
        x = np.clip(arr / scale, 0, 1) ** (1 / 2.2)
        ax.imshow(x)
        ax.set_title(name.replace("_", " "), fontsize=8)
        ax.axis("off")
    fig.savefig(f"docs/render_reference_{a.material}.png", dpi=110)


if __name__ == "__main__":
    main()
