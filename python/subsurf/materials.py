"""Per-channel optical properties for the diffusion models: :class:`Material` and the measured
table of Jensen, Marschner, Levoy & Hanrahan, "A Practical Model for Subsurface Light
Transport", SIGGRAPH 2001 (σs' and σa per R, G, B channel in mm⁻¹).

Provenance of the table (cross-checked copies; the paper's text was not reachable here):
pbrt-v3 ``src/core/medium.cpp`` (``SubsurfaceParameterTable``, mm⁻¹ as Jensen), pbrt-v4
``GetMediumScatteringProperties``, Mitsuba 0.6 ``src/medium/materials.h`` and several
independent ports (Go, Julia, yocto-gl) agree digit for digit except:

- chicken1 / chicken2 σa (red): 0.015 / 0.018 in pbrt and all the ports, 0.0015 / 0.0018 in
  Mitsuba. We take 0.015 / 0.018: with the paper's η these give a red total diffuse
  reflectance of 0.314 / 0.321 (the paper's figure lists ≈ 0.31 / 0.32), whereas Mitsuba's
  values would give 0.65 — an order of magnitude slip in Mitsuba's copy.
- η: 1.3 for every material in pbrt-era usage; Mitsuba gives marble η = 1.5. We use 1.3 for
  all but marble, and 1.5 for marble: only η = 1.5 reproduces the marble row of the paper's
  diffuse-reflectance column (0.83, 0.79, 0.75: computed 0.830, 0.791, 0.753 at η = 1.5 versus
  0.867, 0.834, 0.801 at η = 1.3), while η = 1.3 reproduces every other row to ≤ 0.008.
  (Pass ``eta=`` to :func:`get` to override.)

Mean free path conventions and the inversions are documented in :mod:`subsurf.diffusion`.
"""

from __future__ import annotations

import numpy as np

from . import _core
from . import diffusion as _dif

#: Jensen et al. (2001) measured parameters: name → (σs' RGB, σa RGB, η); mm⁻¹.
JENSEN_2001 = {
    "apple": ((2.29, 2.39, 1.97), (0.0030, 0.0034, 0.046), 1.3),
    "chicken1": ((0.15, 0.21, 0.38), (0.015, 0.077, 0.19), 1.3),
    "chicken2": ((0.19, 0.25, 0.32), (0.018, 0.088, 0.20), 1.3),
    "cream": ((7.38, 5.47, 3.15), (0.0002, 0.0028, 0.0163), 1.3),
    "ketchup": ((0.18, 0.07, 0.03), (0.061, 0.97, 1.45), 1.3),
    "marble": ((2.19, 2.62, 3.00), (0.0021, 0.0041, 0.0071), 1.5),
    "potato": ((0.68, 0.70, 0.55), (0.0024, 0.0090, 0.12), 1.3),
    "skimmilk": ((0.70, 1.22, 1.90), (0.0014, 0.0025, 0.0142), 1.3),
    "skin1": ((0.74, 0.88, 1.01), (0.032, 0.17, 0.48), 1.3),
    "skin2": ((1.09, 1.59, 1.79), (0.013, 0.070, 0.145), 1.3),
    "spectralon": ((11.6, 20.4, 14.9), (0.0, 0.0, 0.0), 1.3),
    "wholemilk": ((2.55, 3.21, 3.77), (0.0011, 0.0024, 0.014), 1.3),
}


def _channels(name, x):
    try:
        a = np.atleast_1d(np.asarray(x, dtype=np.float64)).copy()
    except (TypeError, ValueError):
        raise _core.ParameterError(f"{name} = {x!r} is not a number or array of numbers") from None
    if a.ndim != 1 or a.size == 0:
        raise _core.ParameterError(f"{name}: expected one value per channel (a 1-D array), got shape {a.shape}")
    return a


def _per_channel(v):
    """Directions or points (..., 3) broadcast against the channel axis: (..., 1, 3)."""
    return np.asarray(v, dtype=np.float64)[..., None, :]


class Material:
    """Optical properties per channel (RGB or any number of spectral samples).

    Parameters
    ----------
    sigma_a : absorption coefficient σa per channel, mm⁻¹ (≥ 0).
    sigma_s_prime : reduced scattering coefficient σs' = σs(1 − g) per channel, mm⁻¹ (≥ 0),
        with σa + σs' > 0.
    eta : relative refractive index n_medium/n_outside, in [1, 2.5] (scalar).
    g : optional mean cosine of the phase function (|g| < 1); only needed to rebuild σs
        (:meth:`to_layers`). ``None`` means unknown (treated as 0 there).
    name : optional label.
    """

    __slots__ = ("sigma_a", "sigma_s_prime", "eta", "g", "name")

    def __init__(self, sigma_a, sigma_s_prime, eta=1.3, g=None, name=None):
        sa = _channels("sigma_a", sigma_a)
        ssp = _channels("sigma_s_prime", sigma_s_prime)
        if sa.size != ssp.size:
            if sa.size == 1:
                sa = np.full(ssp.size, sa[0])
            elif ssp.size == 1:
                ssp = np.full(sa.size, ssp[0])
            else:
                raise _core.ParameterError(
                    f"sigma_a has {sa.size} channels but sigma_s_prime has {ssp.size}: they must match"
                )
        try:
            eta = float(eta)
        except (TypeError, ValueError):
            raise _core.ParameterError(f"eta = {eta!r} is not a number") from None
        _core.diffusion_check_properties(sa, ssp, np.full(sa.size, eta))
        if g is not None:
            try:
                g = float(g)
            except (TypeError, ValueError):
                raise _core.ParameterError(f"g = {g!r} is not a number") from None
            if not (abs(g) < 1):
                raise _core.ParameterError(f"g = {g} is out of range: must be a finite number with |g| < 1")
        sa.flags.writeable = False
        ssp.flags.writeable = False
        self.sigma_a, self.sigma_s_prime, self.eta, self.g, self.name = sa, ssp, eta, g, name

    # ---- constructors -------------------------------------------------------------------
    @classmethod
    def from_layer(cls, layer, n_outside=1.0, name=None):
        """From a :class:`subsurf.Layer` (one channel) or a sequence of layers (one per channel):
        σa = mua, σs' = mus(1 − g), η = n/n_outside, g = the layers' g (if all equal)."""
        layers = list(layer) if isinstance(layer, (list, tuple)) else [layer]
        from .medium import Layer

        for i, l in enumerate(layers):
            if not isinstance(l, Layer):
                raise _core.ParameterError(f"layer[{i}] = {l!r} is not a subsurf.Layer")
        ns = {l.n for l in layers}
        if len(ns) != 1:
            raise _core.ParameterError(f"layers have different refractive indices {sorted(ns)}: a Material has one eta")
        gs = {l.g for l in layers}
        g = gs.pop() if len(gs) == 1 else None
        return cls(
            [l.mua for l in layers], [l.mus_prime for l in layers], eta=layers[0].n / float(n_outside), g=g, name=name
        )

    @classmethod
    def from_reflectance(
        cls,
        reflectance,
        mfp,
        *,
        eta=1.3,
        g=0.0,
        model="dipole",
        power="incident",
        mfp_kind="extinction",
        name=None,
        table=None,
    ):
        """From a reflectance (∈ [0, 1]) and a mean free path (mm) per channel, by
        :func:`subsurf.bssrdf.material_from_reflectance` (same parameters: ``power`` incident or
        entering, ``mfp_kind`` extinction, transport, diffuse or burley_d): σa, σs' = σs(1 − g)."""
        from .bssrdf import material_from_reflectance

        layers = material_from_reflectance(
            reflectance, mfp, eta=eta, g=g, model=model, power=power, mfp_kind=mfp_kind, table=table
        )
        return cls([l.mua for l in layers], [l.mus_prime for l in layers], eta=eta, g=g, name=name)

    @classmethod
    def from_color(cls, diffuse_color, mean_free_path, eta=1.3, model="dipole", mfp_kind="transport", name=None):
        """Deprecated forwarding alias, kept until the demo that calls it is merged:
        :meth:`from_reflectance` with ``power="entering"``, ``g=0`` and ``mfp_kind`` transport
        (default) or diffuse."""
        return cls.from_reflectance(
            diffuse_color, mean_free_path, eta=eta, model=model, power="entering", mfp_kind=mfp_kind, name=name
        )

    # ---- derived quantities -------------------------------------------------------------
    @property
    def channels(self) -> int:
        return int(self.sigma_a.size)

    @property
    def sigma_t_prime(self):
        """σt' = σa + σs' (mm⁻¹)."""
        return self.sigma_a + self.sigma_s_prime

    @property
    def alpha_prime(self):
        """Reduced albedo α' = σs'/σt'."""
        return self.sigma_s_prime / self.sigma_t_prime

    @property
    def transport_mfp(self):
        """Transport mean free path 1/σt' (mm)."""
        return 1.0 / self.sigma_t_prime

    def sigma_tr(self, model="dipole"):
        """Effective transport coefficient per channel (mm⁻¹)."""
        return _dif.sigma_tr(self.sigma_a, self.sigma_s_prime, model)

    def rd(self, r, model="dipole"):
        """R_d(r) in mm⁻², shape ``np.shape(r) + (channels,)``."""
        r = np.asarray(r, dtype=np.float64)[..., None]
        return _dif.rd(r, self.sigma_a, self.sigma_s_prime, self.eta, model)

    def total_rd(self, model="dipole"):
        """Total diffuse reflectance per channel (closed form)."""
        return _dif.total_diffuse_reflectance(self.alpha_prime, self.eta, model)

    def sd(self, xi, wi, xo, wo, model="dipole"):
        """S_d per channel, shape (..., channels); see :func:`subsurf.diffusion.sd`."""
        return _dif.sd(
            _per_channel(xi),
            _per_channel(wi),
            _per_channel(xo),
            _per_channel(wo),
            self.sigma_a,
            self.sigma_s_prime,
            self.eta,
            model,
        )

    def diffusion_brdf(self, wi, wo, model="dipole"):
        """∫ S_d dA per channel (sr⁻¹), shape (..., channels)."""
        return _dif.diffusion_brdf(
            _per_channel(wi), _per_channel(wo), self.sigma_a, self.sigma_s_prime, self.eta, model
        )

    def single_scattering_brdf(self, wi, wo):
        """S⁽¹⁾ integrated over the surface per channel (sr⁻¹), shape (..., channels): the
        Hanrahan–Krueger first-order BRDF of the semi-infinite medium (g = self.g or 0)."""
        g = 0.0 if self.g is None else self.g
        return np.stack(
            [
                _dif.single_scattering_brdf(wi, wo, float(a), float(s), self.eta, g)
                for a, s in zip(self.sigma_a, self.sigma_s_prime)
            ],
            axis=-1,
        )

    def complete_brdf(self, wi, wo, model="dipole"):
        """The complete BSSRDF S_d + S⁽¹⁾ (Jensen et al. 2001) integrated over the surface per
        channel (sr⁻¹), shape (..., channels)."""
        return self.diffusion_brdf(wi, wo, model) + self.single_scattering_brdf(wi, wo)

    def to_layers(self, thickness=float("inf")):
        """One semi-infinite :class:`subsurf.Layer` per channel, for the Monte Carlo engine:
        n = η (ambient index 1), mua = σa, mus = σs'/(1 − g), g = self.g or 0."""
        from .medium import Layer

        g = 0.0 if self.g is None else self.g
        return [
            Layer(n=self.eta, mua=float(a), mus=float(s) / (1.0 - g), g=g, thickness=thickness)
            for a, s in zip(self.sigma_a, self.sigma_s_prime)
        ]

    def __eq__(self, other):
        return (
            isinstance(other, Material)
            and np.array_equal(self.sigma_a, other.sigma_a)
            and np.array_equal(self.sigma_s_prime, other.sigma_s_prime)
            and self.eta == other.eta
            and self.g == other.g
        )

    def __repr__(self):
        nm = f"name={self.name!r}, " if self.name else ""
        return (
            f"Material({nm}sigma_a={self.sigma_a.tolist()!r}, sigma_s_prime={self.sigma_s_prime.tolist()!r}, "
            f"eta={self.eta!r}, g={self.g!r})"
        )

    def _repr_html_(self):
        from .display import material_html

        return material_html(self)


def names() -> list[str]:
    """Names of the library materials (Jensen et al. 2001 table), sorted."""
    return sorted(JENSEN_2001)


def get(name: str, eta: float | None = None) -> Material:
    """The named material (case-insensitive) from the Jensen et al. (2001) table, RGB channels;
    ``eta`` overrides the table's index. Unknown names raise ParameterError listing the valid ones."""
    key = str(name).strip().lower()
    if key not in JENSEN_2001:
        raise _core.ParameterError(f"material {name!r} is unknown: must be one of {names()}")
    ssp, sa, e = JENSEN_2001[key]
    return Material(sa, ssp, eta=e if eta is None else eta, name=key)


__all__ = ["JENSEN_2001", "Material", "get", "names"]
