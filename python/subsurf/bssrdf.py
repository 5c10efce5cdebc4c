"""Radial BSSRDF profiles R_d(r) for renderers and fits (all physics in ``subsurf_core::bssrdf``).

A :class:`Profile` is the diffuse reflectance per unit area R_d(r) (mm⁻²) at distance r (mm) from a
normally incident pencil beam of unit power, for one colour channel. Models, selected by name
(:data:`MODELS`; each cites its paper in the core's ``bssrdf/<model>.rs``):

- ``"dipole"`` (Jensen et al. 2001), ``"better_dipole"`` (d'Eon 2012),
- ``"multipole"`` (Donner & Jensen 2005: finite slabs and layered stacks),
- ``"photon_beam_diffusion"`` (Habel, Christensen & Jarosz 2013, pbrt-v4's profile; single
  scattering kept separate: :meth:`Profile.single_scattering`),
- ``"normalized_diffusion"`` (Christensen & Burley 2015; :meth:`Profile.normalized_diffusion`
  takes their surface albedo A and mean free path directly),
- ``"monte_carlo"`` (:meth:`Profile.from_monte_carlo`: the engine's R(r) on a log grid,
  energy-exact, for any :class:`subsurf.Stack`),
- ``"adaptive"`` (the renderer's geometry-aware model: finite-slab R(r; d) and T(r; d) of the
  engine per local thickness, :class:`AdaptiveTable`; as a plain profile, the Monte Carlo one).

Every method takes and returns numpy arrays or floats. A material given per channel (RGB or a
spectrum) is a list of stacks: :func:`profiles`. :class:`ProfileTable` tabulates Monte Carlo
profiles in optical units (albedo × r/ℓ) for a g and η, saved to HDF5. Inverse problems:
:func:`material_from_reflectance`, :func:`fit_profile`, :func:`fit_profile_layer`,
:func:`fit_slab_totals` (:class:`SlabTable`). Bad input raises :class:`subsurf.ParameterError`.
"""

from __future__ import annotations

import dataclasses
import json
import os

import numpy as np

from . import _core
from .medium import Layer, Stack

MODELS = tuple(_core.bssrdf_models())
POWERS = tuple(_core.BSSRDF_POWERS)
MFP_KINDS = tuple(_core.BSSRDF_MFP_KINDS)
TABLE_FORMAT = "subsurf-profile-table"
#: 2: the checksummed container (:mod:`subsurf.container`); 1 (plain HDF5) is refused.
TABLE_FORMAT_VERSION = 2
_POINT_ARRAYS = ("edges", "weight", "stderr", "single", "single_stderr")

__all__ = [
    "MFP_KINDS",
    "MODELS",
    "POWERS",
    "AdaptiveTable",
    "Fit",
    "Profile",
    "ProfileTable",
    "SlabTable",
    "chandrasekhar_reflectance",
    "fit_profile",
    "fit_profile_layer",
    "fit_slab_totals",
    "material_from_reflectance",
    "profiles",
]


def _arr(name, x):
    try:
        return np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError):
        raise _core.ParameterError(f"{name} = {x!r} is not a number or array of numbers") from None


def _vec(fn, name, x):
    a = _arr(name, x)
    out = np.asarray(fn(np.ascontiguousarray(a.ravel()))).reshape(a.shape)
    return float(out) if a.ndim == 0 else out


def _model(model):
    if model not in MODELS:
        raise _core.ParameterError(f"model = {model!r} is not a profile model: must be one of {list(MODELS)}")
    return model


def _stack(stack) -> Stack:
    if isinstance(stack, Layer):
        stack = Stack([stack])
    if not isinstance(stack, Stack):
        raise _core.ParameterError(f"stack = {stack!r} is not a subsurf.Stack (or Layer)")
    return stack


class Profile:
    """R_d(r) of one model for one channel. Build with :meth:`from_model`, :meth:`from_stack`,
    :meth:`from_monte_carlo` or :meth:`normalized_diffusion`.

    Methods (arrays or floats in and out): :meth:`rd` (mm⁻²), :meth:`total` (∫R_d 2πr dr),
    :meth:`pdf` (2πr R_d/total, mm⁻¹), :meth:`cdf`, :meth:`sample_r` (its inverse, u ∈ [0, 1)),
    :meth:`radius_for_fraction`.
    """

    __slots__ = ("_p",)

    def __init__(self, core):
        self._p = core

    @classmethod
    def from_model(cls, model, sigma_a, sigma_s, g=0.0, eta=1.0) -> Profile:
        """A closed-form model for a homogeneous semi-infinite medium: σa, σs in mm⁻¹, HG g,
        relative index η = n_medium/n_outside (≥ 1 for the diffusion models)."""
        if _model(model) in ("monte_carlo", "adaptive"):  # adaptive on a flat half-space: Monte Carlo
            return cls.from_monte_carlo(Stack([Layer(eta, sigma_a, sigma_s, g)]))
        return cls(_core.bssrdf_medium_profile(model, float(sigma_a), float(sigma_s), float(g), float(eta)))

    @classmethod
    def from_stack(cls, stack, model="multipole", **mc) -> Profile:
        """Any model for a stack (only ``multipole`` and ``monte_carlo`` take layered or finite
        stacks); ``mc`` are :meth:`from_monte_carlo`'s keywords."""
        if _model(model) in ("monte_carlo", "adaptive"):
            return cls.from_monte_carlo(stack, **mc)
        s = _stack(stack)
        return cls(_core.bssrdf_stack_profile(model, s._to_core(), 1, 0, None, 10, 0.2))

    @classmethod
    def from_monte_carlo(
        cls,
        stack,
        photons=100_000,
        seed=0,
        *,
        threads=None,
        per_decade=10,
        max_rel_err=0.2,
        r_min=None,
        r_max=None,
        progress=None,
    ) -> Profile:
        """The engine's profile of ``stack`` under a normally incident pencil beam: ``photons``
        packets, log grid of ``per_decade`` bins per decade from ``r_min`` (default 10⁻³ of the
        smallest 1/σt) to ``r_max`` (10³ of the largest 1/σt'); bins past the median radius whose
        relative standard error exceeds ``max_rel_err`` are replaced by a fitted diffusion tail.
        Its total is the Monte Carlo total diffuse reflectance (:meth:`mc_data` has the bins).
        Ctrl-C (or ``progress(done, total)`` raising it) stops the run with KeyboardInterrupt."""
        s = _stack(stack)
        return cls(
            _core.bssrdf_stack_profile(
                "monte_carlo",
                s._to_core(),
                int(photons),
                int(seed),
                threads,
                int(per_decade),
                float(max_rel_err),
                r_min,
                r_max,
                progress,
            )
        )

    @classmethod
    def normalized_diffusion(cls, albedo, mfp, variant="searchlight") -> Profile:
        """Christensen & Burley (2015) with surface albedo A = ``albedo`` and length ℓ = ``mfp``
        (mm); ``variant``: ``"searchlight"`` (eq. 5, ℓ = 1/σt), ``"diffuse_surface"`` (eq. 6) or
        ``"searchlight_dmfp"`` (eq. 8, ℓ = diffuse mean free path)."""
        return cls(_core.bssrdf_normalized_diffusion(float(albedo), float(mfp), str(variant)))

    @property
    def model(self) -> str:
        return self._p.model

    def rd(self, r):
        """R_d(r), mm⁻²."""
        return _vec(self._p.rd, "r", r)

    def total(self) -> float:
        """∫₀^∞ R_d(r) 2πr dr."""
        return self._p.total()

    def pdf(self, r):
        """2πr R_d(r)/total, mm⁻¹."""
        return _vec(self._p.pdf, "r", r)

    def cdf(self, r):
        """Fraction of the total inside radius r."""
        return _vec(self._p.cdf, "r", r)

    def sample_r(self, u):
        """The radius r with cdf(r) = u (u ∈ [0, 1))."""
        return _vec(self._p.sample_r, "u", u)

    def radius_for_fraction(self, q):
        """The radius holding a fraction q of the energy."""
        return _vec(self._p.radius_for_fraction, "q", q)

    def single_scattering(self):
        """(R_d,single(r) as a function, its total) for models that separate it, else None."""
        if not self._p.has_single():
            return None
        return (lambda r: _vec(self._p.single_rd, "r", r)), self._p.single_total()

    def mc_data(self):
        """Monte Carlo profiles: the tallied bins (edges, weight, stderr, single, total, …)."""
        return self._p.mc_data()

    def __repr__(self):
        return f"Profile(model={self.model!r}, total={self.total():.6g})"


def profiles(stacks, model="monte_carlo", **mc) -> list[Profile]:
    """One :class:`Profile` per channel (a list of stacks, e.g. RGB); Monte Carlo channel i uses
    ``seed + i``."""
    stacks = [stacks] if isinstance(stacks, (Stack, Layer)) else list(stacks)
    if not stacks:
        raise _core.ParameterError("stacks: give at least one stack (one per channel)")
    seed = int(mc.pop("seed", 0))
    out = []
    for i, s in enumerate(stacks):
        try:
            if model == "monte_carlo":
                out.append(Profile.from_monte_carlo(s, seed=seed + i, **mc))
            else:
                out.append(Profile.from_stack(s, model))
        except _core.ParameterError as e:
            raise _core.ParameterError(f"channels[{i}]: {e}") from None
    return out


def chandrasekhar_reflectance(albedo) -> float:
    """1 − H(1)√(1 − a): exact total reflectance of a semi-infinite, index-matched,
    isotropically scattering medium under normal incidence (Chandrasekhar's H-function)."""
    return _core.bssrdf_chandrasekhar_reflectance(float(albedo))


# ---- tables ---------------------------------------------------------------------------------


class _TablePoint:
    """A :class:`ProfileTable` albedo point as a sweep point (picklable; threads: one per task on
    a cluster, the settings' otherwise)."""

    def __init__(self, settings: dict):
        self.settings = dict(settings)

    def fingerprint(self) -> dict:
        return {"kind": "subsurf.bssrdf.ProfileTable", **{k: v for k, v in self.settings.items() if k != "threads"}}

    def __call__(self, albedo):
        from .cluster import task_threads

        s = {**self.settings, "threads": task_threads(self.settings.get("threads"))}
        p = ProfileTable.point(s, s["albedos"].index(albedo))
        return {k: (np.asarray(v, dtype=float) if np.ndim(v) else float(v)) for k, v in p.items()}


def _sweep_points(point, axes, path, client, progress, what):
    """Run a table's points with :func:`subsurf.sweep`; an interrupted build raises
    KeyboardInterrupt (its finished points are in ``path``, if given)."""
    import warnings

    from .sweeps import sweep

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        res = sweep(point, axes, path, client=client, progress=progress)
    if not res.complete:
        where = f"; its finished points are in {os.fspath(path)}: build again to resume" if path is not None else ""
        raise KeyboardInterrupt(f"{what} interrupted: {res.points_done} of {res.done.size} points done{where}")
    return res


class ProfileTable:
    """Monte Carlo profiles of semi-infinite media in optical units (σt = 1: r in mean free
    paths) on a grid of single-scattering albedos, for one g and η; interpolation keeps the total
    consistent (:meth:`rho_eff`). Build with :meth:`build` (or :meth:`point` per albedo and
    :meth:`assemble`, e.g. on a cluster), save/load with :meth:`save`/:meth:`load` (HDF5)."""

    def __init__(self, core, settings: dict):
        self._t = core
        self.settings = dict(settings)

    @staticmethod
    def default_settings(g=0.0, eta=1.0, n_albedos=24, **overrides) -> dict:
        """The settings dict: g, eta, albedos, photons (per albedo), seed, r_min, r_max,
        per_decade, max_rel_err, threads."""
        s = dict(_core.bssrdf_table_defaults(float(g), float(eta), int(n_albedos)))
        for k, v in overrides.items():
            if k not in s:
                raise _core.ParameterError(f"{k}: not a table setting (one of {sorted(s)})")
            s[k] = list(map(float, v)) if k == "albedos" else v
        return s

    @staticmethod
    def point(settings: dict, index: int, progress=None) -> dict:
        """Trace albedo point ``index`` (seed + index): a picklable dict of arrays. Ctrl-C (or
        ``progress(done, total)`` raising it) interrupts it with KeyboardInterrupt."""
        return dict(_core.bssrdf_table_point(settings, int(index), progress))

    @classmethod
    def assemble(cls, settings: dict, points) -> ProfileTable:
        """A table from its settings and its points (in albedo order)."""
        pts = list(points)
        if not pts:
            raise _core.ParameterError("points: the table is empty; give one point per albedo")
        return cls(_core.ProfileTable.assemble(settings, pts), settings)

    @classmethod
    def build(cls, g=0.0, eta=1.0, *, client=None, path=None, progress=None, **settings) -> ProfileTable:
        """Compute every albedo point with :func:`subsurf.sweep` — here, or one task per albedo on
        a Dask ``client`` — and assemble the table (the same table either way: point i always
        uses seed + i). ``path``: a sweep file keeping finished points, so that a build stopped by
        Ctrl-C (KeyboardInterrupt) resumes where it stopped when called again with the same
        arguments. ``progress(done, total)`` counts albedo points."""
        s = cls.default_settings(g, eta, **settings)
        res = _sweep_points(_TablePoint(s), {"albedo": s["albedos"]}, path, client, progress, "profile table")
        n = len(s["albedos"])
        pts = [{k: (v[i] if np.ndim(v) > 1 else v[i].item()) for k, v in res.data.items()} for i in range(n)]
        for p in pts:
            p["photons"] = int(p["photons"])
        return cls.assemble(s, pts)

    def rho_eff(self, albedo):
        """Total diffuse reflectance ρ_eff(α) (interpolated between the nodes)."""
        return _vec(self._t.rho_eff, "albedo", albedo)

    def albedo_for(self, rho):
        """The single-scattering albedo with ρ_eff(α) = rho."""
        return _vec(self._t.albedo_for, "rho", rho)

    def profile(self, sigma_a, sigma_s) -> Profile:
        """The interpolated profile of a medium (σa, σs in mm⁻¹) with this table's g and η."""
        return Profile(self._t.profile(float(sigma_a), float(sigma_s)))

    def save(self, path) -> str:
        """Write the table to ``path`` (atomically, :mod:`subsurf.atomic`; the directory must
        exist) in subsurf's checksummed HDF5 container (:mod:`subsurf.container`): the settings,
        the version that built it and every point's bins, verified before HDF5 reads them back."""
        from . import atomic, container

        pts = [dict(p) for p in self._t.points()]

        def fill(f) -> None:
            f.attrs["settings"] = json.dumps(self.settings, sort_keys=True)
            for i, p in enumerate(pts):
                g = f.create_group(f"points/{i:04d}")
                for k in _POINT_ARRAYS:
                    g.create_dataset(k, data=np.asarray(p[k], dtype=np.float64))
                g.attrs["total"], g.attrs["total_stderr"] = float(p["total"]), float(p["total_stderr"])
                g.attrs["photons"] = int(p["photons"])

        return atomic.write_bytes(path, container.to_bytes(TABLE_FORMAT, TABLE_FORMAT_VERSION, fill), force=True)

    @classmethod
    def load(cls, path) -> ProfileTable:
        """Read a table written by :meth:`save`. A damaged, altered or foreign file — or one of
        format version 1, from before tables were checksummed — raises
        :class:`subsurf.container.FileFormatError` (a :class:`subsurf.ParameterError`), one line
        naming the file."""
        from . import container

        path = os.fspath(path)
        with container.open_file(path, TABLE_FORMAT, TABLE_FORMAT_VERSION, "profile table", advice="; rebuild it") as o:
            settings = json.loads(o.f.attrs["settings"])
            pts = []
            for name in sorted(o.f["points"]):
                g = o.f["points"][name]
                p = {k: np.asarray(g[k][()], dtype=np.float64) for k in _POINT_ARRAYS}
                p.update(total=float(g.attrs["total"]), total_stderr=float(g.attrs["total_stderr"]))
                p["photons"] = int(g.attrs["photons"])
                pts.append(p)
        try:
            return cls.assemble(settings, pts)
        except (_core.ParameterError, TypeError) as e:
            raise container.FileFormatError(f"{path}: not a valid profile table ({container.one_line(e)})") from None


# ---- inverse --------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class Fit:
    """A fit: ``params`` (mm⁻¹), their covariance ``cov`` and standard errors, χ² and dof."""

    names: tuple
    params: np.ndarray
    cov: np.ndarray
    stderr: np.ndarray
    chi2: float
    dof: int
    iterations: int

    @classmethod
    def _from(cls, d, names):
        n = len(names)
        return cls(
            tuple(names),
            np.asarray(d["params"]),
            np.asarray(d["cov"]).reshape(n, n),
            np.asarray(d["stderr"]),
            float(d["chi2"]),
            int(d["dof"]),
            int(d["iterations"]),
        )

    def as_dict(self) -> dict:
        return {n: (float(p), float(s)) for n, p, s in zip(self.names, self.params, self.stderr)}


def material_from_reflectance(
    reflectance,
    mfp,
    *,
    eta=1.3,
    g=0.0,
    model="dipole",
    power="incident",
    mfp_kind="extinction",
    table=None,
    client=None,
) -> list[Layer]:
    """One semi-infinite :class:`subsurf.Layer` per channel from a reflectance and a mean free
    path per channel: the package's one colour → material inversion (``subsurf_core::bssrdf::
    inverse::appearance``; :meth:`subsurf.Material.from_reflectance` and
    :meth:`subsurf.render.Translucent.from_reflectance` forward to it). Spelling as pbrt's
    ``SubsurfaceMaterial`` (``reflectance``, ``mfp``).

    Parameters:

    - ``reflectance`` (∈ [0, 1], one per channel): the total diffuse reflectance under a
      normally incident beam, specular reflection excluded, under ``model``;
    - ``mfp`` (mm, > 0; one, or one per channel): a mean free path of kind ``mfp_kind``;
    - ``eta`` (n_medium / n_outside), ``g`` (Henyey–Greenstein, |g| < 1);
    - ``model`` (:data:`MODELS`) whose total is inverted for the single-scattering albedo:
      closed forms for ``dipole``, ``better_dipole``, ``multipole``; the integrated total of
      ``photon_beam_diffusion``; the engine's ρ_eff from a :class:`ProfileTable` for
      ``monte_carlo`` and for ``normalized_diffusion`` (whose total is its surface albedo for
      every medium: its material is the engine's);
    - ``power`` (:data:`POWERS`): ``"incident"`` — per unit power incident on the surface (what
      :func:`subsurf.simulate` and a render show) — or ``"entering"`` — per unit power entering
      the medium (the diffusion totals, pbrt's ρ_eff); incident = (1 − R_sp) × entering;
    - ``mfp_kind`` (:data:`MFP_KINDS`): ``"extinction"`` 1/σt (pbrt's ``mfp``),
      ``"transport"`` 1/σt', ``"diffuse"`` 1/σtr with the model's diffusion coefficient (Jensen &
      Buhler 2002, §4: 1/(3σt'); Grosjean's (2σa + σs')/(3σt'²) for ``better_dipole`` and
      ``photon_beam_diffusion``), or ``"burley_d"`` Christensen & Burley's (2015) d, the d of the
      ``normalized_diffusion`` profile a render builds (its median radius, 1.5522 d, is the
      medium's photon beam diffusion median; finite without absorption);
    - ``table``: the :class:`ProfileTable` for (g, eta) of the two table models (built with
      default settings — on a Dask ``client`` if given — and cached in memory if not given).

    The result reproduces the reflectance under ``model``; the engine's reflectance of a
    closed-form model's material differs by that model's error (``docs/profiles.md``)."""
    r = np.atleast_1d(_arr("reflectance", reflectance)).astype(float).ravel()
    m = np.atleast_1d(_arr("mfp", mfp)).astype(float).ravel()
    m = np.repeat(m, r.size) if m.size == 1 else m
    core_table = None
    if _model(model) in ("monte_carlo", "adaptive", "normalized_diffusion"):
        core_table = (table if table is not None else _default_table(float(g), float(eta), client))._t
    out = _core.bssrdf_material_from_reflectance(
        list(r), list(m), float(eta), float(g), model, str(power), str(mfp_kind), core_table
    )
    return [Layer(n, mua, mus, gg) for n, mua, mus, gg in out]


_TABLES: dict = {}


def _default_table(g, eta, client=None) -> ProfileTable:
    key = (g, eta)
    if key not in _TABLES:
        _TABLES[key] = ProfileTable.build(g, eta, client=client)
    return _TABLES[key]


def _data(r, rd, sigma):
    r, rd, sigma = (np.ravel(_arr(n, v)) for n, v in (("r", r), ("rd", rd), ("sigma", sigma)))
    sigma = np.broadcast_to(sigma, rd.shape)
    return list(map(float, r)), list(map(float, rd)), list(map(float, sigma))


def fit_profile(r, rd, sigma, model="dipole", g=0.0, eta=1.0, initial=(0.01, 1.0), table=None) -> Fit:
    """Fit (σa, σs') in mm⁻¹ of a semi-infinite medium to R_d(r) (mm⁻² at radii r in mm, with
    standard deviations ``sigma``) by Levenberg–Marquardt; the covariance is (JᵀWJ)⁻¹. Model
    ``monte_carlo`` evaluates the profile from ``table`` (a :class:`ProfileTable` of g, eta).
    Data that do not identify the parameters (no signal, χ² not finite, a relative standard
    uncertainty above 1) raise :class:`subsurf.ParameterError` (docs/profiles.md), as in every fit here."""
    args = _data(r, rd, sigma)
    t = table._t if table is not None else None
    d = _core.bssrdf_fit_profile(_model(model), *args, float(g), float(eta), tuple(map(float, initial)), t)
    return Fit._from(d, ("sigma_a", "sigma_s_prime"))


def fit_profile_layer(stack, layer, r, rd, sigma, initial=(0.01, 1.0)) -> Fit:
    """Fit (μa, μs') of layer ``layer`` of ``stack`` (others fixed) with the layered multipole."""
    d = _core.bssrdf_fit_profile_layer(_stack(stack)._to_core(), int(layer), *_data(r, rd, sigma), tuple(initial))
    return Fit._from(d, ("mua", "mus_prime"))


class SlabTable:
    """Monte Carlo (Rd, Tt) of slabs on a grid of albedos × optical thicknesses τ (σt = 1 mm⁻¹,
    thickness τ mm; one engine run of ``photons`` photons per point, point (i, j) with seed
    ``seed + i·len(taus) + j``), for the Monte Carlo slab fit. The points are computed with
    :func:`subsurf.sweep` — here, or one task per point on a Dask ``client`` (the same table
    either way); ``path`` keeps finished points so that a build stopped by Ctrl-C
    (KeyboardInterrupt) resumes when started again with the same arguments."""

    def __init__(
        self,
        g,
        n,
        albedos,
        taus,
        n_above=1.0,
        n_below=1.0,
        photons=20_000,
        seed=0,
        *,
        client=None,
        path=None,
        progress=None,
    ):
        self.g, self.n, self.n_above, self.n_below = float(g), float(n), float(n_above), float(n_below)
        albedos, taus = list(map(float, albedos)), list(map(float, taus))
        point = _SlabPoint(self.g, self.n, self.n_above, self.n_below, albedos, taus, int(photons), int(seed))
        res = _sweep_points(point, {"albedo": albedos, "tau": taus}, path, client, progress, "slab table")
        totals = np.stack([res[k] for k in ("rd", "rd_stderr", "tt", "tt_stderr")], axis=-1).reshape(-1, 4)
        args = (self.g, self.n, self.n_above, self.n_below, albedos, taus)
        self._t = _core.SlabTable.from_totals(*args, [tuple(map(float, t)) for t in totals])

    def totals(self, albedo, tau):
        """Interpolated (Rd, Tt) at ``albedo`` and optical thickness ``tau`` inside the grid."""
        return self._t.totals(float(albedo), float(tau))


class _SlabPoint:
    """A :class:`SlabTable` point as a sweep point (picklable)."""

    def __init__(self, g, n, n_above, n_below, albedos, taus, photons, seed):
        self.args = dict(g=g, n=n, n_above=n_above, n_below=n_below, photons=photons, seed=seed)
        self.albedos, self.taus = albedos, taus

    def fingerprint(self) -> dict:
        return {"kind": "subsurf.bssrdf.SlabTable", **self.args, "albedos": self.albedos, "taus": self.taus}

    def __call__(self, albedo, tau):
        from .cluster import task_threads

        a = self.args
        k = self.albedos.index(albedo) * len(self.taus) + self.taus.index(tau)
        rd, rd_se, tt, tt_se = _core.bssrdf_slab_point(
            a["g"],
            a["n"],
            a["n_above"],
            a["n_below"],
            albedo,
            tau,
            a["photons"],
            (a["seed"] + k) % 2**64,
            task_threads(None),
        )
        return {"rd": rd, "rd_stderr": rd_se, "tt": tt, "tt_stderr": tt_se}


def fit_slab_totals(
    rd, tt, sigma, thickness, g=0.0, n=1.4, n_above=1.0, n_below=1.0, model="multipole", table=None, initial=(0.1, 1.0)
) -> Fit:
    """Fit (μa, μs') of a slab (thickness mm) to its total diffuse reflectance and total
    transmittance (standard deviations ``sigma`` = (σ_Rd, σ_Tt)), with ``multipole`` (diffusion)
    or ``monte_carlo`` (a :class:`SlabTable` for the same g and indices)."""
    s = np.broadcast_to(_arr("sigma", sigma), (2,))
    t = table._t if table is not None else None
    d = _core.bssrdf_fit_slab_totals(
        float(rd),
        float(tt),
        (float(s[0]), float(s[1])),
        float(thickness),
        float(g),
        float(n),
        float(n_above),
        float(n_below),
        _model(model),
        tuple(map(float, initial)),
        t,
    )
    return Fit._from(d, ("mua", "mus_prime"))


from .adaptive_table import AdaptiveTable  # noqa: E402  (imports Profile from here)
