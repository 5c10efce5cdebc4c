"""Photon beam diffusion totals over the 2,160-point grid of issue 20 (σa × σs × g × η =
6 × 6 × 10 × 6): the largest total and how many exceed 1 (130 before the multiple-scattering
weight of `photon_beam_diffusion::profile`, up to 1.129). About 0.4 s a profile on one core.
Usage: python docs/scripts/pbd_totals.py"""

from __future__ import annotations

import itertools
import time

from subsurf.bssrdf import Profile

SIGMA_A = (0.0, 1e-4, 1e-3, 0.01, 0.1, 1.0)
SIGMA_S = (0.1, 0.5, 0.99, 2.0, 10.0, 100.0)
G = (-0.9, -0.5, 0.0, 0.3, 0.5, 0.7, 0.8, 0.9, 0.95, 0.99)
ETA = (1.0, 1.2, 1.3, 1.4, 1.5, 2.0)


def main():
    t0 = time.time()
    worst, above, n = (0.0, None), 0, 0
    for sa, ss, g, eta in itertools.product(SIGMA_A, SIGMA_S, G, ETA):
        t = Profile.from_model("photon_beam_diffusion", sa, ss, g, eta).total()
        n += 1
        above += t > 1.0
        if t > worst[0]:
            worst = (t, (sa, ss, g, eta))
    print(f"{n} media: {above} totals above 1; largest {worst[0]:.12f} at (σa, σs, g, η) = {worst[1]}")
    print(f"({time.time() - t0:.0f} s)")


if __name__ == "__main__":
    main()
