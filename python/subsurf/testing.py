"""A χ² goodness-of-fit kit for testing samplers (yours and ours).

How it works (after Mitsuba 3's ``chi2.py``): draw N samples of a direction, histogram them on
a grid of (cos θ, φ) cells, integrate the claimed pdf over every cell to get the expected
counts, pool all cells whose expected count is below ``min_expected`` (5, Cochran's rule) into
one cell, and compute Pearson's statistic X² = Σ (O − E)²/E with ``cells − 1`` degrees of
freedom. The test passes when the p-value exceeds the Šidák-corrected per-test significance
α_i = 1 − (1 − α)^(1/m) for ``tests = m`` tests at overall level α — so a suite of m tests
fails by chance with probability α only. Samples outside the grid go into an extra cell whose
expected count is N − Σ E: a pdf whose integral is not 1, or a sample where the pdf is 0,
makes the test fail. All of this is computed by the Rust core (``subsurf_core::stats``, the
same code the Rust tests use); the pdf is called with arrays, once per row of cells and
refinement.

Example — test your own phase-function sampler about the +z axis::

    import numpy as np
    from subsurf import optics, testing

    def sampler(n, rng):                       # returns (cos θ, φ) pairs, shape (n, 2)
        cos = optics.sample_hg(rng.random(n), 0.7)
        return np.stack([cos, 2 * np.pi * rng.random(n)], axis=-1)

    res = testing.chi2_test(sampler, lambda c, p: optics.hg_phase(c, 0.7),
                            cos_edges=testing.graded_cos_edges(), tests=1)
    assert res.passed, res

Use fixed seeds (``seed=``) so a test is reproducible; choose N so that most cells have an
expected count well above 5.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from . import _core

__all__ = [
    "Chi2Result",
    "chi2_test",
    "chi2_test_1d",
    "chi2_pooled",
    "chi2_sf",
    "gamma_q",
    "sidak_alpha",
    "graded_cos_edges",
    "to_cos_phi",
]


@dataclass(frozen=True)
class Chi2Result:
    """Outcome of a χ² test.

    Attributes
    ----------
    statistic : Pearson's X² over the pooled cells (``inf`` if a sample fell where E = 0).
    dof : degrees of freedom (cells after pooling − 1).
    p_value : P(X² ≥ statistic) under the null hypothesis.
    significance : the per-test level α_i the p-value was compared with (Šidák-corrected).
    passed : ``p_value > significance``.
    pooled_cells : how many cells were pooled because their expected count was < min_expected.
    n_samples : number of samples tested.
    outside : samples that fell outside the grid.
    pdf_integral : ∫ pdf over the grid (should be 1 when the grid covers the pdf's domain).
    quadrature_error : estimated absolute error of the largest expected count (in counts).
    """

    statistic: float
    dof: int
    p_value: float
    significance: float
    passed: bool
    pooled_cells: int = 0
    n_samples: int = 0
    outside: int = 0
    pdf_integral: float = float("nan")
    quadrature_error: float = 0.0

    def __bool__(self) -> bool:
        return self.passed


def chi2_sf(statistic: float, dof: float) -> float:
    """χ² survival function P(X² ≥ statistic) = Q(dof/2, statistic/2) (regularised upper
    incomplete gamma, Numerical Recipes §6.2)."""
    return _core.chi2_sf(float(statistic), float(dof))


def gamma_q(a: float, x: float) -> float:
    """Regularised upper incomplete gamma function Q(a, x) = Γ(a, x)/Γ(a), a > 0, x ≥ 0."""
    return _core.gamma_q(float(a), float(x))


def sidak_alpha(significance: float, tests: int) -> float:
    """Šidák per-test level 1 − (1 − α)^(1/m) for ``tests = m`` independent tests at overall
    level α = ``significance`` (Šidák 1967)."""
    return _core.sidak_alpha(float(significance), int(tests))


def graded_cos_edges(n_end: int = 12, n_mid: int = 16, min_gap: float = 1e-5) -> np.ndarray:
    """Bin edges on [−1, 1] refined geometrically towards both poles (``n_end`` cells per side
    from width ``min_gap`` up to a total of 0.1, ``n_mid`` equal cells on [−0.9, 0.9]) —
    for peaked pdfs such as Henyey–Greenstein with |g| → 1."""
    return _core.graded_cos_edges(int(n_end), int(n_mid), float(min_gap))


def chi2_pooled(
    observed, expected, *, min_expected: float = 5.0, significance: float = 0.01, tests: int = 1
) -> Chi2Result:
    """Pearson's χ² of observed against expected counts (any shape, flattened), pooling every
    cell with expected count < ``min_expected`` into one cell. Degrees of freedom: cells − 1
    (the caller's expected counts should sum to the number of samples)."""
    o = np.ascontiguousarray(np.asarray(observed, dtype=np.float64).ravel())
    e = np.ascontiguousarray(np.asarray(expected, dtype=np.float64).ravel())
    stat, dof, p, pooled = _core.chi2_pooled(o, e, float(min_expected))
    alpha = sidak_alpha(significance, tests)
    return Chi2Result(stat, dof, p, alpha, bool(p > alpha), pooled, int(round(o.sum())))


def to_cos_phi(directions) -> np.ndarray:
    """Unit vectors (..., 3) → (cos θ, φ) pairs (..., 2) with θ from +z and φ ∈ [0, 2π)."""
    d = np.asarray(directions, dtype=np.float64)
    phi = np.mod(np.arctan2(d[..., 1], d[..., 0]), 2.0 * math.pi)
    return np.stack([np.clip(d[..., 2], -1.0, 1.0), phi], axis=-1)


def _samples_2d(samples, n_samples: int, seed: int) -> np.ndarray:
    if callable(samples):
        samples = samples(int(n_samples), np.random.default_rng(seed))
    s = np.asarray(samples, dtype=np.float64)
    if s.ndim != 2 or s.shape[1] not in (2, 3):
        raise _core.ParameterError(
            f"samples: expected shape (N, 2) of (cos θ, φ) or (N, 3) unit vectors, got {s.shape}"
        )
    return to_cos_phi(s) if s.shape[1] == 3 else s


def _edges(edges, n: int, lo: float, hi: float) -> np.ndarray:
    """Explicit edges, or ``n`` equal cells over [lo, hi] (the core checks them)."""
    if edges is None:
        return np.linspace(lo, hi, max(int(n), 1) + 1)
    return np.asarray(edges, dtype=np.float64).ravel()


def _batch(pdf: Callable):
    """The user's vectorised pdf as the core calls it: flat float64 arrays in, one value per point out."""

    def call(*coords):
        v = np.asarray(pdf(*coords), dtype=np.float64)
        return np.ascontiguousarray(np.broadcast_to(v, coords[0].shape), dtype=np.float64).ravel()

    return call


def _grid_test(samples, edges, names, pdf, min_expected, quad_points, max_subdivisions, significance, tests):
    """Histogram, cell probabilities, pooling and Pearson's χ²: the core's test on a grid
    (``subsurf_core::stats::grid``), shared with the Rust tests."""
    flat = lambda a: np.ascontiguousarray(a, dtype=np.float64).ravel()  # noqa: E731
    stat, dof, p, pooled, outside, integral, qerr = _core.chi2_test_grid(
        [flat(x) for x in samples],
        [flat(e) for e in edges],
        list(names),
        _batch(pdf),
        float(min_expected),
        int(quad_points),
        int(max_subdivisions),
    )
    alpha = sidak_alpha(significance, tests)
    n = len(samples[0])
    return Chi2Result(stat, dof, p, alpha, bool(p > alpha), pooled, int(n), int(outside), float(integral), qerr)


def chi2_test(
    samples,
    pdf: Callable,
    *,
    n_theta: int = 20,
    n_phi: int = 16,
    cos_edges=None,
    phi_edges=None,
    cos_range: tuple[float, float] = (-1.0, 1.0),
    significance: float = 0.01,
    tests: int = 1,
    n_samples: int = 1_000_000,
    seed: int = 0,
    min_expected: float = 5.0,
    quad_points: int = 6,
    max_subdivisions: int = 32,
) -> Chi2Result:
    """χ² test of directions against a pdf with respect to solid angle (dω = d cos θ dφ).

    Parameters
    ----------
    samples : array (N, 2) of (cos θ, φ), or (N, 3) unit vectors, or a callable
        ``sampler(n, rng)`` returning either (called with ``n_samples`` and
        ``numpy.random.default_rng(seed)``).
    pdf : vectorised ``pdf(cos_theta, phi)`` in sr⁻¹ (φ in [0, 2π)).
    n_theta, n_phi : equal cells over ``cos_range`` and [0, 2π) unless ``cos_edges`` /
        ``phi_edges`` give explicit edges (e.g. :func:`graded_cos_edges` for peaked pdfs).
    significance, tests : overall level α and number m of tests in the suite (Šidák).
    min_expected : cells with a smaller expected count are pooled.
    quad_points, max_subdivisions : per-cell Gauss–Legendre order and the largest number of
        sub-cells per axis of the refinement (stopped when cell probabilities change < 1e-10).
    """
    s = _samples_2d(samples, n_samples, seed)
    ce = _edges(cos_edges, n_theta, *cos_range)
    pe = _edges(phi_edges, n_phi, 0.0, 2.0 * math.pi)
    return _grid_test(
        (s[:, 0], s[:, 1]),
        (ce, pe),
        ("cos_edges", "phi_edges"),
        pdf,
        min_expected,
        quad_points,
        max_subdivisions,
        significance,
        tests,
    )


def chi2_test_1d(
    samples,
    pdf: Callable,
    *,
    n_bins: int = 50,
    edges=None,
    range: tuple[float, float] = (-1.0, 1.0),
    significance: float = 0.01,
    tests: int = 1,
    n_samples: int = 1_000_000,
    seed: int = 0,
    min_expected: float = 5.0,
    quad_points: int = 8,
    max_subdivisions: int = 1024,
) -> Chi2Result:
    """χ² test of scalar samples (e.g. cos θ alone) against a 1-D density ``pdf(x)``.

    ``samples``: array (N,) or a callable ``sampler(n, rng)``. Note that the density of cos θ
    for a phase function p (sr⁻¹) is 2π p(cos θ). Other arguments as :func:`chi2_test`.
    """
    if callable(samples):
        samples = samples(int(n_samples), np.random.default_rng(seed))
    x = np.asarray(samples, dtype=np.float64).ravel()
    e = _edges(edges, n_bins, *range)
    return _grid_test((x,), (e,), ("bin_edges",), pdf, min_expected, quad_points, max_subdivisions, significance, tests)
