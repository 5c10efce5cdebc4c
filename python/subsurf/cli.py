"""The ``subsurf`` command line.

Sub-commands: ``simulate CONFIG.toml``, ``sweep SWEEP.toml`` (both also on a Dask cluster with
``--scheduler tcp://HOST:PORT``), ``mcml INPUT.mci``, ``profile MATERIAL``, ``fit FILE.csv``, ``materials``,
``plot RESULT``, ``merge A B -o C``, ``demo`` and ``render SCENE.toml -o IMAGE.exr``;
``subsurf COMMAND --help`` explains each.
Bad input ends the program with exit status 2 and one line on stderr
(``subsurf: error: FILE:LINE: KEY: problem``), never a traceback (set ``SUBSURF_DEBUG=1`` to see one).
Ctrl-C during a simulation still writes the photons traced so far, marked partial (exit status 130).
"""

from __future__ import annotations

import argparse
import contextlib
import inspect
import os
import sys

import numpy as np

EXIT_BAD_INPUT = 2
EXIT_INTERRUPTED = 130


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, no usage dump
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


class UserError(Exception):
    """An error to report as one line."""


def _simulate(stack, progress=None, **kwargs):
    """Call subsurf.simulate, passing ``progress`` only where the engine accepts it."""
    import subsurf

    sim = getattr(subsurf, "simulate", None)
    if sim is None:
        raise UserError("this build of subsurf has no Monte Carlo engine (subsurf.simulate)")
    if progress is not None:
        try:
            accepts = "progress" in inspect.signature(sim).parameters
        except (TypeError, ValueError):
            accepts = True
        if accepts:
            kwargs["progress"] = progress
    import warnings

    with warnings.catch_warnings():
        # an interrupted run warns; the command line reports "partial" itself, in one line
        warnings.simplefilter("ignore", RuntimeWarning)
        return sim(stack, **kwargs)


def _bar(label, quiet):
    from .progress import ProgressBar

    return ProgressBar(label=label, quiet=quiet)


def _summary(result) -> str:
    from .result import TOTALS

    rows = [(n.replace("_", " "), getattr(result, n), getattr(result, n + "_stderr")) for n in TOTALS]
    for i, (a, s) in enumerate(zip(result.absorbed_per_layer, result.absorbed_per_layer_stderr)):
        rows.append((f"  absorbed in layer {i}", a, s))
    w = max(len(r[0]) for r in rows)
    out = [f"{'quantity':<{w}}  {'value':>10}   {'± stderr':<9}"]
    out += [f"{n:<{w}}  {v:>10.6f} ± {s:<9.2e}" for n, v, s in rows]
    out.append(f"{'energy balance':<{w}}  {result.energy_balance:>10.6f}")
    rate = result.events_per_s
    state = f"  PARTIAL: {result.photons} of {result.photons_requested} photons" if result.partial else ""
    out.append(
        f"{result.photons:,} photons, seed {result.seed}, {result.elapsed_s:.2f} s, "
        f"{rate:.3g} scattering events/s, {result.photons / max(result.elapsed_s, 1e-12):.3g} photons/s{state}"
    )
    return "\n".join(out)


# --- simulate ---------------------------------------------------------------------------------


def add_scheduler_options(p) -> None:
    """``--scheduler`` and ``--connect-timeout`` of the commands that can run on a Dask cluster."""
    p.add_argument(
        "--scheduler",
        metavar="tcp://HOST:PORT",
        help="run on the Dask cluster of this scheduler (pip install 'subsurf[cluster]'; docs/cluster.md)",
    )
    p.add_argument(
        "--connect-timeout", type=float, default=10.0, metavar="SECONDS", help="wait this long for the scheduler"
    )


@contextlib.contextmanager
def scheduler_client(a):
    """A Dask client for ``--scheduler`` (closed at the end), or None."""
    if not getattr(a, "scheduler", None):
        yield None
        return
    from .cluster import connect

    if not (a.connect_timeout > 0):
        raise UserError(f"--connect-timeout = {a.connect_timeout:g} is out of range: must be > 0 (seconds)")
    try:
        client = connect(a.scheduler, timeout=a.connect_timeout)
    except ImportError as e:  # no dask.distributed: say how to get it, in one line
        raise UserError(str(e)) from None
    try:
        yield client
    finally:
        client.close()


def cmd_simulate(a) -> int:
    from . import io
    from .config import load_config

    cfg = load_config(a.config)
    kw = cfg.simulate_kwargs()
    if a.photons is not None:
        kw["photons"] = a.photons
    if a.seed is not None:
        kw["seed"] = a.seed
    if a.threads is not None:
        kw["threads"] = a.threads
    out = a.output or cfg.output or os.path.splitext(os.path.basename(a.config))[0] + ".h5"
    if cfg.output and not a.output and not os.path.isabs(out):
        out = os.path.join(os.path.dirname(a.config), out)
    bar = _bar("simulate", a.quiet)
    with scheduler_client(a) as client:
        if client is not None:
            kw["client"] = client
        try:
            result = _simulate(cfg.stack, progress=bar, **kw)
        except KeyboardInterrupt:
            bar.close()
            raise UserError("interrupted before any photons were traced; nothing written") from None
        finally:
            bar.close()
    if isinstance(result.config, dict):
        result.config.setdefault("config_file", os.path.abspath(a.config))
    io.save(result, out)
    if not a.quiet:
        print(_summary(result))
    print(f"wrote {out}" + (" (partial: interrupted)" if result.partial else ""))
    return EXIT_INTERRUPTED if result.partial else 0


# --- mcml ---------------------------------------------------------------------------------------


def cmd_mcml(a) -> int:
    from . import mcml

    bars = []

    def factory(i, run):
        b = _bar(f"run {i + 1} ({run.out_fname})", a.quiet)
        bars.append(b)
        return b

    done = mcml.run_mci(
        a.input, force=a.force, seed=a.seed, threads=a.threads, progress_factory=factory, photons=a.photons
    )
    for b in bars:
        b.close()
    partial = False
    for path, res in done:
        partial |= bool(res.partial)
        tag = " (partial: interrupted)" if res.partial else ""
        print(
            f"wrote {path}: Rsp {res.specular_reflectance:.6g}  Rd {res.diffuse_reflectance:.6g}  "
            f"A {res.absorbed:.6g}  Tt {res.transmittance:.6g}  ({res.photons:,} photons){tag}"
        )
    return EXIT_INTERRUPTED if partial else 0


# --- materials ---------------------------------------------------------------------------------


def cmd_materials(a) -> int:
    try:
        from subsurf import materials
    except ImportError:
        raise UserError("this build of subsurf has no material library (subsurf.materials)") from None
    print(f"{'name':<12} {'sigma_s_prime R G B (mm^-1)':>30}   {'sigma_a R G B (mm^-1)':>30}   {'eta':>5}")
    for n in materials.names():
        m = materials.get(n)
        sp = " ".join(f"{x:9.4g}" for x in np.atleast_1d(m.sigma_s_prime))
        sa = " ".join(f"{x:9.4g}" for x in np.atleast_1d(m.sigma_a))
        eta = float(np.atleast_1d(m.eta)[0])
        print(f"{n:<12} {sp:>30}   {sa:>30}   {eta:>5.3g}")
    print("(Jensen, Marschner, Levoy & Hanrahan, SIGGRAPH 2001, Fig. 5)")
    return 0


# --- plot / merge / demo ------------------------------------------------------------------------


def cmd_plot(a) -> int:
    from . import io, plot

    res = io.load(a.result)
    out = a.output or os.path.splitext(a.result)[0] + ".png"
    fig = plot.figure(res, models=() if a.no_models else ("dipole", "better_dipole"))
    plot.save_figure(fig, out)
    print(f"wrote {out}")
    return 0


def cmd_merge(a) -> int:
    from . import io

    res = io.load(a.inputs[0])
    for p in a.inputs[1:]:
        res = io.merge(res, io.load(p))
    if os.path.exists(a.output) and not a.force:
        raise UserError(f"{a.output}: exists; use --force to overwrite")
    io.save(res, a.output)
    print(f"wrote {a.output}: {res.photons:,} photons from seeds {res.config.get('seeds')}")
    return 0


def cmd_demo(a) -> int:
    from . import demo

    return demo.run(out_dir=a.out_dir, photons=a.photons, threads=a.threads, quiet=a.quiet)


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="subsurf", description="Light transport in layered translucent media (units mm, mm^-1).")
    from . import __version__

    p.add_argument("--version", action="version", version=f"subsurf {__version__}")
    sub = p.add_subparsers(dest="command", parser_class=_Parser, metavar="COMMAND")
    sub.required = True

    s = sub.add_parser("simulate", help="run a Monte Carlo simulation described by a TOML file")
    s.add_argument("config", metavar="CONFIG.toml")
    s.add_argument("--photons", type=int, help="override the number of photons")
    s.add_argument("--seed", type=int, help="override the seed")
    s.add_argument("--threads", type=int, help="worker threads (default: all cores; with --scheduler: per task, 1)")
    s.add_argument("-o", "--output", metavar="RESULT.h5", help="results file (default: CONFIG.h5)")
    s.add_argument("-q", "--quiet", action="store_true", help="no progress bar or table")
    add_scheduler_options(s)
    s.set_defaults(func=cmd_simulate)

    m = sub.add_parser("mcml", help="MCML drop-in: simulate every run of an .mci file, write .mco files")
    m.add_argument("input", metavar="INPUT.mci")
    m.add_argument("--force", action="store_true", help="overwrite existing .mco files")
    m.add_argument("--seed", type=int, default=1, help="seed of the first run (run i uses seed + i)")
    m.add_argument("--threads", type=int)
    m.add_argument("--photons", type=int, help="override every run's photon count (quick checks)")
    m.add_argument("-q", "--quiet", action="store_true")
    m.set_defaults(func=cmd_mcml)

    from .commands import fit, profile, sweep

    for command in (profile, fit, sweep):
        command.add_parser(sub)

    ma = sub.add_parser("materials", help="list the material library")
    ma.set_defaults(func=cmd_materials)

    pl = sub.add_parser("plot", help="plot a results file to a PNG")
    pl.add_argument("result", metavar="RESULT.h5")
    pl.add_argument("-o", "--output", metavar="FIGURE.png")
    pl.add_argument("--no-models", action="store_true", help="do not draw the diffusion curves")
    pl.set_defaults(func=cmd_plot)

    me = sub.add_parser("merge", help="merge results of the same configuration with different seeds")
    me.add_argument("inputs", nargs="+", metavar="RESULT.h5")
    me.add_argument("-o", "--output", required=True, metavar="MERGED.h5")
    me.add_argument("--force", action="store_true")
    me.set_defaults(func=cmd_merge)

    d = sub.add_parser("demo", help="three-layer skin: simulate, compare with the dipole, write out/demo.*")
    d.add_argument("--out-dir", default="out")
    d.add_argument("--photons", type=int, help="photons per run (default: the demo's own)")
    d.add_argument("--threads", type=int)
    d.add_argument("-q", "--quiet", action="store_true")
    d.set_defaults(func=cmd_demo)

    from .render.cli import add_parser as add_render_parser

    add_render_parser(sub, EXIT_INTERRUPTED)
    return p


def main(argv=None) -> int:
    """Entry point of the ``subsurf`` console script; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    from . import _core
    from .cluster import ClusterError

    if getattr(args, "photons", None) is not None and args.photons < 1:
        parser.exit(EXIT_BAD_INPUT, f"subsurf: error: --photons = {args.photons} is out of range: must be >= 1\n")
    if getattr(args, "threads", None) is not None and args.threads < 1:
        parser.exit(EXIT_BAD_INPUT, f"subsurf: error: --threads = {args.threads} is out of range: must be >= 1\n")
    if getattr(args, "seed", None) is not None and not (0 <= args.seed < 2**64):
        parser.exit(EXIT_BAD_INPUT, f"subsurf: error: --seed = {args.seed} is out of range: must be in [0, 2^64)\n")
    try:
        return int(args.func(args) or 0)
    except (
        UserError,
        ClusterError,
        _core.ParameterError,
        FileExistsError,
        FileNotFoundError,
        PermissionError,
        IsADirectoryError,
        ValueError,
    ) as e:
        if os.environ.get("SUBSURF_DEBUG"):
            raise
        msg = str(e).replace("\n", " ")
        sys.stderr.write(f"subsurf: error: {msg}\n")
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        sys.stderr.write("subsurf: interrupted\n")
        return EXIT_INTERRUPTED


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
