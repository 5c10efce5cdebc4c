"""subsurf.optics: closed forms, reference values, χ² of the samplers."""

import math

import numpy as np
import pytest
from subsurf import ParameterError, optics, testing

# ---------------------------------------------------------------------------- Fresnel


@pytest.mark.parametrize("n1, n2", [(1.0, 1.5), (1.5, 1.0), (1.33, 1.4), (1.0, 2.4)])
def test_normal_incidence(n1, n2):
    r = ((n1 - n2) / (n1 + n2)) ** 2
    for pol in ("unpolarized", "s", "p"):
        assert optics.fresnel_reflectance(1.0, n1, n2, pol) == pytest.approx(r, abs=1e-15)


def test_brewster_and_sum_rules():
    for n1, n2 in [(1.0, 1.5), (1.5, 1.0), (1.0, 1.33)]:
        tb = math.atan(n2 / n1)
        assert optics.fresnel_reflectance(math.cos(tb), n1, n2, "p") < 1e-28
        assert optics.fresnel_reflectance(math.cos(tb), n1, n2, "s") > 0.01
    cos = np.linspace(-1, 1, 101)
    for pol in ("unpolarized", "s", "p"):
        r = optics.fresnel_reflectance(cos, 1.0, 1.4, pol)
        t = optics.fresnel_transmittance(cos, 1.0, 1.4, pol)
        np.testing.assert_allclose(r + t, 1.0, atol=1e-15)
        assert np.all((r >= 0) & (r <= 1))
    # Unpolarised = mean of s and p; grazing incidence reflects everything.
    rs = optics.fresnel_reflectance(cos, 1.4, 1.0, "s")
    rp = optics.fresnel_reflectance(cos, 1.4, 1.0, "p")
    np.testing.assert_allclose(optics.fresnel_reflectance(cos, 1.4, 1.0), 0.5 * (rs + rp), atol=1e-15)
    assert optics.fresnel_reflectance(0.0, 1.0, 1.5) == pytest.approx(1.0)


def test_total_internal_reflection_both_directions():
    # From the dense side past the critical angle R = 1; from the light side never.
    for n_dense in (1.33, 1.5, 2.0):
        tc = math.asin(1 / n_dense)
        past = np.cos(np.linspace(tc + 1e-6, math.pi / 2, 50))
        np.testing.assert_array_equal(optics.fresnel_reflectance(past, n_dense, 1.0), 1.0)
        np.testing.assert_array_equal(optics.fresnel_reflectance(-past, n_dense, 1.0), 1.0)  # sign ignored
        assert optics.fresnel_reflectance(math.cos(tc - 1e-3), n_dense, 1.0) < 1.0
        assert np.all(optics.fresnel_reflectance(past, 1.0, n_dense) < 1.0)
        assert np.all(optics.fresnel_transmittance(past, n_dense, 1.0, "s") == 0.0)


def test_fresnel_broadcasting_and_scalars():
    r = optics.fresnel_reflectance(np.array([[1.0], [0.5]]), 1.0, np.array([1.3, 1.5, 2.0]))
    assert r.shape == (2, 3)
    assert isinstance(optics.fresnel_reflectance(0.3, 1.0, 1.5), float)
    assert r[0, 1] == pytest.approx(0.04)


def test_refract_snell_and_tir_nan(rng):
    th = rng.uniform(0, math.pi / 2 - 1e-3, 200)
    ph = rng.uniform(0, 2 * math.pi, 200)
    d = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), -np.cos(th)], axis=-1)
    t = optics.refract(d, [0.0, 0.0, 1.0], 1.0, 1.4)
    sin_t = np.hypot(t[:, 0], t[:, 1])
    np.testing.assert_allclose(1.4 * sin_t, np.sin(th), atol=1e-13)
    np.testing.assert_allclose(np.linalg.norm(t, axis=-1), 1.0, atol=1e-13)
    assert np.all(t[:, 2] < 0)
    # Same plane of incidence: t, d and n coplanar.
    np.testing.assert_allclose(np.cross(d, t) @ np.array([0, 0, 1.0]), 0, atol=1e-13)
    # From the dense side: NaN rows exactly where sin θ > 1/1.5.
    t2 = optics.refract(d, [0.0, 0.0, -1.0], 1.5, 1.0)
    tir = np.sin(th) > 1 / 1.5
    assert np.all(np.isnan(t2[tir])) and not np.any(np.isnan(t2[~tir]))
    r = optics.reflect(d, [0.0, 0.0, 1.0])
    np.testing.assert_allclose(r, d * [1, 1, -1], atol=1e-15)


# ---------------------------------------------------------------------------- diffuse Fresnel

TABLE = [(1.3, 0.44446, 0.06113), (1.4, 0.52899, 0.07681), (1.5, 0.59635, 0.09178)]


@pytest.mark.parametrize("eta, internal, external", TABLE)
def test_diffuse_fresnel_reference(eta, internal, external):
    assert optics.diffuse_fresnel_reflectance(eta) == pytest.approx(internal, abs=5e-6)
    assert optics.diffuse_fresnel_reflectance(eta, internal=False) == pytest.approx(external, abs=5e-6)


def test_diffuse_fresnel_identity_moments_and_fit():
    eta = np.array([0.8, 1.05, 1.2, 1.33, 1.5, 2.0])
    fi = optics.diffuse_fresnel_reflectance(eta)
    fe = optics.diffuse_fresnel_reflectance(eta, internal=False)
    np.testing.assert_allclose(fi, 1 - (1 - fe) / eta**2, atol=1e-10)
    np.testing.assert_allclose(2 * optics.fresnel_moment1(eta), fi, atol=1e-14)
    # Independent check with numpy quadrature of the Fresnel function itself (fine grid,
    # midpoint rule on a μ-grid split at the critical cosine).
    for e in (1.3, 1.5):
        mu_c = math.sqrt(1 - 1 / e**2)
        s = (np.arange(200_000) + 0.5) / 200_000
        mu = mu_c + (1 - mu_c) * s**2
        w = 2 * (1 - mu_c) * s / 200_000
        c2 = mu_c**3 / 3 + np.sum(optics.fresnel_reflectance(mu, e, 1.0) * mu**2 * w)
        assert optics.fresnel_moment2(e) == pytest.approx(c2, abs=1e-9)
    etas = np.linspace(1.0, 1.6, 61)
    err = np.abs(optics.diffuse_fresnel_reflectance_fit(etas) - optics.diffuse_fresnel_reflectance(etas))
    assert err.max() < 2e-3


# ---------------------------------------------------------------------------- phase functions

GS = [-0.9, -0.3, 0.0, 0.5, 0.9, 0.99]
N_TESTS = len(GS) + 2  # HG values + mixture + cosine hemisphere, one family at α = 0.01
# Power of the χ² tests below: a relative deviation ±δ of the cell probabilities over cells holding
# a fraction f of the probability adds λ = N Σ(δp)²/p ≈ N f δ² to X²; the test fails with
# probability 0.9 once λ exceeds the non-central χ² value for its cells at α_i = 1.3·10⁻³ (Šidák
# over N_TESTS): λ ≈ 93 on 160 cells, 54 on 40 bins, 110 on 240 cells (scipy.stats.ncx2).


def _integrate_cos(f, n=4000):
    # Gauss–Legendre on a grid graded towards both poles (for peaked HG).
    e = testing.graded_cos_edges(40, 40, 1e-7)
    x, w = np.polynomial.legendre.leggauss(20)
    a, b = e[:-1, None], e[1:, None]
    pts = 0.5 * (a + b) + 0.5 * (b - a) * x
    return float(np.sum(f(pts) * 0.5 * (b - a) * w))


@pytest.mark.parametrize("g", GS + [-0.99, 0.999])
def test_hg_normalisation_and_mean_cosine(g):
    norm = 2 * math.pi * _integrate_cos(lambda c: optics.hg_phase(c, g))
    mean = 2 * math.pi * _integrate_cos(lambda c: c * optics.hg_phase(c, g))
    assert norm == pytest.approx(1.0, abs=1e-9)
    assert mean == pytest.approx(g, abs=1e-9)


@pytest.mark.parametrize("g", GS)
def test_hg_sampling_chi2(g):
    # Power: 4·10⁵ samples on 40 graded cos θ × 4 φ cells (λ ≳ 93): δ ≈ 1.5 % over the whole pdf,
    # ≈ 5 % over a tenth of it, fails.
    def sampler(n, rng):
        return np.stack([optics.sample_hg(rng.random(n), g), 2 * math.pi * rng.random(n)], axis=-1)

    res = testing.chi2_test(
        sampler,
        lambda c, p: optics.hg_pdf(c, g),
        cos_edges=testing.graded_cos_edges(),
        n_phi=4,
        n_samples=400_000,
        seed=1000 + GS.index(g),
        tests=N_TESTS,
    )
    assert res.passed, res
    assert res.pdf_integral == pytest.approx(1.0, abs=1e-8)


def test_mixture_phase_and_sampling():
    lobes = [(0.7, 0.8), (0.3, -0.4)]
    c = np.linspace(-1, 1, 11)
    np.testing.assert_allclose(
        optics.mixture_phase(c, lobes), 0.7 * optics.hg_phase(c, 0.8) + 0.3 * optics.hg_phase(c, -0.4), rtol=1e-14
    )
    assert 2 * math.pi * _integrate_cos(lambda x: x * optics.mixture_phase(x, lobes)) == pytest.approx(
        0.7 * 0.8 - 0.3 * 0.4, abs=1e-9
    )
    # Power: 4·10⁵ samples on 40 graded cos θ bins (λ ≳ 54): δ ≈ 1.2 % over the whole pdf, ≈ 4 %
    # over a tenth of it, fails.
    res = testing.chi2_test_1d(
        lambda n, rng: optics.sample_mixture(rng.random(n), lobes),
        lambda x: 2 * math.pi * optics.mixture_phase(x, lobes),
        edges=testing.graded_cos_edges(),
        n_samples=400_000,
        seed=7,
        tests=N_TESTS,
    )
    assert res.passed, res
    # weights are normalised
    np.testing.assert_allclose(
        optics.mixture_phase(c, [(7, 0.8), (3, -0.4)]), optics.mixture_phase(c, lobes), rtol=1e-14
    )


def test_isotropic_and_hg_limits():
    assert optics.isotropic_phase() == pytest.approx(1 / (4 * math.pi))
    np.testing.assert_allclose(optics.hg_phase(np.linspace(-1, 1, 5), 0.0), 1 / (4 * math.pi), rtol=1e-15)
    for g in (-0.9999999, 0.9999999, 1e-9, -1e-9, 0.0):
        v = optics.hg_phase(np.array([-1.0, 0.0, 1.0]), g)
        assert np.all(np.isfinite(v) & (v > 0))
        s = optics.sample_hg(np.linspace(0, 1, 101), g)
        assert np.all(np.isfinite(s) & (s >= -1) & (s <= 1)) and np.all(np.diff(s) >= 0)
    # peak closed form p(1) = (1 + g) / (4π (1 − g)²)
    g = 0.9999
    assert optics.hg_phase(1.0, g) == pytest.approx((1 + g) / (4 * math.pi * (1 - g) ** 2), rel=1e-12)


def test_cosine_hemisphere_chi2_and_beer_lambert(rng):
    # Power: 3·10⁵ samples on 20 × 12 cells (λ ≳ 110): δ ≈ 1.9 % over the whole pdf, ≈ 6 % over a
    # tenth of it, fails.
    def sampler(n, rng):
        return optics.sample_cosine_hemisphere(rng.random(n), rng.random(n))

    res = testing.chi2_test(
        sampler,
        lambda c, p: optics.cosine_hemisphere_pdf(c),
        cos_range=(0.0, 1.0),
        n_theta=20,
        n_phi=12,
        n_samples=300_000,
        seed=3,
        tests=N_TESTS,
    )
    assert res.passed and res.outside == 0, res
    assert optics.beer_lambert(2.0, 0.5) == pytest.approx(math.exp(-1.0), rel=1e-15)
    assert optics.beer_lambert(1.0, math.inf) == 0.0 and optics.beer_lambert(0.0, math.inf) == 1.0
    # free paths: sample mean 1/σt within 4 standard errors (the band is 0.9 % of 1/σt: a 1 % bias fails)
    s = optics.sample_free_path(rng.random(200_000), 4.0)
    assert abs(s.mean() - 0.25) < 4 * 0.25 / math.sqrt(s.size)
    assert optics.free_path_pdf(0.0, 4.0) == 4.0 and optics.free_path_pdf(-1.0, 4.0) == 0.0


# ---------------------------------------------------------------------------- validation


@pytest.mark.parametrize(
    "call, field",
    [
        (lambda: optics.hg_phase(0.5, 1.0), "g"),
        (lambda: optics.hg_phase(0.5, -1.2), "g"),
        (lambda: optics.sample_hg(0.5, math.nan), "g"),
        (lambda: optics.sample_hg(1.5, 0.3), "u"),
        (lambda: optics.hg_phase(1.5, 0.3), "cos_theta"),
        (lambda: optics.fresnel_reflectance(0.5, 0.0, 1.5), "eta_i"),
        (lambda: optics.fresnel_reflectance(0.5, 1.0, math.nan), "eta_t"),
        (lambda: optics.fresnel_reflectance(0.5, 1.0, 1.5, "x"), "polarization"),
        (lambda: optics.fresnel_reflectance(2.0, 1.0, 1.5), "cos_theta_i"),
        (lambda: optics.refract([0, 0, -1.0], [0, 0, 1.0], -1.0, 1.5), "eta_i"),
        (lambda: optics.diffuse_fresnel_reflectance(0.0), "eta"),
        (lambda: optics.diffuse_fresnel_reflectance(math.nan), "eta"),
        (lambda: optics.diffuse_fresnel_reflectance_fit(0.9), "eta"),
        (lambda: optics.fresnel_moment1(-1.0), "eta"),
        (lambda: optics.mixture_phase(0.1, [(1.0, 1.0)]), "g"),
        (lambda: optics.mixture_phase(0.1, [(-1.0, 0.1), (2.0, 0.2)]), "weight"),
        (lambda: optics.beer_lambert(-1.0, 1.0), "mu_t"),
        (lambda: optics.beer_lambert(1.0, -1.0), "distance"),
        (lambda: optics.sample_free_path(0.5, 0.0), "sigma_t"),
        (lambda: optics.refract([1.0, 0.0], [0, 0, 1.0], 1.0, 1.5), "d"),
    ],
)
def test_bad_arguments_raise_parameter_error(call, field):
    with pytest.raises(ParameterError, match=field):
        call()
