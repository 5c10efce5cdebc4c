"""``subsurf sweep SWEEP.toml [--scheduler tcp://HOST:PORT]``: a Monte Carlo run on every point
of a grid of configurations (a run configuration plus ``[[sweep]]`` axes, see
:class:`subsurf.config.SweepConfig` and docs/cluster.md), locally or on a Dask cluster.

Writes a sweep file (:mod:`subsurf.sweeps`: HDF5 with the grid coordinates, totals and
histograms per point) as it goes; Ctrl-C keeps the finished points (exit status 130) and running
the same command again computes only the points still missing."""

from __future__ import annotations

import os

#: Points listed in the summary table (the file has them all).
SHOWN = 20


def add_parser(sub):
    from . import add_scheduler_options

    p = sub.add_parser("sweep", help="Monte Carlo runs on a grid of configurations (TOML with [[sweep]] axes)")
    p.add_argument("config", metavar="SWEEP.toml")
    p.add_argument("-o", "--output", metavar="SWEEP.h5", help="sweep file (default: the TOML's output or SWEEP.h5)")
    p.add_argument("--photons", type=int, help="override the photons of every point")
    p.add_argument("--threads", type=int, help="threads per point when run locally (default: all cores)")
    p.add_argument(
        "--force",
        action="store_true",
        help="replace an output file that holds another sweep or is damaged (its points are lost)",
    )
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar or table")
    add_scheduler_options(p)
    p.set_defaults(func=run)


def _output(a, cfg) -> str:
    if a.output:
        return a.output
    if cfg.output:
        return cfg.output if os.path.isabs(cfg.output) else os.path.join(os.path.dirname(a.config), cfg.output)
    return os.path.splitext(os.path.basename(a.config))[0] + ".h5"


def _table(res) -> str:
    import numpy as np

    names = list(res.axes)
    cols = [("Rd", "diffuse_reflectance"), ("Tt", "transmittance"), ("A", "absorbed")]
    head = "  ".join(f"{n:>10}" for n in names) + "  " + "  ".join(f"{c:>21}" for c, _ in cols)
    lines = [head]
    shown = 0
    for idx in np.ndindex(*res.shape):
        if not res.done[idx]:
            continue
        if shown == SHOWN:
            lines.append(f"... ({res.points_done - SHOWN} more points in the file)")
            break
        coords = "  ".join(f"{res.axes[n][i].item():>10.5g}" for n, i in zip(names, idx))
        vals = "  ".join(f"{res[q][idx]:>10.6f} ± {res[q + '_stderr'][idx]:<8.2e}" for _, q in cols)
        lines.append(f"{coords}  {vals}")
        shown += 1
    return "\n".join(lines)


def _check_output(a, cfg, out) -> None:
    """An existing output is resumed when it holds this sweep; otherwise it is replaced only with
    --force, and never when it is the configuration itself."""
    from .. import atomic, container, sweeps
    from . import CommandError as UserError

    if not os.path.lexists(out):
        return
    atomic.check_target(out, force=True, inputs=(a.config,))  # a directory, or the TOML itself
    try:
        old = sweeps.load(out)
    except container.FileFormatError as e:
        if not a.force:
            raise UserError(f"{e}; use --force to discard it (and any points it held) or -o elsewhere") from None
        os.unlink(out)
        return
    if not sweeps.same_sweep(old, cfg, cfg.grid()):
        if not a.force:
            raise UserError(
                f"{out}: holds another sweep (other configuration or grid); use --force to replace it or -o elsewhere"
            )
        os.unlink(out)
    elif not a.quiet:
        print(f"{out}: resuming, {old.points_done} of {old.done.size} points already done")


def run(a) -> int:
    import warnings

    from .. import sweeps
    from ..config import load_sweep
    from ..runner import EXIT_INTERRUPTED, Interrupted, scheduler_client
    from ..runner import progress_bar as _bar

    cfg = load_sweep(a.config)
    if a.photons is not None:
        cfg.base["photons"] = a.photons
        cfg.run_config(**{k: v[0] for k, v in cfg.grid().items()})  # the override is checked as the file is
    cfg.threads = a.threads
    out = _output(a, cfg)
    _check_output(a, cfg, out)
    bar = _bar("sweep", a.quiet)
    with scheduler_client(a) as client, warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # "interrupted" is reported below, in one line
        try:
            res = sweeps.sweep(cfg, cfg.grid(), out, client=client, progress=bar, units=cfg.units())
        finally:
            bar.close()
    if res.points_done == 0:
        raise Interrupted("sweep: interrupted before any point was done; nothing written")
    if not a.quiet:
        print(_table(res))
    if res.complete:
        print(f"wrote {out}: {res.points_done} points ({' x '.join(map(str, res.shape))})")
        return 0
    print(f"wrote {out} (partial: {res.points_done} of {res.done.size} points; run the same command again to finish)")
    return EXIT_INTERRUPTED
