"""Hanrahan–Krueger first-order (single-scattering) model of layered media.

Reference: P. Hanrahan and W. Krueger, "Reflection from layered surfaces due to subsurface
scattering", SIGGRAPH 1993, §4 (eqs. 21–23), generalised to stacks as in the paper: each layer's
single scattering, attenuated by the layers above (and, for transmission, below) along the
refracted paths and weighted by the Fresnel transmittances of the interfaces on the way in and
out. No interface reflections are included: those paths are of higher order in the Monte Carlo
sense (the MC tallies ``brdf_single_direct`` / ``btdf_single_direct`` / ``rd_single_direct`` hold
exactly the paths modelled here).

Conventions (pbrt): surface normal +z; ``wi`` and ``wo`` are unit vectors (arrays of shape
(..., 3), broadcast against each other) pointing *away* from the surface. For the BRDF both have
z > 0; for the BTDF ``wo`` has z < 0 (it lies in the medium below, index ``stack.n_below``).
BRDF/BTDF values are per solid angle *outside* the stack (sr⁻¹), f = dL_o / (L_i cos θi dωi).

For layer j (index n_j, albedo α, optical thickness τ, refracted cosines μi, μo, phase function p
at the angle between the refracted propagation directions)::

    f_r = Σ_j (n_0/n_j)² T_in T_out A_in A_out α p (1 − e^{−τ(1/μi + 1/μo)}) / (μi + μo)
    f_t = Σ_j (n_b/n_j)² T_in T_out A_in A_out α p (e^{−τ/μi} − e^{−τ/μo}) / (μi μo (1/μo − 1/μi))

with T the products of the interface (Fresnel) transmittances and A the Beer–Lambert attenuations
of the other layers crossed. The (n_0/n_j)² factor is the radiance change across the interfaces
(L/n² is invariant); restatements without it (e.g. the seed's eq. 1.25) overestimate the
reflected flux by (n_j/n_0)². With it f_r is reciprocal and its hemispherical integral equals the
flux count inside the layer (tested).
Total internal reflection on the way in or out gives zero.
"""

from __future__ import annotations

import numpy as np

from . import _core
from .medium import Stack

__all__ = [
    "single_scattering_brdf",
    "single_scattering_btdf",
    "single_scattering_brdf_layers",
    "single_scattering_btdf_layers",
    "single_scattering_reflectance",
    "single_scattering_transmittance",
    "unscattered_transmittance",
]


def _stack(stack) -> tuple:
    if not isinstance(stack, Stack):
        raise _core.ParameterError(f"stack = {stack!r} is not a subsurf.Stack")
    return stack._to_core()


def _directions(name: str, w) -> np.ndarray:
    """An array of 3-vectors (..., 3) as float64 (unit length and hemisphere are the core's to check)."""
    try:
        a = np.asarray(w, dtype=np.float64)
    except (TypeError, ValueError):
        raise _core.ParameterError(f"{name}: expected an array of 3-vectors, got {w!r}") from None
    if a.ndim == 0 or a.shape[-1] != 3:
        raise _core.ParameterError(f"{name}: expected shape (..., 3), got {a.shape}")
    return a


def _flat(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a.reshape(-1), dtype=np.float64)


def _pairs(stack, wi, wo):
    s = _stack(stack)
    a = _directions("wi", wi)
    b = _directions("wo", wo)
    try:
        shape = np.broadcast_shapes(a.shape[:-1], b.shape[:-1])
    except ValueError:
        raise _core.ParameterError(f"wi and wo: shapes {a.shape} and {b.shape} do not broadcast") from None
    a = np.broadcast_to(a, shape + (3,))
    b = np.broadcast_to(b, shape + (3,))
    return s, shape, _flat(a), _flat(b)


def single_scattering_brdf(stack: Stack, wi, wo) -> np.ndarray:
    """First-order (single-scattering) BRDF of ``stack``, sr⁻¹ (H&K 1993 eq. 21, layered).

    ``wi``, ``wo``: unit vectors, shape (..., 3), z > 0, broadcast together. Returns an array of
    the broadcast shape (a float for single directions). Reciprocal: f(wi, wo) = f(wo, wi).
    """
    s, shape, a, b = _pairs(stack, wi, wo)
    out = _core.hk_brdf(s, a, b, list(shape)).reshape(shape)
    return out if shape else float(out)


def single_scattering_btdf(stack: Stack, wi, wo) -> np.ndarray:
    """First-order (single-scattering) BTDF of ``stack``, sr⁻¹ per solid angle below the stack
    (H&K 1993 eq. 23, layered). ``wi``: z > 0; ``wo``: z < 0. Zero for a semi-infinite stack.
    Generalised reciprocity: f_t(wi → wo)/n_below² = f_t(wo → wi)/n_above²."""
    s, shape, a, b = _pairs(stack, wi, wo)
    out = _core.hk_btdf(s, a, b, list(shape)).reshape(shape)
    return out if shape else float(out)


def single_scattering_brdf_layers(stack: Stack, wi, wo) -> np.ndarray:
    """Per-layer contributions to :func:`single_scattering_brdf`: shape (..., len(stack)), sr⁻¹."""
    s, shape, a, b = _pairs(stack, wi, wo)
    return _core.hk_layer_terms(s, a, b, False, list(shape)).reshape(shape + (len(stack),))


def single_scattering_btdf_layers(stack: Stack, wi, wo) -> np.ndarray:
    """Per-layer contributions to :func:`single_scattering_btdf`: shape (..., len(stack)), sr⁻¹."""
    s, shape, a, b = _pairs(stack, wi, wo)
    return _core.hk_layer_terms(s, a, b, True, list(shape)).reshape(shape + (len(stack),))


def unscattered_transmittance(stack: Stack, wi, return_direction: bool = False):
    """Unscattered (order-0) directional transmittance of ``stack`` (dimensionless).

    T = Π_k T_k · Π_layers e^{−σt d/μ} along the refracted path (Fresnel transmittance at every
    interface, Beer–Lambert in every layer, no interface reflections; H&K 1993 §4). Zero for a
    semi-infinite stack and on total internal reflection. This is a transmittance for a
    collimated beam, not a BTDF (it is a delta function in direction). With
    ``return_direction=True`` also returns the exit directions (..., 3) below the stack (Snell;
    NaN where T = 0).
    """
    s = _stack(stack)
    a = _directions("wi", wi)
    shape = a.shape[:-1]
    t, d = _core.hk_unscattered(s, _flat(a), list(shape))
    t = t.reshape(shape)
    d = d.reshape(shape + (3,))
    if not shape:
        t = float(t)
    return (t, d) if return_direction else t


def _albedo(stack, wi, n_theta, n_phi, transmission):
    s = _stack(stack)
    a = _directions("wi", wi)
    for name, v in (("n_theta", n_theta), ("n_phi", n_phi)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)):
            raise _core.ParameterError(f"{name} = {v!r} is not an integer")
    shape = a.shape[:-1]
    out = _core.hk_albedo(s, _flat(a), int(n_theta), int(n_phi), transmission, list(shape)).reshape(shape)
    return out if shape else float(out)


def single_scattering_reflectance(stack: Stack, wi, n_theta: int = 96, n_phi: int = 96):
    """First-order directional-hemispherical reflectance ρ₁(wi) = ∫ f_r(wi, wo) cos θo dωo.

    Product quadrature over the outside hemisphere: Gauss–Legendre in u with sin θo = s_c(1 − u²)
    (s_c: each layer's total-internal-reflection cut-off, so the √ edge is smooth) times the
    midpoint rule in Δφ. The Monte Carlo counterpart is ``rd_single_direct``. Accuracy: ~1e-10
    relative for smooth phase functions; strongly peaked ones (|g| → 1) need larger ``n_phi``
    / ``n_theta``.
    """
    return _albedo(stack, wi, n_theta, n_phi, False)


def single_scattering_transmittance(stack: Stack, wi, n_theta: int = 96, n_phi: int = 96):
    """First-order directional-hemispherical transmittance τ₁(wi) = ∫ f_t(wi, wo) |cos θo| dωo
    (same quadrature as :func:`single_scattering_reflectance`); zero for a semi-infinite stack.
    The forward HG peak makes this converge slowly for g → 1: raise ``n_theta``/``n_phi``."""
    return _albedo(stack, wi, n_theta, n_phi, True)
