"""subsurf.bssrdf: the Python contract (arrays and floats in/out, models by name, tables saved
atomically with a checksum, inverse round trips, ParameterError naming the field). The physics
is tested next to the Rust code (crates/subsurf-core/src/bssrdf/*tests*.rs)."""

from __future__ import annotations

import h5py
import numpy as np
import pytest
import subsurf
from subsurf import ParameterError, bssrdf, testing


def test_every_model_by_name_arrays_and_floats():
    assert set(bssrdf.MODELS) == {
        "dipole",
        "better_dipole",
        "multipole",
        "photon_beam_diffusion",
        "normalized_diffusion",
        "monte_carlo",
        "adaptive",
    }
    for m in bssrdf.MODELS:
        kw = {"photons": 5000} if m in ("monte_carlo", "adaptive") else {}
        p = bssrdf.Profile.from_stack(subsurf.Stack([subsurf.Layer(1.33, 0.05, 1.2, 0.3)]), model=m, **kw)
        assert isinstance(p.rd(1.0), float) and isinstance(p.pdf(0.5), float)
        r = np.array([[0.1, 1.0], [2.0, 5.0]])
        assert p.rd(r).shape == (2, 2) and p.cdf(r).shape == (2, 2)
        u = np.linspace(0.01, 0.99, 7)
        assert np.allclose(p.cdf(p.sample_r(u)), u, atol=1e-9), m
        assert 0 < p.total() < 1 and p.radius_for_fraction(0.99) > p.radius_for_fraction(0.5)


def test_sampling_chi2_python_kit():
    p = bssrdf.Profile.from_model("photon_beam_diffusion", 0.02, 1.0, 0.0, 1.4)
    edges = np.concatenate([[0.0], p.sample_r(np.linspace(0.02, 0.98, 30))])
    res = testing.chi2_test_1d(
        lambda n, rng: p.sample_r(rng.random(n)), p.pdf, edges=edges, n_samples=50_000, seed=3, max_subdivisions=64
    )
    assert res.passed, res


def test_monte_carlo_contract_and_channels():
    stack = subsurf.Stack(
        [subsurf.Layer(1.4, 0.3, 10.0, 0.8, 0.1), subsurf.Layer(1.4, 0.02, 12.0, 0.9)], n_above=1.0, n_below=1.0
    )
    p = bssrdf.Profile.from_monte_carlo(stack, photons=5000, seed=2)
    d = p.mc_data()
    assert p.total() == pytest.approx(d["weight"].sum(), abs=1e-12)
    f, ss_total = p.single_scattering()
    assert 0 < ss_total < p.total() and f(0.5) >= 0
    chans = bssrdf.profiles([stack, stack], photons=3000, seed=5)
    assert len(chans) == 2 and chans[0].total() != chans[1].total()
    with pytest.raises(ParameterError, match=r"channels\[1\]"):
        bssrdf.profiles([stack, subsurf.Stack([subsurf.Layer(1.4, 0.0, 0.0, 0.0)])], photons=100)


def test_chandrasekhar_and_normalized_diffusion_values():
    # van de Hulst's published plane albedos (the engine's tests use the same numbers)
    assert bssrdf.chandrasekhar_reflectance(0.8) == pytest.approx(0.28525, abs=1e-5)
    assert bssrdf.chandrasekhar_reflectance(0.99) == pytest.approx(0.75272, abs=1e-5)
    p = bssrdf.Profile.normalized_diffusion(0.5, 1.0)  # s = 1.539 (eq. 5)
    assert p.total() == 0.5
    assert p.rd(1.0) == pytest.approx(0.5 * 1.539 * (np.exp(-1.539) + np.exp(-0.513)) / (8 * np.pi), rel=1e-12)


def test_table_roundtrip_and_corruption(profile_table, tmp_path):
    table = profile_table
    path = table.save(tmp_path / "t.h5")
    back = bssrdf.ProfileTable.load(path)
    assert back.rho_eff(0.93) == table.rho_eff(0.93)
    assert [p.name for p in tmp_path.iterdir()] == ["t.h5"]  # saved atomically: no temporary file left
    a = table.albedo_for(0.5)
    assert table.rho_eff(a) == pytest.approx(0.5, abs=1e-12)
    prof = table.profile(0.01, 0.99)
    assert prof.total() == pytest.approx(table.rho_eff(0.99), abs=1e-12)
    with h5py.File(path, "r+") as f:
        f["points/0002/weight"][5] += 1e-3
    with pytest.raises(ParameterError, match=r"t.h5: /points/0002/weight: fails its checksum"):
        bssrdf.ProfileTable.load(path)
    (tmp_path / "junk.h5").write_bytes(b"not hdf5")
    with pytest.raises(ParameterError, match="junk.h5: not an HDF5 profile table file"):
        bssrdf.ProfileTable.load(tmp_path / "junk.h5")
    with pytest.raises(ParameterError, match="empty"):
        bssrdf.ProfileTable.assemble(table.settings, [])


def test_inverse_and_bad_input(profile_table):
    table = profile_table
    inv = bssrdf.material_from_reflectance
    layers = inv([0.5, 0.4], [1.0, 2.0], eta=1.3, g=0.0, model="monte_carlo", table=table)
    assert [round(1 / l.sigma_t, 12) for l in layers] == [1.0, 2.0]
    for lay, c in zip(layers, [0.5, 0.4]):
        assert table.rho_eff(lay.albedo) == pytest.approx(c, abs=1e-9)
    # Per unit incident power (default) the dipole's total times the transmitted 1 − R_sp; per
    # entering power the total itself.
    r_sp = float(subsurf.optics.fresnel_reflectance(1.0, 1.0, 1.3))
    for power, k in [("incident", 1 - r_sp), ("entering", 1.0)]:
        layers = inv([0.3], [1.0], eta=1.3, model="dipole", power=power)
        assert k * subsurf.diffusion.total_diffuse_reflectance(layers[0].albedo, 1.3) == pytest.approx(0.3, abs=1e-9)
    assert bssrdf.POWERS == ("incident", "entering")
    assert bssrdf.MFP_KINDS == ("extinction", "transport", "diffuse", "burley_d")
    with pytest.raises(ParameterError, match=r"reflectance\[0\] = 1.5"):
        inv([1.5], [1.0], model="dipole")
    with pytest.raises(ParameterError, match=r"reflectance\[0\] = 0.99 is out of range"):
        inv([0.99], [1.0], eta=1.3, model="monte_carlo", table=table)
    with pytest.raises(ParameterError, match=r"mfp\[0\] = 0"):
        inv([0.5], [0.0])
    with pytest.raises(ParameterError, match="mfp_kind.*burley_d"):
        inv([0.5], [1.0], mfp_kind="free")
    with pytest.raises(ParameterError, match="power.*entering"):
        inv([0.5], [1.0], power="emitted")
    with pytest.raises(ParameterError, match="no absorption"):
        inv([1.0], [1.0], power="entering", mfp_kind="diffuse")
    with pytest.raises(ParameterError, match="model"):
        bssrdf.Profile.from_model("tripole", 0.1, 1.0)
    prof = bssrdf.Profile.from_model("dipole", 0.02, 1.0, 0.0, 1.4)
    r = np.geomspace(0.2, 5, 15)
    fit = bssrdf.fit_profile(r, prof.rd(r), 0.01 * prof.rd(r), model="dipole", eta=1.4)
    assert fit.params == pytest.approx([0.02, 1.0], rel=1e-5) and fit.cov.shape == (2, 2) and fit.dof == 13
    with pytest.raises(ParameterError, match=r"sigma\[0\]"):
        bssrdf.fit_profile(r, prof.rd(r), 0.0 * r, model="dipole")


def test_profile_queries_refuse_arguments_outside_their_domain():
    """Regression: ``rd(nan)`` was 0, ``sample_r(nan)`` 0 (∞ for monte_carlo),
    ``sample_r(1.5)`` clamped, ``rd(inf)`` NaN for the dipoles, ``pdf(0)`` NaN for monte_carlo.
    One contract for every model (checked in the core: bssrdf::Query), errors naming the argument."""
    stack = subsurf.Stack([subsurf.Layer(1.33, 0.05, 1.2, 0.3)])
    for m in bssrdf.MODELS:
        kw = {"photons": 5000} if m in ("monte_carlo", "adaptive") else {}
        p = bssrdf.Profile.from_stack(stack, model=m, **kw)
        assert p.rd(np.inf) == 0.0 and p.pdf(np.inf) == 0.0 and p.cdf(np.inf) == 1.0, m
        assert np.isfinite(p.pdf(0.0)) and p.pdf(0.0) >= 0.0, m
        for call, arg, match in [
            (p.rd, np.nan, r"^r = nan is out of range: must be a radius in \[0, inf\]"),
            (p.pdf, -1.0, r"^r = -1.0 "),
            (p.cdf, [0.5, np.nan], r"^r = nan "),
            (p.sample_r, np.nan, r"^u = nan is out of range: must be a fraction in \[0, 1\)"),
            (p.sample_r, 1.5, r"^u = 1.5 "),
            (p.sample_r, 1.0, r"^u = 1.0 "),
            (p.radius_for_fraction, -0.5, r"^q = -0.5 "),
        ]:
            with pytest.raises(ParameterError, match=match):
                call(arg)
