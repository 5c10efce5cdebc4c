"""Result objects shared by the Monte Carlo engine, the results files and the plots.

A :class:`Histogram` is one tally with its standard error, bin edges and units; a
:class:`Result` holds the totals of a run, its histograms by name and its provenance.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np


@dataclasses.dataclass
class Histogram:
    """A binned tally.

    Attributes
    ----------
    values : array of bin averages, shape = tuple(len(e) - 1 for e in edges) (an axis named
        ``"order"`` has integer-like edges 0, 1, …, K+1, K+2: the last bin is "more than K").
    stderr : standard errors of ``values`` (batch means over fixed photon batches), same shape;
        NaN when the run skipped them (``Tallies(errors=False)``).
    edges : one array of bin edges per axis.
    axes : the axis names, e.g. ``("r",)``, ``("r", "z")``, ``("order", "cos_theta", "phi")``.
    edge_units : unit of each axis ("mm", "rad", "ps", "1", …).
    units : unit of ``values`` (e.g. "mm^-2", "sr^-1").
    description : one line saying what it is (MCML name where there is one).
    measures : per axis, the exact measure of each bin that ``values`` are per (annulus area in
        mm² for r, solid angle or projected solid angle in sr for θ, width for z and t, …, as the
        core normalises); the bin weight (fraction of the launched power) is ``values`` times
        :meth:`bin_measure`. Empty when unknown (a hand-built histogram).
    overflow : per axis, whether its last bin also collects everything beyond its last edge (the
        r, z and t axes, as in MCML, and the "more than K" bin of an order axis). Empty when
        unknown.
    """

    values: np.ndarray
    stderr: np.ndarray
    edges: tuple
    axes: tuple
    edge_units: tuple
    units: str
    description: str = ""
    measures: tuple = ()
    overflow: tuple = ()

    def bin_measure(self) -> np.ndarray:
        """The measure of every bin (the outer product of the per-axis ``measures``), shaped like
        ``values``; ``values * bin_measure()`` are the bin weights."""
        if len(self.measures) != len(self.edges):
            raise ValueError(f"histogram has no bin measures (measures = {self.measures!r})")
        out = np.ones(())
        for m in self.measures:
            out = np.multiply.outer(out, np.asarray(m, dtype=float))
        return out

    def centers(self, axis: int | str = 0) -> np.ndarray:
        """Bin centres along an axis (given by index or name)."""
        i = self.axes.index(axis) if isinstance(axis, str) else axis
        e = np.asarray(self.edges[i], dtype=float)
        return 0.5 * (e[1:] + e[:-1])


#: The totals every run reports; each has a ``*_stderr`` twin on :class:`Result`.
TOTALS = ("specular_reflectance", "diffuse_reflectance", "transmittance", "unscattered_transmittance", "absorbed")


@dataclasses.dataclass
class Result:
    """What a Monte Carlo run produced. Fractions are of the incident power.

    ``absorbed_per_layer`` (and its stderr) has one entry per layer; ``histograms`` maps a
    tally name (``"rd_r"``, ``"a_z"``, ``"brdf"`` …) to its :class:`Histogram` and each is also
    reachable as an attribute (``res.rd_r``). ``config`` is the full configuration as plain
    data (stack, source, tallies) so a result file describes itself; ``partial`` is True when
    the run was interrupted and holds fewer photons than asked for (always photons 0 … N−1).

    Absorption: ``absorbed_per_layer`` and the A(z), A(r, z) histograms hold the physical
    deposits (never negative; exactly 0 in a layer with μa = 0). ``absorbed`` is all the weight
    that did not leave the stack, 1 − specular − diffuse − transmitted exactly: the physical
    deposits plus ``roulette``, the zero-mean control term of Russian roulette (see
    docs/architecture.md), so ``absorbed == sum(absorbed_per_layer) + roulette`` to rounding and
    the energy balance is exact. ``absorbed`` is never negative either.

    ``state`` is the exact raw state of the run (:class:`subsurf.state.TallyState`): pass the
    result as ``subsurf.simulate(..., resume=result)`` to continue an interrupted run to the
    same bits as an uninterrupted one. It is ``None`` for merged or hand-built results.
    """

    specular_reflectance: float
    specular_reflectance_stderr: float
    diffuse_reflectance: float
    diffuse_reflectance_stderr: float
    transmittance: float
    transmittance_stderr: float
    unscattered_transmittance: float
    unscattered_transmittance_stderr: float
    absorbed: float
    absorbed_stderr: float
    absorbed_per_layer: np.ndarray
    absorbed_per_layer_stderr: np.ndarray
    photons: int
    seed: int
    elapsed_s: float
    events: int = 0
    photons_requested: int = 0
    partial: bool = False
    histograms: dict = dataclasses.field(default_factory=dict)
    config: dict = dataclasses.field(default_factory=dict)
    version: str = ""
    roulette: float = 0.0
    roulette_stderr: float = 0.0
    state: Any = None

    def __getattr__(self, name: str) -> Any:
        hist = self.__dict__.get("histograms", {})
        if name in hist:
            return hist[name]
        raise AttributeError(f"{type(self).__name__} has no attribute or histogram {name!r}")

    @property
    def energy_balance(self) -> float:
        """specular + diffuse reflectance + absorbed + transmitted (1 to rounding)."""
        return self.specular_reflectance + self.diffuse_reflectance + self.absorbed + self.transmittance

    @property
    def events_per_s(self) -> float:
        return self.events / self.elapsed_s if self.elapsed_s > 0 else math.nan

    def summary(self) -> str:
        """A small table of the totals with standard errors."""
        rows = [(name.replace("_", " "), getattr(self, name), getattr(self, name + "_stderr")) for name in TOTALS]
        w = max(len(r[0]) for r in rows)
        lines = [f"{'quantity':<{w}}  {'value':>10}  {'stderr':>10}"]
        lines += [f"{n:<{w}}  {v:>10.6f}  {s:>10.2e}" for n, v, s in rows]
        for i, (a, s) in enumerate(zip(self.absorbed_per_layer, self.absorbed_per_layer_stderr)):
            lines.append(f"{'  absorbed, layer ' + str(i):<{w}}  {a:>10.6f}  {s:>10.2e}")
        state = " (PARTIAL: interrupted)" if self.partial else ""
        lines.append(
            f"{self.photons} photons, seed {self.seed}, {self.elapsed_s:.2f} s, "
            f"{self.events_per_s:.3g} scattering events/s{state}"
        )
        return "\n".join(lines)
