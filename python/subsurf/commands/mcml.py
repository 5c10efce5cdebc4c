"""``subsurf mcml INPUT.mci``: the MCML drop-in — every run of an ``.mci`` file → one ``.mco`` each."""

from __future__ import annotations

from . import U64_MAX, add_force, add_quiet, integer


def add_parser(sub) -> None:
    m = sub.add_parser("mcml", help="MCML drop-in: simulate every run of an .mci file, write .mco files")
    m.add_argument("input", metavar="INPUT.mci")
    add_force(m, ".mco file")
    m.add_argument(
        "--seed", type=integer("--seed", 0, U64_MAX), default=1, help="seed of the first run (run i uses seed + i)"
    )
    m.add_argument("--threads", type=integer("--threads", 1, U64_MAX))
    m.add_argument(
        "--photons", type=integer("--photons", 1, U64_MAX), help="override every run's photon count (quick checks)"
    )
    add_quiet(m)
    m.set_defaults(func=run)


def run(a) -> int:
    from .. import atomic, mcml, runner

    for i, (r, stack, tallies, target) in enumerate(mcml.plan_runs(a.input, a.force, photons=a.photons)):
        res = runner.simulate(
            stack,
            label=f"run {i + 1} ({r.out_fname})",
            quiet=a.quiet,
            photons=r.photons,
            seed=a.seed + i,
            threads=a.threads,
            tallies=tallies,
        )
        with atomic.hold_sigint() as held:
            path = mcml.write_run(target, r, res, force=a.force, inputs=(a.input,))
        tag = " (partial: interrupted)" if res.partial else ""
        print(
            f"wrote {path}: Rsp {res.specular_reflectance:.6g}  Rd {res.diffuse_reflectance:.6g}  "
            f"A {res.absorbed:.6g}  Tt {res.transmittance:.6g}  ({res.photons:,} photons){tag}"
        )
        if res.partial or held.received:
            return runner.EXIT_INTERRUPTED
    return 0
