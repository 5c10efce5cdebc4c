"""``subsurf merge A.h5 B.h5 … -o C.h5``: results of one configuration traced with different seeds."""

from __future__ import annotations

from . import add_force


def add_parser(sub) -> None:
    p = sub.add_parser("merge", help="merge results of the same configuration with different seeds")
    p.add_argument("inputs", nargs="+", metavar="RESULT.h5")
    p.add_argument("-o", "--output", required=True, metavar="MERGED.h5")
    add_force(p, "results file")
    p.set_defaults(func=run)


def run(a) -> int:
    from .. import atomic, io

    atomic.check_target(a.output, force=a.force, inputs=a.inputs)
    res = io.load(a.inputs[0])
    for p in a.inputs[1:]:
        res = io.merge(res, io.load(p))
    path = io.save(res, a.output, force=a.force)
    print(f"wrote {path}: {res.photons:,} photons from seeds {res.config.get('seeds')}")
    return 0
