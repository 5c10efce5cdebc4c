"""Result objects shared by the Monte Carlo engine, the results files and the plots.

A :class:`Histogram` is one tally with its standard error, bin edges and units; a
:class:`Result` holds the totals of a run, its histograms by name and its provenance.
Both print as readable summaries (``repr``, ``Result.summary()``) and as HTML tables in notebooks.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from . import display


@dataclasses.dataclass(repr=False)
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
        e = np.asarray(self.edges[self._axis(axis)], dtype=float)
        return 0.5 * (e[1:] + e[:-1])

    def _axis(self, axis: int | str) -> int:
        if isinstance(axis, str):
            if axis not in self.axes:
                raise ValueError(f"histogram has no axis {axis!r}; its axes are {tuple(self.axes)}")
            return tuple(self.axes).index(axis)
        if not -len(self.axes) <= axis < len(self.axes):
            raise ValueError(f"axis {axis} is out of range: the histogram has {len(self.axes)} axes")
        return axis % len(self.axes)

    def take(self, axis: int | str, index: int) -> Histogram:
        """The histogram with ``axis`` removed at bin ``index`` (e.g. one scattering order of
        ``brdf_order``: ``h.take("order", 1)``)."""
        i = self._axis(axis)
        n = np.shape(self.values)[i]
        if not -n <= index < n:
            raise ValueError(f"bin {index} is out of range: axis {self.axes[i]!r} has {n} bins")
        keep = [k for k in range(len(self.axes)) if k != i]
        lo, hi = self.edges[i][index % n], self.edges[i][index % n + 1]
        return Histogram(
            values=np.take(self.values, index, axis=i),
            stderr=np.take(self.stderr, index, axis=i),
            edges=tuple(self.edges[k] for k in keep),
            axes=tuple(self.axes[k] for k in keep),
            edge_units=tuple(self.edge_units[k] for k in keep),
            units=self.units,
            description=f"{self.description} ({self.axes[i]} in [{display.num(lo, 4)}, {display.num(hi, 4)}])",
            measures=tuple(self.measures[k] for k in keep) if self.measures else (),
            overflow=tuple(self.overflow[k] for k in keep) if self.overflow else (),
        )

    def plot(self, ax=None, **kwargs):
        """Draw this tally on one set of axes and return them (see :func:`subsurf.plot.histogram`):
        1-D as a line with a ±1 standard-error band, 2-D as an image with a colour bar, axes
        labelled with their units."""
        from . import plot

        return plot.histogram(self, ax=ax, **kwargs)

    def _axis_texts(self) -> list[str]:
        return [
            display.axis_text(a, len(e) - 1, e[0], e[-1], u)
            for a, e, u in zip(self.axes, (np.asarray(x, float) for x in self.edges), self.edge_units)
        ]

    def __repr__(self) -> str:
        v = np.asarray(self.values, float)
        finite = v[np.isfinite(v)]
        parts = [" × ".join(self._axis_texts()), f"units {self.units}"]
        if finite.size:
            parts.append(f"values in [{display.num(finite.min(), 4)}, {display.num(finite.max(), 4)}]")
        parts.append(repr(self.description))
        return f"Histogram({'; '.join(parts)})"

    def _repr_html_(self) -> str:
        rows = [
            (a, len(e) - 1, display.num(e[0], 4), display.num(e[-1], 4), u)
            for a, e, u in zip(self.axes, (np.asarray(x, float) for x in self.edges), self.edge_units)
        ]
        v, s = np.asarray(self.values, float), np.asarray(self.stderr, float)
        ok = np.isfinite(v)
        stats = (
            f"values in [{display.num(v[ok].min(), 4)}, {display.num(v[ok].max(), 4)}] {self.units}; "
            f"largest standard error {display.num(np.nanmax(s) if s.size and np.isfinite(s).any() else 0, 3)}"
            if ok.any()
            else "no finite values"
        )
        return (
            display.html_table(
                ("axis", "bins", "from", "to", "unit"), rows, caption=f"Histogram: {self.description} ({self.units})"
            )
            + f"<p>{display.html.escape(stats)}</p>"
        )


#: The totals every run reports; each has a ``*_stderr`` twin on :class:`Result`.
TOTALS = ("specular_reflectance", "diffuse_reflectance", "transmittance", "unscattered_transmittance", "absorbed")


@dataclasses.dataclass(repr=False)
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

    def _rows(self) -> list[tuple[str, float, float]]:
        rows = [(n.replace("_", " "), getattr(self, n), getattr(self, n + "_stderr")) for n in TOTALS]
        rows += [
            (f"  absorbed in layer {i}", a, s)
            for i, (a, s) in enumerate(zip(self.absorbed_per_layer, self.absorbed_per_layer_stderr))
        ]
        return rows

    def _provenance(self) -> str:
        rate = self.photons / self.elapsed_s if self.elapsed_s > 0 else math.nan
        line = (
            f"{self.photons:,} photons, seed {self.seed}, {self.elapsed_s:.2f} s, "
            f"{self.events_per_s:.3g} scattering events/s, {rate:.3g} photons/s"
        )
        if self.partial:
            line += f"\nPARTIAL: {self.photons:,} of {self.photons_requested:,} photons (interrupted)"
        return line

    def summary(self) -> str:
        """The table of totals ± standard errors, the absorption per layer, the energy balance and
        the run's photons, seed, time and rate (what ``subsurf simulate`` prints)."""
        rows = self._rows()
        w = max(len(r[0]) for r in rows + [("energy balance", 0, 0)])
        out = [f"{'quantity':<{w}}  {'value':>10}   stderr"]
        out += [f"{n:<{w}}  {v:>10.6f} ± {_stderr_text(s)}" for n, v, s in rows]
        out.append(f"{'energy balance':<{w}}  {self.energy_balance:>10.6f}")
        out.append(self._provenance())
        return "\n".join(out)

    def _histogram_lines(self) -> list[str]:
        return [f"{k}: {' × '.join(h._axis_texts())} ({h.units})" for k, h in self.histograms.items()]

    def __repr__(self) -> str:
        lines = [f"Result({self._provenance().splitlines()[0]}{', PARTIAL' if self.partial else ''})"]
        lines += ["  " + line for line in self.summary().splitlines()[1:-1]]
        if self.histograms:
            lines.append("  histograms:")
            lines += ["    " + line for line in self._histogram_lines()]
        return "\n".join(lines)

    def _repr_html_(self) -> str:
        rows = [(n, display.num(v), _stderr_text(s), "1") for n, v, s in self._rows()]
        rows.append(("energy balance", display.num(self.energy_balance, 12), "", "1"))
        out = [
            display.html_table(
                ("quantity", "value", "± stderr", "unit"), rows, caption=self._provenance().replace("\n", " — ")
            )
        ]
        if self.histograms:
            hrows = [
                (k, " × ".join(f"{a} ({len(e) - 1})" for a, e in zip(h.axes, h.edges)), h.units, h.description)
                for k, h in self.histograms.items()
            ]
            out.append(display.html_table(("histogram", "axes (bins)", "unit", "what"), hrows))
        return "".join(out)


def _stderr_text(s: float) -> str:
    """A standard error in three significant digits; an exact 0 (a deterministic quantity) as 0."""
    return "0" if s == 0 else f"{s:.2e}"
