"""Which optional Monte Carlo tallies a run scores, and on which grids.

:class:`Tallies` mirrors the core's ``mc::tally::TallyConfig`` field by field. Conventions
(MCML's, Wang, Jacques & Zheng 1995, Comput. Methods Programs Biomed. 47:131, §4–5, with exact
bin measures): the radial, depth and time axes start at 0 and their last bin also collects
everything beyond the grid, so every histogram integrates to its total; exit angles are in the
ambient medium after refraction. See ``crates/subsurf-core/src/mc/tally/set.rs`` for every
normalisation.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

from ._core import ParameterError

#: Largest number of bins in one histogram and largest order K (as the core enforces).
MAX_BINS = 10_000_000
MAX_ORDER = 10_000


def _count(name: str, v: Any, lo: int) -> int:
    if isinstance(v, bool) or not hasattr(v, "__index__"):
        raise ParameterError(f"tallies.{name} = {v!r} is out of range: must be an integer in [{lo}, {MAX_BINS}]")
    v = int(v)
    if not lo <= v <= MAX_BINS:
        raise ParameterError(f"tallies.{name} = {v} is out of range: must be an integer in [{lo}, {MAX_BINS}]")
    return v


def _width(name: str, v: Any, unit: str) -> float:
    try:
        f = float(v)
    except (TypeError, ValueError):
        f = math.nan
    if isinstance(v, bool) or not (math.isfinite(f) and f > 0.0):
        raise ParameterError(f"tallies.{name} = {v!r} is out of range: must be a finite number > 0 ({unit})")
    return f


@dataclasses.dataclass(frozen=True)
class Tallies:
    """Optional tallies of :func:`subsurf.simulate` (the totals are always scored).

    Parameters
    ----------
    nr, dr : number of radial bins and their width in mm (R(r), T(r), A(r,z), R(r,θ), R(r,t)).
    nz, dz : number of depth bins and their width in mm (A(z), A(r,z), fluence).
    na : number of exit-angle bins over θ ∈ [0, π/2] (width π/(2 na) rad).
    nt, dt : number of time bins (0 disables R(t), R(r,t)) and their width in ps.
    brdf : ``(n_cos_theta, n_phi)`` enables BRDF/BTDF on equal-solid-angle bins (uniform in
        cos θ ∈ [0, 1] × φ ∈ [0, 2π)), in sr⁻¹; None disables them.
    max_order : K enables the split by scattering order 0…K and "> K" of the totals (and of the
        BRDF/BTDF), and the ``*_single_direct`` tallies (order 1 with no interface reflection:
        the Hanrahan–Krueger paths). None disables it.
    spatial : score rd_r, tt_r, a_z, a_rz, fluence_z, fluence_rz (and rd_rt when nt > 0).
    angular : score rd_a, tt_a (and rd_ra, tt_ra when ``spatial`` too).
    errors : keep standard errors of the histograms (batch means over fixed photon batches, see
        ``subsurf_core::mc::tally::accum``); False skips them entirely (``stderr`` is NaN) and
        makes each deposit a single add. The totals always have standard errors.
    """

    nr: int = 100
    dr: float = 0.01
    nz: int = 100
    dz: float = 0.01
    na: int = 30
    nt: int = 0
    dt: float = 1.0
    brdf: tuple[int, int] | None = None
    max_order: int | None = None
    spatial: bool = True
    angular: bool = True
    errors: bool = True

    def __post_init__(self) -> None:
        set_ = lambda k, v: object.__setattr__(self, k, v)  # noqa: E731 (frozen dataclass)
        set_("nr", _count("nr", self.nr, 1))
        set_("dr", _width("dr", self.dr, "mm"))
        set_("nz", _count("nz", self.nz, 1))
        set_("dz", _width("dz", self.dz, "mm"))
        set_("na", _count("na", self.na, 1))
        set_("nt", _count("nt", self.nt, 0))
        set_("dt", _width("dt", self.dt, "ps"))
        if self.brdf is not None:
            try:
                nc, nphi = self.brdf
            except (TypeError, ValueError):
                raise ParameterError(
                    f"tallies.brdf = {self.brdf!r} is invalid: "
                    "must be None or a pair (n_cos_theta, n_phi) of integers >= 1"
                ) from None
            set_("brdf", (_count("brdf[0]", nc, 1), _count("brdf[1]", nphi, 1)))
        if self.max_order is not None:
            k = self.max_order
            if isinstance(k, bool) or not hasattr(k, "__index__") or not 0 <= int(k) <= MAX_ORDER:
                raise ParameterError(
                    f"tallies.max_order = {k!r} is out of range: must be None or an integer in [0, {MAX_ORDER}]"
                )
            set_("max_order", int(k))
        for name in ("spatial", "angular", "errors"):
            v = getattr(self, name)
            if not isinstance(v, bool):
                raise ParameterError(f"tallies.{name} = {v!r} is invalid: must be True or False")
        sizes = []
        if self.spatial:
            sizes += [("a_rz", self.nr * self.nz), ("rd_rt", self.nr * max(self.nt, 1))]
            if self.angular:
                sizes.append(("rd_ra", self.nr * self.na))
        if self.brdf is not None and self.max_order is not None:
            sizes.append(("brdf_order", (self.max_order + 2) * self.brdf[0] * self.brdf[1]))
        for what, n in sizes:
            if n > MAX_BINS:
                raise ParameterError(
                    f"tallies: the {what} histogram would have {n} bins, more than {MAX_BINS}; use coarser grids"
                )

    def to_dict(self) -> dict:
        """Plain values (JSON/TOML friendly): ``brdf`` as a list or None."""
        d = dataclasses.asdict(self)
        d["brdf"] = None if self.brdf is None else list(self.brdf)
        return d

    @classmethod
    def from_dict(cls, d: dict) -> Tallies:
        """Inverse of :meth:`to_dict`; missing keys take their defaults, unknown keys are refused."""
        if not isinstance(d, dict):
            raise ParameterError(f"tallies: expected a dict, got {type(d).__name__}")
        known = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(d) - known)
        if unknown:
            raise ParameterError(f"tallies: unknown field(s) {unknown}; known: {sorted(known)}")
        kw = dict(d)
        if kw.get("brdf") is not None and isinstance(kw["brdf"], list):
            kw["brdf"] = tuple(kw["brdf"])
        return cls(**kw)
