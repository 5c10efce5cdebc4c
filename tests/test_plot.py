"""Figures build from a synthetic result, carry labelled axes with units, and save as PNG."""

import pytest
from subsurf import plot
from synthetic import make_result

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def res():
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


def test_overlay_uses_top_layer_optics(res):
    assert plot.top_layer_optics(res) == pytest.approx((0.1, 10.0 * (1 - 0.9), 1.4))


def test_summary_figure_saves_png(res, tmp_path):
    fig = plot.figure(res)
    p = plot.save_figure(fig, tmp_path / "figs" / "r.png")
    data = open(p, "rb").read()
    assert data[:8] == PNG_MAGIC and len(data) > 20_000
    assert len(fig.axes) >= 5  # four panels + BRDF colour bar (+ orders)
    labels = [a.get_xlabel() for a in fig.axes]
    assert any("radius" in l for l in labels) and any("depth" in l for l in labels)


def test_figure_without_histograms(res, tmp_path):
    import copy

    bare = copy.copy(res)
    bare.histograms = {}
    p = plot.save_figure(plot.figure(bare), tmp_path / "bare.png")
    assert open(p, "rb").read()[:8] == PNG_MAGIC


def test_overflow_bin_is_not_drawn(res):
    import copy

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
