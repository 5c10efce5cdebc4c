"""The sub-commands of ``subsurf``: one module each, registered in :data:`subsurf.cli.COMMANDS`.

A sub-command module defines ``COMMAND = Command(name, help, add_arguments, run)``:
``add_arguments(parser)`` declares its arguments on an ``argparse`` sub-parser and ``run(args)``
does the work and returns the exit status. It reports bad input by raising
:class:`subsurf.runner.UserError`, ``ValueError`` (``subsurf.ParameterError`` …) or ``OSError``
with a one-line message; :func:`subsurf.cli.main` prints it as ``subsurf: error: …`` (status 2).
Shared run/report helpers live in :mod:`subsurf.runner`, argument helpers here. Modules import
only the standard library at the top, and the rest inside ``run``, so ``subsurf --help`` is fast.
"""

from __future__ import annotations

import argparse
import dataclasses
from typing import Callable

__all__ = ["Command", "integer", "add_force", "add_quiet"]


@dataclasses.dataclass(frozen=True)
class Command:
    """A sub-command: its name, one-line help, argument declaration and implementation."""

    name: str
    help: str
    add_arguments: Callable[[argparse.ArgumentParser], None]
    run: Callable[[argparse.Namespace], int]


def integer(flag: str, lo: int, hi: int) -> Callable[[str], int]:
    """An ``argparse`` type: an integer in [lo, hi], refused in one line naming ``flag``."""

    def parse(text: str) -> int:
        try:
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"invalid int value: {text!r}") from None
        if not lo <= v <= hi:
            top = "2^64 - 1" if hi == 2**64 - 1 else str(hi)
            raise argparse.ArgumentTypeError(f"{flag} = {v} is out of range: must be an integer in [{lo}, {top}]")
        return v

    return parse


#: The engine counts photons, seeds and threads in 64-bit integers.
U64_MAX = 2**64 - 1


def add_force(p: argparse.ArgumentParser, what: str) -> None:
    p.add_argument("--force", action="store_true", help=f"replace an existing {what}")


def add_quiet(p: argparse.ArgumentParser) -> None:
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar or table")
