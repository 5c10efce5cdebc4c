"""Test-only hooks, active only when the environment variable ``SUBSURF_TEST_HOOK`` is set.

The test suite uses them to interrupt and kill the ``subsurf`` command at exact points instead of
after sleeps and timers. ``SUBSURF_TEST_HOOK`` holds comma-separated ``name[=value]`` items:

* ``interrupt_after=N`` — the command line's progress callback raises ``KeyboardInterrupt`` (what
  Ctrl-C does) at its first call with at least N photons (``render``: samples per pixel) done;
* ``terminate_after=N`` — the same callback sends the process SIGTERM (what ``kill`` does) at
  its first call with at least N done;
* ``setup_interrupt_after=N``, ``setup_terminate_after=N`` — the same for the progress of
  ``render``'s set-up (Monte Carlo profile photons, irradiance samples), before any pass;
* ``pause_in_write=DIR`` — an atomic write (:mod:`subsurf.atomic`), with half of its bytes in the
  temporary file, creates ``DIR/paused`` and waits up to 60 s for ``DIR/resume`` to appear;
* ``sigint_at_start`` — the ``subsurf`` command sends itself SIGINT before it loads numpy and the
  extension (a Ctrl-C during start-up);
* ``connecting=DIR`` — :func:`subsurf.cluster.connect` creates ``DIR/connecting`` once it waits for
  the scheduler's answer (tests then interrupt it there);
* ``task_photons=N`` — a cluster run uses photon ranges of N photons (a multiple of 4096);
* ``kill_scheduler_after=N:PID`` — after the N-th finished range (or sweep point) of a cluster run,
  SIGKILL process PID (the test's scheduler) and wait until the client has seen the connection close.

This module imports nothing but the standard library, so the command can read it first.
"""

from __future__ import annotations

import os
import signal
import time

ENV = "SUBSURF_TEST_HOOK"


def get(name: str) -> str | None:
    """The value of hook ``name`` ("" for a bare name), or None when it is not set."""
    for item in os.environ.get(ENV, "").split(","):
        key, _, value = item.partition("=")
        if key.strip() == name:
            return value.strip()
    return None


def wrap_progress(progress, prefix: str = ""):
    """``progress`` (a callable or None), raising KeyboardInterrupt as ``interrupt_after`` asks or
    sending SIGTERM as ``terminate_after`` does (hooks named ``prefix`` + those names)."""
    after, term = get(prefix + "interrupt_after"), get(prefix + "terminate_after")
    if after is None and term is None:
        return progress
    n = int(after if after is not None else term)

    def hooked(done: int, total: int) -> None:
        if progress is not None:
            progress(done, total)
        if done >= n:
            if after is None:
                os.kill(os.getpid(), signal.SIGTERM)
            else:
                raise KeyboardInterrupt

    return hooked


def touch(name: str) -> None:
    """Create ``DIR/name`` if hook ``name=DIR`` is set (tells a test the command reached that point)."""
    d = get(name)
    if d:
        with open(os.path.join(d, name), "w"):
            pass


def after_task(count: int, client) -> None:
    """``kill_scheduler_after=N:PID``: at ``count == N``, kill PID and wait (at most 60 s) until
    ``client`` (a Dask client) no longer says it is running."""
    value = get("kill_scheduler_after")
    if not value:
        return
    n, _, pid = value.partition(":")
    if count != int(n):
        return
    os.kill(int(pid), signal.SIGKILL)
    deadline = time.monotonic() + 60.0
    while client.status == "running" and time.monotonic() < deadline:
        time.sleep(0.01)


def pause_in_write() -> None:
    """Signal ``DIR/paused`` and wait for ``DIR/resume`` (at most 60 s), if ``pause_in_write`` is set."""
    d = get("pause_in_write")
    if not d:
        return
    with open(os.path.join(d, "paused"), "w"):
        pass
    deadline = time.monotonic() + 60.0
    while not os.path.exists(os.path.join(d, "resume")) and time.monotonic() < deadline:
        time.sleep(0.01)
