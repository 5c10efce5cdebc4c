"""Every BSSRDF profile model against Monte Carlo on the comparison grid of docs/profiles.md; writes the figures
``docs/profiles_total.png``, ``docs/profiles_shape.png`` and the tables ``docs/profiles_tables.md``.

Semi-infinite medium, σt = 1 mm⁻¹ (σs = α, σa = 1 − α), HG g, relative index η, under a normally
incident pencil beam. The Monte Carlo reflectance is divided by 1 − R_sp (the analytic models
describe the power that entered). Total error: model/MC − 1. Profile error: the largest
|model/MC − 1| of ring averages over the Monte Carlo log bins (10 per decade) between 0.1 and 10
transport mean free paths 1/σt', using only bins whose Monte Carlo relative error is < 5 %.

Usage: python docs/scripts/compare_profiles.py [--photons N] [--seed S] [--out DIR] [--quick]
(``--quick``: two albedos, one g and one η instead of 5 × 3 × 3, to check the pipeline.)
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np
from subsurf import Layer, bssrdf
from subsurf.optics import fresnel_reflectance

ALBEDOS = (0.3, 0.6, 0.9, 0.99, 0.999)
GS = (0.0, 0.5, 0.9)
ETAS = (1.0, 1.33, 1.5)
MODELS = ("dipole", "better_dipole", "multipole", "photon_beam_diffusion", "normalized_diffusion")


def compare(a, g, eta, photons, seed):
    mc = bssrdf.Profile.from_monte_carlo(Layer(eta, 1 - a, a, g), photons=photons, seed=seed)
    rsp = float(fresnel_reflectance(1.0, 1.0, eta))
    d = mc.mc_data()
    e, w, s = d["edges"], d["weight"], d["stderr"]
    ell = 1.0 / (1.0 - a * g)  # transport mean free path
    out = {}
    for m in MODELS:
        p = bssrdf.Profile.from_model(m, 1 - a, a, g, eta)
        tot = p.total() / (d["total"] / (1 - rsp)) - 1
        worst = None
        for i in range(1, len(e) - 1):
            lo, hi = e[i], e[i + 1]
            if lo < 0.1 * ell or hi > 10 * ell or w[i] <= 0 or s[i] > 0.05 * w[i]:
                continue
            model_ring = p.total() * (p.cdf(hi) - p.cdf(lo))
            err = abs(model_ring / (w[i] / (1 - rsp)) - 1)
            worst = err if worst is None else max(worst, err)
        out[m] = (tot, worst)
    return d["total"] / (1 - rsp), d["total_stderr"] / (1 - rsp), out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--photons", type=int, default=40000)
    ap.add_argument("--seed", type=int, default=8)
    ap.add_argument("--out", default=os.path.dirname(os.path.dirname(os.path.abspath(__file__))), help="directory")
    ap.add_argument("--quick", action="store_true", help="albedos 0.6, 0.99 at g 0.5, η 1.33 (checks the pipeline)")
    args = ap.parse_args(argv)
    albedos, gs, etas = ((0.6, 0.99), (0.5,), (1.33,)) if args.quick else (ALBEDOS, GS, ETAS)
    here = args.out
    t0 = time.time()
    rows = {}
    for gi, g in enumerate(gs):
        for ei, eta in enumerate(etas):
            for ai, a in enumerate(albedos):
                rows[(g, eta, a)] = compare(a, g, eta, args.photons, args.seed + 100 * gi + 10 * ei + ai)
    elapsed = time.time() - t0
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    for k, (fname, label) in enumerate(
        (("profiles_total.png", "total: model/MC − 1"), ("profiles_shape.png", "max |ring model/MC − 1|, 0.1–10 mfp"))
    ):
        size = (4 * len(etas), 10 / 3 * len(gs))
        fig, axes = plt.subplots(len(gs), len(etas), figsize=size, sharex=True, squeeze=False)
        for gi, g in enumerate(gs):
            for ei, eta in enumerate(etas):
                ax = axes[gi, ei]
                positive = False
                for m in MODELS:
                    y = [rows[(g, eta, a)][2][m][k] for a in albedos]
                    y = [np.nan if v is None else v for v in y]
                    positive |= any(v > 0 for v in y)
                    ax.plot([1 - a for a in albedos], y, "o-", label=m, ms=3)
                ax.set_xscale("log")
                if k and positive:  # (no profile error is defined when the MC bins are all too noisy)
                    ax.set_yscale("log")
                ax.axhline(0, color="k", lw=0.5)
                ax.set_title(f"g = {g}, η = {eta}", fontsize=9)
                if gi == len(gs) - 1:
                    ax.set_xlabel("1 − albedo")
                if ei == 0:
                    ax.set_ylabel(label, fontsize=8)
        axes[0, 0].legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(os.path.join(here, fname), dpi=80)
    lines = [
        "# Profile tables: every model against Monte Carlo",
        "",
        f"Monte Carlo: {args.photons} photons per case, seed {args.seed}+; {elapsed:.0f} s.",
        "",
        "| g | η | albedo | MC total/(1−R_sp) | " + " | ".join(f"{m} total, shape" for m in MODELS) + " |",
        "|---|---|---|---|" + "---|" * len(MODELS),
    ]
    for (g, eta, a), (t, ts, out) in rows.items():
        shape = {m: "n/a" if out[m][1] is None else f"{100 * out[m][1]:.0f} %" for m in MODELS}
        cells = " | ".join(f"{100 * out[m][0]:+.1f} %, {shape[m]}" for m in MODELS)
        lines.append(f"| {g} | {eta} | {a} | {t:.4f} ± {ts:.4f} | {cells} |")
    with open(os.path.join(here, "profiles_tables.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
