"""Results files (HDF5): save/load round trip, merge and its exact standard-error identity."""

import json
import math

import h5py
import numpy as np
import pytest
import subsurf
from subsurf.io import ResultFileError, UnverifiedResultWarning, merge, results_equal
from subsurf.result import TOTALS, Histogram


def test_round_trip_is_equal(tmp_path, make_result):
    res, _ = make_result(seed=3)
    res.partial = True
    res.photons_requested = 20_000
    res.histograms["fluence_z"] = Histogram(
        np.array([1.0, np.nan]), np.array([0.1, np.nan]), (np.array([0, 1.0, 2.0]),), ("z",), ("mm",), "mm^-2", "A/mua"
    )
    p = subsurf.save(res, tmp_path / "r.h5")
    back = subsurf.load(p)
    assert results_equal(res, back)
    assert back.partial and back.photons_requested == 20_000
    assert back.rd_r.units == "mm^-2" and back.rd_ra.axes == ("r", "theta")
    assert back.config["stack"]["layers"][-1]["thickness"] == math.inf
    assert back.a_rz.values.shape == res.a_rz.values.shape
    # a changed number is noticed by results_equal (the comparison can fail)
    back.rd_r.values[3] += 1e-12
    assert not results_equal(res, back)


def test_file_is_self_describing(tmp_path, make_result):
    res, _ = make_result()
    p = subsurf.save(res, tmp_path / "r.h5")
    with h5py.File(p, "r") as f:
        assert f.attrs["format"] == "subsurf-result"
        assert f["histograms/a_z"].attrs["units"] == "mm^-1"
        assert f["histograms/a_z/edges_0"].attrs["units"] == "mm"
        assert f["totals/diffuse_reflectance"][()] == res.diffuse_reflectance
        assert '"tallies"' in f.attrs["config"]
        assert f.attrs["seed"] == res.seed and f.attrs["version"] == "0.1.0-test"
        assert f.attrs["format_version"] == 2
        userblock = f.userblock_size
    # the user block holds the checksum manifest: every dataset, and the rest of the file
    head = open(p, "rb").read(userblock)
    assert head.startswith(b"subsurf-result manifest 1 ")
    manifest = json.loads(head.split(b"\n")[1])
    assert "/histograms/a_rz/values" in manifest["datasets"] and len(manifest["rest"]) == 64


def test_load_rejects_other_files(tmp_path):
    with pytest.raises(ResultFileError, match="no such file"):
        subsurf.load(tmp_path / "nope.h5")
    (tmp_path / "x.h5").write_text("hello")
    with pytest.raises(ResultFileError, match="not an HDF5"):
        subsurf.load(tmp_path / "x.h5")
    with h5py.File(tmp_path / "y.h5", "w") as f:
        f["a"] = 1
    with pytest.raises(ResultFileError, match="not a subsurf results file"):
        subsurf.load(tmp_path / "y.h5")


def _summary(x):
    n = len(x)
    m = x.mean(axis=0)
    return m, x.std(axis=0, ddof=1) / math.sqrt(n)


def test_merge_identity_matches_pooled_samples(rng, make_result):
    """Merged mean/stderr equal those computed directly from the pooled per-photon scores."""
    xa = rng.exponential(0.3, size=(1234, 5)) * (rng.random((1234, 5)) < 0.4)
    xb = rng.exponential(0.3, size=(777, 5)) * (rng.random((777, 5)) < 0.4)
    ra, _ = make_result(seed=1, photons=len(xa), rng=rng)
    rb, _ = make_result(seed=2, photons=len(xb), rng=rng)
    for r, x in ((ra, xa), (rb, xb)):
        m, s = _summary(x)
        for k, name in enumerate(TOTALS):
            setattr(r, name, float(m[k]))
            setattr(r, name + "_stderr", float(s[k]))
        r.histograms["rd_r"] = Histogram(m, s, (np.arange(6.0),), ("r",), ("mm",), "mm^-2", "")
    c = merge(ra, rb)
    m, s = _summary(np.vstack([xa, xb]))
    for k, name in enumerate(TOTALS):
        assert getattr(c, name) == pytest.approx(m[k], rel=1e-12, abs=1e-15)
        assert getattr(c, name + "_stderr") == pytest.approx(s[k], rel=1e-10, abs=1e-15)
    np.testing.assert_allclose(c.rd_r.values, m, rtol=1e-12)
    np.testing.assert_allclose(c.rd_r.stderr, s, rtol=1e-10)
    assert c.photons == len(xa) + len(xb) and c.events == ra.events + rb.events
    assert c.config["seeds"] == [1, 2] and not c.partial
    assert c.elapsed_s == pytest.approx(ra.elapsed_s + rb.elapsed_s)


def test_merge_refuses_mismatches(make_result):
    a, _ = make_result(seed=1)
    b, _ = make_result(seed=1)
    with pytest.raises(subsurf.ParameterError, match="seed 1"):
        merge(a, b)
    c, _ = make_result(seed=2, nr=10)
    with pytest.raises(subsurf.ParameterError, match="different configurations.*tallies"):
        merge(a, c)
    d, _ = make_result(seed=3)
    del d.histograms["brdf"]
    with pytest.raises(subsurf.ParameterError, match="different histograms"):
        merge(a, d)
    # merged results carry their seeds: merging again with a used seed is refused
    ab = merge(a, make_result(seed=5)[0])
    with pytest.raises(subsurf.ParameterError, match="seed 5"):
        merge(ab, make_result(seed=5)[0])


def test_merge_of_partials_round_trips(tmp_path, make_result):
    a, _ = make_result(seed=1, photons=300)
    a.partial, a.photons_requested = True, 1000
    b, _ = make_result(seed=2, photons=1000)
    c = merge(a, b)
    assert c.photons == 1300 and c.photons_requested == 2000 and c.partial
    assert results_equal(subsurf.load(subsurf.save(c, tmp_path / "c.h5")), c)


def test_round_trip_of_a_real_run(tmp_path):
    stack = subsurf.Stack([subsurf.Layer(1.4, 0.1, 5.0, 0.8, 1.0)])
    t = subsurf.Tallies(nr=10, dr=0.1, nz=10, dz=0.1, na=5, brdf=(3, 4), max_order=2)
    res = subsurf.simulate(stack, photons=2000, seed=3, threads=1, tallies=t)
    back = subsurf.load(subsurf.save(res, tmp_path / "r.h5"))
    assert results_equal(res, back)
    assert set(back.histograms) == set(res.histograms) and "brdf_order" in back.histograms
    both = merge(res, subsurf.simulate(stack, photons=1000, seed=4, threads=1, tallies=t))
    assert both.photons == 3000 and abs(both.energy_balance - 1) < 1e-12
    # the exact state (for resuming) is covered by the checksums too
    assert back.state == res.state
    with h5py.File(tmp_path / "r.h5", "r") as f:
        offset = f["state/s1"].id.get_offset()
    _flip(tmp_path / "r.h5", offset + 3)
    with pytest.raises(ResultFileError, match=r"r.h5: /state/s1: fails its checksum"):
        subsurf.load(tmp_path / "r.h5")


def _flip(path, offset):
    with open(path, "r+b") as fh:
        fh.seek(offset)
        b = fh.read(1)
        fh.seek(offset)
        fh.write(bytes([b[0] ^ 0x10]))


def test_a_flipped_byte_in_any_dataset_is_named(tmp_path, make_result):
    """Each dataset's bytes are covered by its checksum: corrupting one names that dataset."""
    res, _ = make_result(seed=3)
    res.histograms["big"] = Histogram(
        np.arange(5000.0), np.ones(5000), (np.arange(5001.0),), ("r",), ("mm",), "mm^-2", "compressed"
    )
    p = subsurf.save(res, tmp_path / "r.h5")
    clean = open(p, "rb").read()
    where = {}
    with h5py.File(p, "r") as f:

        def visit(name, obj):
            if isinstance(obj, h5py.Dataset) and obj.size > 0:
                off = obj.id.get_offset()
                where["/" + name] = off if off is not None else obj.id.get_chunk_info(0).byte_offset + 20

        f.visititems(visit)
    assert len(where) > 40 and "/histograms/big/values" in where
    for name, off in where.items():
        open(p, "wb").write(clean)
        _flip(p, off)
        with pytest.raises(ResultFileError) as e:
            subsurf.load(p)
        assert str(e.value).startswith(f"{p}: {name}: ") and "\n" not in str(e.value), str(e.value)


def test_atomic_save_and_force(tmp_path, make_result):
    res, _ = make_result(seed=3)
    p = tmp_path / "r.h5"
    p.write_text("old")
    with pytest.raises(FileExistsError, match="exists; use --force"):
        subsurf.save(res, p, force=False)
    assert p.read_text() == "old"
    subsurf.save(res, p)  # the API default replaces, as numpy and h5py do
    assert results_equal(subsurf.load(p), res)
    with pytest.raises(FileNotFoundError, match="does not exist"):
        subsurf.save(res, tmp_path / "no" / "r.h5")
    assert sorted(x.name for x in tmp_path.iterdir()) == ["r.h5"]


def test_format_1_files_load_with_a_warning(tmp_path, make_result, as_format_1):
    res, _ = make_result(seed=3)
    p = subsurf.save(res, tmp_path / "r.h5")
    as_format_1(p)
    with pytest.warns(UnverifiedResultWarning, match="format version 1 has no checksums"):
        back = subsurf.load(p)
    assert results_equal(back, res)
    with h5py.File(p, "r+") as f:
        f.attrs["format_version"] = 3
    with pytest.raises(ResultFileError, match="version 3 is newer than this subsurf reads"):
        subsurf.load(p)
