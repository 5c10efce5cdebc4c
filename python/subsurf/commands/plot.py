"""``subsurf plot RESULT.h5``: every panel a results file supports, as one figure (PNG, PDF, SVG …)."""

from __future__ import annotations

import os

from . import add_force


def add_parser(sub) -> None:
    p = sub.add_parser("plot", help="plot a results file to a PNG")
    p.add_argument("result", metavar="RESULT.h5")
    p.add_argument("-o", "--output", metavar="FIGURE.png", help="figure file (default: RESULT.png)")
    p.add_argument("--no-models", action="store_true", help="do not draw the diffusion curves")
    add_force(p, "figure")
    p.set_defaults(func=run)


def run(a) -> int:
    from .. import atomic, io, plot

    out = a.output or os.path.splitext(a.result)[0] + ".png"
    atomic.check_target(out, force=a.force, inputs=(a.result,))
    res = io.load(a.result)
    fig = plot.figure(res, models=() if a.no_models else ("dipole", "better_dipole"))
    print(f"wrote {plot.save_figure(fig, out, force=a.force)}")
    return 0
