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
from typing import Any

from . import _core
from ._core import ParameterError

#: Largest number of bins in one histogram and largest order K (the core's limits; every range
#: is checked by the core, ``subsurf_core::mc::tally::config``).
MAX_BINS: int = _core.MC_MAX_BINS
MAX_ORDER: int = _core.MC_MAX_ORDER
#: Kind of each field ("count", "length", "pair", "order", "bool"), from the core's list of the
#: fields (``TallyConfig::fields``); ``tests/test_registry.py`` checks that the dataclass matches it.
KINDS: dict[str, str] = {name: kind for name, kind, _ in _core.MC_TALLY_FIELDS}


def _integer(name: str, v: Any) -> int:
    if isinstance(v, bool) or not hasattr(v, "__index__"):
        raise ParameterError(f"tallies.{name} = {v!r} is not an integer")
    return int(v)


def _number(name: str, v: Any) -> float:
    if isinstance(v, bool):
        raise ParameterError(f"tallies.{name} = {v!r} is not a number")
    try:
        return float(v)
    except (TypeError, ValueError):
        raise ParameterError(f"tallies.{name} = {v!r} is not a number") from None


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
    errors : keep standard errors of the histograms (per photon for the escape histograms; batch
        means over fixed batches of 256 photons for A(z), A(r,z) and fluence, NaN for runs of at
        most 256 photons; see ``subsurf_core::mc::tally::accum``); False skips them entirely
        (``stderr`` is NaN) and makes each deposit a single add. The totals always have them.
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
        for name, kind in KINDS.items():
            v = getattr(self, name)
            if kind == "count" or (kind == "order" and v is not None):
                set_(name, _integer(name, v))
            elif kind == "length":
                set_(name, _number(name, v))
            elif kind == "pair" and v is not None:
                try:
                    a, b = v
                except (TypeError, ValueError):
                    msg = "must be None or a pair (n_cos_theta, n_phi) of integers >= 1"
                    raise ParameterError(f"tallies.{name} = {v!r} is invalid: {msg}") from None
                set_(name, (_integer(f"{name}[0]", a), _integer(f"{name}[1]", b)))
            elif kind == "bool" and not isinstance(v, bool):
                raise ParameterError(f"tallies.{name} = {v!r} is invalid: must be True or False")
        _core.mc_validate_tallies({**self.to_dict(), "brdf": self.brdf})

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
