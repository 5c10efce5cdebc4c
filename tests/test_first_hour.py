"""A newcomer's first hour — a plain install, the demo — and the render set-up's Ctrl-C.

* A plain ``pip install .`` has no ``openexr`` (an extra): ``subsurf demo --quick`` and ``subsurf
  render`` still write every output, as PNG, and say in one line — before the work — how to get
  OpenEXR. The optional modules are hidden from a subprocess by a ``sitecustomize`` shim
  (``sys.modules[name] = None`` makes ``import name`` raise ImportError); trimesh is hidden too,
  to show that the built-in shapes need nothing else.
* The render set-up — Monte Carlo profiles, the hierarchical irradiance samples — stops on Ctrl-C
  and SIGTERM (through ``subsurf._testhooks``, no sleeps), and ``random_walk`` builds no profile.
"""

from __future__ import annotations

import os

import numpy as np
import pytest
import subsurf._core as core
import subsurf.render as R

HINT = "pip install 'subsurf[render]'"


def _plain_install(tmp_path):
    """Environment variables under which ``openexr`` and ``trimesh`` cannot be imported."""
    shim = tmp_path / "shim"
    shim.mkdir()
    (shim / "sitecustomize.py").write_text("import sys\nsys.modules['OpenEXR'] = None\nsys.modules['trimesh'] = None\n")
    return {"PYTHONPATH": str(shim)}


@pytest.mark.slow  # 4-6 s: subprocesses that render
def test_demo_quick_without_the_optional_packages(tmp_path, cli):
    r = cli("demo", "--quick", "--out-dir", tmp_path / "out", env=_plain_install(tmp_path))
    assert r.returncode == 0, r.stderr
    names = sorted(os.listdir(tmp_path / "out"))
    assert names == ["demo.h5", "demo.png", "demo_dermis.h5", "render.png"], names
    notes = [line for line in r.stderr.splitlines() if "openexr" in line]
    assert len(notes) == 1 and HINT in notes[0], r.stderr
    assert r.stderr.splitlines()[0] == notes[0]  # said before any work
    assert "wrote" in r.stdout and "render.png" in r.stdout


@pytest.mark.slow  # 4-6 s: subprocesses that render
def test_render_example_without_the_optional_packages(tmp_path, cli, small_example):
    env = _plain_install(tmp_path)
    r = cli("render", small_example, "-o", tmp_path / "x.png", "--spp", "1", env=env)
    assert r.returncode == 0 and r.stderr == "", r.stderr
    assert os.path.getsize(tmp_path / "x.png") > 1000
    r = cli("render", small_example, "-o", tmp_path / "y.exr", "--spp", "1", env=env)
    assert r.returncode == 0, r.stderr
    assert r.stderr.count("\n") == 1 and HINT in r.stderr and "y.png only" in r.stderr
    assert sorted(os.listdir(tmp_path)) == ["shim", "x.png", "y.png"]


def _scene(mat, width=16):
    return R.Scene(
        [R.Object.sphere(mat, radius=1, subdivisions=2), R.Object.plane(R.Lambertian(0.5), center=(0, 0, -1))],
        [R.RectLight((0, -10, 20), (4, 0, 0), (0, -3, 3), 5e3)],
        (0.05, 0.05, 0.06),
        R.Camera((0, -8, 2), fov=25, width=width, height=width),
    )


def test_random_walk_builds_no_monte_carlo_profile():
    # 3e12 photons would never end: a "profiles" stage would be reported within 50 ms and stopped
    mat = R.Translucent.library("skin1", model="monte_carlo", mc_photons=10**12)
    stages = []

    def setup(stage, done, total):
        stages.append((stage, total))
        raise KeyboardInterrupt

    img = R.render(_scene(mat), "random_walk", spp=1, setup_progress=setup)
    assert stages == [] and img.spp == 1 and not img.partial


def test_ctrl_c_stops_the_hierarchical_set_up():
    # sigma_s = 1e6 /mm: the irradiance samples take seconds; Ctrl-C at the first report
    mat = R.Translucent([1e4] * 3, [1e6] * 3, name="dense")
    seen = []

    def setup(stage, done, total):
        seen.append((stage, done, total))
        raise KeyboardInterrupt

    img = R.render(_scene(mat), "hierarchical", spp=4, setup_progress=setup, hierarchical={"spacing": 1e4})
    assert img.spp == 0 and img.partial and img.array.shape == (16, 16, 3) and not img.array.any()
    assert len(seen) == 1 and seen[0][0] == "irradiance" and seen[0][1] < seen[0][2], seen


def test_render_job_set_up_reports_progress():
    mat = R.Translucent.library("skin1", model="monte_carlo", mc_photons=400_000)
    seen = []
    core.RenderJob(_scene(mat)._to_core("probe"), "probe", 0, None, None, lambda *a: seen.append(a))
    profiles = [s for s in seen if s[0] == "profiles"]
    assert profiles and all(total == 1_200_000 for _, _, total in profiles)
    assert profiles[-1][1] == 1_200_000  # the final call reports completion
    assert np.all(np.diff([d for _, d, _ in profiles]) >= 0)


def _mc_scene_file(tmp_path):
    p = tmp_path / "mc.toml"
    p.write_text(
        """[render]
spp = 1
[camera]
position = [0.0, -8.0, 2.0]
width = 8
height = 8
[materials.m]
sigma_a = [0.01, 0.02, 0.03]
sigma_s = [1.0, 1.0, 1.0]
model = "monte_carlo"
mc_photons = 10000000000
[[objects]]
shape = "sphere"
radius = 1.0
subdivisions = 2
material = "m"
[[lights]]
type = "point"
position = [0.0, -5.0, 5.0]
power = 100.0
"""
    )
    return p


def test_cli_ctrl_c_and_sigterm_stop_a_monte_carlo_profile_set_up(tmp_path, cli):
    scene = _mc_scene_file(tmp_path)
    r = cli("render", scene, "-o", tmp_path / "a.png", hook="setup_interrupt_after=1")
    assert r.returncode == 130 and "nothing written" in r.stderr, r.stderr
    r = cli("render", scene, "-o", tmp_path / "a.png", hook="setup_terminate_after=1")
    assert r.returncode == 143 and r.stderr == "subsurf: terminated\n", r.stderr
    assert sorted(os.listdir(tmp_path)) == ["mc.toml"]
    # random_walk uses no profile: 3e10 photons are not traced, the image is written
    r = cli("render", scene, "-o", tmp_path / "w.png", "--method", "random_walk")
    assert r.returncode == 0 and os.path.exists(tmp_path / "w.png"), r.stderr


def test_profile_command_monte_carlo_stops_on_ctrl_c(cli):
    r = cli("profile", "skin1", "--model", "monte_carlo", "--photons", "10000000000", hook="interrupt_after=1")
    assert r.returncode == 130 and r.stderr.count("\n") == 1 and "interrupt" in r.stderr, r.stderr


@pytest.mark.slow  # 4-6 s: subprocesses that render
def test_cli_ctrl_c_in_the_passes_writes_a_partial_image(tmp_path, cli, small_example):
    # interrupt_after counts samples per pixel: the set-up runs to its end, the first pass is kept
    r = cli("render", small_example, "-o", tmp_path / "p.png", "--spp", "4", hook="interrupt_after=1")
    assert r.returncode == 130 and "partial: 1 of 4 spp" in r.stdout, (r.stdout, r.stderr)
    assert os.path.getsize(tmp_path / "p.png") > 1000
