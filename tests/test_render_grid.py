"""Heterogeneous media (``MediumGrid``) through the Python API, the scene files and the
command line: the grid reaches the core's delta tracking (a grid equal to the material is the
homogeneous walk bit for bit; a constant grid with null collisions renders the homogeneous
image within 4σ), the energy balance of ``simulate_walk`` stays exact, the grid follows the
object's transform, and bad grids are refused in one line naming the field. The statistical
comparisons of two-valued grids against nested meshes are the core's
(``render/grid_tests.rs``)."""

from __future__ import annotations

import numpy as np
import pytest
import subsurf.render as R
from subsurf import ParameterError

A = ([0.05, 0.1, 0.2], [2.0, 3.0, 4.0])
BOX = [[-2.0] * 3, [2.0] * 3]


def _scene(grid=None, base=A, camera=None, **placement):
    m = R.Translucent(*base, g=0.3, eta=1.4, grid=grid)
    return R.Scene([R.Object.box(m, lo=BOX[0], hi=BOX[1], **placement)], environment=(0.3,) * 3, camera=camera)


def _const(shape=(2, 2, 2), bounds=BOX, values=A):
    return R.MediumGrid(np.broadcast_to(values[0], (*shape, 3)), np.broadcast_to(values[1], (*shape, 3)), bounds)


def test_grid_equal_to_the_material_is_the_homogeneous_walk():
    a = R.simulate_walk(_scene(), 400, seed=2, origin=(0.3, 0.2, 10), channel=1, voxels=(*BOX, (2, 2, 2)))
    b = R.simulate_walk(_scene(_const()), 400, seed=2, origin=(0.3, 0.2, 10), channel=1, voxels=(*BOX, (2, 2, 2)))
    for k in ("exitance", "absorbed", "roulette", "specular", "lost"):
        assert a[k] == b[k], k
    assert np.array_equal(a["voxels"], b["voxels"])


def test_grid_from_npy_files_and_one_channel(tmp_path):
    np.save(tmp_path / "a.npy", np.full((3, 2, 2), 0.1))
    np.save(tmp_path / "s.npy", np.full((3, 2, 2, 3), 2.0))
    g = R.MediumGrid(tmp_path / "a.npy", str(tmp_path / "s.npy"), BOX)
    assert g.shape == (3, 2, 2) and g.sigma_a.shape == (3, 2, 2, 3) and np.all(g.sigma_a == 0.1)


@pytest.mark.parametrize("channel", [0, 1, 2])
def test_simulate_walk_with_a_grid_conserves_energy(channel):
    sa = np.zeros((4, 4, 4, 3))
    sa[2:] = [0.5, 0.3, 0.05]  # an absorbing half (object x > 0)
    ss = np.full((4, 4, 4), 2.0)
    ss[:, :2] = 6.0
    out = R.simulate_walk(_scene(R.MediumGrid(sa, ss, BOX)), 3000, seed=channel, origin=(0.3, 0.2, 10), channel=channel)
    balance = out["specular"] + out["exitance"] + out["absorbed"] + out["lost"]
    assert abs(balance - 1) < 1e-12


def test_the_grid_follows_the_object():
    """Absorbing in object x > 0; the object turned 90° about z, scaled 2 and moved +1 in x: the
    absorption lands in world y > 0 only (voxel tallies in world space)."""
    sa = np.zeros((4, 4, 4))
    sa[2:] = 0.5
    g = R.MediumGrid(sa, np.full((4, 4, 4), 2.0), BOX)
    sc = _scene(g, base=([0.0] * 3, [2.0] * 3), translate=(1, 0, 0), rotate=(0, 0, 90), scale=2)
    out = R.simulate_walk(sc, 2000, seed=2, origin=(1.3, 0.2, 20), voxels=([-3, -4, -4], [5, 4, 4], (1, 2, 1)))
    v = out["voxels"].ravel()
    assert v[0] == 0 and v[1] > 0.1
    # The map itself: world positions back to the mesh's own coordinates.
    o = sc.objects[0]
    m = np.asarray(o._to_object())
    back = o.positions @ m[:, :3].T + m[:, 3]
    assert np.allclose(np.abs(back), 2.0, atol=1e-12)


@pytest.mark.slow
def test_constant_grid_renders_the_homogeneous_image():
    """A constant grid of A in a material whose own σ (3 × A's, outside the box, never reached)
    sets the majorant: two of three tentative collisions are null. Image means over 10
    independent seeds each (16 spp, 6×6 px on the cube), 4σ with σ from the seeds' spread.
    Power: the band is asserted below 5 % of the mean, so a 5 % bias cannot pass."""
    cam = R.Camera((6, -12, 3), look_at=(0, 0, 0), fov=10, width=6, height=6)
    big = ([3 * x for x in A[0]], [3 * x for x in A[1]])
    g = _const(bounds=[[-2.5] * 3, [2.5] * 3])

    def means(sc, seed0):
        return np.array([R.render(sc, "random_walk", spp=16, seed=seed0 + s).array.mean() for s in range(10)])

    a, b = means(_scene(camera=cam), 0), means(_scene(g, base=big, camera=cam), 100)
    sig = np.sqrt(a.var(ddof=1) / a.size + b.var(ddof=1) / b.size)
    assert 4 * sig < 0.05 * a.mean(), (a, b)
    assert abs(a.mean() - b.mean()) < 4 * sig, (a.mean(), b.mean(), sig)


@pytest.mark.parametrize(
    "kw, fragments",
    [
        ({"sigma_a": -np.ones((2, 2, 2))}, ["grid.sigma_a[0, 0, 0, 0] = -1.0", "finite number >= 0"]),
        ({"sigma_s": np.full((2, 2, 2), np.nan)}, ["grid.sigma_s[0, 0, 0, 0] = nan", "finite number >= 0"]),
        ({"sigma_a": np.ones((2, 2))}, ["grid.sigma_a", "(nx, ny, nz) or (nx, ny, nz, 3)", "(2, 2)"]),
        ({"sigma_a": np.ones((2, 2, 3))}, ["sigma_a has shape", "sigma_s"]),
        ({"bounds": [[0, 0, 0], [1, 0, 1]]}, ["grid.bounds", "empty", "axis 1"]),
        ({"bounds": [0, 1]}, ["grid.bounds", "[[x0, y0, z0], [x1, y1, z1]]"]),
        ({"sigma_a": np.ones((2000, 1, 1)), "sigma_s": np.ones((2000, 1, 1))}, ["grid.shape[0] = 2000", "[1, 1024]"]),
    ],
)
def test_bad_grids_are_refused(kw, fragments):
    args = {"sigma_a": np.ones((2, 2, 2)), "sigma_s": np.ones((2, 2, 2)), "bounds": BOX, **kw}
    with pytest.raises(ParameterError) as e:
        R.simulate_walk(_scene(R.MediumGrid(**args)), 10, origin=(0, 0, 10))
    msg = str(e.value)
    assert "\n" not in msg and all(f in msg for f in fragments), msg


def test_missing_grid_file_and_bssrdf_methods_are_refused(tmp_path):
    with pytest.raises(FileNotFoundError, match="grid.sigma_a: grid file .* does not exist"):
        R.MediumGrid(tmp_path / "none.npy", np.ones((2, 2, 2)), BOX)
    with pytest.raises(ParameterError, match="a grid file must be a NumPy .npy file"):
        R.MediumGrid(tmp_path / "a.png", np.ones((2, 2, 2)), BOX)
    from subsurf.render import export

    with pytest.raises(ParameterError, match="has a medium grid"):
        export.to_pbrt(R.Translucent(*A, grid=_const()))
    sc = _scene(_const(), camera=R.Camera((0, -20, 0), width=2, height=2))
    with pytest.raises(ParameterError, match="grid: only the random walk"):
        R.render(sc, "hierarchical", spp=1)


SCENE = """
[render]
method = "random_walk"
spp = 1

[camera]
position = [0.0, -20.0, 0.0]
width = 4
height = 4

[materials.m]
sigma_a = [0.1, 0.1, 0.1]
sigma_s = [2.0, 2.0, 2.0]

[materials.m.grid]
sigma_a = "a.npy"
sigma_s = "s.npy"
bounds = [[-2.0, -2.0, -2.0], [2.0, 2.0, 2.0]]

[[objects]]
shape = "box"
lo = [-2.0, -2.0, -2.0]
hi = [2.0, 2.0, 2.0]
material = "m"
"""


def test_scene_file_with_a_grid(tmp_path, cli_here):
    np.save(tmp_path / "a.npy", np.full((2, 2, 2), 0.1))
    np.save(tmp_path / "s.npy", np.full((2, 2, 2), 2.0))
    (tmp_path / "s.toml").write_text(SCENE)
    sc, settings = R.load_scene(tmp_path / "s.toml")
    assert sc.objects[0].material.grid.shape == (2, 2, 2) and settings["method"] == "random_walk"
    status, _, err = cli_here("render", tmp_path / "s.toml", "-o", tmp_path / "o.png", "-q")
    assert status == 0, err


@pytest.mark.parametrize(
    "edit, fragments",
    [
        (('sigma_a = "a.npy"', 'sigma_a = "none.npy"'), ["materials.m.grid.sigma_a", "does not exist"]),
        (("bounds = [[-2.0, -2.0, -2.0]", "bounds = [[-2.0, 2.0, -2.0]"), ["materials.m.grid.bounds", "empty"]),
        (("bounds =", "size = 3\nbounds ="), ["materials.m", "grid: unknown keys ['size']"]),
        (('sigma_s = "s.npy"\n', ""), ["materials.m", "grid: missing 'sigma_s'"]),
        (('sigma_a = "a.npy"', 'sigma_a = "neg.npy"'), ["materials.m.grid.sigma_a[1, 0, 0, 0] = -0.5", ">= 0"]),
        (('method = "random_walk"', 'method = "probe"'), ["materials.m.grid: only the random walk"]),
    ],
)
def test_scene_file_grid_errors_are_one_line(tmp_path, error_here, edit, fragments):
    np.save(tmp_path / "a.npy", np.full((2, 2, 2), 0.1))
    np.save(tmp_path / "s.npy", np.full((2, 2, 2), 2.0))
    neg = np.full((2, 2, 2), 0.1)
    neg[1, 0, 0] = -0.5
    np.save(tmp_path / "neg.npy", neg)
    (tmp_path / "s.toml").write_text(SCENE.replace(*edit))
    error_here("render", tmp_path / "s.toml", "-o", tmp_path / "o.png", "-q", fragments=fragments)
