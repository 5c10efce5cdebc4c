"""Surface maps (``Texture`` as the reflectance and/or the mfp of ``Translucent.from_reflectance``):
the texel where a walk enters a mesh with texture coordinates sets its medium (σs and σt), the
BSSRDF methods take the texel at the shading point. Constant maps are the untextured material
(hierarchical to rounding, random walk bit for bit at the same seed); each texel is the
untextured inversion of its (reflectance, mfp) for every kind of mean free path. A map of one constant
colour is the untextured material (4σ, renderer and simulation); a two-colour map gives each
walk the medium of its entry point; bad inputs are refused in one line naming the field."""

from __future__ import annotations

import numpy as np
import pytest
import subsurf.render as R
from subsurf import ParameterError

COLOUR = [0.55, 0.4, 0.25]
MFP = [0.4, 0.3, 0.25]


def _sphere(material, **kw):
    """An icosphere of radius 2 mm with v = ½ + z/(2r) (u from the azimuth)."""
    o = R.Object.sphere(material, radius=2.0, subdivisions=3, **kw)
    p = o.positions
    uv = np.stack([0.5 + np.arctan2(p[:, 1], p[:, 0]) / (2 * np.pi), 0.5 + p[:, 2] / 4.0], axis=1)
    return R.Object(p, o.triangles, material, uv=uv)


def _walk(obj, channel, seed, z, photons=20_000):
    return R.simulate_walk(
        R.Scene([obj]), photons, seed=seed, origin=(0.2, 0.1, z), direction=(0, 0, -np.sign(z)), channel=channel
    )


def _agree(a, b):
    """Exitance of two runs within 4σ; returns the band."""
    sig = np.hypot(a["exitance_stderr"], b["exitance_stderr"])
    assert abs(a["exitance"] - b["exitance"]) < 4 * sig, (a["exitance"], b["exitance"], sig)
    return 4 * sig


@pytest.mark.parametrize("channel", [0, 1, 2])
def test_constant_colour_map_is_the_untextured_material(channel):
    """Simulation, per channel, 20 000 photons each. Power: the band is asserted below 0.02 of
    the launched power (3–6 % of these exitances)."""
    plain = R.Translucent.from_reflectance(COLOUR, MFP, eta=1.4)
    tex = R.Translucent.from_reflectance(R.Texture(np.broadcast_to(COLOUR, (4, 8, 3))), MFP, eta=1.4)
    assert np.allclose(tex.texel_sigma_s, plain.sigma_s, rtol=0, atol=0)
    band = _agree(_walk(_sphere(plain), channel, 1, 10), _walk(_sphere(tex), channel, 2, 10))
    assert band < 0.02
    # The same seed: the texel's σs is the material's, so the walk is the same, bit for bit.
    a, b = _walk(_sphere(plain), channel, 7, 10, 500), _walk(_sphere(tex), channel, 7, 10, 500)
    assert (a["exitance"], a["absorbed"], a["roulette"]) == (b["exitance"], b["absorbed"], b["roulette"])


@pytest.mark.slow
def test_constant_colour_map_renders_the_untextured_image():
    """Image means of 10 seeds each (16 spp, 6×6 px on the sphere), 4σ from the seeds' spread.
    Power: the band is asserted below 5 % of the mean."""
    cam = R.Camera((0, -14, 0), fov=12, width=6, height=6)
    plain = R.Translucent.from_reflectance(COLOUR, MFP, eta=1.4)
    tex = R.Translucent.from_reflectance(R.Texture(np.broadcast_to(COLOUR, (2, 2, 3))), MFP, eta=1.4)

    def means(m, seed0):
        sc = R.Scene([_sphere(m)], environment=(0.3,) * 3, camera=cam)
        return np.array([R.render(sc, "random_walk", spp=16, seed=seed0 + s).array.mean() for s in range(10)])

    a, b = means(plain, 0), means(tex, 100)
    sig = np.sqrt(a.var(ddof=1) / a.size + b.var(ddof=1) / b.size)
    assert 4 * sig < 0.05 * a.mean(), (a, b)
    assert abs(a.mean() - b.mean()) < 4 * sig, (a.mean(), b.mean(), sig)


def test_each_walk_takes_the_medium_of_its_entry_point():
    """Top half of the map (v > ½: the sphere's z > 0) dark, bottom half light: a beam from above
    enters the dark half and gives the dark material's exitance, a beam from below the light
    one's (4σ each; a walk crossing the equator keeps its entry medium)."""
    dark, light = [0.1, 0.15, 0.2], [0.7, 0.6, 0.5]
    img = np.empty((2, 1, 3))
    img[0], img[1] = dark, light  # row 0 is the top (v = 1)
    tex = R.Translucent.from_reflectance(R.Texture(img), MFP, eta=1.4)
    for colour, z, seed in [(dark, 10, 3), (light, -10, 5)]:
        plain = R.Translucent.from_reflectance(colour, MFP, eta=1.4)
        _agree(_walk(_sphere(plain), 1, seed, z, 10_000), _walk(_sphere(tex), 1, seed + 1, z, 10_000))
    d, lt = (_walk(_sphere(tex), 1, 9, z, 2000)["exitance"] for z in (10, -10))
    assert lt > 2 * d


OBJ = """v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1
vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1
f 1/1 4/4 3/3\nf 1/1 3/3 2/2\nf 5/1 6/2 7/3\nf 5/1 7/3 8/4\nf 1/1 2/2 6/3\nf 1/1 6/3 5/4
f 2/1 3/2 7/3\nf 2/1 7/3 6/4\nf 3/1 4/2 8/3\nf 3/1 8/3 7/4\nf 4/1 1/2 5/3\nf 4/1 5/3 8/4
"""


def test_obj_with_uvs_stays_closed(tmp_path):
    """trimesh splits vertices at UV seams; Object.mesh merges them again (per-corner UVs)."""
    (tmp_path / "cube.obj").write_text(OBJ)
    m = R.Translucent.from_reflectance(R.Texture(np.full((2, 2, 3), 0.5)), MFP)
    o = R.Object.mesh(tmp_path / "cube.obj", m, scale=4)
    assert o.uv.shape == (12, 3, 2) and len(o.positions) == 8
    closed, open_edges, _, _ = o.info()
    assert closed and open_edges == 0
    out = R.simulate_walk(R.Scene([o]), 500, origin=(2.1, 2.2, 10))
    assert abs(out["specular"] + out["exitance"] + out["absorbed"] + out["lost"] - 1) < 1e-12


def test_bad_textures_are_refused(tmp_path):
    m = R.Translucent.from_reflectance(R.Texture(np.full((2, 2, 3), 0.5)), MFP)
    with pytest.raises(
        ParameterError, match=r"objects\[0\]\.uv: the material has a surface texture but the mesh has no"
    ):
        R.simulate_walk(R.Scene([R.Object.box(m)]), 10, origin=(0, 0, 10))
    with pytest.raises(FileNotFoundError, match="texture: image file .* does not exist"):
        R.Texture(tmp_path / "none.png")
    with pytest.raises(
        ParameterError, match=r"texture\[0, 1, 2\] = 1.5 is out of range: must be a reflectance in \[0, 1\]"
    ):
        a = np.full((2, 2, 3), 0.5)
        a[0, 1, 2] = 1.5
        R.Translucent.from_reflectance(R.Texture(a), MFP)
    with pytest.raises(ParameterError, match=r"texture\[0, 0, 0\] = nan"):
        R.Texture(np.full((1, 1, 3), np.nan))
    with pytest.raises(ParameterError, match=r"texture: expected an image of shape \(height, width, 3\)"):
        R.Texture(np.zeros((2, 2, 5)))
    with pytest.raises(ParameterError, match=r"texture, channel 0: reflectance\[0\] = 0.999 is out of range"):
        R.Translucent.from_reflectance(R.Texture(np.full((1, 1, 3), 0.999)), MFP)
    from subsurf.render import export

    with pytest.raises(ParameterError, match="has a colour map"):
        export.to_mitsuba(m)
    with pytest.raises(ParameterError, match='model = "adaptive" takes no surface texture'):
        R.Translucent.from_reflectance(R.Texture(np.full((1, 1, 3), 0.5)), MFP, model="adaptive")


SCENE = """
[render]
method = "random_walk"
spp = 1

[camera]
position = [0.0, -20.0, 0.0]
width = 4
height = 4

[materials.m]
reflectance = "map.png"
mfp = [0.4, 0.3, 0.25]

[[objects]]
mesh = "cube.obj"
scale = 4
material = "m"
"""


def test_scene_file_with_a_texture(tmp_path, cli_here):
    from PIL import Image

    Image.fromarray(np.full((2, 2, 3), 128, dtype=np.uint8)).save(tmp_path / "map.png")
    (tmp_path / "cube.obj").write_text(OBJ)
    (tmp_path / "s.toml").write_text(SCENE)
    sc, _ = R.load_scene(tmp_path / "s.toml")
    m = sc.objects[0].material
    assert m.texture.shape == (2, 2)  # sRGB 128/255 → linear 0.2158
    assert np.allclose(m.texture.reflectance, ((128 / 255 + 0.055) / 1.055) ** 2.4)
    status, _, err = cli_here("render", tmp_path / "s.toml", "-o", tmp_path / "o.png", "-q")
    assert status == 0, err


@pytest.mark.parametrize(
    "edit, fragments",
    [
        (('reflectance = "map.png"', 'reflectance = "none.png"'), ["materials.m.reflectance", "does not exist"]),
        (('mesh = "cube.obj"\nscale = 4', 'shape = "box"'), ["uv: the material has a surface texture", "no texture"]),
    ],
)
def test_scene_file_texture_errors_are_one_line(tmp_path, error_here, edit, fragments):
    from PIL import Image

    Image.fromarray(np.full((2, 2, 3), 128, dtype=np.uint8)).save(tmp_path / "map.png")
    (tmp_path / "cube.obj").write_text(OBJ)
    (tmp_path / "s.toml").write_text(SCENE.replace(*edit))
    error_here("render", tmp_path / "s.toml", "-o", tmp_path / "o.png", "-q", fragments=fragments)


def _image(m, method, seed=3):
    cam = R.Camera((0, -14, 0), fov=12, width=4, height=4)
    sc = R.Scene([_sphere(m)], [R.DirectionalLight((0.3, -1, 0.5), 1.0)], environment=(0.3,) * 3, camera=cam)
    return R.render(sc, method, spp=1, seed=seed, hierarchical={"spacing": 1.0, "env_samples": 4}).array


def test_constant_maps_render_the_untextured_material():
    plain = R.Translucent.from_reflectance(COLOUR, MFP, eta=1.4)
    maps = R.Translucent.from_reflectance(
        R.Texture(np.broadcast_to(COLOUR, (2, 3, 3))), R.Texture(np.broadcast_to(MFP, (2, 3, 3))), eta=1.4
    )
    a, b = _image(plain, "hierarchical"), _image(maps, "hierarchical")
    assert a.mean() > 0.01 and np.allclose(a, b, rtol=1e-6, atol=0)
    assert np.array_equal(_image(plain, "random_walk"), _image(maps, "random_walk"))


def test_mfp_map_sets_the_medium_of_each_walk():
    """Top half of the map (the sphere's z > 0) mean free path 0.15 mm, bottom half 1.2 mm, one
    colour: a beam from above gives the short material's exitance, from below the long one's
    (4σ each, 10 000 photons), and the two differ by far more than their bands."""
    short, long = [0.15] * 3, [1.2] * 3
    img = np.empty((2, 1, 3))
    img[0], img[1] = short, long  # row 0 is the top (v = 1)
    tex = R.Translucent.from_reflectance(COLOUR, R.Texture(img), eta=1.4)
    out = {}
    for mfp, z, seed in [(short, 10, 3), (long, -10, 5)]:
        plain = R.Translucent.from_reflectance(COLOUR, mfp, eta=1.4)
        a, b = _walk(_sphere(plain), 1, seed, z, 10_000), _walk(_sphere(tex), 1, seed + 1, z, 10_000)
        out[z] = (a["exitance"], _agree(a, b))
    assert abs(out[10][0] - out[-10][0]) > 3 * (out[10][1] + out[-10][1]), out


@pytest.mark.parametrize("kind", ["extinction", "transport", "diffuse"])
def test_each_texel_is_the_inversion_of_its_reflectance_and_mfp(kind):
    refl = np.array([[[0.2, 0.5, 0.7], [0.6, 0.3, 0.1]]])
    mfp = np.array([[[0.5, 1.0, 2.0], [0.3, 0.3, 4.0]]])
    m = R.Translucent.from_reflectance(R.Texture(refl), R.Texture(mfp), eta=1.3, g=0.2, mfp_kind=kind)
    for j in range(2):
        one = R.Translucent.from_reflectance(refl[0, j], mfp[0, j], eta=1.3, g=0.2, mfp_kind=kind)
        assert np.allclose(m.texel_sigma_a[0, j], one.sigma_a, rtol=1e-12, atol=0)
        assert np.allclose(m.texel_sigma_s[0, j], one.sigma_s, rtol=1e-12, atol=0)


def test_bad_maps_are_refused():
    two, three = R.Texture(np.full((2, 2, 3), 0.5)), R.Texture(np.full((3, 2), 0.5))
    shapes = r"mfp: the mean-free-path map has shape \(3, 2\) but the colour map \(2, 2\)"
    with pytest.raises(ParameterError, match=shapes):
        R.Translucent.from_reflectance(two, three)
    with pytest.raises(ParameterError, match=r"texture\[0, 0, 1\] = -0.5 is out of range: must be finite and >= 0"):
        R.Texture(np.array([[[1.0, -0.5, 1.0]]]))
    zero = r"mfp texture\[1, 0, 0\] = 0.0 is out of range: a mean free path must be > 0"
    with pytest.raises(ParameterError, match=zero):
        R.Translucent.from_reflectance(COLOUR, R.Texture(np.array([[1.0], [0.0]])))
    with pytest.raises(ParameterError, match=r"every mean free path must be > 0"):
        R.Translucent.from_reflectance(two, [0.4, -1, 0.3])
    with pytest.raises(ParameterError, match=r"texture.scale = -2.0: must be a finite number > 0"):
        R.Texture(np.ones((1, 1)), scale=-2)
    m = R.Translucent.from_reflectance(COLOUR, R.Texture(np.full((2, 2), 0.4)))
    cam = R.Camera((0, -14, 0), width=2, height=2)
    with pytest.raises(ParameterError, match=r"objects\[0\]\.uv: the material has a surface texture"):
        R.render(R.Scene([R.Object.sphere(m, radius=2.0)], camera=cam), "hierarchical", spp=1)


MFP_SCENE = """
[render]
method = "probe"
spp = 1

[camera]
position = [0.0, -20.0, 0.0]
width = 4
height = 4

[materials.m]
reflectance = [0.5, 0.4, 0.3]
mfp = "mfp.png"
mfp_scale = 2.0

[[objects]]
mesh = "cube.obj"
scale = 4
material = "m"

[[lights]]
type = "directional"
direction = [0.0, -1.0, 0.2]
irradiance = 1.0
"""


def test_scene_file_with_an_mfp_map(tmp_path, cli_here, error_here):
    from PIL import Image

    Image.fromarray(np.array([[[51, 102, 153]]], dtype=np.uint8)).save(tmp_path / "mfp.png")
    (tmp_path / "cube.obj").write_text(OBJ)
    (tmp_path / "s.toml").write_text(MFP_SCENE)
    sc, _ = R.load_scene(tmp_path / "s.toml")
    assert np.allclose(sc.objects[0].material.mfp_texture.values, [[[0.4, 0.8, 1.2]]])  # linear × mfp_scale
    status, _, err = cli_here("render", tmp_path / "s.toml", "-o", tmp_path / "o.png", "-q")
    assert status == 0, err
    (tmp_path / "bad.toml").write_text(MFP_SCENE.replace('mfp = "mfp.png"', "mfp = [0.4, 0.3, 0.2]"))
    error_here("render", tmp_path / "bad.toml", "-o", tmp_path / "o.png", "-q", fragments=["materials.m.mfp_scale"])


def test_more_than_4096_reflectances_snap_to_4096():
    """5000 distinct reflectances in a channel: each texel takes the nearest of 4096 evenly spaced
    ones (error ≤ range/8190), inverted exactly, so at most 4096 distinct profiles per channel."""
    values = np.linspace(0.1, 0.8, 5000)
    m = R.Translucent.from_reflectance(R.Texture(values[None, :, None] * np.ones((1, 1, 3))), MFP)
    assert [len(np.unique(m.texel_sigma_s[..., k])) for k in range(3)] == [4096] * 3
    grid = np.linspace(0.1, 0.8, 4096)
    for j in (0, 1234, 4999):
        snapped = grid[np.argmin(abs(grid - values[j]))]
        assert abs(snapped - values[j]) <= 0.7 / 8190 + 1e-15
        one = R.Translucent.from_reflectance([snapped] * 3, MFP)
        assert np.allclose(m.texel_sigma_s[0, j], one.sigma_s, rtol=1e-12, atol=0)


def test_maps_render_the_same_for_any_thread_count():
    """Random 8 × 8 colour and mfp maps: each method's image is the same with 1 and 2 threads."""
    img = np.random.default_rng(1).integers(40, 200, size=(8, 8, 3), dtype=np.uint8)
    mfp = R.Texture(np.random.default_rng(2).uniform(0.2, 1.0, size=(8, 8)))
    m = R.Translucent.from_reflectance(R.Texture(img), mfp, eta=1.4)
    cam = R.Camera((0, -14, 0), fov=12, width=6, height=6)
    sc = R.Scene([_sphere(m)], [R.DirectionalLight((0.3, -1, 0.5), 1.0)], environment=(0.2,) * 3, camera=cam)
    for method in ["hierarchical", "probe", "random_walk"]:
        a, b = (R.render(sc, method, spp=1, seed=4, threads=t).array for t in (1, 2))
        assert a.mean() > 0.01 and np.array_equal(a, b), method
