"""Monte Carlo light transport in layered media: :func:`simulate` and the light sources.

The engine is MCML's algorithm (Wang, Jacques & Zheng 1995, Comput. Methods Programs Biomed.
47:131; after Prahl et al. 1989) in Rust — see ``crates/subsurf-core/src/mc/kernel.rs`` for the
physics and its references. Units: mm, mm⁻¹, radians. Results are fractions of the incident
power, each with a standard error from per-photon second moments, and are bit-identical for a
given seed whatever the number of threads, interruptions or photon ranges (per-photon
xoshiro128++ streams seeded by Philox4x32-10 keyed by seed and photon index; chunk sums merged
exactly, see :mod:`subsurf.state`).
"""

from __future__ import annotations

import operator
import time
import warnings

import numpy as np

from . import _core
from .medium import Layer, Stack
from .result import TOTALS, Histogram, Result
from .state import TallyState
from .tallies import Tallies


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


def _integer(name: str, value) -> int:
    """An integer argument (its range is the core's to check)."""
    if isinstance(value, bool):
        raise _core.ParameterError(f"{name} = {value!r} is not an integer")
    try:
        return operator.index(value)
    except TypeError:
        raise _core.ParameterError(f"{name} = {value!r} is not an integer") from None


#: Above this many expected scattering events (about an hour of one core), :func:`simulate`
#: warns before it starts.
WARN_EVENTS = 1e11


def _prepare(stack, seed, threads, source, tallies, progress):
    """Checked arguments shared by :func:`simulate` and :func:`simulate_range`."""
    if isinstance(stack, Layer):
        stack = Stack([stack])
    if not isinstance(stack, Stack):
        raise _core.ParameterError(f"stack = {stack!r} is not a subsurf.Stack or subsurf.Layer")
    seed = _integer("seed", seed)
    if threads is not None:
        threads = _integer("threads", threads)
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
    return stack, seed, threads, source, tallies


def _core_tallies(tallies):
    return None if tallies is None else {**tallies.to_dict(), "brdf": tallies.brdf}


def _warn_cost(stack, photons: int) -> None:
    """Refuse endless histories (ParameterError from the core) and warn about very long runs."""
    per_photon = _core.mc_expected_events(*stack._to_core())
    total = per_photon * photons
    if total > WARN_EVENTS:
        warnings.warn(
            f"subsurf.simulate: about {total:.2g} scattering events expected ({per_photon:.3g} per photon), "
            f"roughly {total / 3e7 / 3600:.2g} core-hours; Ctrl-C returns the photons traced so far",
            RuntimeWarning,
            stacklevel=3,
        )


def _run(stack, photons, seed, threads, source, tallies, progress, state=None, start=None) -> dict:
    layers, n_above, n_below = stack._to_core()
    return _core.mc_run(
        layers,
        n_above,
        n_below,
        photons,
        seed,
        threads,
        source._to_core(),
        progress,
        _core_tallies(tallies),
        None if state is None else state._core(),
        start,
    )


def simulate(
    stack, photons=10**6, seed=0, threads=None, source=None, tallies=None, progress=None, resume=None, client=None
) -> Result:
    """Trace photon packets through a layered medium (Monte Carlo, MCML's algorithm).

    Parameters
    ----------
    stack : :class:`subsurf.Stack` (or a single :class:`subsurf.Layer`).
    photons : number of packets, an integer in [1, 2⁶⁴).
    seed : an integer in [0, 2⁶⁴). The result is a pure function of (stack, source, tallies,
        seed, photons): bit-identical for any ``threads``, any interruption and resumption, and
        any split into photon ranges (:func:`simulate_range`).
    threads : worker threads (1 … 1024); ``None`` uses one per core (with a ``client``: threads
        per task, default 1, as a Dask worker runs one task per worker thread).
    source : :class:`PencilBeam` (default, normal incidence) or :class:`DiffuseIllumination`.
    tallies : :class:`subsurf.Tallies` (or its ``to_dict()``) selecting the histograms to score
        (R(r), A(z), BRDF/BTDF, per-order splits …, see docs/architecture.md); ``None`` scores
        only the totals (fastest).
    progress : optional callable ``progress(done, total)`` (photons of this call), called about
        every 50 ms while the run lasts and once at the end.
    resume : a partial :class:`~subsurf.result.Result` (or its ``state``, a
        :class:`~subsurf.state.TallyState` holding photons [0, N)) of the same stack, source,
        tallies and seed: the run continues from photon N to ``photons``, giving the bits of an
        uninterrupted run. A state that already holds ``photons`` photons (e.g. states of photon
        ranges merged with :meth:`TallyState.merge`) is just finished into a result.
    client : a ``dask.distributed.Client`` (``pip install 'subsurf[cluster]'``): the photons
        are traced on its workers as tasks of consecutive photon ranges sized to run for seconds,
        whose exact states are merged in range order — the result has the bits of a local run
        with the same seed, whatever the number of workers, and survives lost workers (Dask
        re-runs their tasks). ``progress(done, total)`` is called as tasks finish; Ctrl-C (or
        ``progress`` raising KeyboardInterrupt) cancels the remaining tasks and returns the
        completed prefix, marked partial and resumable (``resume=``, with or without a client).
        See :mod:`subsurf.cluster` and docs/cluster.md.

    Interruption (Ctrl-C, or ``progress`` raising ``KeyboardInterrupt`` — also on its final
    call, or during a run shorter than 50 ms): the run stops and the photons completed so far are
    returned as a result with ``partial=True`` (they are always photons 0 … N−1 with N a multiple
    of 4096, resumable with ``resume=``) and a ``RuntimeWarning``; if the run was complete, the
    complete result is returned. If *no* photon was completed, ``KeyboardInterrupt`` is raised
    again (so the CLI and :func:`subsurf.mcml.run_mci` write nothing rather than an all-NaN
    result). Any other exception from ``progress`` stops the run and propagates.

    Refused up front with :class:`subsurf.ParameterError`: stacks whose photon histories would be
    endless (a non-absorbing semi-infinite scattering layer) or longer than ~10⁹ events each, and
    tallies that would not fit in memory; a ``RuntimeWarning`` announces runs expected to take
    more than about an hour of one core.

    Returns
    -------
    :class:`subsurf.result.Result` with ``specular_reflectance``, ``diffuse_reflectance``,
    ``transmittance`` (total, including ``unscattered_transmittance``), ``absorbed`` (=
    Σ ``absorbed_per_layer`` + ``roulette``), each with a ``*_stderr`` twin; ``events`` =
    scattering events; ``state`` = the exact raw state.
    """
    stack, seed, threads, source, tallies = _prepare(stack, seed, threads, source, tallies, progress)
    photons = _integer("photons", photons)
    _core.mc_validate_run(photons, seed, threads)
    prior, elapsed0 = None, 0.0
    if resume is not None:
        prior = check_resume(stack, resume, seed=seed, source=source, tallies=tallies)
        elapsed0 = float(resume.elapsed_s) if isinstance(resume, Result) else 0.0
    remaining = photons - (prior.stop if prior is not None else 0)
    _warn_cost(stack, max(remaining, 0))
    if client is not None:
        from .cluster import run_ranges

        t0 = time.perf_counter()
        state, stopped = run_ranges(client, stack, photons, seed, threads, source, tallies, progress, prior)
        elapsed = time.perf_counter() - t0
    else:
        d = _run(stack, photons, seed, threads, source, tallies, progress, state=prior)
        state, elapsed = TallyState(d["state"]), d["elapsed_s"]
        stopped = "interrupted" if d["interrupted"] else None
    if stopped and (state is None or state.photons == 0):
        if stopped != "interrupted":  # the cluster went away: an error, not an interruption
            from .cluster import ClusterError

            raise ClusterError(f"subsurf.simulate: {stopped} before any photon range was completed; nothing traced")
        raise KeyboardInterrupt("subsurf.simulate was interrupted before any photon was completed")
    partial = state.photons < photons
    if partial:
        why = "subsurf.simulate interrupted" if stopped in (None, "interrupted") else f"subsurf.simulate: {stopped}"
        warnings.warn(
            f"{why}: returning the {state.photons} of {photons} photons traced so far (resume= finishes the run)",
            RuntimeWarning,
            stacklevel=2,
        )
    return _result(stack, seed, source, tallies, photons, state, elapsed0 + elapsed)


def check_resume(stack, resume, seed=0, source=None, tallies=None) -> TallyState:
    """The state of ``resume`` (a partial :class:`~subsurf.result.Result` or a
    :class:`~subsurf.state.TallyState`) after checking, without tracing anything, that it can
    continue the run of ``stack`` with ``seed``, ``source`` and ``tallies`` (as
    :func:`simulate` does before it resumes); raises :class:`subsurf.ParameterError` otherwise."""
    if isinstance(resume, Result):
        if resume.state is None:
            raise _core.ParameterError("resume: the result holds no state (merged or loaded from an old file)")
        prior = resume.state
    elif isinstance(resume, TallyState):
        prior = resume
    else:
        raise _core.ParameterError(f"resume = {resume!r} is not a subsurf.Result or subsurf.TallyState")
    if prior.start != 0:
        raise _core.ParameterError(
            f"resume: the state holds photons [{prior.start}, {prior.stop}), not a run from photon 0; "
            "merge it after the states of the photons before it"
        )
    stack, seed, _, source, tallies = _prepare(stack, seed, None, source, tallies, None)
    layers, n_above, n_below = stack._to_core()
    _core.mc_check_state(layers, n_above, n_below, seed, source._to_core(), prior._core(), _core_tallies(tallies))
    return prior


def simulate_range(stack, start, stop, seed=0, threads=None, source=None, tallies=None, progress=None) -> TallyState:
    """Trace photons ``[start, stop)`` of the run (stack, source, tallies, seed) — the same
    per-photon random streams as :func:`simulate` uses — and return their exact raw state.

    ``start`` must be a multiple of :data:`subsurf.state.CHUNK_PHOTONS` (4096); ``stop`` may be
    anything above it (a state ending inside a chunk cannot be continued: use it as the last
    range). States of consecutive ranges merge with :meth:`TallyState.merge` to the bits of one
    run; ``simulate(stack, photons=stop, ..., resume=merged)`` finishes them into a result. This is
    what a cluster worker runs. If interrupted, the state of the completed prefix of the range is
    returned with a ``RuntimeWarning`` (``KeyboardInterrupt`` if none was completed).
    """
    stack, seed, threads, source, tallies = _prepare(stack, seed, threads, source, tallies, progress)
    start, stop = _integer("start", start), _integer("stop", stop)
    _core.mc_validate_run(stop, seed, threads)
    _warn_cost(stack, max(stop - start, 0))
    d = _run(stack, stop, seed, threads, source, tallies, progress, start=start)
    state = TallyState(d["state"])
    if d["interrupted"] and state.photons == 0 and stop > start:
        raise KeyboardInterrupt("subsurf.simulate_range was interrupted before any photon was completed")
    if state.stop < stop:
        warnings.warn(
            f"subsurf.simulate_range interrupted: returning photons [{state.start}, {state.stop}) of [{start}, {stop})",
            RuntimeWarning,
            stacklevel=2,
        )
    return state


def _result(stack, seed, source, tallies, photons, state, elapsed_s) -> Result:
    layers, n_above, n_below = stack._to_core()
    d = _core.mc_finish(layers, n_above, n_below, seed, source._to_core(), state._core(), _core_tallies(tallies))
    return Result(
        **{name: d[name] for name in TOTALS},
        **{name + "_stderr": d[name + "_stderr"] for name in TOTALS},
        absorbed_per_layer=np.asarray(d["absorbed_per_layer"], dtype=float),
        absorbed_per_layer_stderr=np.asarray(d["absorbed_per_layer_stderr"], dtype=float),
        photons=d["photons"],
        seed=seed,
        elapsed_s=elapsed_s,
        events=d["events"],
        photons_requested=photons,
        partial=state.photons < photons,
        histograms={h["name"]: _histogram(h) for h in d["histograms"]},
        config={
            "stack": _stack_dict(stack),
            "source": source.to_dict(),
            "tallies": None if tallies is None else tallies.to_dict(),
            "photons": photons,
            "seed": seed,
        },
        version=_core.__version__,
        roulette=d["roulette"],
        roulette_stderr=d["roulette_stderr"],
        state=state,
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
        measures=tuple(np.asarray(m, dtype=float) for m in h["measures"]),
        overflow=tuple(bool(o) for o in h["overflow"]),
    )
