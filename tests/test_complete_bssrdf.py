"""Jensen et al. 2001 complete BSSRDF (S_d + S⁽¹⁾) integrated over the surface."""

import math

import numpy as np
import pytest
import subsurf
from subsurf import diffusion, hk


def _hemisphere(n=64):
    x, w = np.polynomial.legendre.leggauss(n)
    mu, wmu = 0.5 * (x + 1), 0.5 * w
    phi = (np.arange(2 * n) + 0.5) * math.pi / n
    M, P = np.meshgrid(mu, phi, indexing="ij")
    s = np.sqrt(1 - M**2)
    wo = np.stack([s * np.cos(P), s * np.sin(P), M], -1)
    weight = np.outer(wmu, np.full(2 * n, math.pi / n)) * M  # cos θ dω
    return wo, weight


def test_single_scattering_albedo_closed_form():
    # index-matched, isotropic, normal incidence: ∫ f cos dω = (α/2)(1 − ln 2) (Chandrasekhar)
    sa, ss = 0.001, 0.999
    wo, weight = _hemisphere()
    f = diffusion.single_scattering_brdf(np.array([0, 0, 1.0]), wo, sa, ss, 1.0)
    assert np.sum(f * weight) == pytest.approx(0.999 / 2 * (1 - math.log(2)), rel=1e-6)


def test_complete_is_sum_and_reciprocal(rng):
    v = rng.normal(size=(2, 50, 3))
    v[..., 2] = np.abs(v[..., 2]) + 0.05
    wi, wo = v / np.linalg.norm(v, axis=-1, keepdims=True)
    args = (0.01, 1.2, 1.3, 0.4)
    full = diffusion.complete_brdf(wi, wo, *args)
    assert full == pytest.approx(
        diffusion.diffusion_brdf(wi, wo, *args[:3]) + diffusion.single_scattering_brdf(wi, wo, *args), rel=1e-14
    )
    assert full == pytest.approx(diffusion.complete_brdf(wo, wi, *args), rel=1e-12)
    # S⁽¹⁾ is the HK BRDF of a semi-infinite layer with σs = σs'/(1 − g)
    stack = subsurf.Stack([subsurf.Layer(1.3, 0.01, 1.2 / 0.6, 0.4, math.inf)])
    assert diffusion.single_scattering_brdf(wi, wo, *args) == pytest.approx(
        hk.single_scattering_brdf(stack, wi, wo), rel=1e-14
    )


def test_material_complete_brdf_per_channel():
    m = subsurf.materials.get("skin1")
    wi, wo = np.array([0, 0, 1.0]), np.array([0.6, 0, 0.8])
    full = m.complete_brdf(wi, wo)
    assert full.shape == (3,)
    for c in range(3):
        expect = diffusion.complete_brdf(wi, wo, m.sigma_a[c], m.sigma_s_prime[c], m.eta)
        assert full[c] == pytest.approx(expect, rel=1e-14)
    with pytest.raises(ValueError, match="sigma_a"):
        diffusion.single_scattering_brdf(wi, wo, [0.1, 0.2], 1.0, 1.3)
