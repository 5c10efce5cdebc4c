"""Sweeps run here (no cluster): the labelled result set and its file, restarts that skip the
points already done, sweep TOML files and the ``subsurf sweep`` command, and Monte Carlo
profile and table builds that Ctrl-C interrupts and that resume."""

import pathlib

import h5py
import numpy as np
import pytest
import subsurf
from subsurf import bssrdf, config, sweeps

EXAMPLES = pathlib.Path(__file__).resolve().parent.parent / "examples" / "sweeps"
CALLS = []


class Quadratic:
    """A cheap deterministic point that logs its calls (the sweep runs it in this process)."""

    def fingerprint(self):
        return {"kind": "test.quadratic"}

    def __call__(self, a, b):
        CALLS.append((a, b))
        return {"s": a * a + b, "v": np.array([a, b, a * b])}


AXES = {"a": [1, 2, 3], "b": [0.5, -1.0]}


def test_sweep_grid_and_labels(tmp_path):
    CALLS.clear()
    res = subsurf.sweep(Quadratic(), AXES, tmp_path / "q.h5", units={"a": "mm"})
    assert res.complete and res.shape == (3, 2) and len(CALLS) == 6
    assert CALLS == [(a, b) for a in AXES["a"] for b in AXES["b"]]  # C order, first axis outermost
    assert res["s"].shape == (3, 2) and res["v"].shape == (3, 2, 3)
    assert res.sel(a=2, b=-1.0) == {"s": 3.0, "v": pytest.approx([2.0, -1.0, -2.0])}
    assert res.at((2, 0))["s"] == 9.5 and res.at(5)["s"] == 8.0
    back = sweeps.load(tmp_path / "q.h5")
    assert back.units == {"a": "mm", "b": ""} and list(back.axes) == ["a", "b"]
    assert all(np.array_equal(back[k], res[k]) for k in res.data) and back.complete
    with h5py.File(tmp_path / "q.h5") as f:
        assert f.attrs["format"] == "subsurf-sweep" and list(f["coords/a"][()]) == [1, 2, 3]
    assert [p.name for p in tmp_path.iterdir()] == ["q.h5"]  # no temporary files left
    with pytest.raises(subsurf.ParameterError, match="not on the axis"):
        res.sel(a=4, b=0.5)


def _stop_after(n):
    def progress(done, total):
        if done >= n:
            raise KeyboardInterrupt

    return progress


def test_interrupted_sweep_resumes_without_recomputing(tmp_path):
    path = tmp_path / "q.h5"
    CALLS.clear()
    with pytest.warns(RuntimeWarning, match="2 of 6 points done"):
        part = subsurf.sweep(Quadratic(), AXES, path, progress=_stop_after(2))
    assert not part.complete and part.points_done == 2 and len(CALLS) == 2
    saved = sweeps.load(path)
    assert saved.points_done == 2 and np.isnan(saved["s"][~saved.done]).all()
    CALLS.clear()
    seen = []
    done = subsurf.sweep(Quadratic(), AXES, path, progress=lambda d, t: seen.append(d))
    assert len(CALLS) == 4 and (1, 0.5) not in CALLS and (1, -1.0) not in CALLS  # finished points not recomputed
    assert seen == [3, 4, 5, 6] and done.complete
    CALLS.clear()
    whole = subsurf.sweep(Quadratic(), AXES)
    assert all(np.array_equal(whole[k], done[k]) for k in whole.data)
    CALLS.clear()
    assert subsurf.sweep(Quadratic(), AXES, path).complete and CALLS == []  # a finished file: nothing to do


def test_sweep_file_is_checked(tmp_path):
    path = tmp_path / "q.h5"
    subsurf.sweep(Quadratic(), AXES, path)
    with pytest.raises(subsurf.ParameterError, match="holds another sweep"):
        subsurf.sweep(Quadratic(), {"a": [1, 2], "b": [0.5]}, path)
    with h5py.File(path, "r+") as f:
        f["data/s"][0, 0] = 42.0
    with pytest.raises(subsurf.ParameterError, match=r"q.h5: /data/s: fails its checksum"):
        sweeps.load(path)
    with pytest.raises(subsurf.ParameterError, match=r"q.h5: /data/s: fails its checksum"):
        subsurf.sweep(Quadratic(), AXES, path)  # a damaged file is neither trusted nor overwritten
    (tmp_path / "junk.h5").write_bytes(b"not hdf5")
    with pytest.raises(subsurf.ParameterError, match="junk.h5: not an HDF5 sweep file"):
        sweeps.load(tmp_path / "junk.h5")
    with pytest.raises(subsurf.ParameterError, match="no such file"):
        sweeps.load(tmp_path / "missing.h5")


@pytest.mark.parametrize(
    "axes, match",
    [({}, "at least one axis"), ({"a": []}, "non-empty"), ({"a": [1, 1]}, "repeat"), ({"a b": [1]}, "axis name")],
)
def test_bad_axes(axes, match):
    with pytest.raises(subsurf.ParameterError, match=match):
        subsurf.sweep(Quadratic(), axes)


def test_points_must_agree():
    with pytest.raises(subsurf.ParameterError, match="same quantities"):
        subsurf.sweep(_ragged, {"a": [1, 2]})
    with pytest.raises(subsurf.ParameterError, match="cannot be pickled"):
        subsurf.sweep(lambda a: {"x": a}, {"a": [1]})


def _ragged(a):
    return {"x": 1.0} if a == 1 else {"y": 2.0}


BASE = """
photons = 2000
seed = 3
[[layers]]
n = 1.4
mua = 0.1
mus = 10.0
g = 0.9
thickness = 1.0
[tallies]
nr = 4
dr = 0.25
"""

AXIS_G = """
[[sweep]]
name = "g"
values = [0.0, 0.5]
set = "layers[0].g"
"""

AXIS_WAVELENGTH = """
[[sweep]]
name = "wavelength"
units = "nm"
values = [500, 600, 700]
[sweep.set]
"layers[0].mua" = [0.3, 0.2, 0.1]
"layers[0].mus" = [12.0, 10.0, 8.0]
"""


def test_sweep_toml_points_are_simulations():
    cfg = config.parse_sweep(BASE + AXIS_WAVELENGTH + AXIS_G, "s.toml")
    assert cfg.grid() == {"wavelength": [500, 600, 700], "g": [0.0, 0.5]} and cfg.units()["wavelength"] == "nm"
    rc = cfg.run_config(wavelength=600, g=0.5)
    assert (rc.stack.layers[0].mua, rc.stack.layers[0].mus, rc.stack.layers[0].g) == (0.2, 10.0, 0.5)
    res = subsurf.sweep(cfg, cfg.grid())
    ref = subsurf.simulate(rc.stack, **rc.simulate_kwargs())
    point = res.sel(wavelength=600, g=0.5)
    assert point["diffuse_reflectance"] == ref.diffuse_reflectance and np.array_equal(point["rd_r"], ref.rd_r.values)
    assert res.attrs["rd_r"]["units"] == "mm^-2" and np.array_equal(res.static["edges/rd_r/r"], ref.rd_r.edges[0])


@pytest.mark.parametrize(
    "extra, match",
    [
        (AXIS_G.replace('set = "layers[0].g"', 'set = "tallies.nr"'), "cannot be swept"),
        (AXIS_G.replace('set = "layers[0].g"', 'set = "layers[3].g"'), "there are 1 layers"),
        (AXIS_G.replace("[0.0, 0.5]", "[0.0, 1.5]"), r"sweep point \(g = 1.5\): layers\[0\].g: 1.5 is out of range"),
        (AXIS_G.replace("name", "nom"), "sweep\\[0\\].nom: unknown key"),
        (AXIS_WAVELENGTH.replace("[0.3, 0.2, 0.1]", "[0.3, 0.2]"), "expected a list of 3 values"),
        (AXIS_G + AXIS_G, "new axis name"),
        ("", "sweep: expected one or more"),
    ],
)
def test_bad_sweep_toml(extra, match):
    with pytest.raises(config.ConfigError, match=match):
        config.parse_sweep(BASE + extra, "s.toml")


def test_cli_sweep_resumes_and_refuses_other_files(tmp_path, run_here):
    (tmp_path / "s.toml").write_text(BASE + AXIS_G)
    cfg = config.load_sweep(tmp_path / "s.toml")
    out = tmp_path / "s.h5"
    with pytest.warns(RuntimeWarning):
        subsurf.sweep(cfg, cfg.grid(), out, progress=_stop_after(1), units=cfg.units())
    p = run_here("sweep", tmp_path / "s.toml", "-o", out)
    assert p.returncode == 0, p.stderr
    assert "resuming, 1 of 2 points already done" in p.stdout and "wrote" in p.stdout
    assert sweeps.load(out).complete
    p = run_here("sweep", tmp_path / "s.toml", "-o", out, "--photons", "1000")  # another sweep: refused
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1 and "--force" in p.stderr
    p = run_here("sweep", tmp_path / "s.toml", "-o", out, "--photons", "1000", "--force", "-q")
    assert p.returncode == 0 and sweeps.load(out)["photons"].max() == 1000


@pytest.mark.slow
@pytest.mark.parametrize("path", sorted(EXAMPLES.glob("*.toml")), ids=lambda p: p.name)
def test_sweep_examples_run(path, tmp_path, run_here):
    p = run_here("sweep", path, "--photons", "2000", "-q", "-o", tmp_path / "out.h5")
    assert p.returncode == 0, p.stderr
    assert sweeps.load(tmp_path / "out.h5").complete


# ---- Monte Carlo profiles and tables: Ctrl-C and resuming -----------------------------------------


def test_profile_and_table_points_are_interruptible():
    stop = _stop_after(0)
    layer = subsurf.Layer(1.3, 0.001, 10.0, 0.0)  # long histories: far from done when stopped
    with pytest.raises(KeyboardInterrupt):
        bssrdf.Profile.from_monte_carlo(layer, photons=10**8, progress=stop)
    s = bssrdf.ProfileTable.default_settings(0.0, 1.3, n_albedos=2, photons=10**8)
    with pytest.raises(KeyboardInterrupt):
        bssrdf.ProfileTable.point(s, 1, progress=stop)
    with pytest.raises(KeyboardInterrupt):
        subsurf._core.bssrdf_slab_point(0.0, 1.4, 1.0, 1.0, 0.99, 5.0, 10**8, 0, None, stop)


def test_table_builds_resume_from_their_file(tmp_path):
    settings = dict(n_albedos=3, photons=2000, r_max=50.0)
    with pytest.raises(KeyboardInterrupt, match="1 of 3 points done.*build again to resume"):
        bssrdf.ProfileTable.build(0.0, 1.3, path=tmp_path / "t.h5", progress=_stop_after(1), **settings)
    assert sweeps.load(tmp_path / "t.h5").points_done == 1
    seen = []
    t = bssrdf.ProfileTable.build(0.0, 1.3, path=tmp_path / "t.h5", progress=lambda d, n: seen.append(d), **settings)
    assert seen == [2, 3]  # the finished point was not traced again
    ref = bssrdf.ProfileTable.build(0.0, 1.3, **settings)
    assert t._t.node_totals() == ref._t.node_totals()
    grid = dict(albedos=[0.5, 0.9], taus=[0.5, 2.0], photons=1000, seed=3)
    with pytest.raises(KeyboardInterrupt, match="slab table interrupted: 2 of 4"):
        bssrdf.SlabTable(0.0, 1.4, path=tmp_path / "s.h5", progress=_stop_after(2), **grid)
    seen.clear()
    s = bssrdf.SlabTable(0.0, 1.4, path=tmp_path / "s.h5", progress=lambda d, n: seen.append(d), **grid)
    assert seen == [3, 4] and s.totals(0.7, 1.0) == bssrdf.SlabTable(0.0, 1.4, **grid).totals(0.7, 1.0)
