"""Diffusion models of subsurface scattering in a semi-infinite homogeneous medium.

Two radial profiles R_d(r) (mm⁻², the radiant exitance at distance r from a unit-power
normally incident pencil beam), selectable by name:

- ``"dipole"``: Jensen, Marschner, Levoy & Hanrahan, "A Practical Model for Subsurface Light
  Transport", SIGGRAPH 2001 (the diffuse reflectance of Farrell, Patterson & Wilson 1992):
  D = 1/(3σt'), σt' = σa + σs', α' = σs'/σt', σtr = √(3σaσt'), z_r = 1/σt', z_v = z_r + 4AD,
  A = (1 + F_dr)/(1 − F_dr), F_dr = −1.440/η² + 0.710/η + 0.668 + 0.0636η,
  R_d(r) = α'/(4π) [z_r(σtr d_r + 1)e^{−σtr d_r}/d_r³ + z_v(σtr d_v + 1)e^{−σtr d_v}/d_v³].
- ``"better_dipole"``: d'Eon, "A Better Dipole" (2012): D = (2σa + σs')/(3σt'²), σtr = √(σa/D),
  A = (1 + 3C₂)/(1 − 2C₁) from the Fresnel moments C₁, C₂ (d'Eon's polynomial fits),
  z_v = z_r + 4AD, R(r) = C_φ φ(r) + C_E E(r) with C_φ = (1 − 2C₁)/4, C_E = (1 − 3C₂)/2 and the
  dipole weighted by α'² (Grosjean's collided flux).

Conventions: σa and σs' = σs(1 − g) in mm⁻¹; r in mm; ``eta`` η = n_medium/n_outside,
accepted in [1, 2.5] (η < 1 is refused: Jensen's F_dr fit is negative there; above 2.5 the
polynomial fits leave their range). Every function broadcasts its array arguments with numpy
rules and returns an array of the broadcast shape (a float for all-scalar input). Invalid input
raises :class:`subsurf.ParameterError` naming the field (and flat index).

Where the models are trustworthy (measured against Monte Carlo, docs/diffusion_vs_mc.md,
semi-infinite medium, normal pencil beam, η ∈ {1.0, 1.3, 1.5}): the total R_d of both models is
within 3.3 % for α' ≥ 0.99 (within 1 % at α' = 0.999), the dipole's within 4 % for α' ≥ 0.95 at
η ≤ 1.3; at α' ≤ 0.8 both are off by 8–60 %. The profile R_d(r) is never better than ~10 %: at
α' ≥ 0.95 and 2–8 mfp the better dipole overestimates by 12–14 % (η = 1.5) to 20–22 % (η = 1.3)
and 35–37 % (η = 1.0); the dipole is within 7 % at η = 1.3, α' ≥ 0.99 but off by up to 38 %
elsewhere. Both fail near the entry point (r < 0.05 mfp: 95–99 % below Monte Carlo, which holds the
single-scattering peak) and at low albedo (α' = 0.5: totals 17–60 % off, profiles up to ×3).
For a Monte Carlo comparison call :func:`rd` (profile) and :func:`total_diffuse_reflectance`
with ``model="dipole"`` or ``"better_dipole"`` on a semi-infinite ``subsurf.Layer(n=eta,
mua=sigma_a, mus=sigma_s_prime, g=0)`` in air, dividing the MC reflectance by 1 − R_sp.
"""

from __future__ import annotations

import numpy as np

from . import _core

MODELS = ("dipole", "better_dipole")

__all__ = [
    "MODELS",
    "fdr",
    "A",
    "fresnel_moments",
    "params",
    "diffusion_coefficient",
    "sigma_tr",
    "z_r",
    "z_v",
    "dipole_rd",
    "better_dipole_rd",
    "rd",
    "profile",
    "total_diffuse_reflectance",
    "alpha_prime_from_rd",
    "ft",
    "sd",
    "diffusion_brdf",
    "single_scattering_brdf",
    "complete_brdf",
]


def _arr(name, x):
    try:
        a = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError):
        raise _core.ParameterError(f"{name} = {x!r} is not a number or array of numbers") from None
    return a


def _model(model):
    if model not in MODELS:
        raise _core.ParameterError(f"model = {model!r} is not a diffusion model: must be one of {list(MODELS)}")
    return model


def _flat(shape, *arrays):
    return [np.ascontiguousarray(np.broadcast_to(a, shape), dtype=np.float64).ravel() for a in arrays]


def _call(fn, names, values, *prefix):
    arrays = [_arr(n, v) for n, v in zip(names, values)]
    try:
        shape = np.broadcast_shapes(*(a.shape for a in arrays))
    except ValueError:
        raise _core.ParameterError(
            f"{', '.join(names)}: shapes {[a.shape for a in arrays]} do not broadcast together"
        ) from None
    out = fn(*prefix, *_flat(shape, *arrays))
    if isinstance(out, (tuple, list)):
        return tuple(_shape(o, shape) for o in out)
    return _shape(out, shape)


def _shape(out, shape):
    out = np.asarray(out).reshape(shape)
    return float(out) if shape == () else out


def fdr(eta):
    """Diffuse Fresnel reflectance F_dr(η) by the Egan–Hilgeman fit Jensen et al. (2001) use:
    −1.440/η² + 0.710/η + 0.668 + 0.0636η (≈ 2∫₀¹F_r μ dμ, the boundary's hemispherical
    reflectance seen from inside). F_dr(1) = 0.0016 with the fit (exact: 0)."""
    return _call(_core.diffusion_fdr, ["eta"], [eta])


def A(eta, model="dipole"):
    """Boundary coefficient: Jensen's (1 + F_dr)/(1 − F_dr) (A(1) = 1.0032 with the fit), or
    d'Eon's (1 + 3C₂)/(1 − 2C₁) for ``model="better_dipole"``."""
    return _call(_core.diffusion_a, ["eta"], [eta], _model(model))


def fresnel_moments(eta):
    """(C₁, C₂), C_n = ∫₀¹ F_r(η, μ) μⁿ dμ (internal reflection), by d'Eon's (2012) polynomial fits
    (pbrt-v3 ``FresnelMoment1/2``); within 2.3e-3 of quadrature on [1, 2.5]."""
    return _call(_core.diffusion_fresnel_moments, ["eta"], [eta])


def params(sigma_a, sigma_s_prime, eta, model="dipole"):
    """The model's constants as a dict of arrays: ``alpha_prime``, ``D`` (mm), ``sigma_tr``
    (mm⁻¹), ``A``, ``z_r`` and ``z_v`` (mm)."""
    out = _call(
        _core.diffusion_params, ["sigma_a", "sigma_s_prime", "eta"], [sigma_a, sigma_s_prime, eta], _model(model)
    )
    return dict(zip(["alpha_prime", "D", "sigma_tr", "A", "z_r", "z_v"], out))


def diffusion_coefficient(sigma_a, sigma_s_prime, model="dipole"):
    """D in mm: 1/(3σt') (dipole) or (2σa + σs')/(3σt'²) (better dipole, Grosjean)."""
    return params(sigma_a, sigma_s_prime, 1.0, model)["D"]


def sigma_tr(sigma_a, sigma_s_prime, model="dipole"):
    """Effective transport coefficient σtr in mm⁻¹: √(3σaσt') (dipole) or √(σa/D) (better dipole)."""
    return params(sigma_a, sigma_s_prime, 1.0, model)["sigma_tr"]


def z_r(sigma_a, sigma_s_prime):
    """Depth of the real source, z_r = 1/σt' (mm), both models."""
    return params(sigma_a, sigma_s_prime, 1.0)["z_r"]


def z_v(sigma_a, sigma_s_prime, eta, model="dipole"):
    """Height of the image source above the surface, z_v = z_r + 4AD (mm)."""
    return params(sigma_a, sigma_s_prime, eta, model)["z_v"]


def rd(r, sigma_a, sigma_s_prime, eta, model="dipole"):
    """Diffuse reflectance profile R_d(r) in mm⁻² (r in mm) of ``model``."""
    return _call(
        _core.diffusion_rd, ["r", "sigma_a", "sigma_s_prime", "eta"], [r, sigma_a, sigma_s_prime, eta], _model(model)
    )


def profile(name, r, sigma_a, sigma_s_prime, eta):
    """R_d(r) by model name (``"dipole"`` or ``"better_dipole"``), mm⁻²."""
    return rd(r, sigma_a, sigma_s_prime, eta, model=name)


def dipole_rd(r, sigma_a, sigma_s_prime, eta):
    """Jensen et al. (2001) dipole R_d(r) in mm⁻² (r in mm, σa, σs' in mm⁻¹).

    Trustworthy (vs Monte Carlo, docs/diffusion_vs_mc.md): at η = 1.3, α' ≥ 0.99 within 7 % for
    r = 2–8 transport mean free paths (1/σt'); at η = 1.5 within −20 %, at η = 1.0 up to +31 %
    (α' = 0.99); +22…+89 % at 0.5–2 mfp for η ≥ 1.3; fails for r → 0 (> 95 % low for
    r < 0.05 mfp) and at low albedo (up to ×3 at α' = 0.5)."""
    return rd(r, sigma_a, sigma_s_prime, eta, "dipole")


def better_dipole_rd(r, sigma_a, sigma_s_prime, eta):
    """d'Eon (2012) better-dipole R(r) = C_φ φ(r) + C_E E(r) in mm⁻².

    Trustworthy (vs Monte Carlo, docs/diffusion_vs_mc.md): at α' ≥ 0.95, r = 2–8 transport mean
    free paths, it overestimates by 12–14 % (η = 1.5), 20–22 % (η = 1.3), 35–37 % (η = 1.0);
    within −3…−10 % at 0.5–1 mfp (α' ≥ 0.95), far better there than the dipole for η ≥ 1.3; fails
    for r → 0 (> 97 % low for r < 0.05 mfp) and at low albedo (+50 % at 2–8 mfp, α' = 0.5)."""
    return rd(r, sigma_a, sigma_s_prime, eta, "better_dipole")


def total_diffuse_reflectance(alpha_prime, eta, model="dipole"):
    """Total diffuse reflectance ∫₀^∞ R_d(r) 2πr dr in closed form.

    Dipole (Jensen et al. 2001, §3): (α'/2)(1 + e^{−(4/3)A√(3(1−α'))}) e^{−√(3(1−α'))}.
    Better dipole: (α'²/2) e^{−σtr z_r}[C_E(1 + x) + C_φ(1 − x)/(σtr D)], x = e^{−4ADσtr},
    σtr z_r = √(3(1−α')/(2−α')), σtr D = √((1−α')(2−α')/3).
    Both rise monotonically from 0 (α' = 0) to 1 (α' = 1).

    Trustworthy (vs Monte Carlo, total reflectance of a normal pencil beam divided by 1 − R_sp,
    docs/diffusion_vs_mc.md): for α' ≥ 0.99 both within 3.3 % (dipole ≤ 1.8 %), at α' = 0.999
    within 1 % with the better dipole the closer for η ≥ 1.3; the dipole within 4 % for
    α' ≥ 0.95 at η ≤ 1.3 (−7 % at α' = 0.9, η = 1.0; +20 % at η = 1.5), the better dipole 9–18 % low
    at α' = 0.9–0.95; at α' = 0.5 dipole −24…+59 %, better dipole −53…−60 %."""
    return _call(_core.diffusion_total_rd, ["alpha_prime", "eta"], [alpha_prime, eta], _model(model))


def alpha_prime_from_rd(rd, eta, model="dipole"):
    """Reduced albedo α' whose total diffuse reflectance is ``rd`` (∈ [0, 1]), by bisection to
    1e-15; ``rd`` outside [0, 1] raises ParameterError."""
    return _call(_core.diffusion_alpha_prime_from_rd, ["rd", "eta"], [rd, eta], _model(model))


def _dirs(name, w):
    w = _arr(name, w)
    if w.ndim == 0 or w.shape[-1] != 3:
        raise _core.ParameterError(f"{name}: expected an array of shape (..., 3), got shape {w.shape}")
    return w


def ft(eta, cos_theta):
    """Fresnel transmittance F_t(η, θ) = 1 − F_r into the medium (light from outside, index 1 → η),
    with F_r the core's unpolarised ``fr_dielectric``; 0 for cos θ ≤ 0."""
    return _call(_core.diffusion_ft, ["eta", "cos_theta"], [eta, cos_theta])


def sd(xi, wi, xo, wo, sigma_a, sigma_s_prime, eta, model="dipole"):
    """Diffusion term of the BSSRDF, mm⁻² sr⁻¹ (Jensen et al. 2001, §2.4):
    S_d(x_i, ω_i; x_o, ω_o) = (1/π) F_t(η, ω_i) R_d(‖x_i − x_o‖) F_t(η, ω_o).

    ``xi``, ``xo``: points (..., 3) in mm on the surface z = 0 (only their distance enters);
    ``wi``, ``wo``: unit directions (..., 3) pointing away from the surface, normal +z (a
    direction below the surface gives 0). Optical properties broadcast with the leading shape.
    F_t = 1 − F_r with F_r the unpolarised Fresnel reflectance (core ``fr_dielectric``) of light
    entering the medium from outside (index 1 → η)."""
    _model(model)
    vecs = [_dirs(n, v) for n, v in (("xi", xi), ("wi", wi), ("xo", xo), ("wo", wo))]
    props = [_arr(n, v) for n, v in (("sigma_a", sigma_a), ("sigma_s_prime", sigma_s_prime), ("eta", eta))]
    shape = np.broadcast_shapes(*(v.shape[:-1] for v in vecs), *(p.shape for p in props))
    v_flat = [np.ascontiguousarray(np.broadcast_to(v, shape + (3,))).ravel() for v in vecs]
    out = _core.diffusion_sd(model, *v_flat, *_flat(shape, *props))
    return _shape(out, shape)


def diffusion_brdf(wi, wo, sigma_a, sigma_s_prime, eta, model="dipole"):
    """∫ S_d dA over the surface (sr⁻¹): (1/π) F_t(η, ω_i) R_d,total(α', η) F_t(η, ω_o), the
    multiple-scattering BRDF of a uniformly lit semi-infinite medium. Shapes as in :func:`sd`."""
    _model(model)
    vecs = [_dirs(n, v) for n, v in (("wi", wi), ("wo", wo))]
    props = [_arr(n, v) for n, v in (("sigma_a", sigma_a), ("sigma_s_prime", sigma_s_prime), ("eta", eta))]
    shape = np.broadcast_shapes(*(v.shape[:-1] for v in vecs), *(p.shape for p in props))
    v_flat = [np.ascontiguousarray(np.broadcast_to(v, shape + (3,))).ravel() for v in vecs]
    out = _core.diffusion_brdf(model, *v_flat, *_flat(shape, *props))
    return _shape(out, shape)


def _semi_infinite_stack(sigma_a, sigma_s_prime, eta, g):
    from .medium import Layer, Stack

    return Stack([Layer(n=eta, mua=sigma_a, mus=sigma_s_prime / (1.0 - g), g=g, thickness=float("inf"))], n_above=1.0)


def single_scattering_brdf(wi, wo, sigma_a, sigma_s_prime, eta, g=0.0):
    """The single-scattering term S⁽¹⁾ of Jensen et al. 2001 (§2.3, eqs. 3–4) integrated over the
    surface, in sr⁻¹: for a flat, uniformly lit semi-infinite medium it is the Hanrahan–Krueger
    first-order BRDF (Jensen derives S⁽¹⁾ from it), computed by :func:`subsurf.hk.single_scattering_brdf`
    on a semi-infinite layer n = η (outside index 1), σa, σs = σs'/(1 − g), HG phase function g.

    ``wi``, ``wo``: unit directions (..., 3) pointing away from the surface (normal +z); the
    optical properties are scalars (one channel; see :meth:`subsurf.Material.complete_brdf`)."""
    from . import hk

    for name, v in (("sigma_a", sigma_a), ("sigma_s_prime", sigma_s_prime), ("eta", eta), ("g", g)):
        if np.ndim(v) != 0:
            raise _core.ParameterError(f"{name}: expected a scalar (one channel), got shape {np.shape(v)}")
    stack = _semi_infinite_stack(float(sigma_a), float(sigma_s_prime), float(eta), float(g))
    return hk.single_scattering_brdf(stack, wi, wo)


def complete_brdf(wi, wo, sigma_a, sigma_s_prime, eta, g=0.0, model="dipole"):
    """The complete BSSRDF S = S_d + S⁽¹⁾ of Jensen et al. 2001 (§2.4) integrated over the surface,
    in sr⁻¹: :func:`diffusion_brdf` (multiple scattering, (1/π) F_t R_d F_t) plus
    :func:`single_scattering_brdf` (Hanrahan–Krueger). This is the BRDF of a uniformly lit
    semi-infinite medium, i.e. seed eq. 1.10 with constant incident radiance over the surface.
    Optical properties are scalars (one channel)."""
    return diffusion_brdf(wi, wo, sigma_a, sigma_s_prime, eta, model=model) + single_scattering_brdf(
        wi, wo, sigma_a, sigma_s_prime, eta, g=g
    )
