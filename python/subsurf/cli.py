"""The ``subsurf`` command line.

Sub-commands: ``simulate CONFIG.toml``, ``mcml INPUT.mci``, ``profile MATERIAL``, ``materials``,
``plot RESULT``, ``merge A B -o C``, ``demo`` and ``render SCENE.toml -o IMAGE.exr``;
``subsurf COMMAND --help`` explains each.
Bad input ends the program with exit status 2 and one line on stderr
(``subsurf: error: FILE:LINE: KEY: problem``), never a traceback (set ``SUBSURF_DEBUG=1`` to see one).
Ctrl-C during a simulation still writes the photons traced so far, marked partial (exit status 130).
"""

from __future__ import annotations

import argparse
import inspect
import math
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


# --- profile / materials ------------------------------------------------------------------------


def _single_scattering_total(sigma_a, sigma_s, eta, n_mu=48, n_phi=48):
    """∫ f_r^(1)(normal incidence → ω) cos θ dω of a semi-infinite isotropic layer (Gauss–Legendre)."""
    import subsurf
    from subsurf import hk

    stack = subsurf.Stack([subsurf.Layer(eta, sigma_a, sigma_s, 0.0)])
    x, w = np.polynomial.legendre.leggauss(n_mu)
    mu = 0.5 * (x + 1)
    wm = 0.5 * w
    phi = (np.arange(n_phi) + 0.5) * 2 * math.pi / n_phi
    M, P = np.meshgrid(mu, phi, indexing="ij")
    s = np.sqrt(1 - M**2)
    wo = np.stack([s * np.cos(P), s * np.sin(P), M], axis=-1)
    wi = np.broadcast_to(np.array([0.0, 0.0, 1.0]), wo.shape)
    f = np.asarray(hk.single_scattering_brdf(stack, wi, wo))
    return float(np.sum(f * M * wm[:, None]) * 2 * math.pi / n_phi)


def _trapezoid(y, x) -> float:
    y, x = np.asarray(y, float), np.asarray(x, float)
    return float(np.sum(0.5 * (y[1:] + y[:-1]) * np.diff(x)))


def cmd_profile(a) -> int:

    try:
        from subsurf import diffusion
    except ImportError:
        raise UserError("this build of subsurf has no diffusion models (subsurf.diffusion)") from None
    if a.material:
        from subsurf import materials

        try:
            m = materials.get(a.material)
        except (KeyError, ValueError):
            raise UserError(
                f"unknown material {a.material!r}; known: {', '.join(materials.names())} "
                "(or give --sigma-a, --sigma-s-prime, --eta)"
            ) from None
        sa, sp, eta = (np.atleast_1d(np.asarray(x, float)) for x in (m.sigma_a, m.sigma_s_prime, m.eta))
        chans = ["R", "G", "B"] if sa.size == 3 else [str(i) for i in range(sa.size)]
        title = a.material
    else:
        if a.sigma_a is None or a.sigma_s_prime is None:
            raise UserError("give a MATERIAL name or --sigma-a and --sigma-s-prime (mm^-1) [--eta]")
        for name, v in (("--sigma-a", a.sigma_a), ("--sigma-s-prime", a.sigma_s_prime)):
            if not (v >= 0 and math.isfinite(v)):
                raise UserError(f"{name} = {v:g} is out of range: must be a finite number >= 0 (mm^-1)")
        if a.sigma_a + a.sigma_s_prime <= 0:
            raise UserError("--sigma-a + --sigma-s-prime must be > 0")
        if not (a.eta >= 1.0 and math.isfinite(a.eta)):
            raise UserError(f"--eta = {a.eta:g} is out of range: must be a finite number >= 1")
        sa, sp, eta = np.array([a.sigma_a]), np.array([a.sigma_s_prime]), np.array([a.eta])
        chans, title = ["-"], f"sigma_a = {a.sigma_a:g}/mm, sigma_s' = {a.sigma_s_prime:g}/mm, eta = {a.eta:g}"
    eta = np.broadcast_to(eta, sa.shape)
    alpha = sp / (sa + sp)
    sigma_tr = np.sqrt(3 * sa * (sa + sp))
    print(f"{title}: diffusion and single-scattering totals (normal incidence)")
    hdr = (
        f"{'channel':>7}  {'sigma_a':>9}  {'sigma_s_p':>9}  {'eta':>5}  {'alpha_p':>7}  {'1/s_tr mm':>9}  "
        f"{'Rd dipole':>9}  {'Rd better':>9}  {'R single':>9}"
    )
    print(hdr)
    r_tab = np.array([0.03, 0.1, 0.3, 1.0, 3.0, 10.0])
    profiles = []
    for i, c in enumerate(chans):
        rd_dip = float(diffusion.total_diffuse_reflectance(alpha[i], eta[i]))
        rr = np.geomspace(1e-5, 60.0 / max(sigma_tr[i], 1e-6), 4000)
        bd = getattr(diffusion, "better_dipole_rd", None)
        rd_bd = _trapezoid(bd(rr, sa[i], sp[i], eta[i]) * 2 * math.pi * rr, rr) if bd else math.nan
        try:
            r1 = _single_scattering_total(sa[i], sp[i], eta[i])
        except Exception:  # the HK module may be absent in this build
            r1 = math.nan
        str_ = 1 / sigma_tr[i] if sigma_tr[i] > 0 else math.inf
        print(
            f"{c:>7}  {sa[i]:>9.4g}  {sp[i]:>9.4g}  {eta[i]:>5.3g}  {alpha[i]:>7.4f}  {str_:>9.3g}  "
            f"{rd_dip:>9.4f}  {rd_bd:>9.4f}  {r1:>9.4f}"
        )
        profiles.append(
            (
                diffusion.dipole_rd(r_tab, sa[i], sp[i], eta[i]),
                bd(r_tab, sa[i], sp[i], eta[i]) if bd else np.full_like(r_tab, math.nan),
            )
        )
    print("\nR_d(r) in mm^-2 (dipole / better dipole)")
    print(f"{'r (mm)':>8}  " + "  ".join(f"{c + ' dipole':>12}  {c + ' better':>12}" for c in chans))
    for k, r in enumerate(r_tab):
        print(f"{r:>8.3g}  " + "  ".join(f"{float(p[0][k]):>12.4e}  {float(p[1][k]):>12.4e}" for p in profiles))
    print(
        "(single scattering: Hanrahan-Krueger first order with g = 0 and sigma_s = sigma_s'; "
        "diffusion is trustworthy at high albedo and r of several mean free paths)"
    )
    return 0


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
    s.add_argument("--threads", type=int, help="worker threads (default: all cores)")
    s.add_argument("-o", "--output", metavar="RESULT.h5", help="results file (default: CONFIG.h5)")
    s.add_argument("-q", "--quiet", action="store_true", help="no progress bar or table")
    s.set_defaults(func=cmd_simulate)

    m = sub.add_parser("mcml", help="MCML drop-in: simulate every run of an .mci file, write .mco files")
    m.add_argument("input", metavar="INPUT.mci")
    m.add_argument("--force", action="store_true", help="overwrite existing .mco files")
    m.add_argument("--seed", type=int, default=1, help="seed of the first run (run i uses seed + i)")
    m.add_argument("--threads", type=int)
    m.add_argument("--photons", type=int, help="override every run's photon count (quick checks)")
    m.add_argument("-q", "--quiet", action="store_true")
    m.set_defaults(func=cmd_mcml)

    pr = sub.add_parser("profile", help="dipole / better dipole / single scattering for a material")
    pr.add_argument("material", nargs="?", help="a library material (see `subsurf materials`)")
    pr.add_argument("--sigma-a", type=float, help="absorption coefficient, mm^-1")
    pr.add_argument("--sigma-s-prime", type=float, help="reduced scattering coefficient, mm^-1")
    pr.add_argument("--eta", type=float, default=1.3, help="relative refractive index (default 1.3)")
    pr.set_defaults(func=cmd_profile)

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
