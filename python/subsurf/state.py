"""The exact raw state of a Monte Carlo run: :class:`TallyState`.

A state holds photons ``[start, stop)`` of a run (a configuration: stack, source, tallies, seed)
as exact sums — fixed-point integers, not floats — so that states of consecutive photon ranges
merge (:meth:`TallyState.merge`) to exactly the bits a single run of all those photons gives,
however the photons were split into ranges, threads or cluster workers. The result of a run is a
pure function of (stack, source, tallies, seed, photons).

Rules (the core's, ``crates/subsurf-core/src/mc/state.rs``): photons are traced in chunks of
:data:`CHUNK_PHOTONS` (4096); a range starts at a multiple of it and may end anywhere, but only a
state ending at a multiple of it can be continued or merged with the next range; states merge in
range order and only with states of the same configuration (checked by a fingerprint).

Everything is plain data (ints, strings, numpy arrays), so a state pickles and travels cheaply:
per histogram bin 9 uint64 words (the sums S₁ and S₂ of the per-photon scores).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from . import _core

__all__ = ["TallyState", "CHUNK_PHOTONS"]

#: Photons per chunk, the unit of merging: ranges start (and, to be continued, end) at multiples.
CHUNK_PHOTONS: int = _core.MC_CHUNK_PHOTONS

_INTS = ("start", "end", "events", "fingerprint")
_ARRAYS = {"s1": np.uint64, "s2": np.uint64, "min": np.float64, "max": np.float64}


class TallyState:
    """Exact raw state of photons ``[start, stop)`` of a Monte Carlo run (see the module docs).

    Attributes
    ----------
    start, stop : the photon range; ``photons = stop - start``.
    events : scattering events of these photons.
    fingerprint : identifies the configuration (stack, source, tallies, seed).
    layout : tuple of ``(name, bins)`` of the channels (totals and histograms).

    Obtain one from :func:`subsurf.simulate_range` or ``result.state``; merge with
    :meth:`merge` (in range order); turn into a :class:`~subsurf.result.Result` with
    ``subsurf.simulate(stack, photons=state.stop, ..., resume=state)``.
    """

    __slots__ = ("_d",)

    def __init__(self, data: dict):
        d = {}
        try:
            d["scheme"] = str(data["scheme"])
            for k in _INTS:
                d[k] = int(data[k])
            d["names"] = [str(n) for n in data["names"]]
            d["lengths"] = [int(n) for n in data["lengths"]]
            d["extremes"] = [bool(x) for x in data["extremes"]]
            for k, t in _ARRAYS.items():
                d[k] = np.ascontiguousarray(np.asarray(data[k]).ravel(), dtype=t)
        except (KeyError, TypeError, ValueError) as e:
            raise _core.ParameterError(f"state: not a Monte Carlo state ({e!r})") from None
        if d["scheme"] != _core.MC_STATE_SCHEME:
            raise _core.ParameterError(
                f"state: format {d['scheme']!r} is not this version's ({_core.MC_STATE_SCHEME!r}):"
                " it was written by another engine version and cannot be resumed by this one"
                " (run it again from the start)"
            )
        self._d = d

    @property
    def start(self) -> int:
        return self._d["start"]

    @property
    def stop(self) -> int:
        return self._d["end"]

    @property
    def photons(self) -> int:
        return self.stop - self.start

    @property
    def events(self) -> int:
        return self._d["events"]

    @property
    def fingerprint(self) -> int:
        return self._d["fingerprint"]

    @property
    def layout(self) -> tuple:
        return tuple(zip(self._d["names"], self._d["lengths"]))

    def _core(self) -> dict:
        """The flat dict the binding takes."""
        return dict(self._d)

    def to_dict(self) -> dict[str, Any]:
        """Plain values and numpy arrays (scheme, start, end, events, fingerprint, names,
        lengths, extremes, s1, s2, min, max) — what :meth:`from_dict` reads back."""
        return {
            k: (v.copy() if isinstance(v, np.ndarray) else (list(v) if isinstance(v, list) else v))
            for k, v in self._d.items()
        }

    @classmethod
    def from_dict(cls, d: dict) -> TallyState:
        """Inverse of :meth:`to_dict`."""
        return cls(d)

    def merge(self, *later: TallyState) -> TallyState:
        """This state followed by the states of the next photon ranges, in range order (each
        starts where the previous one ends, at a multiple of :data:`CHUNK_PHOTONS`). Exact: the
        merged state is bit for bit the state of one run of all these photons."""
        return TallyState.concat([self, *later])

    @staticmethod
    def concat(states) -> TallyState:
        """Merge states of consecutive photon ranges given in range order (see :meth:`merge`)."""
        states = list(states)
        for s in states:
            if not isinstance(s, TallyState):
                raise _core.ParameterError(f"states: {s!r} is not a subsurf.TallyState")
        return TallyState(_core.mc_merge_states([s._d for s in states]))

    def __eq__(self, other) -> bool:
        if not isinstance(other, TallyState):
            return NotImplemented
        a, b = self._d, other._d
        return all(np.array_equal(a[k], b[k]) if isinstance(a[k], np.ndarray) else a[k] == b[k] for k in a)

    def __getstate__(self):
        return self._d

    def __setstate__(self, d):
        self._d = d

    def __repr__(self) -> str:
        bins = sum(self._d["lengths"])
        return f"TallyState(photons [{self.start}, {self.stop}), {self.events} events, {bins} bins)"
