"""subsurf.testing: the χ² kit itself — special functions, pooling, Šidák, and that it can fail."""

import math

import numpy as np
import pytest
from subsurf import ParameterError, optics, testing


def test_special_functions_known_values():
    # χ² critical values (Abramowitz & Stegun Table 26.8) and closed forms.
    assert testing.chi2_sf(3.841458820694124, 1) == pytest.approx(0.05, abs=1e-10)
    assert testing.chi2_sf(23.209251158954356, 10) == pytest.approx(0.01, abs=1e-10)
    assert testing.chi2_sf(2.0, 1) == pytest.approx(math.erfc(1.0), rel=1e-12)
    for x in (0.1, 1.0, 7.5):
        assert testing.gamma_q(1.0, x) == pytest.approx(math.exp(-x), rel=1e-13)
        assert testing.gamma_q(0.5, x) == pytest.approx(math.erfc(math.sqrt(x)), rel=1e-12)
    assert testing.sidak_alpha(0.05, 2) == pytest.approx(1 - math.sqrt(0.95), rel=1e-14)
    with pytest.raises(ParameterError, match="significance"):
        testing.sidak_alpha(1.5, 2)
    with pytest.raises(ParameterError, match="dof"):
        testing.chi2_sf(1.0, 0)


def test_pooling_matches_hand_computation():
    r = testing.chi2_pooled([10, 1, 4, 2, 12], [12, 1, 2, 3, 10])
    assert r.statistic == pytest.approx(4 / 12 + 1 / 6 + 4 / 10, rel=1e-14)
    assert r.dof == 2 and r.pooled_cells == 3


def test_p_values_are_uniform_under_the_null(rng):
    # 300 tests of an exact uniform sampler: the count with p < 0.1 is Binomial(300, 0.1),
    # mean 30, σ ≈ 5.2 — accept within 4σ. Power: the band is ±21 of 30 (70 %), so only a gross
    # excess or deficit of small p-values (a count outside 9…51) fails.
    low = 0
    for _ in range(300):
        obs = np.bincount(rng.integers(0, 25, 500), minlength=25)
        low += testing.chi2_pooled(obs, np.full(25, 20.0)).p_value < 0.1
    assert abs(low - 30) < 4 * math.sqrt(300 * 0.09)


def test_kit_rejects_a_wrong_sampler(rng):
    # Sampling HG with g = 0.5 but testing against g = 0.6 must fail, in 2-D and 1-D. Power: a
    # relative deviation ±δ of the cells holding a fraction f of the probability adds
    # λ = N Σ(δp)²/p ≈ N f δ² to X²; g = 0.5 vs 0.6 gives λ ≈ 6100 at N = 10⁵ (2-D: 160 cells, 1-D:
    # 50 bins), far past the X² of p = 10⁻¹⁰ (≈ 300 and ≈ 140). The passing control (160 cells,
    # α = 0.01, λ ≳ 76 for probability 0.9) would fail for δ ≈ 2.8 % over the whole pdf.
    def sampler(n, rng):
        return np.stack([optics.sample_hg(rng.random(n), 0.5), 2 * math.pi * rng.random(n)], axis=-1)

    res = testing.chi2_test(
        sampler, lambda c, p: optics.hg_phase(c, 0.6), n_theta=40, n_phi=4, n_samples=100_000, seed=1
    )
    assert not res.passed and res.p_value < 1e-10, res
    ok = testing.chi2_test(
        sampler, lambda c, p: optics.hg_phase(c, 0.5), n_theta=40, n_phi=4, n_samples=100_000, seed=1
    )
    assert ok.passed, ok
    res1 = testing.chi2_test_1d(
        lambda n, rng: optics.sample_hg(rng.random(n), 0.5),
        lambda x: 2 * math.pi * optics.hg_phase(x, 0.6),
        n_samples=100_000,
        seed=2,
    )
    assert not res1.passed and res1.p_value < 1e-10
    # A misnormalised pdf (integral 1.02) is detected through the total count: every one of the 20
    # bins is 2 % short, λ ≈ 4·10⁵ × 0.02² ≈ 160 against a critical X² ≈ 36 (α = 0.01, 19 dof).
    bad = testing.chi2_test_1d(rng.random(400_000), lambda x: np.full_like(x, 1.02), range=(0, 1), n_bins=20)
    assert not bad.passed and bad.pdf_integral == pytest.approx(1.02)
    # A sample outside the pdf's support (pdf = 1 on [0, 1], 0 on (1, 2]) fails outright; the
    # same samples without it pass.
    s = rng.random(10_000)
    pdf = lambda x: (x <= 1.0).astype(float)  # noqa: E731
    assert testing.chi2_test_1d(s, pdf, range=(0, 2), n_bins=20).passed
    out = testing.chi2_test_1d(np.append(s, 1.5), pdf, range=(0, 2), n_bins=20)
    assert out.p_value == 0.0 and math.isinf(out.statistic) and out.outside == 0


def test_directions_and_input_checks(rng):
    d = optics.sample_cosine_hemisphere(rng.random(1000), rng.random(1000))
    cp = testing.to_cos_phi(d)
    assert cp.shape == (1000, 2) and np.all((cp[:, 1] >= 0) & (cp[:, 1] < 2 * math.pi))
    with pytest.raises(ParameterError, match="samples"):
        testing.chi2_test(np.zeros((5, 4)), lambda c, p: c)
    with pytest.raises(ParameterError, match="cos_edges"):
        testing.chi2_test(np.zeros((5, 2)), lambda c, p: c, cos_edges=[0.0, 0.0])
