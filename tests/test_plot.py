"""Figures build from a synthetic result, carry labelled axes with units, and save as PNG; one tally
draws in one call (``Histogram.plot``)."""

import copy
import io

import numpy as np
import pytest
from matplotlib import image
from matplotlib.collections import QuadMesh
from subsurf import plot


@pytest.fixture(scope="module")
def res(make_result):
    return make_result(seed=4)[0]


def test_panels_have_labels_with_units(res):
    ax = plot.reflectance_profile(res, models=())
    assert ax.get_xscale() == "log" and ax.get_yscale() == "log"
    assert "r (mm)" in ax.get_xlabel() and "mm$^{-2}$" in ax.get_ylabel()
    assert ax.get_legend() is not None
    ax = plot.absorption_depth(res)
    assert "z (mm)" in ax.get_xlabel() and "mm$^{-1}$" in ax.get_ylabel()
    # the layer boundary (0.5 mm, inside the 0.6 mm grid) is marked
    assert any(l.get_label() == "layer boundary" for l in ax.get_lines())
    assert plot.layer_boundaries(res) == [0.5]
    ax = plot.in_plane(res)
    assert "θ" in ax.get_xlabel() and "sr$^{-1}$" in ax.get_ylabel()
    ax = plot.orders(res)
    assert [t.get_text() for t in ax.get_xticklabels()] == ["0", "1", "2", "3", ">3"]
    assert "order" in ax.get_xlabel()
    ax = plot.hemisphere_map(res)
    assert ax.name == "polar"


def test_model_overlays_are_the_diffusion_profiles(res):
    from subsurf import diffusion

    ax = plot.reflectance_profile(res)
    lines = {l.get_label(): l for l in ax.get_lines()}
    dip = lines["dipole (Jensen et al. 2001)"]
    r = dip.get_xdata()
    np.testing.assert_allclose(dip.get_ydata(), diffusion.dipole_rd(r, 0.1, 10.0 * (1 - 0.9), 1.4), rtol=1e-12)
    bd = lines["better dipole (d'Eon 2012)"]
    np.testing.assert_allclose(bd.get_ydata(), diffusion.better_dipole_rd(r, 0.1, 1.0, 1.4), rtol=1e-12)


def test_overlay_uses_top_layer_optics(res):
    assert plot.top_layer_optics(res) == pytest.approx((0.1, 10.0 * (1 - 0.9), 1.4))


def _pixels(data: bytes):
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and data[-8:-4] == b"IEND"
    return image.imread(io.BytesIO(data), format="png")


@pytest.mark.slow
def test_summary_figure_saves_png(res, tmp_path):
    fig = plot.figure(res)
    assert len(fig.axes) == 6  # R(r), A(z), BRDF map + its colour bar, in-plane BRDF, orders
    labels = [a.get_xlabel() for a in fig.axes]
    assert any("radius" in l for l in labels) and any("depth" in l for l in labels)
    p = plot.save_figure(fig, tmp_path / "r.png")
    px = _pixels(open(p, "rb").read())
    assert px.shape[:2] == (round(3 * 4.5 * 130), round(2 * 6 * 130))
    ink = (px[..., :3] < 0.5).any(axis=-1).mean()
    assert 0.01 < ink < 0.6, ink
    # other formats by extension
    p = plot.save_figure(fig, tmp_path / "r.svg")
    assert open(p).read(200).lstrip().startswith("<?xml")


def test_figure_without_histograms(res, tmp_path):
    bare = copy.copy(res)
    bare.histograms = {}
    fig = plot.figure(bare)
    assert [t.get_text() for t in fig.axes[0].texts] == ["no histograms in this result"]
    p = plot.save_figure(fig, tmp_path / "bare.png")
    assert _pixels(open(p, "rb").read()).shape[:2] == (round(4.5 * 130), round(6 * 130))


def test_overflow_bin_is_not_drawn(res):
    # the histogram says its last r bin holds the overflow (structured data, not its description)
    assert res.rd_r.overflow == (True,)
    ax = plot.reflectance_profile(res, models=())
    x = ax.containers[0].lines[0].get_xdata()
    assert len(x) == len(res.rd_r.values) - 1 and x.max() < res.rd_r.edges[0][-2]
    r = copy.deepcopy(res)
    r.histograms["rd_r"].overflow = (False,)
    r.histograms["rd_r"].description += "; last bin also holds r > 1 mm"  # prose is not read
    ax = plot.reflectance_profile(r, models=())
    assert len(ax.containers[0].lines[0].get_xdata()) == len(r.rd_r.values)


# --- Histogram.plot: one tally, one call ---------------------------------------------------------


def test_plot_of_a_1d_histogram(res):
    h = res.rd_r  # its last r bin holds everything beyond the grid: not drawn
    assert h.overflow == (True,)
    ax = h.plot()
    assert ax.get_xlabel() == "r (mm)" and ax.get_ylabel() == f"{h.description} (mm$^{{-2}}$)"
    line, band = ax.patches[:2]  # the values as steps, the ±1σ band between v − s and v + s
    np.testing.assert_array_equal(line.get_data().values, h.values[:-1])
    np.testing.assert_array_equal(line.get_data().edges, h.edges[0][:-1])
    np.testing.assert_allclose(band.get_data().values, (h.values + h.stderr)[:-1])
    np.testing.assert_allclose(band.get_data().baseline, (h.values - h.stderr)[:-1])
    assert ax.get_yscale() == "linear"
    assert h.plot(log=True).get_yscale() == "log"
    a = res.rd_a  # no overflow on an angle axis: every bin
    assert len(a.plot().patches[0].get_data().values) == len(a.values)


def test_plot_of_a_2d_histogram(res):
    h = res.a_rz  # overflow bins in r and z: not drawn
    ax = h.plot()
    mesh = next(c for c in ax.collections if isinstance(c, QuadMesh))
    inner = h.values[:-1, :-1].T
    np.testing.assert_array_equal(np.asarray(mesh.get_array()).reshape(inner.shape), inner)
    assert ax.get_xlabel() == "r (mm)" and ax.get_ylabel() == "z (mm)"
    assert ax.yaxis_inverted()  # depth grows downwards
    cbar = ax.figure.axes[-1]
    assert "mm$^{-3}$" in cbar.get_ylabel()
    assert not res.brdf.plot().yaxis_inverted()


def test_plot_of_a_3d_histogram_takes_a_slice():
    from subsurf import Histogram

    v = np.arange(24.0).reshape(2, 3, 4)
    h = Histogram(
        v,
        v / 10,
        (np.arange(3.0), np.linspace(0, 1, 4), np.linspace(0, 6, 5)),
        ("order", "cos_theta", "phi"),
        ("1", "1", "rad"),
        "sr^-1",
        "BRDF by order",
    )
    with pytest.raises(ValueError, match=r"h.take\('order', 0\).plot\(\)"):
        h.plot()
    one = h.take("order", 1)
    np.testing.assert_array_equal(one.values, v[1])
    np.testing.assert_array_equal(one.stderr, v[1] / 10)
    assert one.axes == ("cos_theta", "phi") and one.edge_units == ("1", "rad")
    assert one.description == "BRDF by order (order in [1, 2])"
    ax = one.plot()
    assert ax.get_xlabel() == "cos_theta" and ax.get_ylabel() == "phi (rad)"
    with pytest.raises(ValueError, match="bin 2 is out of range"):
        h.take(0, 2)
    with pytest.raises(ValueError, match="no axis 'x'"):
        h.take("x", 0)
