"""The adaptive BSSRDF model's tables (``subsurf.bssrdf.AdaptiveTable``): their on-disk cache
(checksummed HDF5, keyed by the inputs and the engine version, rebuilt when damaged), their
physics on a flat slab, and the model in a render. The physics is tested in the core
(``bssrdf/adaptive_tests.rs``, ``render/adaptive_tests.rs``); here the Python side."""

from __future__ import annotations

import h5py
import numpy as np
import pytest
import subsurf.render as R
from subsurf import ParameterError, Stack, _core
from subsurf.bssrdf import AdaptiveTable, Profile
from subsurf.medium import Layer
from subsurf.optics import diffuse_fresnel_reflectance, fresnel_transmittance

# ℓ = 0.45 mm, L = 0.83 mm: five thickness nodes and ∞, short histories.
STACK = Stack([Layer(1.4, 0.2, 2.0, 0.0)])


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("SUBSURF_CACHE", str(tmp_path))
    return tmp_path / "adaptive"


def test_cache_builds_once_and_round_trips(cache):
    t = AdaptiveTable.cached([STACK], photons=500, seed=2)
    files = list(cache.iterdir())
    assert len(files) == 1 and files[0].suffix == ".h5"
    mtime = files[0].stat().st_mtime_ns
    again = AdaptiveTable.cached([STACK], photons=500, seed=2)
    assert files[0].stat().st_mtime_ns == mtime  # read back, not rebuilt
    assert AdaptiveTable.load(files[0]).key == t.key
    for d in (0.1, 0.5, 2.0, 100.0, np.inf):
        assert again.totals(0, d) == t.totals(0, d)
    assert again.curvature() == t.curvature()  # the curvature data round-trip, scales re-derived equal
    for h in (-1.0, -0.01, 0.0, 0.05, 2.0):
        assert again.curvature_scale(0, h) == t.curvature_scale(0, h)
    # the same bits as a fresh build (deterministic)
    fresh = AdaptiveTable.build([STACK], photons=500, seed=2)
    assert fresh.totals(0, 0.7) == t.totals(0, 0.7)
    # other inputs or another engine version: another file
    AdaptiveTable.cached([STACK], photons=500, seed=3)
    assert len(list(cache.iterdir())) == 2
    assert t.key["engine_version"] == _core.__version__


def test_damaged_cache_is_rebuilt_and_load_names_the_file(cache):
    t = AdaptiveTable.cached([STACK], photons=500, seed=2)
    (path,) = cache.iterdir()
    with h5py.File(path, "r+") as f:
        f["channels/00/001/top/weight"][3] += 1e-3
    with pytest.raises(ParameterError, match=r"fails its checksum"):
        AdaptiveTable.load(path)
    back = AdaptiveTable.cached([STACK], photons=500, seed=2)  # rebuilt, same numbers
    assert back.totals(0, 0.3) == t.totals(0, 0.3)
    assert AdaptiveTable.load(path).totals(0, 0.3) == t.totals(0, 0.3)


def test_profiles_and_bad_input(cache):
    t = AdaptiveTable.build([STACK], photons=500, seed=2)
    r, tr = t.totals(0, 0.5)
    assert t.profile(0, 0.5, "R").total() == pytest.approx(r, rel=1e-12)
    assert t.profile(0, 0.5, "T").total() == pytest.approx(tr, rel=1e-12)
    assert t.totals(0, np.inf)[1] == 0.0
    # the thinner the slab, the more it transmits: T (the scattered light only; the renderer adds the
    # unscattered chord itself) plus what crosses unscattered, e^(−σt d) (1 − F(0)) per entering power
    f = float(fresnel_transmittance(1.0, 1.4, 1.0))
    all_t = [t.totals(0, d)[1] + f * np.exp(-2.2 * d) for d in (0.2, 1.0, 3.0)]
    assert all_t[0] > all_t[1] > all_t[2]
    assert t.totals(0, 0.2)[1] < t.totals(0, 1.0)[1]  # thin: mostly unscattered, which T leaves out
    with pytest.raises(ParameterError, match="channel"):
        t.totals(3, 1.0)
    with pytest.raises(ParameterError, match="thickness"):
        t.totals(0, -1.0)
    with pytest.raises(ParameterError, match="which"):
        t.profile(0, 1.0, "X")
    with pytest.raises(ParameterError, match="photons"):
        AdaptiveTable.build([STACK], photons=1)
    cd = t.curvature()[0]
    assert cd["rho"] == _core.bssrdf_adaptive_curvature_nodes(STACK._to_core())
    for k in ("sphere", "cylinder"):
        assert sum(cd[f"{k}_bins"][0]) == pytest.approx(cd[f"{k}_near"][0], rel=1e-12)
    assert len(cd["scale_cylinder"]) == len(cd["scale_cylinder_far"]) == len(cd["rho"])
    assert cd["scale_concave"][0] < 0.5  # a small cavity returns less light than a flat surface
    assert t.curvature_scale(0, 0.0) == ([1.0] * 8, 1.0)
    # the oblique-incidence gain: 1 at normal incidence, from the flat pencil runs at 30–80°
    assert cd["oblique_theta"] == [30.0, 50.0, 65.0, 80.0] and len(cd["oblique"]) == 4
    assert t.oblique_gain(0, 1.0) == 1.0 and t.oblique_gain(0, 0.0) > 0
    # the azimuthal harmonic: ⟨cos φ⟩ per curvature node and angle, forward (> 0) on the near side
    for k in ("harmonic_near", "harmonic_far"):
        assert len(cd[k]) == len(cd["rho"]) and all(len(a) == 4 and all(-1 <= x <= 1 for x in a) for a in cd[k])
    assert all(a[2] > 0 for a in cd["harmonic_near"])
    with pytest.raises(ParameterError, match="mu"):
        t.oblique_gain(0, 1.5)
    # the exit term: the flat exit-angle histogram under diffuse light (10 bins in the exit cosine,
    # the diffuse reflectance in all) and its fitted shape, every hemispherical total unchanged
    assert len(cd["exit"]) == len(cd["exit_stderr"]) == 10
    assert sum(cd["exit"]) == pytest.approx(cd["flat"], rel=0.05)
    mu = (np.arange(2000) + 0.5) / 2000
    ftm = fresnel_transmittance(mu, 1.0, 1.4)
    s = np.array([t.exit_factor(0, m) for m in mu])
    assert np.mean(s * ftm * mu) == pytest.approx(np.mean(ftm * mu), rel=1e-5)
    assert -0.95 <= cd["exit_beta"] <= 20 and (s[-1] > 1) == (cd["exit_beta"] > 0)
    with pytest.raises(ParameterError, match="mu"):
        t.exit_factor(0, -0.1)
    # the exit coupling: per oblique angle the flat pencil run's exit weight, then its cos Δφ moment,
    # on 5 exit-cosine bins (the weights: that run's diffuse reflectance), and the fitted amplitudes
    assert len(cd["coupling"]) == len(cd["coupling_stderr"]) == 4
    assert all(len(r) == 10 for r in cd["coupling"])
    for r, total in zip(cd["coupling"], cd["oblique"]):
        assert sum(r[:5]) == pytest.approx(total, rel=0.1) and all(abs(c) <= w for w, c in zip(r[:5], r[5:]))
    assert len(cd["coupling_a_theta"]) == len(cd["coupling_a_theta_stderr"]) == len(cd["coupling_chi2"]) == 4
    assert -0.9 <= cd["coupling_a"] <= 0.9 and cd["coupling_a_stderr"] > 0
    # the exit flow: the flat diffuse run's exit weight per (distance bin, exit-cosine bin), then its
    # cos Δφ moment about the direction from the entry point; its amplitudes per distance bin
    assert len(cd["flow"]) == len(cd["flow_stderr"]) == 2 * 9 * 5
    assert sum(cd["flow"][:45]) == pytest.approx(cd["flat"], rel=0.1)
    assert all(abs(c) <= w for w, c in zip(cd["flow"][:45], cd["flow"][45:]))
    assert len(cd["flow_b"]) == len(cd["flow_b_stderr"]) == 9
    # the curved transport: a non-absorbing, index-matched sphere returns every photon
    clear = Stack([Layer(1.0, 0.0, 2.0, 0.0)])._to_core()
    assert _core.bssrdf_curved_escape(clear, "sphere", 1.0, 200, 1) == (1.0, 0.0)
    with pytest.raises(ParameterError, match="kind"):
        _core.bssrdf_curved_escape(clear, "cube", 1.0, 200, 1)
    with pytest.raises(ParameterError, match="rho"):
        _core.bssrdf_curved_escape(clear, "sphere", 0.0, 200, 1)
    # the pencil launch and the sun-on-sphere exitance: the sun's bins hold the diffuse run's photons
    st = Stack([Layer(1.3, 0.06, 0.18, 0.0)])._to_core()
    mean, _, near, _, bins, shift, harm = _core.bssrdf_curved_escape_parts(st, "sphere", 10.0, 500, 2, theta_deg=50.0)
    assert 0 < near < mean < 1 and len(bins) == 8 and shift > 0 and len(harm) == 9 and sum(harm) > 0
    sun = _core.bssrdf_sun_exitance(st, 10.0, 10, 500, 2)
    assert sum(sun) * 4 / 10 == pytest.approx(_core.bssrdf_curved_escape(st, "sphere", 10.0, 500, 2)[0], rel=1e-12)
    with pytest.raises(ParameterError, match="theta"):
        _core.bssrdf_curved_escape_parts(st, "sphere", 10.0, 500, 2, theta_deg=95.0)
    # as a plain profile, "adaptive" is the semi-infinite Monte Carlo profile
    assert Profile.from_model("adaptive", 0.2, 2.0, 0.0, 1.4).total() > 0


def test_backlit_thin_slab_renders_the_transmitted_light(cache):
    """A 1 mm slab lit from behind: adaptive shows the transmitted light (within 3 % of its
    table's T × E_t at the centre; the core's test bounds the quadrature to 2 %), monte_carlo
    (a half-space) much less."""
    mats = {m: R.Translucent(0.2, 2.0, eta=1.4, model=m, mc_photons=2000) for m in ("adaptive", "monte_carlo")}
    out = {}
    for m, mat in mats.items():
        scene = R.Scene(
            [R.Object.box(mat, lo=(-15, -15, -1), hi=(15, 15, 0))],
            [R.DirectionalLight((0, 0, -1), 1.0)],
            (0, 0, 0),
            R.Camera((0, 0, 50), look_at=(0, 0, 0), up=(0, 1, 0), fov=0.5, width=3, height=3),
        )
        out[m] = R.render(scene, "hierarchical", spp=1).array[1, 1]
    t = mats["adaptive"].adaptive_table()
    f0 = 1 - ((1.4 - 1) / (1.4 + 1)) ** 2
    c = 1 - float(diffuse_fresnel_reflectance(1.4, internal=False))
    want = f0 * t.totals(0, 1.0)[1] * f0 / (np.pi * c)  # light across the part: the flat exit term
    assert out["adaptive"][0] == pytest.approx(want, rel=0.03)
    # T is the scattered light only (σt d = 2.2: 11 % of the entering power crosses unscattered,
    # which a directional light sends past this camera): adaptive ≈ 2.4× the half-space's
    assert np.all(out["adaptive"] > 2 * out["monte_carlo"])
