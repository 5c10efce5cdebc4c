"""Photon beam diffusion totals over the 2,160-point grid (σa × σs × g × η =
6 × 6 × 10 × 6): the largest total and how many exceed 1 (130 before the multiple-scattering
weight of `photon_beam_diffusion::profile`, up to 1.129). A total depends on σa and σs only
through the albedo α = σs/(σa + σs) (lengths scale as 1/σt; the tabulated totals agree across
scales to ~1e-9), so each distinct (α, g, η) of the grid is evaluated once, at σt = 1, highest
albedo first (where the overshoot was), on ``--workers`` processes (about 0.4 CPU-s a profile).
Totals count as above 1 beyond 1 + 1e-12 (a lossless total is 1 to the quadrature's rounding).
Usage: python docs/scripts/pbd_totals.py [--workers 2]"""

from __future__ import annotations

import argparse
import itertools
import time
from multiprocessing import Pool

from subsurf.bssrdf import Profile

SIGMA_A = (0.0, 1e-4, 1e-3, 0.01, 0.1, 1.0)
SIGMA_S = (0.1, 0.5, 0.99, 2.0, 10.0, 100.0)
G = (-0.9, -0.5, 0.0, 0.3, 0.5, 0.7, 0.8, 0.9, 0.95, 0.99)
ETA = (1.0, 1.2, 1.3, 1.4, 1.5, 2.0)


def total(point):
    a, g, eta = point
    return point, Profile.from_model("photon_beam_diffusion", 1.0 - a, a, g, eta).total()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args()
    t0 = time.time()
    grid = list(itertools.product(SIGMA_A, SIGMA_S, G, ETA))
    albedos = sorted({round(ss / (sa + ss), 15) for sa, ss, _, _ in grid}, reverse=True)
    points = list(itertools.product(albedos, G, ETA))
    print(f"{len(grid)} media, {len(points)} distinct (albedo, g, eta)", flush=True)
    worst, above = (0.0, None), 0
    with Pool(args.workers) as pool:
        for i, (p, t) in enumerate(pool.imap(total, points, chunksize=4)):
            above += t > 1.0 + 1e-12  # the lossless totals are 1 to the quadrature's rounding
            if t > worst[0]:
                worst = (t, p)
            if (i + 1) % 60 == 0 or i + 1 == len(points):
                print(
                    f"{i + 1}/{len(points)} (down to albedo {p[0]:.6g}): {above} above 1 + 1e-12; largest "
                    f"1 {worst[0] - 1:+.2e} at (albedo, g, eta) = {worst[1]} ({time.time() - t0:.0f} s)",
                    flush=True,
                )


if __name__ == "__main__":
    main()
