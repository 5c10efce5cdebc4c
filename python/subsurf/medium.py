"""Layered media: :class:`Layer`, :class:`Stack` and :func:`mix`.

Coefficients are in mm⁻¹, thicknesses in mm. Validation and the derived properties (σt, albedo,
σs', transport mean free path, optical thickness, interface depths) are the Rust core's, so the
rules, formulas and messages are the same everywhere: invalid values raise
:class:`subsurf.ParameterError` (a ``ValueError``) naming the field and the allowed range.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from typing import NamedTuple

from . import _core


def _num(name: str, value) -> float:
    try:
        return float(value)
    except (TypeError, ValueError):
        raise _core.ParameterError(f"{name} = {value!r} is not a number") from None


class Layer:
    """A homogeneous layer.

    Parameters
    ----------
    n : refractive index (≥ 1).
    mua : absorption coefficient σa in mm⁻¹ (≥ 0).
    mus : scattering coefficient σs in mm⁻¹ (≥ 0).
    g : mean cosine of the Henyey–Greenstein phase function (|g| < 1).
    thickness : mm (> 0); ``math.inf`` for a semi-infinite last layer.
    phase : optional mixture of HG lobes ``[(weight, g), …]`` (weights normalised); when given,
        ``g`` is ignored and the layer's ``g`` is the mixture's mean cosine.
    """

    __slots__ = ("n", "mua", "mus", "thickness", "lobes")

    def __init__(self, n, mua, mus, g=0.0, thickness=math.inf, *, phase: Sequence[tuple[float, float]] | None = None):
        self.n = _num("n", n)
        self.mua = _num("mua", mua)
        self.mus = _num("mus", mus)
        self.thickness = _num("thickness", thickness)
        if phase is None:
            lobes = [(1.0, _num("g", g))]
        else:
            lobes = [(_num(f"phase[{i}].weight", w), _num(f"phase[{i}].g", gg)) for i, (w, gg) in enumerate(phase)]
            total = sum(w for w, _ in lobes)
            if total > 0:
                lobes = [(w / total, gg) for w, gg in lobes]
        _core.validate_layer(self.n, self.mua, self.mus, lobes, self.thickness)
        self.lobes = tuple(lobes)

    def _derived(self, name: str) -> float:
        return _core.layer_properties(self._to_core())[name]

    @property
    def g(self) -> float:
        """Mean cosine of the phase function."""
        return self._derived("g")

    @property
    def sigma_t(self) -> float:
        """Extinction coefficient σt = σa + σs, mm⁻¹."""
        return self._derived("sigma_t")

    @property
    def albedo(self) -> float:
        """Single-scattering albedo σs/σt (0 for a non-interacting layer)."""
        return self._derived("albedo")

    @property
    def mus_prime(self) -> float:
        """Reduced scattering coefficient σs' = σs(1 − g), mm⁻¹."""
        return self._derived("mus_prime")

    reduced_scattering = mus_prime

    @property
    def transport_mfp(self) -> float:
        """Transport mean free path 1/(σa + σs'), mm (infinite for a non-interacting layer)."""
        return self._derived("transport_mfp")

    @property
    def optical_thickness(self) -> float:
        """Optical thickness τ = σt·d (0 for a non-interacting layer)."""
        return self._derived("optical_thickness")

    def _to_core(self):
        return (self.n, self.mua, self.mus, list(self.lobes), self.thickness)

    def __eq__(self, other):
        return isinstance(other, Layer) and self._to_core() == other._to_core()

    def __repr__(self):
        if len(self.lobes) == 1:
            ph = f"g={self.lobes[0][1]!r}"
        else:
            ph = f"phase={list(self.lobes)!r}"
        return f"Layer(n={self.n!r}, mua={self.mua!r}, mus={self.mus!r}, {ph}, thickness={self.thickness!r})"

    def _repr_html_(self):
        from .display import layer_html

        return layer_html(self)


class Stack:
    """Layers from the top (light arrives from above, at z = 0) down, between two ambient media.

    Parameters
    ----------
    layers : a non-empty sequence of :class:`Layer`; only the last may be semi-infinite.
    n_above, n_below : refractive indices of the ambient media (≥ 1).
    """

    __slots__ = ("layers", "n_above", "n_below")

    def __init__(self, layers: Iterable[Layer] | Layer, n_above=1.0, n_below=1.0):
        if isinstance(layers, Layer):
            layers = [layers]
        layers = list(layers)
        for i, l in enumerate(layers):
            if not isinstance(l, Layer):
                raise _core.ParameterError(f"layers[{i}] = {l!r} is not a subsurf.Layer")
        self.layers = tuple(layers)
        self.n_above = _num("n_above", n_above)
        self.n_below = _num("n_below", n_below)
        _core.validate_stack([l._to_core() for l in self.layers], self.n_above, self.n_below)

    @property
    def boundaries(self) -> list[float]:
        """Depths of the interfaces in mm: [0, d0, d0 + d1, …]."""
        return _core.stack_boundaries(*self._to_core())

    @property
    def thickness(self) -> float:
        return self.boundaries[-1]

    def _to_core(self):
        return ([l._to_core() for l in self.layers], self.n_above, self.n_below)

    def __len__(self):
        return len(self.layers)

    def __iter__(self):
        return iter(self.layers)

    def __getitem__(self, i):
        return self.layers[i]

    def __eq__(self, other):
        return isinstance(other, Stack) and self._to_core() == other._to_core()

    def __repr__(self):
        inner = ",\n  ".join(repr(l) for l in self.layers)
        return f"Stack([\n  {inner}\n], n_above={self.n_above!r}, n_below={self.n_below!r})"

    def _repr_html_(self):
        from .display import stack_html

        return stack_html(self)


class Component(NamedTuple):
    """One component of a mixture: volume fraction, and σa, σs (mm⁻¹) and g of the pure component."""

    fraction: float
    mua: float
    mus: float
    g: float = 0.0


def mix(components: Sequence[Component | tuple], n: float = 1.0, thickness: float = math.inf) -> Layer:
    """Build a layer from components by volume fraction (seed eq. 1.5; Hanrahan & Krueger 1993).

    σa = Σ f_l σa,l, σs = Σ f_l σs,l, and the phase function is the mixture of the components'
    HG lobes weighted by f_l σs,l (so the layer's ``g`` is their scattering-weighted mean).
    Fractions must lie in [0, 1] and sum to at most 1.
    """
    comps = [tuple(_num(f"components[{i}]", v) for v in Component(*c)) for i, c in enumerate(components)]
    n_, mua, mus, lobes, d = _core.mix_components(_num("n", n), _num("thickness", thickness), comps)
    return Layer(n_, mua, mus, thickness=d, phase=lobes)
