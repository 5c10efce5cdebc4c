"""Monte Carlo engine: validation against exact transport results and closed forms.

All statistical checks use fixed seeds and 4 standard errors as reported by the run (plus half a
unit in the last digit of a published reference value). Units: the references are quoted in cm;
μ in cm⁻¹ × 0.1 → mm⁻¹, d in cm × 10 → mm.
"""

import math
import os
import signal
import warnings

import numpy as np
import pytest
import subsurf
from subsurf import DiffuseIllumination, Layer, ParameterError, PencilBeam, Stack, simulate


def close(value, stderr, want, k=4.0, ref_halfulp=0.0):
    assert stderr > 0 and math.isfinite(stderr)
    assert abs(value - want) <= k * stderr + ref_halfulp, (
        f"{value} ± {stderr} vs {want} ({(value - want) / stderr:+.2f}σ)"
    )


def fresnel(cos_i, n1, n2):
    """Unpolarised Fresnel reflectance (Born & Wolf §1.5.2), written out independently here."""
    sin_t = n1 / n2 * math.sqrt(max(0.0, 1 - cos_i**2))
    if sin_t >= 1:
        return 1.0
    cos_t = math.sqrt(1 - sin_t**2)
    rs = (n1 * cos_i - n2 * cos_t) / (n1 * cos_i + n2 * cos_t)
    rp = (n2 * cos_i - n1 * cos_t) / (n2 * cos_i + n1 * cos_t)
    return 0.5 * (rs * rs + rp * rp)


SLAB_A = Stack([Layer(1.0, 1.0, 9.0, 0.75, 0.2)], 1.0, 1.0)  # van de Hulst / MCML case (a)


def test_van_de_hulst_slab():
    # van de Hulst (1980) as tabulated in Wang, Jacques & Zheng 1995 (Table 2):
    # Rd = 0.09739, Tt = 0.66096 for n = 1, μa = 10, μs = 90 /cm, g = 0.75, d = 0.02 cm.
    # Power: σ ≈ √(p(1−p)/N) at 4·10⁵ photons, so the 4σ band is ≈ 1.9 % of Rd, 0.45 % of Tt and
    # 1.6 % of the unscattered e⁻²: a 2 % bias of Rd or 0.5 % of Tt fails.
    r = simulate(SLAB_A, photons=400_000, seed=1)
    close(r.diffuse_reflectance, r.diffuse_reflectance_stderr, 0.09739, ref_halfulp=5e-6)
    close(r.transmittance, r.transmittance_stderr, 0.66096, ref_halfulp=5e-6)
    close(r.unscattered_transmittance, r.unscattered_transmittance_stderr, math.exp(-2.0))
    assert r.specular_reflectance == 0.0
    assert abs(r.energy_balance - 1.0) < 1e-12
    assert r.photons == r.photons_requested == 400_000 and not r.partial
    assert r.events > r.photons and r.elapsed_s > 0
    assert r.absorbed_per_layer.shape == (1,)
    assert r.absorbed_per_layer[0] + r.roulette == pytest.approx(r.absorbed, abs=1e-12)


def test_giovanelli_semi_infinite():
    # Giovanelli (1955), as quoted by Wang et al. 1995: n = 1.5 in air, g = 0, μa = 10,
    # μs = 90 /cm, semi-infinite: specular + diffuse reflectance = 0.2600 (specular = 0.04).
    s = Stack([Layer(1.5, 1.0, 9.0, 0.0, math.inf)], 1.0, 1.0)
    # Power: the diffuse part (≈ 0.22) at 2·10⁵ photons has 4σ ≈ 3.7·10⁻³, 1.7 % of it (1.4 % of
    # 0.26): a 2 % bias of the diffuse reflectance fails.
    r = simulate(s, photons=200_000, seed=2)
    assert r.specular_reflectance == pytest.approx(0.04, abs=1e-12)
    close(r.specular_reflectance + r.diffuse_reflectance, r.diffuse_reflectance_stderr, 0.2600, ref_halfulp=5e-5)
    assert r.transmittance == 0.0
    assert abs(r.energy_balance - 1.0) < 1e-12


@pytest.mark.parametrize(
    "albedo, rd, photons", [(0.8, 0.28525, 200_000), (0.9, 0.41495, 200_000), (0.99, 0.75272, 50_000)]
)
def test_exact_semi_infinite_isotropic(albedo, rd, photons):
    # Exact (H-function) diffuse reflectance of a semi-infinite, index-matched, isotropically
    # scattering medium at normal incidence (van de Hulst 1980; Giovanelli 1955). Power:
    # 4σ ≈ 4√(Rd(1−Rd)/N) is 1.4 % (albedo 0.8), 1.1 % (0.9) and 1.0 % (0.99, 5·10⁴ photons) of
    # Rd: a 1.5 % bias fails.
    s = Stack([Layer(1.0, 1.0 - albedo, albedo, 0.0, math.inf)], 1.0, 1.0)
    r = simulate(s, photons=photons, seed=3)
    close(r.diffuse_reflectance, r.diffuse_reflectance_stderr, rd, ref_halfulp=5e-6)
    assert abs(r.energy_balance - 1.0) < 1e-12


def test_glass_slab():
    # Clear slab n = 1.5 in air, normal incidence; incoherent multiple reflections:
    # R = R0 + (1 − R0)² R0 / (1 − R0²) = 2 R0 / (1 + R0), T = 1 − R.
    s = Stack([Layer(1.5, 0.0, 0.0, 0.0, 2.0)], 1.0, 1.0)
    # Power: only the diffuse part (≈ 0.037) is random; at 2·10⁵ photons its 4σ ≈ 1.7·10⁻³ is
    # 2.2 % of R = 0.077: a 2.5 % error in R fails.
    r = simulate(s, photons=200_000, seed=4)
    r0 = ((1.5 - 1) / (1.5 + 1)) ** 2
    close(r.specular_reflectance + r.diffuse_reflectance, r.diffuse_reflectance_stderr, 2 * r0 / (1 + r0))
    assert r.absorbed == 0.0 and r.events == 0
    assert r.unscattered_transmittance == r.transmittance
    assert abs(r.energy_balance - 1.0) < 1e-12


def test_oblique_pencil_specular_is_fresnel():
    s = Stack([Layer(1.4, 0.1, 10.0, 0.9, 1.0)], 1.0, 1.0)
    r = simulate(s, photons=2_000, seed=5, source=PencilBeam(theta=1.0, phi=0.5))
    assert r.specular_reflectance == pytest.approx(fresnel(math.cos(1.0), 1.0, 1.4), rel=1e-12)
    assert r.specular_reflectance_stderr < 1e-12
    assert abs(r.energy_balance - 1.0) < 1e-12


def test_diffuse_illumination_specular():
    # Lambertian light from air onto n = 1.5: the specular reflectance is the cosine-weighted
    # hemispherical average 2∫₀¹ R(μ) μ dμ, here by Gauss–Legendre quadrature. Power: the
    # per-photon R(μ) has sd ≈ 0.10 about the mean 0.092, so at 10⁵ photons the 4σ band is 1.4 %
    # of it: a 1.5 % error fails.
    s = Stack([Layer(1.5, 0.5, 5.0, 0.5, math.inf)], 1.0, 1.0)
    r = simulate(s, photons=100_000, seed=6, source=DiffuseIllumination())
    x, w = np.polynomial.legendre.leggauss(200)
    mu = 0.5 * (x + 1)
    want = float(np.sum(0.5 * w * 2 * mu * np.array([fresnel(m, 1.0, 1.5) for m in mu])))
    close(r.specular_reflectance, r.specular_reflectance_stderr, want)
    assert abs(r.energy_balance - 1.0) < 1e-12
    assert r.config["source"] == {"type": "diffuse"}


MULTI = Stack(
    [
        Layer(1.5, 0.0, 0.0, 0.0, 0.1),
        Layer(1.4, 0.1, 10.0, 0.9, 0.1),
        Layer(1.33, 0.05, 15.0, 0.85, 2.0),
        Layer(1.4, 0.02, 12.0, 0.0, math.inf, phase=[(0.8, 0.9), (0.2, -0.2)]),
    ],
    1.0,
    1.3,
)


@pytest.mark.slow
@pytest.mark.parametrize("source", [PencilBeam(), PencilBeam(0.7, 2.0), DiffuseIllumination()])
def test_energy_balance_and_thread_invariance(source):
    a = simulate(MULTI, photons=9_000, seed=7, threads=1, source=source)
    b = simulate(MULTI, photons=9_000, seed=7, threads=2, source=source)
    c = simulate(MULTI, photons=9_000, seed=7, threads=2, source=source)
    assert abs(a.energy_balance - 1.0) < 1e-12
    for name in subsurf.result.TOTALS:
        assert getattr(a, name) == getattr(b, name) == getattr(c, name)
        assert getattr(a, name + "_stderr") == getattr(b, name + "_stderr")
    assert np.array_equal(a.absorbed_per_layer, b.absorbed_per_layer)
    assert a.events == b.events
    d = simulate(MULTI, photons=9_000, seed=8, threads=1, source=source)
    assert d.diffuse_reflectance != a.diffuse_reflectance


def test_result_provenance():
    r = simulate(SLAB_A, photons=100, seed=2**64 - 1)
    assert r.seed == 2**64 - 1 and r.version == subsurf.__version__
    assert r.config["stack"]["layers"][0] == {"n": 1.0, "mua": 1.0, "mus": 9.0, "thickness": 0.2, "g": 0.75}
    assert r.config["source"] == {"type": "pencil", "theta": 0.0, "phi": 0.0}
    assert r.config["tallies"] is None
    r2 = simulate(SLAB_A.layers[0], photons=100, seed=2**64 - 1)  # a Layer is a one-layer stack
    assert r2.diffuse_reflectance == r.diffuse_reflectance


@pytest.mark.parametrize(
    "kwargs, field",
    [
        (dict(photons=0), "photons"),
        (dict(photons=-5), "photons"),
        (dict(photons=1.5), "photons"),
        (dict(photons=True), "photons"),
        (dict(photons="10"), "photons"),
        (dict(seed=-1), "seed"),
        (dict(seed=2**64), "seed"),
        (dict(seed=0.5), "seed"),
        (dict(threads=0), "threads"),
        (dict(threads=2.0), "threads"),
        (dict(tallies=object()), "tallies"),
        (dict(source="pencil"), "source"),
        (dict(progress=5), "progress"),
    ],
)
def test_bad_input(kwargs, field):
    args = dict(stack=SLAB_A, photons=10)
    args.update(kwargs)
    with pytest.raises(ParameterError, match=f"^{field}"):
        simulate(**args)


@pytest.mark.parametrize("theta", [-0.1, math.pi / 2, math.nan, "x"])
def test_bad_source(theta):
    with pytest.raises(ParameterError, match="^source.theta"):
        PencilBeam(theta=theta)


def test_bad_stack():
    with pytest.raises(ParameterError, match="^stack"):
        simulate([Layer(1.0, 1.0, 9.0)], photons=10)


HEAVY = Stack([Layer(1.4, 0.001, 100.0, 0.0, math.inf)], 1.0, 1.0)  # ~5·10³ events per photon
HEAVIER = Stack([Layer(1.4, 1e-4, 100.0, 0.0, math.inf)], 1.0, 1.0)  # a chunk takes seconds
MEDIUM = Stack([Layer(1.4, 0.05, 50.0, 0.0, math.inf)], 1.0, 1.0)  # ~5·10² events per photon
CHUNK = subsurf.state.CHUNK_PHOTONS


def _interrupt_after(photons_traced, signal_it=False):
    """A progress callback that interrupts the run (raising KeyboardInterrupt, or sending SIGINT
    as Ctrl-C does) once `photons_traced` photons were traced: a deterministic Ctrl-C."""

    def progress(done, total):
        if done >= photons_traced:
            if signal_it:
                os.kill(os.getpid(), signal.SIGINT)
            else:
                raise KeyboardInterrupt

    return progress


@pytest.mark.parametrize("signal_it", [False, True])
def test_interrupted_run_is_a_resumable_prefix(signal_it):
    # One thread: once more than a chunk's photons were traced, chunk 0 is committed; the
    # interrupt comes at the next progress call, so the result holds 1 … 3 whole chunks (or, on
    # a machine fast enough to finish first, all of them: the final call's interrupt is ignored).
    n = 4 * CHUNK
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        r = simulate(MEDIUM, photons=n, seed=9, threads=1, progress=_interrupt_after(CHUNK + 64, signal_it))
    assert r.photons % CHUNK == 0 and CHUNK <= r.photons <= n
    assert r.partial == (r.photons < n) and r.state.stop == r.photons
    if r.partial:
        assert any("interrupted" in str(w.message) for w in caught)
    assert abs(r.energy_balance - 1.0) < 1e-12
    # continuing it gives the bits of one uninterrupted run, with any number of threads
    done = simulate(MEDIUM, photons=n, seed=9, threads=2, resume=r)
    whole = simulate(MEDIUM, photons=n, seed=9, threads=2)
    for name in subsurf.result.TOTALS + ("roulette",):
        assert getattr(done, name) == getattr(whole, name), name
        assert getattr(done, name + "_stderr") == getattr(whole, name + "_stderr"), name
    assert done.state == whole.state and done.events == whole.events and not done.partial


def test_interrupt_before_any_photon_raises():
    # a chunk of HEAVIER takes ~1 s on one thread: interrupted at the first 50 ms progress call,
    # no photon is complete, and the KeyboardInterrupt propagates (nothing to return)
    with pytest.raises(KeyboardInterrupt, match="before any photon"):
        simulate(HEAVIER, photons=10**6, seed=9, threads=1, progress=_interrupt_after(0))


def test_interrupt_on_the_final_progress_call_keeps_the_result():
    seen = []

    def progress(done, total):
        seen.append(done)
        if done == total:
            raise KeyboardInterrupt

    r = simulate(SLAB_A, photons=5_000, seed=0, progress=progress)
    assert not r.partial and r.photons == 5_000 and seen[-1] == 5_000


def test_progress_reports_completion_and_other_errors_propagate():
    seen = []
    r = simulate(SLAB_A, photons=5_000, seed=0, progress=lambda d, t: seen.append((d, t)))
    assert seen[-1] == (5_000, 5_000) and not r.partial

    def bad(done, total):
        raise ZeroDivisionError("boom")

    with pytest.raises(ZeroDivisionError):
        simulate(HEAVY, photons=10**7, seed=0, progress=bad)
