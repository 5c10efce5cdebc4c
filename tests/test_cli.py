"""The `subsurf` command line, run as a subprocess: one-line errors, simulate, plot, mcml, Ctrl-C."""

import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
import subsurf
from subsurf import bssrdf
from synthetic import make_result

HAS_ENGINE = hasattr(subsurf, "simulate")
HAS_TALLIES = hasattr(subsurf, "Tallies")
try:
    from subsurf import diffusion, materials  # noqa: F401

    HAS_DIFFUSION = hasattr(diffusion, "dipole_rd") and hasattr(materials, "names")
except ImportError:
    HAS_DIFFUSION = False
needs_engine = pytest.mark.skipif(not HAS_ENGINE, reason="needs the Monte Carlo engine")

GOOD = """\
photons = 3000
seed = 5
[[layers]]
n = 1.4
mua = 0.2
mus = 5.0
g = 0.8
thickness = 1.0
[tallies]  # TALLIES
nr = 20
dr = 0.1
nz = 20
dz = 0.05
na = 6
"""


GOOD_HERE = GOOD if HAS_TALLIES else GOOD[: GOOD.index("[tallies]")]


def run(*args, cwd=None, timeout=120):
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    env.pop("SUBSURF_DEBUG", None)
    return subprocess.run(
        [sys.executable, "-m", "subsurf.cli", *map(str, args)],
        capture_output=True,
        text=True,
        cwd=cwd,
        timeout=timeout,
        env=env,
    )


def one_line_error(p, *fragments):
    assert p.returncode == 2, (p.returncode, p.stdout, p.stderr)
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1, p.stderr
    assert "Traceback" not in p.stderr
    for f in fragments:
        assert f in lines[0], (f, lines[0])


@pytest.mark.parametrize(
    "text, fragments",
    [
        (GOOD.replace("g = 0.8", "g = 1.8"), ["bad.toml:7: layers[0].g: 1.8 is out of range"]),
        (GOOD + "colour = 3\n", ["bad.toml:", "tallies.colour: unknown key"]),
        (GOOD.replace("photons = 3000", "photons = 3000 3"), ["bad.toml:1: invalid TOML"]),
        (GOOD.replace("nr = 20", "nr = -2"), ["bad.toml:10: tallies.nr: -2 is out of range"]),
    ],
)
def test_bad_config_is_one_line(tmp_path, text, fragments):
    p = tmp_path / "bad.toml"
    p.write_text(text)
    one_line_error(run("simulate", p), *fragments)


def test_bad_arguments_are_one_line(tmp_path):
    one_line_error(run("simulate", tmp_path / "missing.toml"), "missing.toml: no such file")
    one_line_error(run("simulate"), "required: CONFIG.toml")
    one_line_error(run("frobnicate"), "invalid choice")
    (tmp_path / "c.toml").write_text(GOOD)
    one_line_error(run("simulate", tmp_path / "c.toml", "--photons", "0"), "--photons = 0 is out of range")
    one_line_error(run("simulate", tmp_path / "c.toml", "--photons", "many"), "invalid int value")
    one_line_error(run("plot", tmp_path / "c.toml"), "not an HDF5 results file")
    one_line_error(run("mcml", tmp_path / "none.mci"), "none.mci: no such file")
    (tmp_path / "b.mci").write_text("1.0\n1\nout.mco A\n-3\n")
    one_line_error(run("mcml", tmp_path / "b.mci"), "b.mci:4: number of photons = -3 is out of range")
    one_line_error(
        run("profile", "--sigma-a", "-1", "--sigma-s-prime", "1"),
        *(["--sigma-a = -1 is out of range"] if HAS_DIFFUSION else []),
    )


def test_plot_and_merge_from_files(tmp_path):
    a, _ = make_result(seed=1)
    b, _ = make_result(seed=2)
    subsurf.save(a, tmp_path / "a.h5")
    subsurf.save(b, tmp_path / "b.h5")
    p = run("plot", tmp_path / "a.h5", "-o", tmp_path / "a.png", "--no-models")
    assert p.returncode == 0, p.stderr
    assert (tmp_path / "a.png").read_bytes()[:4] == b"\x89PNG"
    p = run("merge", tmp_path / "a.h5", tmp_path / "b.h5", "-o", tmp_path / "m.h5")
    assert p.returncode == 0, p.stderr
    m = subsurf.load(tmp_path / "m.h5")
    assert m.photons == a.photons + b.photons and m.config["seeds"] == [1, 2]
    one_line_error(run("merge", tmp_path / "a.h5", tmp_path / "a.h5", "-o", tmp_path / "x.h5"), "seed 1")
    one_line_error(run("merge", tmp_path / "a.h5", tmp_path / "b.h5", "-o", tmp_path / "m.h5"), "--force")


@needs_engine
def test_simulate_writes_result_and_table(tmp_path):
    (tmp_path / "c.toml").write_text(GOOD_HERE)
    p = run("simulate", tmp_path / "c.toml", "-o", tmp_path / "r.h5", "--seed", "9", "--threads", "1")
    assert p.returncode == 0, p.stderr
    assert "diffuse reflectance" in p.stdout and "±" in p.stdout and "events/s" in p.stdout
    r = subsurf.load(tmp_path / "r.h5")
    assert r.photons == 3000 and r.seed == 9 and not r.partial
    assert abs(r.energy_balance - 1) < 1e-9
    if HAS_TALLIES:
        assert r.rd_r.values.shape == (20,)
    # same seed, different thread count: bit-identical numbers
    p = run("simulate", tmp_path / "c.toml", "-o", tmp_path / "r2.h5", "--seed", "9", "--threads", "2", "-q")
    assert p.returncode == 0 and "diffuse reflectance" not in p.stdout
    r2 = subsurf.load(tmp_path / "r2.h5")
    assert r2.diffuse_reflectance == r.diffuse_reflectance
    if HAS_TALLIES:
        np.testing.assert_array_equal(r2.rd_r.values, r.rd_r.values)
    p = run("plot", tmp_path / "r.h5")
    assert p.returncode == 0 and (tmp_path / "r.png").exists()


@needs_engine
def test_ctrl_c_writes_partial_result(tmp_path):
    (tmp_path / "long.toml").write_text(GOOD_HERE.replace("photons = 3000", "photons = 2000000000"))
    env = dict(os.environ)
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "subsurf.cli",
            "simulate",
            str(tmp_path / "long.toml"),
            "-o",
            str(tmp_path / "p.h5"),
            "--threads",
            "1",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )
    time.sleep(4.0)
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, (out, err)
    assert "Traceback" not in err
    r = subsurf.load(tmp_path / "p.h5")
    assert r.partial and 0 < r.photons < 2_000_000_000 and r.photons_requested == 2_000_000_000
    assert abs(r.energy_balance - 1) < 1e-9
    assert "partial" in out


@pytest.mark.skipif(not (HAS_ENGINE and HAS_TALLIES), reason="needs the engine and its tallies")
def test_mcml_drop_in(tmp_path):
    from test_mcml import SAMPLE_MCI

    (tmp_path / "s.mci").write_text(SAMPLE_MCI)
    p = run("mcml", "s.mci", "--photons", "1000", cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    assert (tmp_path / "first.mco").exists() and (tmp_path / "second.mco").exists()
    one_line_error(run("mcml", "s.mci", "--photons", "100", cwd=tmp_path), "first.mco: exists", "--force")
    p = run("mcml", "s.mci", "--photons", "100", "--force", cwd=tmp_path)
    assert p.returncode == 0, p.stderr


@pytest.mark.skipif(not HAS_DIFFUSION, reason="needs subsurf.diffusion and subsurf.materials")
def test_profile_and_materials():
    p = run("materials")
    assert p.returncode == 0, p.stderr
    assert "marble" in p.stdout and "skin1" in p.stdout
    p = run("profile", "marble", "--photons", "3000")
    assert p.returncode == 0, p.stderr
    for m in bssrdf.MODELS:
        assert m in p.stdout
    p = run("profile", "--sigma-a", "0.01", "--sigma-s-prime", "1.0", "--eta", "1.3", "--model", "dipole")
    assert p.returncode == 0, p.stderr
    row = next(line for line in p.stdout.splitlines() if line.startswith("dipole"))
    # the dipole's total and R_d(1 mm): the library's own values, printed
    assert float(row.split()[1]) == pytest.approx(float(diffusion.total_diffuse_reflectance(1 / 1.01, 1.3)), abs=6e-5)
    assert "3.0312e-02" in row
    one_line_error(run("profile", "unobtainium"), "unknown material 'unobtainium'")


@pytest.mark.skipif(not (HAS_ENGINE and HAS_TALLIES and HAS_DIFFUSION), reason="needs engine, tallies, diffusion")
def test_demo_small(tmp_path):
    p = run("demo", "--photons", "3000", "--out-dir", tmp_path / "out", "-q")
    assert p.returncode == 0, p.stderr
    for f in ("demo.h5", "demo_dermis.h5", "demo.png"):
        assert (tmp_path / "out" / f).exists()
    assert "wrote" in p.stdout and "dipole" in p.stdout
    r = subsurf.load(tmp_path / "out" / "demo.h5")
    assert len(r.absorbed_per_layer) == 3 and abs(r.energy_balance - 1) < 1e-9


def test_profile_plot_and_fit(tmp_path):
    out = tmp_path / "p.png"
    p = run("profile", "skin1", "--model", "dipole", "--model", "normalized_diffusion", "-o", out)
    assert p.returncode == 0, p.stderr
    assert out.exists() and "wrote" in p.stdout
    prof = bssrdf.Profile.from_model("dipole", 0.02, 1.0, 0.0, 1.4)
    r = np.geomspace(0.2, 5, 12)
    rows = "\n".join(f"{x},{y},{0.02 * y}" for x, y in zip(r, prof.rd(r)))
    (tmp_path / "m.csv").write_text("r,rd,sigma\n" + rows + "\n")
    p = run("fit", tmp_path / "m.csv", "--model", "dipole", "--eta", "1.4")
    assert p.returncode == 0, p.stderr
    assert "sigma_a" in p.stdout and "0.02 ±" in p.stdout
    (tmp_path / "s.csv").write_text("rd,tt,sigma_rd,sigma_tt\n0.2,0.4,0.005,0.005\n")
    p = run("fit", tmp_path / "s.csv", "--kind", "slab", "--thickness", "1.0")
    assert p.returncode == 0, p.stderr and "mus_prime" in p.stdout
    one_line_error(run("fit", tmp_path / "s.csv", "--kind", "slab"), "--thickness")
    one_line_error(run("fit", tmp_path / "none.csv"), "none.csv: no such file")
