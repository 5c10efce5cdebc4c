"""The ``subsurf`` command line.

Sub-commands (``subsurf COMMAND --help`` explains each) are listed in :data:`COMMANDS`; each lives in
its own module under :mod:`subsurf.commands`. Bad input ends the program with exit
status 2 and one line on stderr (``subsurf: error: FILE:LINE: KEY: problem``), never a traceback (set
``SUBSURF_DEBUG=1`` to see one). Ctrl-C during a simulation writes the photons traced so far, marked
partial, and never over an existing file (exit status 130); Ctrl-C before the first photons were
traced writes nothing (130). SIGTERM ends it with status 143; files are written atomically, so an
interrupted or killed save never leaves a truncated file.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import signal
import sys
import threading
import warnings

from .commands import demo, fit, materials, mcml, merge, plot, profile, render, simulate, sweep
from .runner import EXIT_BAD_INPUT, EXIT_INTERRUPTED, Interrupted, UserError

EXIT_TERMINATED = 128 + signal.SIGTERM


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, no usage dump
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


#: Every sub-command, in the order ``subsurf --help`` lists them. A new one is a module under
#: ``subsurf/commands/`` (``add_parser(sub)`` and ``run(args)``, see :mod:`subsurf.commands`) and one
#: entry here.
COMMANDS = (simulate, sweep, mcml, profile, fit, materials, plot, merge, demo, render)


def build_parser() -> argparse.ArgumentParser:
    from ._core import __version__

    p = _Parser(prog="subsurf", description="Light transport in layered translucent media (units mm, mm^-1).")
    p.add_argument("--version", action="version", version=f"subsurf {__version__}")
    sub = p.add_subparsers(dest="command", parser_class=_Parser, metavar="COMMAND")
    sub.required = True
    for command in COMMANDS:
        command.add_parser(sub)
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
        except (UserError, ValueError, OSError) as e:  # ParameterError and file errors; OSError: ClusterError
            if os.environ.get("SUBSURF_DEBUG"):
                raise
            sys.stderr.write(f"subsurf: error: {_message(e)}\n")
            return EXIT_BAD_INPUT


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
