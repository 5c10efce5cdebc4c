"""``subsurf simulate CONFIG.toml``: a Monte Carlo run described by a TOML file → an HDF5 result."""

from __future__ import annotations

import os

from . import U64_MAX, add_force, add_quiet, add_scheduler_options, integer


def add_parser(sub) -> None:
    s = sub.add_parser("simulate", help="run a Monte Carlo simulation described by a TOML file")
    s.add_argument("config", metavar="CONFIG.toml")
    s.add_argument("--photons", type=integer("--photons", 1, U64_MAX), help="override the number of photons")
    s.add_argument("--seed", type=integer("--seed", 0, U64_MAX), help="override the seed")
    s.add_argument(
        "--threads",
        type=integer("--threads", 1, U64_MAX),
        help="worker threads (default: all cores; with --scheduler: per task, 1)",
    )
    s.add_argument("-o", "--output", metavar="RESULT.h5", help="results file (default: CONFIG.h5)")
    s.add_argument(
        "--resume",
        metavar="PARTIAL.h5",
        help="continue an interrupted run of the same configuration from its partial results file "
        "(the result has the bits of an uninterrupted run)",
    )
    add_force(s, "results file")
    add_quiet(s)
    add_scheduler_options(s)
    s.set_defaults(func=run)


def run(a) -> int:
    from .. import atomic, runner
    from ..config import load_config

    cfg = load_config(a.config)
    kw = cfg.simulate_kwargs()
    for key in ("photons", "seed", "threads"):
        if getattr(a, key) is not None:
            kw[key] = getattr(a, key)
    out = a.output or runner.default_output(a.config, cfg.output)
    inputs = (a.config,) if a.resume is None else (a.config, a.resume)
    atomic.check_target(out, force=a.force, inputs=inputs)  # before the run: a refusal costs nothing
    if a.resume is not None:
        from ..io import load
        from ..mc import check_resume

        kw["resume"] = prior = load(a.resume)
        check_resume(cfg.stack, prior, kw.get("seed", 0), kw.get("source"), kw.get("tallies"))  # before saying so
        print(f"resuming from {a.resume}: {prior.photons:,} photons already traced")
    with runner.scheduler_client(a) as client:
        if client is not None:
            kw["client"] = client
        result = runner.simulate(cfg.stack, label="simulate", quiet=a.quiet, **kw)
    result.config["config_file"] = os.path.abspath(a.config)
    path, held = runner.save_result(result, out, force=a.force, inputs=inputs)
    if not a.quiet:
        print(result.summary())
    print(f"wrote {path}" + (" (partial: interrupted)" if result.partial else ""))
    return runner.EXIT_INTERRUPTED if (result.partial or held) else 0
