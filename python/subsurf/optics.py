"""Optics primitives, numpy-vectorised (computed by the Rust core).

Every function accepts scalars or arrays; array arguments broadcast against each other
(numpy rules) and scalar inputs give a Python ``float``. Invalid values raise
:class:`subsurf.ParameterError` (a ``ValueError``) naming the argument and its allowed range.

Conventions
-----------
- ``cos_theta_i`` is the cosine of the angle between the incident direction and the surface
  normal; its sign is ignored. Which side the light comes from is given by the pair
  ``(eta_i, eta_t)``: light travels from index ``eta_i`` into ``eta_t``.
- For diffuse quantities ``eta = n_inside / n_outside``; *internal* means light inside the
  medium hitting its boundary.
- Phase functions are normalised over the sphere (sr⁻¹); ``cos_theta`` is the cosine of the
  scattering angle (g > 0 forward scattering).

References: Born & Wolf, *Principles of Optics* §1.5 (Fresnel); Henyey & Greenstein 1941;
Egan & Hilgeman 1979 via Jensen et al. 2001 (diffuse Fresnel fit); d'Eon 2012 and pbrt-v3
(Fresnel moments); Wang, Jacques & Zheng 1995 (MCML sampling).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from . import _core

__all__ = [
    "fresnel_reflectance",
    "fresnel_transmittance",
    "refract",
    "reflect",
    "diffuse_fresnel_reflectance",
    "diffuse_fresnel_reflectance_fit",
    "fresnel_moment1",
    "fresnel_moment2",
    "hg_phase",
    "hg_pdf",
    "sample_hg",
    "isotropic_phase",
    "mixture_phase",
    "sample_mixture",
    "beer_lambert",
    "sample_free_path",
    "free_path_pdf",
    "sample_cosine_hemisphere",
    "cosine_hemisphere_pdf",
]


def _float_array(name: str, x) -> np.ndarray:
    try:
        return np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError):
        raise _core.ParameterError(f"{name} = {x!r} is not a number or array of numbers") from None


def _broadcast(**kw):
    """Broadcast named inputs; returns (shape, list of flat contiguous float64 arrays)."""
    arrs = [_float_array(k, v) for k, v in kw.items()]
    try:
        b = np.broadcast_arrays(*arrs)
    except ValueError:
        shapes = ", ".join(f"{k}{a.shape}" for k, a in zip(kw, arrs))
        raise _core.ParameterError(f"shapes do not broadcast: {shapes}") from None
    shape = b[0].shape
    return shape, [np.ascontiguousarray(a, dtype=np.float64).ravel() for a in b]


def _out(flat: np.ndarray, shape):
    if shape == ():
        return float(flat[0])
    return flat.reshape(shape)


def _polarization(p) -> str:
    if not isinstance(p, str):
        raise _core.ParameterError(f'polarization = {p!r} is not allowed: must be "unpolarized", "s" or "p"')
    return p


def fresnel_reflectance(cos_theta_i, eta_i, eta_t, polarization: str = "unpolarized"):
    """Fresnel power reflectance of a smooth dielectric interface (Born & Wolf eqs. 1.5.21).

    Parameters
    ----------
    cos_theta_i : cosine of the angle of incidence, in [-1, 1] (sign ignored).
    eta_i, eta_t : refractive indices (> 0) of the incident and transmitting media.
    polarization : ``"unpolarized"`` (mean of s and p), ``"s"`` (TE) or ``"p"`` (TM).

    Returns R in [0, 1]; R = 1 beyond the critical angle (total internal reflection).
    """
    shape, (c, ei, et) = _broadcast(cos_theta_i=cos_theta_i, eta_i=eta_i, eta_t=eta_t)
    return _out(_core.fresnel_v(c, ei, et, _polarization(polarization), False), shape)


def fresnel_transmittance(cos_theta_i, eta_i, eta_t, polarization: str = "unpolarized"):
    """Fresnel power transmittance T = 1 − R (same arguments as :func:`fresnel_reflectance`)."""
    shape, (c, ei, et) = _broadcast(cos_theta_i=cos_theta_i, eta_i=eta_i, eta_t=eta_t)
    return _out(_core.fresnel_v(c, ei, et, _polarization(polarization), True), shape)


def _vectors(name: str, v) -> np.ndarray:
    a = _float_array(name, v)
    if a.ndim == 0 or a.shape[-1] != 3:
        raise _core.ParameterError(f"{name}: expected an array of shape (..., 3), got shape {a.shape}")
    return a


def refract(d, normal, eta_i, eta_t):
    """Refract propagation directions by Snell's law (vector form, pbrt-v4 ``Refract``).

    Parameters
    ----------
    d : unit propagation directions travelling towards the surface, shape (..., 3).
    normal : unit surface normals (either orientation), shape (..., 3), broadcast with ``d``.
    eta_i, eta_t : indices (> 0) of the incident and transmitting media (broadcast over rows).

    Returns the transmitted unit directions, shape (..., 3). Rows with total internal
    reflection are NaN (all three components) — test with ``np.isnan(t[..., 0])`` and use
    :func:`reflect` for them.
    """
    d = _vectors("d", d)
    n = _vectors("normal", normal)
    eta_i, eta_t = _float_array("eta_i", eta_i), _float_array("eta_t", eta_t)
    try:
        rows = np.broadcast_shapes(d.shape[:-1], n.shape[:-1], eta_i.shape, eta_t.shape)
    except ValueError:
        raise _core.ParameterError(
            f"shapes do not broadcast: d{d.shape}, normal{n.shape}, eta_i{eta_i.shape}, eta_t{eta_t.shape}"
        ) from None
    d = np.ascontiguousarray(np.broadcast_to(d, rows + (3,))).ravel()
    n = np.ascontiguousarray(np.broadcast_to(n, rows + (3,))).ravel()
    ei = np.ascontiguousarray(np.broadcast_to(eta_i, rows)).ravel()
    et = np.ascontiguousarray(np.broadcast_to(eta_t, rows)).ravel()
    return _core.refract_v(d, n, ei, et).reshape(rows + (3,))


def reflect(d, normal):
    """Mirror reflection d − 2 (d·n) n of directions ``d`` about unit normals, shape (..., 3)."""
    d = _vectors("d", d)
    n = _vectors("normal", normal)
    try:
        rows = np.broadcast_shapes(d.shape[:-1], n.shape[:-1])
    except ValueError:
        raise _core.ParameterError(f"shapes do not broadcast: d{d.shape}, normal{n.shape}") from None
    d = np.ascontiguousarray(np.broadcast_to(d, rows + (3,))).ravel()
    n = np.ascontiguousarray(np.broadcast_to(n, rows + (3,))).ravel()
    return _core.reflect_v(d, n).reshape(rows + (3,))


def diffuse_fresnel_reflectance(eta, internal: bool = True):
    """Diffuse Fresnel reflectance F_dr = 2∫₀¹ R(μ) μ dμ by adaptive quadrature (error ~1e-12).

    ``eta = n_inside / n_outside`` in [0.001, 1000]. ``internal=True``: light inside the medium hitting
    the boundary (Jensen et al. 2001's F_dr); ``False``: diffuse light from outside.
    Reference values: η = 1.3 → 0.44446 / 0.06113; 1.4 → 0.52899 / 0.07681;
    1.5 → 0.59635 / 0.09178 (internal / external).
    """
    shape, (e,) = _broadcast(eta=eta)
    return _out(_core.diffuse_fresnel_reflectance_v(e, bool(internal)), shape)


def diffuse_fresnel_reflectance_fit(eta):
    """Egan & Hilgeman (1979) fit of the internal F_dr, as quoted by Jensen et al. (2001):
    −1.440/η² + 0.710/η + 0.668 + 0.0636 η, for η ≥ 1 (absolute error < 2e-3 on [1, 1.6], largest at η = 1)."""
    shape, (e,) = _broadcast(eta=eta)
    return _out(_core.diffuse_fresnel_reflectance_fit_v(e), shape)


def fresnel_moment1(eta):
    """First Fresnel moment C₁(η) = ∫₀¹ R(μ) μ dμ for light inside a medium of relative index
    η = n_inside/n_outside (d'Eon 2012; pbrt-v3 ``FresnelMoment1``). 2 C₁ = internal F_dr."""
    shape, (e,) = _broadcast(eta=eta)
    return _out(_core.fresnel_moment_v(e, 1), shape)


def fresnel_moment2(eta):
    """Second Fresnel moment C₂(η) = ∫₀¹ R(μ) μ² dμ (internal; pbrt-v3 ``FresnelMoment2``)."""
    shape, (e,) = _broadcast(eta=eta)
    return _out(_core.fresnel_moment_v(e, 2), shape)


def hg_phase(cos_theta, g):
    """Henyey–Greenstein phase function (1 − g²) / (4π (1 + g² − 2g cos θ)^{3/2}) in sr⁻¹.

    ``cos_theta`` in [-1, 1]; ``|g| < 1``. Normalised: ∫ p dω = 1, mean cosine g.
    """
    shape, (c, gg) = _broadcast(cos_theta=cos_theta, g=g)
    return _out(_core.hg_phase_v(c, gg), shape)


def hg_pdf(cos_theta, g):
    """pdf (sr⁻¹) of the direction sampled by :func:`sample_hg` with a uniform azimuth: equal to
    :func:`hg_phase`. The density of cos θ alone is 2π times this."""
    return hg_phase(cos_theta, g)


def sample_hg(u, g):
    """Sample cos θ from HG by inverting its CDF (MCML eq. 3.28), ``u`` uniform in [0, 1].

    Monotonic in ``u`` for every g (u = 0 → −1); exact isotropic limit for |g| < 1e-6.
    """
    shape, (uu, gg) = _broadcast(u=u, g=g)
    return _out(_core.sample_hg_v(uu, gg), shape)


def isotropic_phase(cos_theta=None):
    """The isotropic phase function 1/(4π) sr⁻¹ (an array shaped like ``cos_theta`` if given)."""
    if cos_theta is None:
        return 1.0 / (4.0 * math.pi)
    shape, (c,) = _broadcast(cos_theta=cos_theta)
    return _out(_core.isotropic_phase_v(c), shape)


def _lobes(lobes) -> list[tuple[float, float]]:
    try:
        out = [(float(w), float(g)) for w, g in lobes]
    except (TypeError, ValueError):
        raise _core.ParameterError(f"lobes = {lobes!r}: expected a sequence of (weight, g) pairs") from None
    return out


def mixture_phase(cos_theta, lobes: Sequence[tuple[float, float]]):
    """A convex mixture of HG lobes Σ w_l p_HG(cos θ; g_l) (seed eq. 1.5); ``lobes`` is
    ``[(weight, g), …]`` (at most 4; weights ≥ 0, normalised to sum 1; |g| < 1)."""
    shape, (c,) = _broadcast(cos_theta=cos_theta)
    return _out(_core.mixture_phase_v(c, _lobes(lobes)), shape)


def sample_mixture(u, lobes: Sequence[tuple[float, float]]):
    """Sample cos θ from :func:`mixture_phase` with one uniform ``u`` per sample (the lobe is
    chosen by ``u`` and ``u`` is rescaled within the lobe)."""
    shape, (uu,) = _broadcast(u=u)
    return _out(_core.sample_mixture_v(uu, _lobes(lobes)), shape)


def beer_lambert(mu_t, distance):
    """Beer–Lambert transmittance exp(−μt d): ``mu_t`` in mm⁻¹ (≥ 0), ``distance`` in mm (≥ 0,
    ``inf`` allowed)."""
    shape, (m, d) = _broadcast(mu_t=mu_t, distance=distance)
    return _out(_core.beer_lambert_v(m, d), shape)


def sample_free_path(u, sigma_t):
    """Free path s = −ln(1 − u)/σt in mm (MCML eq. 3.19), ``u`` in [0, 1], ``sigma_t`` > 0 mm⁻¹."""
    shape, (uu, s) = _broadcast(u=u, sigma_t=sigma_t)
    return _out(_core.sample_free_path_v(uu, s), shape)


def free_path_pdf(s, sigma_t):
    """pdf of :func:`sample_free_path` in mm⁻¹: σt exp(−σt s) for s ≥ 0, else 0."""
    shape, (ss, st) = _broadcast(s=s, sigma_t=sigma_t)
    return _out(_core.free_path_pdf_v(ss, st), shape)


def sample_cosine_hemisphere(u1, u2):
    """Cosine-weighted directions on the upper hemisphere (Malley's method), shape (..., 3),
    from uniform ``u1, u2`` in [0, 1]; pdf = cos θ / π (:func:`cosine_hemisphere_pdf`)."""
    shape, (a, b) = _broadcast(u1=u1, u2=u2)
    return _core.sample_cosine_hemisphere_v(a, b).reshape(shape + (3,))


def cosine_hemisphere_pdf(cos_theta):
    """pdf of :func:`sample_cosine_hemisphere` in sr⁻¹: max(cos θ, 0)/π."""
    shape, (c,) = _broadcast(cos_theta=cos_theta)
    return _out(_core.cosine_hemisphere_pdf_v(c), shape)
