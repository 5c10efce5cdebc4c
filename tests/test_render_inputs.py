"""Hostile input on the render surface: every case is refused in
one line naming the field and its range — from the command line (exit 2, no traceback) or as a
``ParameterError`` from the API — or, where the input is valid, handled instead of dropped."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import subsurf.render as R
from subsurf import ParameterError

BASE = """
[render]
method = "hierarchical"
spp = 1
seed = 1

[camera]
position = [0.0, -70.0, 28.0]
look_at = [0.0, 0.0, 8.0]
width = 8
height = 6

[materials.marble]
library = "marble"

[materials.floor]
type = "lambertian"
albedo = [0.5, 0.5, 0.5]

[[objects]]
shape = "sphere"
radius = 10.0
subdivisions = 1
translate = [0.0, 0.0, 10.0]
material = "marble"

[[objects]]
shape = "plane"
size = [200.0, 200.0]
material = "floor"

[[lights]]
type = "point"
position = [0.0, -30.0, 60.0]
power = [3000.0, 3000.0, 3000.0]
"""
LIGHT = '[[lights]]\ntype = "point"\nposition = [0.0, -30.0, 60.0]\npower = [3000.0, 3000.0, 3000.0]\n'


def _without(text, *sections):
    """BASE without the tables whose header starts with one of ``sections``."""
    out, skip = [], False
    for line in text.splitlines():
        if line.startswith("["):
            skip = any(line.startswith(s) for s in sections)
        if not skip:
            out.append(line)
    return "\n".join(out) + "\n"


CASES = [
    ("width = inf", BASE.replace("width = 8", "width = inf"), ["camera.width = inf", "[1, 32768]"]),
    ("width < 0", BASE.replace("width = 8", "width = -8"), ["camera.width = -8", "[1, 32768]"]),
    ("spp = inf", BASE.replace("spp = 1", "spp = inf"), ["render.spp = inf", "[1, 4294967295]"]),
    ("seed = -1", BASE.replace("seed = 1", "seed = -1"), ["render.seed = -1", "[0, 2**64 - 1]"]),
    ("camera = 5", "camera = 5\n" + _without(BASE, "[camera]"), ["camera = 5: expected a table"]),
    ("render = 3", "render = 3\n" + _without(BASE, "[render]"), ["render = 3: expected a table"]),
    ("materials = 5", "materials = 5\n" + _without(BASE, "[materials"), ["materials = 5: expected a table"]),
    ("lights = 5", "lights = 5\n" + _without(BASE, "[[lights"), ["lights = 5: expected an array of tables"]),
    ("lights = [5]", "lights = [5]\n" + _without(BASE, "[[lights"), ["lights = [5]: expected an array"]),
    ("objects = [1]", "objects = [1]\n" + _without(BASE, "[[objects"), ["objects = [1]: expected an array"]),
    ("size = [100, 1, 2]", BASE.replace("size = [200.0, 200.0]", "size = [100, 1, 2]"), ["size = [100, 1, 2]"]),
    ("size = 'big'", BASE.replace("size = [200.0, 200.0]", "size = 'big'"), ["size = 'big'"]),
    ("size = -1", BASE.replace("size = [200.0, 200.0]", "size = -1"), ["size[0] = -1.0", "> 0"]),
    ("subdivisions < 0", BASE.replace("subdivisions = 1", "subdivisions = -1"), ["subdivisions = -1", "[0, 8]"]),
    ("radius = inf", BASE.replace("radius = 10.0", "radius = inf"), ["radius = inf", "[1e-100, 1e15]"]),
    ("radius = 1e300", BASE.replace("radius = 10.0", "radius = 1e300"), ["radius = 1e+300", "[1e-100, 1e15]"]),
    ("radius = 1e-300", BASE.replace("radius = 10.0", "radius = 1e-300"), ["radius = 1e-300", "[1e-100, 1e15]"]),
    ("type = glass", BASE.replace('type = "lambertian"', 'type = "glass"'), ["materials.floor.type = 'glass'"]),
    (
        "no sigma",
        BASE.replace('library = "marble"', "g = 0.5"),
        ["materials.marble: give 'library'", "'sigma_a' and 'sigma_s'"],
    ),
    ("camera far", BASE.replace("[0.0, -70.0, 28.0]", "[0.0, -1e200, 28.0]"), ["camera.position = -1e+200"]),
    ("[render] key", BASE.replace("spp = 1", "spp = 1\nspps = 3"), ["render: unknown keys ['spps']"]),
    ("lambertian key", BASE.replace("albedo = [0.5, 0.5, 0.5]", "albedo = 0.5\ncolor = 3"), ["unknown keys ['color']"]),
    (
        "light key",
        BASE.replace("power = [3000.0", "radius = 3\npower = [3000.0"),
        ["lights[0]: unknown keys ['radius']"],
    ),
    ("light type", BASE.replace('type = "point"', 'type = "laser"'), ["lights[0].type = 'laser'", "'rect'"]),
    ("method", BASE.replace('method = "hierarchical"', 'method = "pm"'), ["render.method = 'pm'", "'probe'"]),
    ("power 1e308", BASE.replace("[3000.0, 3000.0, 3000.0]", "1e308"), ["lights[0].power[0] = 1e+308", "[0, 1e100]"]),
    ("huge image", BASE.replace("width = 8", "width = 32768").replace("height = 6", "height = 32768"), ["GB"]),
]


@pytest.mark.parametrize("name, text, fragments", CASES, ids=[c[0] for c in CASES])
def test_scene_file_errors_are_one_line(tmp_path, error_here, name, text, fragments):
    p = tmp_path / "s.toml"
    p.write_text(text)
    error_here("render", p, "-o", tmp_path / "o.png", "-q", fragments=fragments)
    assert not (tmp_path / "o.png").exists()


def test_command_line_integers(tmp_path, cli):
    p = tmp_path / "s.toml"
    p.write_text(BASE)
    for flag, value, fragment in [
        ("--seed", "-1", "--seed = -1 is out of range: must be an integer in [0, 2^64 - 1]"),
        ("--threads", "-1", "--threads = -1 is out of range"),
        ("--threads", "20000", "--threads = 20000 is out of range: must be an integer in [1, 1024]"),
        ("--spp", "0", "--spp = 0 is out of range"),
    ]:
        r = cli("render", p, "-o", tmp_path / "o.png", flag, value)
        lines = r.stderr.strip().splitlines()
        assert r.returncode == 2 and len(lines) == 1 and fragment in lines[0], r.stderr
    assert not (tmp_path / "o.png").exists()


TET_P = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
TET_T = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])


def _obj(path, positions, triangles=TET_T):
    lines = [f"v {float(x)} {float(y)} {float(z)}" for x, y, z in positions] + [
        f"f {a + 1} {b + 1} {c + 1}" for a, b, c in triangles
    ]
    path.write_text("\n".join(lines) + "\n")
    return path


def test_mesh_inputs(tmp_path):
    mat = R.Translucent.library("marble")
    cases = [
        (lambda: R.Object.mesh(_obj(tmp_path / "big.obj", TET_P * 1e20), mat), "coordinate = 1e+20"),
        (lambda: R.Object(TET_P, TET_T, mat, tint=np.full((4, 2), 0.5)), "tint: expected an array of shape (n, 3)"),
        (lambda: R.Object(TET_P, [[0, 1, 2**40]], mat), "refers to vertex 1099511627776, but the mesh has 4"),
        (lambda: R.Object(TET_P, [[0, 1, -2]], mat), "refers to vertex -2"),
        (lambda: R.Object.mesh(_obj(tmp_path / "nan.obj", [*TET_P[:2], [np.nan, 1, 0], TET_P[3]]), mat), "vertex 2"),
    ]
    (tmp_path / "garbage.obj").write_bytes(bytes(range(256)) * 40)
    cases.append((lambda: R.Object.mesh(tmp_path / "garbage.obj", mat), "cannot read mesh file"))
    for make, fragment in cases:
        with pytest.raises(ParameterError) as e:
            make().info()
        assert fragment in str(e.value) and "\n" not in str(e.value), str(e.value)
        assert "charset_normalizer" not in str(e.value) and "no triangles" not in str(e.value)


def _sphere_scene(material, lights=(), camera=None):
    cam = camera or R.Camera((0, -30, 5), width=6, height=6)
    return R.Scene([R.Object.sphere(material, radius=5, subdivisions=2)], list(lights), camera=cam)


def test_light_inside_a_closed_object_warns():
    sc = _sphere_scene(R.Translucent.library("marble"), [R.PointLight((0, 0, 0), 100)])
    with pytest.warns(RuntimeWarning, match=r"lights\[0\] is inside the closed object objects\[0\]"):
        R.render(sc, "probe", spp=1)
    sc.lights = [R.PointLight((0, -20, 20), 100)]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        R.render(sc, "probe", spp=1)


def test_directional_light_with_huge_components_is_kept():
    """(1e300, 1e300, 1e300) is the direction (1, 1, 1): the same image, not a dropped light."""
    mat = R.Translucent.library("marble")
    a = R.render(_sphere_scene(mat, [R.DirectionalLight((1e300, 1e300, 1e300), 1)]), "probe", spp=1)
    b = R.render(_sphere_scene(mat, [R.DirectionalLight((1, 1, 1), 1)]), "probe", spp=1)
    assert a.array.max() > 0
    np.testing.assert_array_equal(a.array, b.array)


def test_walk_source_must_start_outside():
    sc = _sphere_scene(R.Translucent.library("marble"))
    with pytest.raises(ParameterError, match=r"source.origin: the pencil beam starts inside objects\[0\]"):
        R.simulate_walk(sc, 100, origin=(0, 0, 0))
    with pytest.raises(ParameterError, match=r"source.origin = nan is out of range"):
        R.simulate_walk(sc, 100, origin=(0, 0, float("nan")))
    with pytest.raises(ParameterError, match=r"photons = -5 is out of range"):
        R.simulate_walk(sc, -5, origin=(0, 0, 20))


def test_refractive_index_follows_one_rule():
    """The random walk takes any η the engine takes (``subsurf.simulate`` accepts n = 10); only the
    diffusion profiles, which the BSSRDF methods use, are limited to η ≤ 2.5 — and say so."""
    mat = R.Translucent([0.01] * 3, [1.0] * 3, eta=10.0)
    sc = _sphere_scene(mat, [R.PointLight((0, -20, 20), 100)])
    out = R.simulate_walk(sc, 2000, origin=(0, 0, 20), direction=(0, 0, -1))
    assert 0 < out["exitance"] < 1 and out["lost"] == 0
    assert np.isfinite(R.render(sc, "random_walk", spp=1).array).all()
    with pytest.raises(ParameterError, match=r"eta = 10.0 is out of range: must be a finite number in \[1, 2.5\]"):
        R.render(sc, "hierarchical", spp=1)


def test_api_integers_through_the_core():
    sc = _sphere_scene(R.Translucent.library("marble"), [R.PointLight((0, -20, 20), 100)])
    for kw, fragment in [
        (dict(seed=-1), "seed = -1 is out of range"),
        (dict(threads=0), "threads = 0 is out of range"),
        (dict(threads=2000), "threads = 2000 is out of range"),
        (dict(spp=float("inf")), "spp = inf is out of range"),
        (dict(hierarchical=dict(env_samples=-1)), "hierarchical.env_samples = -1 is out of range"),
        (dict(hierarchical=dict(samples_per_exitance=0)), "hierarchical.samples_per_exitance = 0 is out of range"),
        (dict(hierarchical=dict(samples_per_exitance=-3)), "hierarchical.samples_per_exitance = -3 is out of range"),
    ]:
        with pytest.raises(ParameterError, match=fragment.replace("[", r"\[").replace(".", r"\.")):
            R.render(sc, **{"spp": 1, **kw})
    bad = R.Translucent.library("marble", model="monte_carlo", mc_photons=-5)
    with pytest.raises(ParameterError, match=r"materials.marble.mc_photons = -5 is out of range"):
        R.render(_sphere_scene(bad), spp=1)
