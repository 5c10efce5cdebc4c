"""``subsurf profile MATERIAL [--model NAME ...] [-o FIGURE.png]``: every BSSRDF profile model side
by side for a library material (or --sigma-a/--sigma-s-prime/--eta), per channel — totals,
single-scattering part, radii holding 50 % and 99 % of the energy, and R_d(r) at a few radii;
``-o`` plots R_d(r) of every model. All numbers come from :mod:`subsurf.bssrdf`."""

from __future__ import annotations

import math

import numpy as np

RADII = (0.1, 0.3, 1.0, 3.0, 10.0)


def add_parser(sub):
    from .. import bssrdf

    p = sub.add_parser("profile", help="BSSRDF profiles of every model for a material, side by side")
    p.add_argument("material", nargs="?", help="a library material (see `subsurf materials`)")
    p.add_argument("--sigma-a", type=float, help="absorption coefficient, mm^-1")
    p.add_argument("--sigma-s-prime", type=float, help="reduced scattering coefficient, mm^-1")
    p.add_argument("--eta", type=float, default=1.3, help="relative refractive index (default 1.3)")
    p.add_argument("--g", type=float, default=0.0, help="HG mean cosine (sigma_s = sigma_s'/(1-g); default 0)")
    p.add_argument(
        "--model", action="append", choices=bssrdf.MODELS, help="model(s) to show (repeatable; default: all)"
    )
    p.add_argument("--photons", type=int, default=20000, help="photons of the monte_carlo profile (default 20000)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("-o", "--output", metavar="FIGURE.png", help="plot R_d(r) of every model")
    p.set_defaults(func=run)


def _channels(a):
    from .. import materials
    from . import CommandError as UserError

    if a.material:
        try:
            m = materials.get(a.material)
        except (KeyError, ValueError):
            raise UserError(
                f"unknown material {a.material!r}; known: {', '.join(materials.names())} "
                "(or give --sigma-a, --sigma-s-prime, --eta)"
            ) from None
        names = ["R", "G", "B"] if m.channels == 3 else [str(i) for i in range(m.channels)]
        return a.material, m.eta, list(zip(names, m.sigma_a, m.sigma_s_prime))
    if a.sigma_a is None or a.sigma_s_prime is None:
        raise UserError("give a MATERIAL name or --sigma-a and --sigma-s-prime (mm^-1) [--eta]")
    for name, v in (("--sigma-a", a.sigma_a), ("--sigma-s-prime", a.sigma_s_prime)):
        if not (math.isfinite(v) and v >= 0):
            raise UserError(f"{name} = {v:g} is out of range: must be a finite number >= 0 (mm^-1)")
    title = f"sigma_a = {a.sigma_a:g}/mm, sigma_s' = {a.sigma_s_prime:g}/mm, eta = {a.eta:g}"
    return title, a.eta, [("-", a.sigma_a, a.sigma_s_prime)]


def _monte_carlo(layer, photons, seed, label):
    """The Monte Carlo profile under a progress bar (Ctrl-C: KeyboardInterrupt, exit status 130)."""
    from .. import _testhooks, bssrdf
    from ..runner import progress_bar

    bar = progress_bar(label, quiet=False)
    try:
        progress = _testhooks.wrap_progress(bar)
        return bssrdf.Profile.from_monte_carlo(layer, photons=photons, seed=seed, progress=progress)
    finally:
        bar.close()


def run(a) -> int:
    from .. import bssrdf
    from ..medium import Layer
    from . import CommandError as UserError

    title, eta, chans = _channels(a)
    if not abs(a.g) < 1:
        raise UserError(f"--g = {a.g:g} is out of range: must satisfy |g| < 1")
    models = a.model or list(bssrdf.MODELS)
    print(f"{title}: R_d(r) of a normally incident pencil beam, g = {a.g:g} (sigma_s = sigma_s'/(1 - g))")
    hdr = f"{'model':<22} {'total':>8} {'single':>8} {'r50 mm':>8} {'r99 mm':>8} " + " ".join(
        f"{'R(' + format(r, 'g') + ')':>10}" for r in RADII
    )
    curves = []
    for c, sa, ssp in chans:
        print(f"\nchannel {c}: sigma_a = {sa:.4g}/mm, sigma_s' = {ssp:.4g}/mm, eta = {eta:.3g}   (R in mm^-2, r in mm)")
        print(hdr)
        for i, model in enumerate(models):
            sigma_s = ssp / (1 - a.g)
            if model in ("monte_carlo", "adaptive"):  # adaptive on a flat half-space: the Monte Carlo profile
                p = _monte_carlo(Layer(eta, sa, sigma_s, a.g), a.photons, a.seed + i, f"profile {c} {model}")
            else:
                p = bssrdf.Profile.from_model(model, sa, sigma_s, a.g, eta)
            ss = p.single_scattering()
            single = f"{ss[1]:>8.4f}" if ss else f"{'-':>8}"
            r50, r99 = p.radius_for_fraction([0.5, 0.99])
            vals = " ".join(f"{v:>10.4e}" for v in p.rd(np.array(RADII)))
            print(f"{model:<22} {p.total():>8.4f} {single} {r50:>8.3g} {r99:>8.3g} {vals}")
            curves.append((c, model, p))
    if a.output:
        _plot(curves, title, a.output)
        print(f"wrote {a.output}")
    return 0


def _plot(curves, title, out):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..plot import save_figure

    chans = list(dict.fromkeys(c for c, _, _ in curves))
    fig, axes = plt.subplots(1, len(chans), figsize=(5 * len(chans), 4), squeeze=False)
    for ax, ch in zip(axes[0], chans):
        for c, model, p in curves:
            if c != ch:
                continue
            r = np.geomspace(1e-3, p.radius_for_fraction(0.999), 200)
            ax.loglog(r, np.maximum(p.rd(r), 1e-30), label=model)
        ax.set_xlabel("r (mm)")
        ax.set_ylabel("R_d(r) (mm$^{-2}$)")
        ax.set_title(f"{title} — channel {ch}", fontsize=8)
        ax.legend(fontsize=7)
    save_figure(fig, out)
