"""Running simulations for the ``subsurf`` command and ``subsurf demo``: progress, Ctrl-C, saving.

Shared by the sub-commands (:mod:`subsurf.commands`) and :mod:`subsurf.demo`, so each has the same
behaviour:

* :class:`UserError` ends a command with one line on stderr and exit status 2;
  :class:`Interrupted` (Ctrl-C before a single photon was traced) with one line and status 130.
* :func:`simulate` runs :func:`subsurf.simulate` under a progress bar; Ctrl-C returns the photons
  traced so far (``partial``), or raises :class:`Interrupted` when there are none.
* :func:`save_result` writes a result atomically; a partial result never replaces an existing file
  (it goes to :func:`subsurf.atomic.partial_path`), and a second Ctrl-C while it is written is
  held back until the file is complete.
"""

from __future__ import annotations

import contextlib
import os
import warnings

from . import _testhooks, atomic

EXIT_BAD_INPUT = 2
EXIT_INTERRUPTED = 130


class UserError(Exception):
    """An error the command line reports as one line (``subsurf: error: MESSAGE``), exit status 2."""


class Interrupted(Exception):
    """Ctrl-C before any photon was traced: reported as one line (``subsurf: MESSAGE``), status 130."""


def progress_bar(label: str, quiet: bool):
    """A :class:`subsurf.progress.ProgressBar` on stderr (silent when ``quiet`` or not a terminal)."""
    from .progress import ProgressBar

    return ProgressBar(label=label, quiet=quiet)


def simulate(stack, label: str = "simulate", quiet: bool = False, **kwargs):
    """:func:`subsurf.simulate` with a progress bar; returns the :class:`~subsurf.result.Result`.

    Ctrl-C during the run returns the photons traced so far (``result.partial``; the command reports
    it, so the API's warning is not repeated); Ctrl-C before the first photons were complete (the API
    raises ``KeyboardInterrupt`` then) raises :class:`Interrupted` ("nothing written").
    """
    from .mc import simulate as run

    bar = progress_bar(label, quiet)
    try:
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message="subsurf.simulate interrupted", category=RuntimeWarning)
            result = run(stack, progress=_testhooks.wrap_progress(bar), **kwargs)
    except KeyboardInterrupt:
        raise Interrupted(f"{label}: interrupted before any photon was traced; nothing written") from None
    finally:
        bar.close()
    return result


def save_result(result, out: str, force: bool = False, inputs=()) -> tuple[str, bool]:
    """Write ``result`` to ``out`` (see the module docstring); returns ``(path written, whether a
    Ctrl-C arrived while it was written)``."""
    from . import io

    if result.partial:
        out, force = atomic.partial_path(out), False
    atomic.check_target(out, force=force, inputs=inputs)
    with atomic.hold_sigint() as held:
        path = io.save(result, out, force=force)
    return path, held.received


def default_output(config_path: str, output: str | None, ext: str = ".h5") -> str:
    """The results file of a configuration: ``output`` (relative to the configuration's directory)
    or the configuration's name with ``ext`` in the current directory."""
    if output is None:
        return os.path.splitext(os.path.basename(config_path))[0] + ext
    if os.path.isabs(output):
        return output
    return os.path.join(os.path.dirname(config_path), output)


@contextlib.contextmanager
def scheduler_client(a):
    """A Dask client for ``--scheduler`` (closed at the end), or None (see :mod:`subsurf.cluster`)."""
    if not getattr(a, "scheduler", None):
        yield None
        return
    from .cluster import check_timeout, connect

    timeout = check_timeout(a.connect_timeout, "--connect-timeout")
    try:
        client = connect(a.scheduler, timeout=timeout)
    except ImportError as e:  # no dask.distributed: say how to get it, in one line
        raise UserError(str(e)) from None
    with _dask_quiet():
        try:
            yield client
        finally:
            _close(client)


@contextlib.contextmanager
def _dask_quiet():
    """Dask's INFO records off while a command holds a client: they are for a cluster's operator,
    and on a lost scheduler ``distributed.batched`` logs one with a traceback (dask 2026.8) beside
    the command's own one-line warning. Warnings and errors still show."""
    import logging

    log = logging.getLogger("distributed")
    level = log.level
    log.setLevel(max(logging.WARNING, level))
    try:
        yield
    finally:
        log.setLevel(level)


def _close(client) -> None:
    """Close a client; after a lost scheduler, without Dask's log line about the reconnection that
    closing ends (the command has said what happened, in one line)."""
    import logging

    log = logging.getLogger("distributed.client")
    level = log.level
    if client.status != "running":
        log.setLevel(logging.CRITICAL)
    try:
        client.close()
    finally:
        log.setLevel(level)
