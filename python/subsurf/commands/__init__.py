"""Implementations of ``subsurf`` sub-commands that have their own module; each exposes
``add_parser(sub)`` (registers the command on the argparse sub-parsers) and ``run(args)``."""


class CommandError(ValueError):
    """Bad input to a command: ``subsurf.cli.main`` prints it as one line (exit status 2)."""
