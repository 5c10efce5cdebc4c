"""A progress bar for long runs: rate and ETA on stderr, driven by ``progress(done, total)``.

:class:`ProgressBar` is a callable suitable as the ``progress`` callback of
:func:`subsurf.simulate`. It stays silent when its stream is not a terminal, when ``quiet`` is set,
or during the first ``delay`` seconds (so runs shorter than a second print nothing).
"""

from __future__ import annotations

import sys
import time


def _fmt_time(s: float) -> str:
    if s != s or s == float("inf"):
        return "--:--"
    s = int(round(s))
    h, rem = divmod(s, 3600)
    m, sec = divmod(rem, 60)
    return f"{h}:{m:02d}:{sec:02d}" if h else f"{m:02d}:{sec:02d}"


def _fmt_rate(r: float) -> str:
    for unit, k in (("G", 1e9), ("M", 1e6), ("k", 1e3)):
        if r >= k:
            return f"{r / k:.3g}{unit}"
    return f"{r:.3g}"


class ProgressBar:
    """``ProgressBar(label="", stream=sys.stderr, quiet=False, delay=1.0, width=28, unit="photons")``.

    Call it as ``bar(done, total)`` (``total`` in ``unit``, e.g. photons, samples, spp, points);
    call :meth:`close` at the end (it ends the line if one was drawn).
    ``enabled`` is False when output is suppressed (quiet, or the stream is not a TTY).
    """

    def __init__(
        self,
        label: str = "",
        stream=None,
        quiet: bool = False,
        delay: float = 1.0,
        width: int = 28,
        force: bool = False,
        clock=time.monotonic,
        unit: str = "photons",
    ):
        self.stream = sys.stderr if stream is None else stream
        isatty = getattr(self.stream, "isatty", lambda: False)
        self.enabled = not quiet and (force or bool(isatty()))
        self.label, self.delay, self.width, self.clock, self.unit = label, delay, width, clock, unit
        self.t0 = clock()
        self.drawn = False
        self.last = -1.0

    def line(self, done: int, total: int, now: float | None = None) -> str:
        """The text of the bar for ``done`` of ``total`` (in ``unit``)."""
        now = self.clock() if now is None else now
        el = max(now - self.t0, 1e-9)
        frac = min(max(done / total, 0.0), 1.0) if total > 0 else 0.0
        fill = int(round(frac * self.width))
        rate = done / el
        eta = (total - done) / rate if rate > 0 else float("inf")
        lab = f"{self.label} " if self.label else ""
        return (
            f"{lab}[{'#' * fill}{'.' * (self.width - fill)}] {100 * frac:5.1f}%  "
            f"{_fmt_rate(rate)} {self.unit}/s  elapsed {_fmt_time(el)}  ETA {_fmt_time(eta)}"
        )

    def __call__(self, done: int, total: int) -> None:
        if not self.enabled:
            return
        now = self.clock()
        if now - self.t0 < self.delay or (now - self.last < 0.1 and done < total):
            return
        self.last = now
        self.stream.write("\r" + self.line(done, total, now) + "\033[K")
        self.stream.flush()
        self.drawn = True

    def close(self) -> None:
        if self.drawn:
            self.stream.write("\n")
            self.stream.flush()
            self.drawn = False
