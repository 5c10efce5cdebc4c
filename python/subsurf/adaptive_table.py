"""The finite-slab tables of the ``adaptive`` BSSRDF model and their on-disk cache.

:class:`AdaptiveTable` holds, per colour channel, the engine's reflection R(r; d) and
transmission T(r; d) profiles of the material cut into slabs of thickness d (nodes d = ℓ·2^j from
ℓ/8 up to several diffusion lengths, plus the semi-infinite profile; the core's
``subsurf_core::bssrdf::adaptive`` documents the grid, the seeds and the interpolation), and the
curvature data: the exact escape of diffuse light from spheres, spherical cavities and cylinders of radius
ρ = ℓ·2^j relative to the flat half-space (``subsurf_core::bssrdf::curvature``), and the flat
half-space's reflectance under pencil beams at 30, 50, 65 and 80° (the oblique-incidence gain,
``subsurf_core::bssrdf::oblique``), and where a pencil beam's light leaves a sphere around its
entry point (the first azimuthal harmonic, ``subsurf_core::bssrdf::harmonic``), and the flat
half-space's exit-angle histogram under diffuse light (the exit term's angular shape,
``subsurf_core::bssrdf::exit``). The renderer picks
the profiles per shading point by the local thickness and scales them by the local principal curvatures
(``render::adaptive``).

A table is deterministic: the same stacks, photons, seed and engine version give the same bits.
:meth:`AdaptiveTable.cached` keeps each in subsurf's checksummed HDF5 container
(:mod:`subsurf.container`) under a name derived from those inputs (a SHA-256), so a changed
engine version, stack or setting builds a new table; a damaged or foreign file is rebuilt.
The cache directory is ``$SUBSURF_CACHE/adaptive`` (default ``~/.cache/subsurf/adaptive``).
"""

from __future__ import annotations

import hashlib
import json
import os

import numpy as np

from . import _core
from .medium import Stack

FORMAT = "subsurf-adaptive-table"
FORMAT_VERSION = 10  # 2: the curvature data (sphere, cavity and flat escapes per channel); 3: and cylinders;
# 4: and the flat oblique pencil runs of the oblique-incidence gain (``oblique``, ``oblique_stderr``);
# 5: and the sphere's azimuthal harmonic under pencil beams (``harmonic_near``, ``harmonic_far``);
# 6: and the flat exit-angle histogram of the exit term (``exit``, ``exit_stderr``);
# 7: and the flat pencil runs of the exit direction's coupling to the light's (``coupling``, ``coupling_stderr``);
# 8: the same arrays, the sphere's and the cylinder's escapes traced to 0.5 % relative standard error;
# 9: and the flat diffuse run of the exit direction's flow from the entry point (``flow``, ``flow_stderr``)
# 10: T without the photons that crossed unscattered (the renderer adds that light itself)
_ARRAYS = ("edges", "weight", "stderr", "single", "single_stderr")


def cache_dir() -> str:
    """The directory of cached tables: ``$SUBSURF_CACHE/adaptive`` or ``~/.cache/subsurf/adaptive``."""
    base = os.environ.get("SUBSURF_CACHE") or os.path.join(os.path.expanduser("~"), ".cache", "subsurf")
    return os.path.join(base, "adaptive")


def _stacks(stacks):
    out = [s if isinstance(s, Stack) else Stack([s]) for s in stacks]
    if not out:
        raise _core.ParameterError("stacks: give at least one stack (one per channel)")
    return [s._to_core() for s in out]


class AdaptiveTable:
    """Reflection and transmission profiles of finite slabs over thickness, one table per channel
    (see the module docs). Build with :meth:`build` or :meth:`cached`; query with :meth:`totals`
    and :meth:`profile`."""

    def __init__(self, core, key: dict):
        self._t = core
        self.key = dict(key)

    @staticmethod
    def _key(stacks, photons, seed, max_rel_err) -> dict:
        return {
            "stacks": json.loads(json.dumps(stacks)),
            "photons": int(photons),
            "seed": int(seed),
            "max_rel_err": float(max_rel_err),
            "engine_version": _core.__version__,
            "format_version": FORMAT_VERSION,
        }

    @classmethod
    def build(cls, stacks, photons=20000, seed=0, threads=None, max_rel_err=0.2, progress=None) -> AdaptiveTable:
        """Trace every (channel, thickness) node: ``photons`` per node; ``progress(done, total)``
        counts photons; Ctrl-C raises KeyboardInterrupt."""
        st = _stacks(stacks)
        core = _core.AdaptiveTable.build(st, photons, seed, threads, max_rel_err, progress)
        return cls(core, cls._key(st, photons, seed, max_rel_err))

    @staticmethod
    def nodes(stack) -> list:
        """The finite thickness nodes (mm) of a stack's table."""
        return list(_core.bssrdf_adaptive_nodes(_stacks([stack])[0]))

    def totals(self, channel, d):
        """(R, T): total reflectance and transmittance per unit entering power at thickness d (mm)."""
        return self._t.totals(int(channel), float(d))

    def curvature(self) -> list:
        """Per channel: a dict of the curvature nodes ``rho`` (mm), the sphere and cavity escapes
        (``sphere``, ``cavity``, the part through the entry's hemisphere ``*_near``, and their
        ``*_stderr``; ``sphere_bins``: the near part per chord bin), the flat one (``flat``,
        ``flat_stderr``), the flat pencil runs at ``oblique_theta`` degrees (``oblique``,
        ``oblique_stderr``: diffuse reflectance per incident power), the first azimuthal harmonic
        ⟨cos φ⟩ of the sphere's escapes under pencil beams at those angles (``harmonic_near``,
        ``harmonic_far``: per curvature node, per angle; ``subsurf_core::bssrdf::harmonic``), the flat
        half-space's exit-angle histogram under diffuse light (``exit``, ``exit_stderr``: weight per
        incident photon on bins uniform in the exit cosine) and its fitted slope ``exit_beta``
        (``subsurf_core::bssrdf::exit``), the flat half-space's exit weight and its cos Δφ moment (Δφ
        the exit azimuth from the light's) per exit-cosine bin under pencil beams at those angles
        (``coupling``, ``coupling_stderr``: per angle, the weights then the moments) with the exit
        coupling's amplitude ``coupling_a`` (± ``coupling_a_stderr``; pooled over the angles) and its
        fit per angle ``coupling_a_theta``, ``coupling_a_theta_stderr``, ``coupling_chi2``
        (``subsurf_core::bssrdf::coupling``), the flat half-space's exit weight and its cos Δφ moment
        about the direction from the entry point per distance bin (in the transport length) and
        exit-cosine bin under diffuse light (``flow``, ``flow_stderr``: the weights then the moments)
        with the fitted amplitude per distance bin ``flow_b`` (± ``flow_b_stderr``;
        ``subsurf_core::bssrdf::flow``), and the
        kernel scales derived from them (``scale_convex``: the near side's per bin, ``scale_convex_far``,
        ``scale_concave``)."""
        return self._t.curvature()

    def oblique_gain(self, channel, mu) -> float:
        """The oblique-incidence gain g(μ) = R(θi)/R(0) of ``channel`` at μ = cos θi: the engine's
        semi-infinite total per unit entering power relative to normal incidence, by which the
        renderer weights light arriving at θi (``subsurf_core::bssrdf::oblique``)."""
        return self._t.oblique_gain(int(channel), float(mu))

    def exit_factor(self, channel, mu) -> float:
        """The exit term's factor s(μ_o) of ``channel`` at the exit cosine μ_o (outside): the
        renderer's radiance is the exitance × F_t(η, μ_o)/(π c) × s(μ_o), s fitted to the engine's
        exit-angle tally with every hemispherical total unchanged (``subsurf_core::bssrdf::exit``)."""
        return self._t.exit_factor(int(channel), float(mu))

    def curvature_scale(self, channel, h) -> tuple:
        """The scales (near side R per chord bin, far side T) of ``channel``'s profiles at mean
        curvature ``h`` (mm⁻¹; > 0 convex, < 0 concave)."""
        return self._t.curvature_scale(int(channel), float(h))

    def profile(self, channel, d, which="R"):
        """The reflection (``"R"``) or transmission (``"T"``) profile at thickness d (mm) as a
        :class:`subsurf.bssrdf.Profile` (per unit entering power)."""
        from .bssrdf import Profile

        return Profile(self._t.profile(int(channel), float(d), which))

    # ---- files ------------------------------------------------------------------------------

    def save(self, path) -> str:
        """Write the table atomically to ``path`` in the checksummed HDF5 container."""
        from . import atomic, container

        nodes = self._t.nodes()

        def fill(f) -> None:
            f.attrs["key"] = json.dumps(self.key, sort_keys=True)
            for c, ch in enumerate(nodes):
                for j, n in enumerate(ch):
                    g = f.create_group(f"channels/{c:02d}/{j:03d}")
                    g.attrs["d"] = float(n["d"])
                    for side in ("top", "bottom"):
                        s = g.create_group(side)
                        for k in _ARRAYS:
                            s.create_dataset(k, data=np.asarray(n[side][k], dtype=np.float64))
                        s.attrs["total"] = float(n[side]["total"])
                        s.attrs["total_stderr"] = float(n[side]["total_stderr"])
                        s.attrs["photons"] = int(n[side]["photons"])
            for c, cd in enumerate(self._t.curvature()):
                g = f.create_group(f"curvature/{c:02d}")
                # The core's curvature data as it gives it (lists: datasets; numbers: attributes);
                # the scales (`scale_*`) are derived from it when the table is assembled.
                for k, v in cd.items():
                    if k.startswith(("scale_", "coupling_a", "flow_b")) or k in ("exit_beta", "coupling_chi2"):
                        continue
                    if isinstance(v, float):
                        g.attrs[k] = v
                    else:
                        g.create_dataset(k, data=np.asarray(v, dtype=np.float64))

        return atomic.write_bytes(path, container.to_bytes(FORMAT, FORMAT_VERSION, fill), force=True)

    @classmethod
    def load(cls, path) -> AdaptiveTable:
        """Read a table written by :meth:`save`; a damaged or foreign file raises
        :class:`subsurf.container.FileFormatError`, one line naming the file."""
        from . import container

        path = os.fspath(path)
        with container.open_file(path, FORMAT, FORMAT_VERSION, "adaptive table", advice="; rebuild it") as o:
            key = json.loads(o.f.attrs["key"])
            nodes = []
            for c in sorted(o.f["channels"]):
                ch = []
                for j in sorted(o.f["channels"][c]):
                    g = o.f["channels"][c][j]
                    n = {"d": float(g.attrs["d"])}
                    for side in ("top", "bottom"):
                        s = g[side]
                        n[side] = {k: np.asarray(s[k][()], dtype=np.float64) for k in _ARRAYS}
                        n[side].update(total=float(s.attrs["total"]), total_stderr=float(s.attrs["total_stderr"]))
                        n[side]["photons"] = int(s.attrs["photons"])
                    ch.append(n)
                nodes.append(ch)
            curvature = []
            for c in sorted(o.f["curvature"]):
                g = o.f["curvature"][c]
                cd = {k: np.asarray(g[k][()], dtype=np.float64).tolist() for k in g}
                cd.update((k, float(v)) for k, v in g.attrs.items())
                curvature.append(cd)
        try:
            st = [([(*l[:3], [tuple(x) for x in l[3]], l[4]) for l in s[0]], s[1], s[2]) for s in key["stacks"]]
            core = _core.AdaptiveTable.assemble(st, nodes, curvature, key["photons"], key["seed"], key["max_rel_err"])
        except (_core.ParameterError, TypeError, KeyError) as e:
            raise container.FileFormatError(f"{path}: not a valid adaptive table ({container.one_line(e)})") from None
        return cls(core, key)

    @classmethod
    def cached(cls, stacks, photons=20000, seed=0, threads=None, max_rel_err=0.2, progress=None) -> AdaptiveTable:
        """The table of these inputs from the cache (:func:`cache_dir`), built and saved if it is
        missing, damaged or of another engine version (the file name is the inputs' SHA-256)."""
        from . import container

        st = _stacks(stacks)
        key = cls._key(st, photons, seed, max_rel_err)
        digest = hashlib.sha256(json.dumps(key, sort_keys=True).encode()).hexdigest()[:32]
        path = os.path.join(cache_dir(), f"{digest}.h5")
        if os.path.exists(path):
            try:
                t = cls.load(path)
                if t.key == key:
                    return t
            except container.FileFormatError:
                pass  # rebuilt below
        t = cls.build(stacks, photons, seed, threads, max_rel_err, progress)
        os.makedirs(os.path.dirname(path), exist_ok=True)
        t.save(path)
        return t

    def __repr__(self):
        k = self.key
        return f"AdaptiveTable(channels={len(k['stacks'])}, photons={k['photons']}, seed={k['seed']})"


__all__ = ["FORMAT", "FORMAT_VERSION", "AdaptiveTable", "cache_dir"]
