"""Monte Carlo light transport in layered media: :func:`simulate` and the light sources.

The engine is MCML's algorithm (Wang, Jacques & Zheng 1995, Comput. Methods Programs Biomed.
47:131; after Prahl et al. 1989) in Rust — see ``crates/subsurf-core/src/mc/kernel.rs`` for the
physics and its references. Units: mm, mm⁻¹, radians. Results are fractions of the incident
power, each with a standard error from per-photon second moments, and are bit-identical for a
given seed whatever the number of threads (per-photon xoshiro128++ streams seeded by
Philox4x32-10 keyed by seed and photon index).
"""

from __future__ import annotations

import operator
import warnings

import numpy as np

from . import _core
from .medium import Layer, Stack
from .result import Histogram, Result
from .tallies import Tallies

_U64 = 2**64


def _num(name: str, value) -> float:
    try:
        return float(value)
    except (TypeError, ValueError):
        raise _core.ParameterError(f"{name} = {value!r} is not a number") from None


class PencilBeam:
    """A collimated pencil beam hitting the origin from above.

    Parameters
    ----------
    theta : polar angle of incidence in radians from the surface normal, 0 ≤ θ < π/2.
    phi : azimuth of the incidence direction in radians; the beam propagates along
        (sin θ cos φ, sin θ sin φ, cos θ) with z pointing into the stack.

    The specular part R(θ) (Fresnel, n_above → top layer) is scored as specular reflectance;
    the rest refracts in by Snell's law (MCML §3.2).
    """

    __slots__ = ("theta", "phi")

    def __init__(self, theta=0.0, phi=0.0):
        self.theta = _num("source.theta", theta)
        self.phi = _num("source.phi", phi)
        _core.mc_validate_source("pencil", self.theta, self.phi)

    def _to_core(self):
        return ("pencil", self.theta, self.phi)

    def to_dict(self) -> dict:
        return {"type": "pencil", "theta": self.theta, "phi": self.phi}

    def __eq__(self, other):
        return isinstance(other, PencilBeam) and self._to_core() == other._to_core()

    def __repr__(self):
        return f"PencilBeam(theta={self.theta!r}, phi={self.phi!r})"


class DiffuseIllumination:
    """Diffuse (Lambertian, cosine-weighted) illumination from the upper hemisphere, arriving at
    the origin. Each photon's specular part R(θ) is scored as specular reflectance, so the
    specular reflectance is the hemispherical (cosine-weighted) average of the Fresnel
    reflectance."""

    __slots__ = ()

    def _to_core(self):
        return ("diffuse", 0.0, 0.0)

    def to_dict(self) -> dict:
        return {"type": "diffuse"}

    def __eq__(self, other):
        return isinstance(other, DiffuseIllumination)

    def __repr__(self):
        return "DiffuseIllumination()"


def _layer_dict(l: Layer) -> dict:
    d = {"n": l.n, "mua": l.mua, "mus": l.mus, "thickness": l.thickness}
    if len(l.lobes) == 1:
        d["g"] = l.lobes[0][1]
    else:
        d["phase"] = [list(lobe) for lobe in l.lobes]
    return d


def _stack_dict(s: Stack) -> dict:
    return {"layers": [_layer_dict(l) for l in s.layers], "n_above": s.n_above, "n_below": s.n_below}


def _int(name: str, value, lo: int, hi: int | None, allowed: str) -> int:
    if isinstance(value, bool):
        raise _core.ParameterError(f"{name} = {value!r} is out of range: must be {allowed}")
    try:
        v = operator.index(value)
    except TypeError:
        raise _core.ParameterError(f"{name} = {value!r} is out of range: must be {allowed}") from None
    if v < lo or (hi is not None and v >= hi):
        raise _core.ParameterError(f"{name} = {v} is out of range: must be {allowed}")
    return v


def simulate(stack, photons=10**6, seed=0, threads=None, source=None, tallies=None, progress=None) -> Result:
    """Trace photon packets through a layered medium (Monte Carlo, MCML's algorithm).

    Parameters
    ----------
    stack : :class:`subsurf.Stack` (or a single :class:`subsurf.Layer`).
    photons : number of packets, an integer ≥ 1.
    seed : an integer in [0, 2⁶⁴); the same seed gives bit-identical results for any ``threads``.
    threads : worker threads (≥ 1); ``None`` uses all cores.
    source : :class:`PencilBeam` (default, normal incidence) or :class:`DiffuseIllumination`.
    tallies : :class:`subsurf.Tallies` (or its ``to_dict()``) selecting the histograms to score
        (R(r), A(z), BRDF/BTDF, per-order splits …, see docs/architecture.md); ``None`` scores
        only the totals (fastest).
    progress : optional callable ``progress(done, total)``, called about every 50 ms while the
        run lasts and once at the end. If it raises ``KeyboardInterrupt`` (as Ctrl-C does) the
        run stops and the photons traced so far are returned with ``partial=True`` (and a
        ``RuntimeWarning``); any other exception stops the run and propagates.

    Returns
    -------
    :class:`subsurf.result.Result` with ``specular_reflectance``, ``diffuse_reflectance``,
    ``transmittance`` (total, including ``unscattered_transmittance``), ``absorbed`` and
    ``absorbed_per_layer``, each with a ``*_stderr`` twin; ``events`` = scattering events.
    """
    if isinstance(stack, Layer):
        stack = Stack([stack])
    if not isinstance(stack, Stack):
        raise _core.ParameterError(f"stack = {stack!r} is not a subsurf.Stack or subsurf.Layer")
    photons = _int("photons", photons, 1, None, "an integer >= 1")
    seed = _int("seed", seed, 0, _U64, "an integer in [0, 2**64)")
    if threads is not None:
        threads = _int("threads", threads, 1, None, "an integer >= 1 (or None for all cores)")
    if source is None:
        source = PencilBeam()
    if not isinstance(source, (PencilBeam, DiffuseIllumination)):
        raise _core.ParameterError(f"source = {source!r} is not a subsurf.PencilBeam or subsurf.DiffuseIllumination")
    if isinstance(tallies, dict):
        tallies = Tallies.from_dict(tallies)
    if tallies is not None and not isinstance(tallies, Tallies):
        raise _core.ParameterError(f"tallies = {tallies!r} is not a subsurf.Tallies (or None)")
    if progress is not None and not callable(progress):
        raise _core.ParameterError(f"progress = {progress!r} is not callable")

    layers, n_above, n_below = stack._to_core()
    d = _core.mc_simulate(
        layers,
        n_above,
        n_below,
        photons,
        seed,
        threads,
        source._to_core(),
        progress,
        None if tallies is None else {**tallies.to_dict(), "brdf": tallies.brdf},
    )
    if d["partial"]:
        warnings.warn(
            f"subsurf.simulate interrupted: returning the {d['photons']} of {photons} photons traced so far",
            RuntimeWarning,
            stacklevel=2,
        )
    from ._core import __version__

    return Result(
        specular_reflectance=d["specular_reflectance"],
        specular_reflectance_stderr=d["specular_reflectance_stderr"],
        diffuse_reflectance=d["diffuse_reflectance"],
        diffuse_reflectance_stderr=d["diffuse_reflectance_stderr"],
        transmittance=d["transmittance"],
        transmittance_stderr=d["transmittance_stderr"],
        unscattered_transmittance=d["unscattered_transmittance"],
        unscattered_transmittance_stderr=d["unscattered_transmittance_stderr"],
        absorbed=d["absorbed"],
        absorbed_stderr=d["absorbed_stderr"],
        absorbed_per_layer=np.asarray(d["absorbed_per_layer"], dtype=float),
        absorbed_per_layer_stderr=np.asarray(d["absorbed_per_layer_stderr"], dtype=float),
        photons=d["photons"],
        seed=seed,
        elapsed_s=d["elapsed_s"],
        events=d["events"],
        photons_requested=photons,
        partial=d["partial"],
        histograms={h["name"]: _histogram(h) for h in d["histograms"]},
        config={
            "stack": _stack_dict(stack),
            "source": source.to_dict(),
            "tallies": None if tallies is None else tallies.to_dict(),
            "photons": photons,
            "seed": seed,
        },
        version=__version__,
    )


def _histogram(h: dict) -> Histogram:
    """A core histogram dict (flat C-order values) as a :class:`subsurf.result.Histogram`."""
    shape = tuple(h["shape"])
    return Histogram(
        values=np.asarray(h["values"], dtype=float).reshape(shape),
        stderr=np.asarray(h["stderr"], dtype=float).reshape(shape),
        edges=tuple(np.asarray(e, dtype=float) for e in h["edges"]),
        axes=tuple(h["axes"]),
        edge_units=tuple(h["edge_units"]),
        units=h["units"],
        description=h["description"],
    )
