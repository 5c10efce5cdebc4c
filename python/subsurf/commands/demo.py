"""``subsurf demo``: the three-layer skin of :mod:`subsurf.demo`, compared with the dipole, and the
translucent materials of :mod:`subsurf.render.demo` rendered beside opaque twins."""

from __future__ import annotations

from . import U64_MAX, add_quiet, integer


def add_parser(sub) -> None:
    d = sub.add_parser(
        "demo",
        help="skin optics vs the dipole, and translucent materials rendered: out/demo.png, out/render.png",
    )
    d.add_argument("--out-dir", default="out", help="directory of the outputs (created; default: out)")
    d.add_argument("--photons", type=integer("--photons", 1, U64_MAX), help="photons per run (default: the demo's)")
    d.add_argument("--threads", type=integer("--threads", 1, U64_MAX))
    d.add_argument(
        "--quick", action="store_true", help="a smoke run in seconds that still writes every output (few photons)"
    )
    add_quiet(d)
    d.set_defaults(func=run)


def run(a) -> int:
    from .. import demo

    return demo.run(out_dir=a.out_dir, photons=a.photons, threads=a.threads, quiet=a.quiet, quick=a.quick)
