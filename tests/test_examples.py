"""Every file in examples/ runs (with small photon counts)."""

import os
import pathlib
import shutil
import subprocess
import sys

import pytest
import subsurf

EXAMPLES = pathlib.Path(__file__).resolve().parent.parent / "examples"


def _run(args, cwd, env=None):
    e = dict(os.environ, SUBSURF_EXAMPLE_PHOTONS="2000", SUBSURF_EXAMPLE_OUT=str(cwd), MPLBACKEND="Agg")
    p = subprocess.run([sys.executable, *args], capture_output=True, text=True, cwd=cwd, timeout=180, env=e)
    assert p.returncode == 0, p.stdout + p.stderr
    return p


def test_there_are_examples():
    kinds = {p.suffix for p in EXAMPLES.iterdir()}
    assert {".toml", ".py", ".mci"} <= kinds


@pytest.mark.slow
@pytest.mark.parametrize("path", sorted(EXAMPLES.glob("*.toml")), ids=lambda p: p.name)
def test_toml_example(path, tmp_path, run_here):
    p = run_here("simulate", path, "--photons", "2000", "-o", tmp_path / "r.h5", "-q", cwd=tmp_path)
    assert p.returncode == 0, p.stdout + p.stderr
    r = subsurf.load(tmp_path / "r.h5")
    assert r.photons == 2000 and not r.partial and abs(r.energy_balance - 1) < 1e-12


@pytest.mark.parametrize("path", sorted(EXAMPLES.glob("*.mci")), ids=lambda p: p.name)
def test_mci_example(path, tmp_path, run_here):
    shutil.copy(path, tmp_path / path.name)
    p = run_here("mcml", path.name, "--photons", "500", "-q", cwd=tmp_path)
    assert p.returncode == 0, p.stdout + p.stderr
    from subsurf import mcml

    runs = mcml.read_mci(path)
    assert p.stdout.count("wrote") == len(runs) > 0
    for run in runs:
        back = mcml.read_mco(tmp_path / run.out_fname)
        assert back["photons"] == 500
        assert back["Rsp"] + back["Rd"] + back["A"] + back["Tt"] == pytest.approx(1, abs=1e-5)


@pytest.mark.slow
@pytest.mark.parametrize("path", sorted(EXAMPLES.glob("*.py")), ids=lambda p: p.name)
def test_script_example(path, tmp_path):
    _run([str(path)], tmp_path)
