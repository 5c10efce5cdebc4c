"""The sub-commands of ``subsurf``: one module each, listed in :data:`subsurf.cli.COMMANDS`.

A sub-command module defines ``add_parser(sub)``, which registers the command on the ``argparse``
sub-parsers (its name, help and arguments, and ``set_defaults(func=run)``), and ``run(args)``, which
does the work and returns the exit status. It reports bad input by raising :class:`CommandError`
(or ``subsurf.ParameterError`` and other ``ValueError``/``OSError``) with a one-line message;
:func:`subsurf.cli.main` prints it as ``subsurf: error: …`` (exit status 2). Shared run/report
helpers live in :mod:`subsurf.runner`, argument helpers here. Modules import the standard library
at the top and the rest inside their functions, so ``subsurf --help`` stays quick.
"""

from __future__ import annotations

import argparse
from typing import Callable

from ..runner import UserError as CommandError

__all__ = ["CommandError", "integer", "add_force", "add_quiet", "add_scheduler_options", "U64_MAX"]

#: The engine counts photons, seeds and threads in 64-bit integers.
U64_MAX = 2**64 - 1


def integer(flag: str, lo: int, hi: int) -> Callable[[str], int]:
    """An ``argparse`` type: an integer in [lo, hi], refused in one line naming ``flag``."""

    def parse(text: str) -> int:
        try:
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"invalid int value: {text!r}") from None
        if not lo <= v <= hi:
            top = "2^64 - 1" if hi == U64_MAX else str(hi)
            raise argparse.ArgumentTypeError(f"{flag} = {v} is out of range: must be an integer in [{lo}, {top}]")
        return v

    return parse


def add_force(p: argparse.ArgumentParser, what: str) -> None:
    p.add_argument("--force", action="store_true", help=f"replace an existing {what}")


def add_quiet(p: argparse.ArgumentParser) -> None:
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar or table")


def add_scheduler_options(p: argparse.ArgumentParser) -> None:
    """``--scheduler`` and ``--connect-timeout`` of the commands that can run on a Dask cluster
    (see :func:`subsurf.runner.scheduler_client`)."""
    p.add_argument(
        "--scheduler",
        metavar="tcp://HOST:PORT",
        help="run on the Dask cluster of this scheduler (pip install 'subsurf[cluster]'; docs/cluster.md)",
    )
    p.add_argument(
        "--connect-timeout", type=float, default=10.0, metavar="SECONDS", help="wait this long for the scheduler"
    )
