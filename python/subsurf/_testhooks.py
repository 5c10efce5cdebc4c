"""Test-only hooks, active only when the environment variable ``SUBSURF_TEST_HOOK`` is set.

The test suite uses them to interrupt and kill the ``subsurf`` command at exact points instead of
after sleeps and timers. ``SUBSURF_TEST_HOOK`` holds comma-separated ``name[=value]`` items:

* ``interrupt_after=N`` — the command line's progress callback raises ``KeyboardInterrupt`` (what
  Ctrl-C does) at its first call with at least N photons (``render``: samples per pixel) done;
* ``pause_in_write=DIR`` — an atomic write (:mod:`subsurf.atomic`), with half of its bytes in the
  temporary file, creates ``DIR/paused`` and waits up to 60 s for ``DIR/resume`` to appear;
* ``sigint_at_start`` — the ``subsurf`` command sends itself SIGINT before it loads numpy and the
  extension (a Ctrl-C during start-up).

This module imports nothing but the standard library, so the command can read it first.
"""

from __future__ import annotations

import os
import time

ENV = "SUBSURF_TEST_HOOK"


def get(name: str) -> str | None:
    """The value of hook ``name`` ("" for a bare name), or None when it is not set."""
    for item in os.environ.get(ENV, "").split(","):
        key, _, value = item.partition("=")
        if key.strip() == name:
            return value.strip()
    return None


def wrap_progress(progress):
    """``progress`` (a callable or None), raising KeyboardInterrupt as ``interrupt_after`` asks."""
    after = get("interrupt_after")
    if after is None:
        return progress
    n = int(after)

    def hooked(done: int, total: int) -> None:
        if progress is not None:
            progress(done, total)
        if done >= n:
            raise KeyboardInterrupt

    return hooked


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
