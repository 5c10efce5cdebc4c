#!/usr/bin/env python3
"""Monte Carlo vs diffusion (dipole, better dipole) for semi-infinite media.

Regenerates the tables of docs/diffusion_vs_mc.md (written to docs/diffusion_vs_mc_tables.md,
to paste; it adds a column max |model−MC|/model over 2–8 mfp) and docs/diffusion_vs_mc.png (relative error of
R_d(r) vs r). For each reduced albedo α' and index ratio η a semi-infinite medium with
σt' = σa + σs' = 1 mm⁻¹ (so r is in transport mean free paths) and isotropic scattering
(σs = σs', g = 0: the similarity-relation equivalent of any g) is lit by a normally incident
pencil beam in air, and the Monte Carlo reflectance (exact up to noise) is compared with
``subsurf.diffusion``:

- total: R_d^MC / (1 − R_sp) (the diffusion models describe the power that entered the medium;
  R_sp = ((η−1)/(η+1))² is the specular part) vs ``total_diffuse_reflectance(α', η, model)``;
- profile: the MC ring averages of R_d(r) (again divided by 1 − R_sp) vs the models' ring
  averages ∫R_d(r)2πr dr / area over the same bins (Gauss–Legendre, so the comparison is exact
  for the bin, not a mid-point value). The last MC bin (overflow) is dropped.

Usage: python docs/scripts/compare_diffusion_mc.py [--photons N] [--seed S] [--threads T]
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time

import numpy as np
import subsurf
from subsurf import diffusion

ALBEDOS = (0.5, 0.8, 0.9, 0.95, 0.99, 0.999)
ETAS = (1.0, 1.3, 1.5)
MODELS = ("dipole", "better_dipole")
NR, DR = 200, 0.05  # R(r) grid: 0 … 10 mfp (last bin = overflow, dropped)
RANGES = ((0.0, 0.05), (0.5, 1.0), (1.0, 2.0), (2.0, 8.0))  # r ranges (mfp) summarised
HERE = os.path.dirname(os.path.abspath(__file__))
DOCS = os.path.dirname(HERE)


def stack(alpha, eta, g=0.0):
    """Semi-infinite layer with σt' = 1 mm⁻¹, reduced albedo ``alpha``, σs = σs'/(1 − g)."""
    return subsurf.Stack(
        [subsurf.Layer(n=eta, mua=1.0 - alpha, mus=alpha / (1.0 - g), g=g, thickness=math.inf)], n_above=1.0
    )


def ring_average(model, edges, alpha, eta, n=16):
    """∫_{r0}^{r1} R_d(r) 2πr dr / (π(r1² − r0²)) per bin, Gauss–Legendre with n nodes (mm⁻²)."""
    x, w = np.polynomial.legendre.leggauss(n)
    r0, r1 = edges[:-1, None], edges[1:, None]
    r = 0.5 * (r1 - r0) * x + 0.5 * (r1 + r0)
    f = diffusion.rd(r, 1.0 - alpha, alpha, eta, model=model) * 2.0 * np.pi * r
    return (0.5 * (r1 - r0)[:, 0] * (f @ w)) / (np.pi * (edges[1:] ** 2 - edges[:-1] ** 2))


def rebin(edges, values, stderr, lo, hi):
    """Area-weighted average of the bins inside [lo, hi] (mfp), with its standard error (the
    bins' errors added in quadrature: conservative, as bins of one photon history anticorrelate)."""
    sel = (edges[:-1] >= lo - 1e-12) & (edges[1:] <= hi + 1e-12)
    area = np.pi * (edges[1:] ** 2 - edges[:-1] ** 2)[sel]
    a = area.sum()
    return (values[sel] * area).sum() / a, math.sqrt(((stderr[sel] * area) ** 2).sum()) / a


def run_case(alpha, eta, photons, seed, threads, g=0.0):
    t = time.time()
    res = subsurf.simulate(
        stack(alpha, eta, g),
        photons,
        seed,
        threads,
        tallies=subsurf.Tallies(nr=NR, dr=DR, nz=1, dz=1.0, spatial=True, angular=False),
    )
    inside = 1.0 - res.specular_reflectance
    h = res.rd_r
    edges = np.asarray(h.edges[0], float)[:-1]  # drop the overflow bin
    case = dict(
        alpha=alpha,
        eta=eta,
        g=g,
        seconds=time.time() - t,
        rd=res.diffuse_reflectance / inside,
        rd_se=res.diffuse_reflectance_stderr / inside,
        edges=edges,
        mc=np.asarray(h.values, float)[:-1] / inside,
        mc_se=np.asarray(h.stderr, float)[:-1] / inside,
    )
    for m in MODELS:
        case["total_" + m] = float(diffusion.total_diffuse_reflectance(alpha, eta, model=m))
        case["prof_" + m] = ring_average(m, edges, alpha, eta)
    return case


def summary(case, model, lo, hi):
    """(relative error of the model's ring average over [lo, hi] vs MC, MC relative stderr)."""
    mc, se = rebin(case["edges"], case["mc"], case["mc_se"], lo, hi)
    mod, _ = rebin(case["edges"], case["prof_" + model], np.zeros_like(case["mc"]), lo, hi)
    if mc <= 0.0:  # no photon came out there (short runs): no estimate
        return math.nan, math.inf
    return mod / mc - 1.0, se / mc


def max_abs_rel(case, model, lo, hi, width=0.5):
    """Largest |model/MC − 1| over sub-ranges of ``width`` mfp tiling [lo, hi], with the largest
    MC relative stderr among them."""
    errs = [summary(case, model, a, a + width) for a in np.arange(lo, hi - 1e-9, width)]
    i = int(np.argmax([abs(e) for e, _ in errs]))
    return errs[i][0], max(s for _, s in errs)


def max_dev_over_model(case, model, lo, hi, width=0.5):
    """Largest |model − MC| / model over rings of ``width`` mfp tiling [lo, hi] (the quantity the
    tests bound: |model − MC| ≤ tol·model + 4σ)."""
    out = []
    for a in np.arange(lo, hi - 1e-9, width):
        mc, _ = rebin(case["edges"], case["mc"], case["mc_se"], a, a + width)
        mod, _ = rebin(case["edges"], case["prof_" + model], np.zeros_like(case["mc"]), a, a + width)
        out.append(abs(mod - mc) / mod)
    return max(out)


def log_groups(edges, n=28):
    """Log-spaced groups of the fine bins from the first bin to the grid's end (for the plot)."""
    b = np.unique(np.round(np.geomspace(1, len(edges) - 1, n + 1)).astype(int))
    return [(edges[i - 1] if i == 1 else edges[i], edges[j]) for i, j in zip(np.r_[0, b[:-1]], b)]


def plot(cases, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, len(ETAS), figsize=(4.2 * len(ETAS), 7.2), sharex=True, sharey=True)
    colors = plt.cm.viridis(np.linspace(0.0, 0.9, len(ALBEDOS)))
    for row, m in enumerate(MODELS):
        for col, eta in enumerate(ETAS):
            ax = axes[row, col]
            for c, alpha in zip(colors, ALBEDOS):
                case = next(k for k in cases if k["alpha"] == alpha and k["eta"] == eta and k["g"] == 0.0)
                pts = []
                for lo, hi in log_groups(case["edges"]):
                    e, s = summary(case, m, lo, hi)
                    if s < 0.05:  # hide noise-dominated points
                        pts.append((math.sqrt(max(lo, DR / 2) * hi), e, s))
                if pts:
                    x, y, s = map(np.array, zip(*pts))
                    ax.errorbar(
                        x, 100 * y, yerr=100 * s, color=c, marker="o", ms=3, lw=1, capsize=0, label=f"α' = {alpha}"
                    )
            ax.axhline(0.0, color="k", lw=0.6)
            ax.axvspan(2.0, 8.0, color="0.92", zorder=0)
            ax.set_xscale("log")
            ax.set_ylim(-60, 60)
            ax.grid(True, which="both", lw=0.3, alpha=0.5)
            ax.set_title(
                f"{'dipole (Jensen 2001)' if m == 'dipole' else 'better dipole (d’Eon 2012)'}, η = {eta}", fontsize=10
            )
            if row == 1:
                ax.set_xlabel("r  [transport mean free paths 1/σt' = mm]")
            if col == 0:
                ax.set_ylabel("R_d(r): model / MC − 1  [%]")
    if axes[0, 0].get_legend_handles_labels()[0]:  # (a short run may hide every point there)
        axes[0, 0].legend(fontsize=8, loc="lower right")
    fig.suptitle(
        "Diffusion vs Monte Carlo, semi-infinite medium, normal pencil beam (error bars: MC 1σ; grey: 2–8 mfp)",
        fontsize=11,
    )
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def pct(x):
    return f"{100 * x:+.1f} %"


def markdown(cases, args, elapsed):
    L = []
    L.append("| η | α' | MC R_d/(1−R_sp) | dipole | dipole err | better dipole | better dipole err |")
    L.append("|---|---|---|---|---|---|---|")
    for c in cases:
        tag = f"{c['alpha']}" + (f" (g = {c['g']})" if c["g"] else "")
        L.append(
            f"| {c['eta']} | {tag} | {c['rd']:.5f} ± {c['rd_se']:.5f} | {c['total_dipole']:.5f} | "
            f"{pct(c['total_dipole'] / c['rd'] - 1)} | {c['total_better_dipole']:.5f} | "
            f"{pct(c['total_better_dipole'] / c['rd'] - 1)} |"
        )
    total = "\n".join(L)
    L = [
        "| η | α' | model | r < 0.05 | 0.5–1 | 1–2 | max over 0.5-mfp rings in 2–8 | MC σ (2–8) "
        "| max \\|model−MC\\|/model (2–8) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for c in cases:
        tag = f"{c['alpha']}" + (f" (g = {c['g']})" if c["g"] else "")
        for m in MODELS:
            cells = [pct(summary(c, m, lo, hi)[0]) for lo, hi in RANGES[:3]]
            e, s = max_abs_rel(c, m, 2.0, 8.0)
            L.append(
                f"| {c['eta']} | {tag} | {m} | " + " | ".join(cells) + f" | {pct(e)} | {100 * s:.1f} % "
                f"| {100 * max_dev_over_model(c, m, 2.0, 8.0):.1f} % |"
            )
    prof = "\n".join(L)
    return total, prof


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--photons", type=int, default=500_000, help="photon packets per case")
    ap.add_argument("--seed", type=int, default=2001)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--out", default=DOCS, help="directory for the .png and a tables .md fragment")
    args = ap.parse_args(argv)
    t0 = time.time()
    cases = []
    for eta in ETAS:
        for alpha in ALBEDOS:
            cases.append(run_case(alpha, eta, args.photons, args.seed, args.threads))
            print(f"η = {eta}, α' = {alpha}: {cases[-1]['seconds']:.1f} s", file=sys.stderr)
    cases.append(run_case(0.99, 1.3, args.photons, args.seed, args.threads, g=0.9))
    elapsed = time.time() - t0
    plot(cases, os.path.join(args.out, "diffusion_vs_mc.png"))
    total, prof = markdown(cases, args, elapsed)
    frag = os.path.join(args.out, "diffusion_vs_mc_tables.md")
    with open(frag, "w") as f:
        f.write(
            f"<!-- python docs/scripts/compare_diffusion_mc.py --photons {args.photons} --seed {args.seed} "
            f"(subsurf {subsurf.__version__}, {elapsed:.0f} s on {args.threads} thread(s)) -->\n\n"
        )
        f.write(
            "### Total diffuse reflectance\n\n" + total + "\n\n### Profile R_d(r): model / MC − 1\n\n" + prof + "\n"
        )
    print(open(frag).read())


if __name__ == "__main__":
    main()
