"""Tests of subsurf.diffusion: exact identities, limits, inversions, shapes and bad input.

References used here are independent of the code under test: Gauss–Legendre quadrature of the
profiles, a numpy Fresnel formula (Born & Wolf) for F_dr and d'Eon's moments, and Farrell,
Patterson & Wilson's (1992) way of writing the dipole.
"""

import math

import numpy as np
import pytest
import subsurf
from subsurf import diffusion as d

MODELS = ["dipole", "better_dipole"]
GL_X, GL_W = np.polynomial.legendre.leggauss(16)


def radial_integral(f, scale):
    """∫₀^∞ f(r) 2πr dr: 16-point Gauss–Legendre on 600 log-spaced panels over [0, 1e5·scale]."""
    edges = np.concatenate([[0.0], scale * np.logspace(-9, 5, 600)])
    a, b = edges[:-1, None], edges[1:, None]
    r = 0.5 * (a + b) + 0.5 * (b - a) * GL_X
    w = 0.5 * (b - a) * GL_W
    return float(np.sum(w * f(r) * 2 * np.pi * r))


def fresnel_internal(mu, eta):
    """Unpolarised Fresnel reflectance inside a medium of relative index eta (Born & Wolf)."""
    mu = np.asarray(mu, float)
    s2 = eta**2 * (1 - mu**2)
    ct = np.sqrt(np.clip(1 - s2, 0, None))
    with np.errstate(invalid="ignore", divide="ignore"):  # grazing 0/0 at η = 1 (value 1)
        rs = np.where(eta * mu + ct > 0, (eta * mu - ct) / (eta * mu + ct), 1.0)
        rp = np.where(mu + eta * ct > 0, (mu - eta * ct) / (mu + eta * ct), 1.0)
    return np.where(s2 >= 1, 1.0, 0.5 * (rs**2 + rp**2))


GAUSS_200 = np.polynomial.legendre.leggauss(200)  # (nodes, weights): 20 ms to compute, so once


def fresnel_moment(eta, n):
    mu_c = math.sqrt(max(0.0, 1 - 1 / eta**2))
    tot = 0.0
    for a, b in [(0.0, mu_c), (mu_c, 1.0)]:
        x, w = GAUSS_200
        m = 0.5 * (a + b) + 0.5 * (b - a) * x
        tot += float(np.sum(0.5 * (b - a) * w * fresnel_internal(m, eta) * m**n))
    return tot


PROPS = [(0.01, 1.0), (0.1, 1.0), (0.5, 0.5), (0.0030, 2.29), (1.45, 0.03), (0.032, 0.74)]


@pytest.mark.parametrize("model", MODELS)
@pytest.mark.parametrize("eta", [1.0, 1.3, 1.5, 2.0])
def test_integral_of_profile_equals_closed_form(model, eta):
    worst = 0.0
    for sa, ssp in PROPS:
        num = radial_integral(lambda r, sa=sa, ssp=ssp: d.rd(r, sa, ssp, eta, model), 1 / (sa + ssp))
        exact = d.total_diffuse_reflectance(ssp / (sa + ssp), eta, model)
        worst = max(worst, abs(num / exact - 1))
    assert worst < 1e-6, worst


def test_dipole_matches_farrell_form():
    # Farrell, Patterson & Wilson (1992): z0 = 1/μt', zb = 2AD, r1 = √(z0² + ρ²), r2 = √((z0 + 2zb)² + ρ²),
    # R(ρ) = a'/(4π) [z0(μeff + 1/r1) e^{−μeff r1}/r1² + (z0 + 2zb)(μeff + 1/r2) e^{−μeff r2}/r2²].
    rho = np.linspace(0, 10, 41)
    for sa, ssp, eta in [(0.01, 1.0, 1.3), (0.2, 0.7, 1.0), (0.0030, 2.29, 1.5)]:
        mt = sa + ssp
        D = 1 / (3 * mt)
        fdr = -1.440 / eta**2 + 0.710 / eta + 0.668 + 0.0636 * eta
        A = (1 + fdr) / (1 - fdr)
        z0, zb, mueff = 1 / mt, 2 * A * D, math.sqrt(3 * sa * mt)
        r1, r2 = np.sqrt(z0**2 + rho**2), np.sqrt((z0 + 2 * zb) ** 2 + rho**2)
        ref = (
            (ssp / mt)
            / (4 * np.pi)
            * (
                z0 * (mueff + 1 / r1) * np.exp(-mueff * r1) / r1**2
                + (z0 + 2 * zb) * (mueff + 1 / r2) * np.exp(-mueff * r2) / r2**2
            )
        )
        np.testing.assert_allclose(d.dipole_rd(rho, sa, ssp, eta), ref, rtol=1e-13)
        assert d.A(eta) == pytest.approx(A, rel=1e-14)
        assert d.z_v(sa, ssp, eta) == pytest.approx(z0 + 2 * zb, rel=1e-14)
        assert d.sigma_tr(sa, ssp) == pytest.approx(mueff, rel=1e-14)
        assert d.diffusion_coefficient(sa, ssp) == pytest.approx(D, rel=1e-14)


def test_better_dipole_constants():
    sa, ssp, eta = 0.1, 0.9, 1.4
    p = d.params(sa, ssp, eta, "better_dipole")
    c1, c2 = d.fresnel_moments(eta)
    D = (2 * sa + ssp) / (3 * (sa + ssp) ** 2)
    A = (1 + 3 * c2) / (1 - 2 * c1)
    assert p["D"] == pytest.approx(D, rel=1e-14)
    assert p["sigma_tr"] == pytest.approx(math.sqrt(sa / D), rel=1e-14)
    assert p["A"] == pytest.approx(A, rel=1e-14)
    assert p["z_v"] == pytest.approx(1 + 4 * A * D, rel=1e-14)
    # Independent evaluation of R = C_φ φ + C_E E at a few r, source weight α'².
    r = np.array([0.0, 0.5, 3.0])
    zr, zv, s, ap = 1.0, 1 + 4 * A * D, math.sqrt(sa / D), ssp / (sa + ssp)
    dr, dv = np.sqrt(r**2 + zr**2), np.sqrt(r**2 + zv**2)
    phi = ap**2 / (4 * np.pi * D) * (np.exp(-s * dr) / dr - np.exp(-s * dv) / dv)
    E = (
        ap**2
        / (4 * np.pi)
        * (zr * (1 + s * dr) * np.exp(-s * dr) / dr**3 + zv * (1 + s * dv) * np.exp(-s * dv) / dv**3)
    )
    ref = (1 - 2 * c1) / 4 * phi + (1 - 3 * c2) / 2 * E
    np.testing.assert_allclose(d.better_dipole_rd(r, sa, ssp, eta), ref, rtol=1e-13)


@pytest.mark.slow
def test_fits_against_fresnel_quadrature():
    etas = np.linspace(1.0, 2.5, 31)
    c1 = np.array([fresnel_moment(e, 1) for e in etas])
    c2 = np.array([fresnel_moment(e, 2) for e in etas])
    f1, f2 = d.fresnel_moments(etas)
    assert np.max(np.abs(f1 - c1)) < 2.5e-3
    assert np.max(np.abs(f2 - c2)) < 2.5e-3
    # Jensen's F_dr fit is the internal hemispherical reflectance 2C1 to 5.1e-3 on [1, 2.5].
    assert np.max(np.abs(d.fdr(etas) - 2 * c1)) < 5.5e-3


def test_limits():
    # Matched boundary: the fit gives F_dr(1) = 0.0016 (exact value 0), hence A(1) = 1.0032.
    assert d.fdr(1.0) == pytest.approx(0.0016, abs=1e-14)
    assert d.A(1.0) == pytest.approx(1.0016 / 0.9984, rel=1e-14)
    # d'Eon's fits at η = 1: C1, C2 within 2.3e-3 of 0, so A(1) ≈ 1 and C_φ ≈ 1/4, C_E ≈ 1/2.
    assert d.A(1.0, "better_dipole") == pytest.approx(1.0, abs=1e-2)
    for model in MODELS:
        assert d.total_diffuse_reflectance(1.0, 1.3, model) == pytest.approx(1.0, abs=1e-14)
        assert d.total_diffuse_reflectance(0.0, 1.3, model) == 0.0
        # α' → 0: the profile vanishes (linearly for the dipole, quadratically for the better dipole).
        small = d.rd([0.0, 1.0], 1.0, 1e-8, 1.3, model)
        assert np.all(small < 1e-8) and np.all(small >= 0)
        # More absorption, less reflectance; total is increasing in α'.
        tot = d.total_diffuse_reflectance(np.linspace(0, 1, 101), 1.3, model)
        assert np.all(np.diff(tot) > 0)
    # A higher index traps more light.
    assert d.total_diffuse_reflectance(0.9, 1.5) < d.total_diffuse_reflectance(0.9, 1.3)


@pytest.mark.parametrize("model", MODELS)
def test_inversion_round_trip(model):
    ap = np.linspace(0, 1, 201)[:, None]
    eta = np.array([1.0, 1.2, 1.3, 1.5, 2.0, 2.5])
    rd = d.total_diffuse_reflectance(ap, eta, model)
    back = d.alpha_prime_from_rd(rd, eta, model)
    assert back.shape == (201, 6)
    assert np.max(np.abs(back - ap)) < 1e-10
    for bad in [-0.01, 1.01, np.nan, np.inf]:
        with pytest.raises(subsurf.ParameterError, match="rd"):
            d.alpha_prime_from_rd(bad, 1.3, model)


def test_vectorised_shapes():
    r = np.linspace(0, 5, 7)[:, None]
    out = d.dipole_rd(r, np.array([0.01, 0.02, 0.03]), 1.0, 1.3)
    assert out.shape == (7, 3)
    assert isinstance(d.dipole_rd(1.0, 0.01, 1.0, 1.3), float)
    np.testing.assert_array_equal(out[:, 1], d.dipole_rd(r[:, 0], 0.02, 1.0, 1.3))
    assert d.profile("better_dipole", r, 0.01, 1.0, 1.3).shape == (7, 1)
    wi = np.array([[0, 0, 1.0], [0.6, 0, 0.8]])
    assert d.sd(np.zeros((5, 1, 3)), wi, np.ones(3) / 3, [0, 0, 1.0], 0.01, 1.0, 1.3).shape == (5, 2)
    assert d.diffusion_brdf(wi, [0, 0, 1.0], [[0.01], [0.1], [1.0]], 1.0, 1.3).shape == (3, 2)


def test_sd_factorises_and_is_reciprocal():
    eta, sa, ssp = 1.3, 0.05, 1.2
    th_i, th_o = 0.3, 1.1
    wi = np.array([math.sin(th_i), 0, math.cos(th_i)])
    wo = np.array([0, math.sin(th_o), math.cos(th_o)])
    xi, xo = np.zeros(3), np.array([0.6, 0.8, 0.0])

    def ft(c):  # external incidence 1 → η, expressed through the internal formula by reciprocity of T
        s2 = (1 - c**2) / eta**2
        ct = math.sqrt(1 - s2)
        rs = (c - eta * ct) / (c + eta * ct)
        rp = (eta * c - ct) / (eta * c + ct)
        return 1 - 0.5 * (rs**2 + rp**2)

    for model in MODELS:
        ref = ft(wi[2]) * d.rd(1.0, sa, ssp, eta, model) * ft(wo[2]) / math.pi
        assert d.sd(xi, wi, xo, wo, sa, ssp, eta, model) == pytest.approx(ref, rel=1e-13)
        assert d.sd(xo, wo, xi, wi, sa, ssp, eta, model) == pytest.approx(ref, rel=1e-13)
        brdf = ft(wi[2]) * d.total_diffuse_reflectance(ssp / (sa + ssp), eta, model) * ft(wo[2]) / math.pi
        assert d.diffusion_brdf(wi, wo, sa, ssp, eta, model) == pytest.approx(brdf, rel=1e-13)
    assert d.ft(eta, 1.0) == pytest.approx(1 - ((eta - 1) / (eta + 1)) ** 2, rel=1e-14)
    assert d.sd(xi, -wi, xo, wo, sa, ssp, eta) == 0.0  # below the surface


def test_bad_inputs():
    P = subsurf.ParameterError
    with pytest.raises(P, match="sigma_a"):
        d.dipole_rd(1.0, -0.1, 1.0, 1.3)
    with pytest.raises(P, match=r"sigma_s_prime\[1\]"):
        d.dipole_rd(1.0, 0.1, [1.0, np.nan], 1.3)
    with pytest.raises(P, match="r = -1"):
        d.better_dipole_rd(-1.0, 0.1, 1.0, 1.3)
    with pytest.raises(P, match=r"eta .*\[1, 2.5\]"):
        d.dipole_rd(1.0, 0.1, 1.0, 0.9)
    with pytest.raises(P, match="eta"):
        d.total_diffuse_reflectance(0.5, 3.0)
    with pytest.raises(P, match="sigma_a \\+ sigma_s_prime"):
        d.dipole_rd(1.0, 0.0, 0.0, 1.3)
    with pytest.raises(P, match="alpha_prime"):
        d.total_diffuse_reflectance(1.5, 1.3)
    with pytest.raises(P, match="model"):
        d.rd(1.0, 0.1, 1.0, 1.3, model="multipole")
    with pytest.raises(P, match="not a number"):
        d.dipole_rd("x", 0.1, 1.0, 1.3)
    with pytest.raises(P, match="broadcast"):
        d.dipole_rd([1.0, 2.0], [0.1, 0.2, 0.3], 1.0, 1.3)
    with pytest.raises(P, match="wi"):
        d.sd(np.zeros(3), [0, 0, 2.0], np.zeros(3), [0, 0, 1.0], 0.1, 1.0, 1.3)
    with pytest.raises(P, match=r"\(\.\.\., 3\)"):
        d.sd(np.zeros(3), [0, 1.0], np.zeros(3), [0, 0, 1.0], 0.1, 1.0, 1.3)
    assert issubclass(P, ValueError)
