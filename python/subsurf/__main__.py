"""``python -m subsurf`` and the ``subsurf`` console script.

The package root loads nothing (see ``subsurf/__init__.py``), so this module runs before numpy and
the extension are imported: a Ctrl-C while they load ends the program with one line, not a traceback.
"""

from __future__ import annotations

import os
import signal
import sys


def main(argv=None) -> int:
    """Entry point of the ``subsurf`` command; returns the exit status (see :func:`subsurf.cli.main`)."""
    try:
        from . import _testhooks

        if _testhooks.get("sigint_at_start") is not None:
            os.kill(os.getpid(), signal.SIGINT)
        from .cli import main as cli_main
    except KeyboardInterrupt:
        sys.stderr.write("subsurf: interrupted\n")
        return 130
    return cli_main(argv)


if __name__ == "__main__":
    sys.exit(main())
