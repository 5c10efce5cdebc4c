"""``subsurf demo``: the three-layer skin of :mod:`subsurf.demo`, compared with the dipole."""

from __future__ import annotations

from . import U64_MAX, add_quiet, integer


def add_parser(sub) -> None:
    d = sub.add_parser("demo", help="three-layer skin: simulate, compare with the dipole, write out/demo.*")
    d.add_argument("--out-dir", default="out", help="directory of the outputs (created; default: out)")
    d.add_argument("--photons", type=integer("--photons", 1, U64_MAX), help="photons per run (default: the demo's)")
    d.add_argument("--threads", type=integer("--threads", 1, U64_MAX))
    add_quiet(d)
    d.set_defaults(func=run)


def run(a) -> int:
    from .. import demo

    return demo.run(out_dir=a.out_dir, photons=a.photons, threads=a.threads, quiet=a.quiet)
