"""The ``subsurf`` command line.

Sub-commands (``subsurf COMMAND --help`` explains each) are listed in :data:`COMMANDS`; each lives in
its own module under :mod:`subsurf.commands` (``profile`` below). Bad input ends the program with exit
status 2 and one line on stderr (``subsurf: error: FILE:LINE: KEY: problem``), never a traceback (set
``SUBSURF_DEBUG=1`` to see one). Ctrl-C during a simulation writes the photons traced so far, marked
partial, and never over an existing file (exit status 130); Ctrl-C before the first photons were
traced writes nothing (130). SIGTERM ends it with status 143; files are written atomically, so an
interrupted or killed save never leaves a truncated file.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import os
import signal
import sys
import threading
import warnings

import numpy as np

from .commands import Command, demo, materials, mcml, merge, plot, simulate
from .runner import EXIT_BAD_INPUT, EXIT_INTERRUPTED, Interrupted, UserError

EXIT_TERMINATED = 128 + signal.SIGTERM


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, no usage dump
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


# --- profile -----------------------------------------------------------------------------------


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


def _profile_arguments(pr) -> None:
    pr.add_argument("material", nargs="?", help="a library material (see `subsurf materials`)")
    pr.add_argument("--sigma-a", type=float, help="absorption coefficient, mm^-1")
    pr.add_argument("--sigma-s-prime", type=float, help="reduced scattering coefficient, mm^-1")
    pr.add_argument("--eta", type=float, default=1.3, help="relative refractive index (default 1.3)")


PROFILE = Command(
    "profile", "dipole / better dipole / single scattering for a material", _profile_arguments, cmd_profile
)

#: Every sub-command, in the order ``subsurf --help`` lists them. A new one is a module under
#: ``subsurf/commands/`` defining ``COMMAND`` (see :mod:`subsurf.commands`) and one entry here.
COMMANDS = (
    simulate.COMMAND,
    mcml.COMMAND,
    PROFILE,
    materials.COMMAND,
    plot.COMMAND,
    merge.COMMAND,
    demo.COMMAND,
)


def build_parser() -> argparse.ArgumentParser:
    from ._core import __version__

    p = _Parser(prog="subsurf", description="Light transport in layered translucent media (units mm, mm^-1).")
    p.add_argument("--version", action="version", version=f"subsurf {__version__}")
    sub = p.add_subparsers(dest="command", parser_class=_Parser, metavar="COMMAND")
    sub.required = True
    for c in COMMANDS:
        sp = sub.add_parser(c.name, help=c.help)
        c.add_arguments(sp)
        sp.set_defaults(func=c.run)
    return p


class Terminated(BaseException):
    """SIGTERM, turned into an exception so that open files are cleaned up on the way out."""


def _terminate(signum, frame):
    raise Terminated


def _warn_one_line(message, category, filename, lineno, file=None, line=None):
    sys.stderr.write(f"subsurf: warning: {' '.join(str(message).split())}\n")


@contextlib.contextmanager
def _handlers():
    """SIGTERM raises :class:`Terminated`; warnings print as one line. Both restored afterwards."""
    with warnings.catch_warnings():
        warnings.showwarning = _warn_one_line
        if threading.current_thread() is not threading.main_thread():
            yield
            return
        old = signal.signal(signal.SIGTERM, _terminate)
        try:
            yield
        finally:
            signal.signal(signal.SIGTERM, old)


def _message(e: BaseException) -> str:
    if isinstance(e, OSError) and e.filename and e.strerror:  # an OSError of the standard library
        return f"{e.filename}: {e.strerror}"
    return " ".join(str(e).split())


def main(argv=None) -> int:
    """Run ``subsurf`` with the arguments ``argv`` (default: ``sys.argv[1:]``); returns the exit status."""
    with _handlers():
        try:
            args = build_parser().parse_args(argv)
            return int(args.func(args) or 0)
        except Interrupted as e:
            sys.stderr.write(f"subsurf: {e}\n")
            return EXIT_INTERRUPTED
        except KeyboardInterrupt:
            sys.stderr.write("subsurf: interrupted\n")
            return EXIT_INTERRUPTED
        except Terminated:
            sys.stderr.write("subsurf: terminated\n")
            return EXIT_TERMINATED
        except (UserError, ValueError, OSError) as e:  # ValueError: subsurf.ParameterError and the file errors
            if os.environ.get("SUBSURF_DEBUG"):
                raise
            sys.stderr.write(f"subsurf: error: {_message(e)}\n")
            return EXIT_BAD_INPUT


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
