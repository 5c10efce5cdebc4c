"""What results, histograms, layers, stacks and materials show in a terminal (``repr``, ``summary``)
and in a notebook (``_repr_html_``): numbers with their standard errors, grid shapes and units."""

import math
import re
from html.parser import HTMLParser

import numpy as np
import pytest
import subsurf
from subsurf import display


class _Cells(HTMLParser):
    """The text of every table cell and caption of an HTML fragment, in order."""

    def __init__(self, text):
        super().__init__()
        self.cells, self.captions, self._in = [], [], None
        self.feed(text)

    def handle_starttag(self, tag, attrs):
        if tag in ("td", "th", "caption"):
            self._in = tag
            (self.captions if tag == "caption" else self.cells).append("")

    def handle_endtag(self, tag):
        self._in = None

    def handle_data(self, data):
        if self._in:
            (self.captions if self._in == "caption" else self.cells)[-1] += data


def test_summary_is_the_table_the_cli_prints(make_result):
    res, _ = make_result(seed=1)
    res.specular_reflectance_stderr = 0.0
    lines = res.summary().splitlines()
    assert lines[0].split() == ["quantity", "value", "stderr"]
    rows = {l[:28].strip(): l[28:].split() for l in lines[1:-1]}
    assert rows["diffuse reflectance"] == ["0.350000", "±", "4.00e-03"]
    assert rows["specular reflectance"] == ["0.050000", "±", "0"]  # a deterministic quantity: exactly 0
    assert rows["absorbed in layer 1"][0] == f"{res.absorbed_per_layer[1]:.6f}"
    assert rows["energy balance"] == ["1.000000"]
    assert lines[-1] == "10,000 photons, seed 1, 1.25 s, 3.2e+05 scattering events/s, 8e+03 photons/s"
    res.partial, res.photons_requested = True, 40_000
    assert res.summary().splitlines()[-1] == "PARTIAL: 10,000 of 40,000 photons (interrupted)"


def test_result_repr_and_html(make_result):
    res, _ = make_result(seed=1)
    text = repr(res)
    assert text.startswith("Result(10,000 photons, seed 1,")
    assert "diffuse reflectance          0.350000 ± 4.00e-03" in text
    assert "a_rz: r: 20 bins in [0, 1] mm × z: 15 bins in [0, 0.6] mm (mm^-3)" in text
    assert "rd_order: order: 5 bins in [0, 5] (1)" in text
    html = _Cells(res._repr_html_())
    assert html.captions[0].startswith("10,000 photons, seed 1")
    i = html.cells.index("diffuse reflectance")
    assert html.cells[i : i + 4] == ["diffuse reflectance", "0.35", "4.00e-03", "1"]
    j = html.cells.index("a_rz")
    assert html.cells[j : j + 3] == ["a_rz", "r (20) × z (15)", "mm^-3"]
    assert len([c for c in html.cells if c.startswith("  absorbed in layer")]) == 2


def test_histogram_repr_and_html(make_result):
    res, _ = make_result(seed=1)
    h = res.rd_ra
    lo, hi = np.min(h.values), np.max(h.values)
    assert repr(h) == (
        "Histogram(r: 20 bins in [0, 1] mm × theta: 6 bins in [0, 1.571] rad; units mm^-2 sr^-1; "
        f"values in [{display.num(lo, 4)}, {display.num(hi, 4)}]; 'rd per area and solid angle')"
    )
    html = _Cells(h._repr_html_())
    assert html.captions == ["Histogram: rd per area and solid angle (mm^-2 sr^-1)"]
    assert html.cells[5:10] == ["r", "20", "0", "1", "mm"] and html.cells[10:15] == ["theta", "6", "0", "1.571", "rad"]
    assert f"largest standard error {display.num(h.stderr.max(), 3)}" in h._repr_html_()
    nan = subsurf.Histogram(np.full(3, np.nan), np.zeros(3), (np.arange(4.0),), ("z",), ("mm",), "mm^-2", "fluence")
    assert "values in" not in repr(nan) and "no finite values" in nan._repr_html_()


def test_layer_stack_and_material_html():
    top, bottom = subsurf.Layer(1.4, 0.1, 10.0, 0.9, 0.5), subsurf.Layer(1.3, 0.02, 12.0, 0.8)
    cells = _Cells(top._repr_html_()).cells
    assert cells[:9] == [
        "layer",
        "n",
        "μa (mm⁻¹)",
        "μs (mm⁻¹)",
        "g",
        "thickness (mm)",
        "albedo",
        "μs′ (mm⁻¹)",
        "τ = μt·d",
    ]
    assert cells[9:] == ["", "1.4", "0.1", "10", "0.9", "0.5", "0.9901", "1", "5.05"]
    stack = subsurf.Stack([top, bottom], n_above=1.0, n_below=1.33)
    html = _Cells(stack._repr_html_())
    assert html.captions == ["Stack of 2 layer(s), inf mm; n above 1, n below 1.33"]
    assert html.cells[18:27] == ["1", "1.3", "0.02", "12", "0.8", "inf", "0.9983", "2.4", "inf"]
    assert eval(repr(stack), {"Stack": subsurf.Stack, "Layer": subsurf.Layer, "inf": math.inf}) == stack
    m = subsurf.materials.get("marble")
    html = _Cells(m._repr_html_())
    assert html.captions == ["Material marble: η = 1.5, g = unknown"]
    assert html.cells[5:10] == ["R", "0.0021", "2.19", display.num(2.19 / 2.1921, 4), display.num(1 / 2.1921, 4)]


@pytest.mark.parametrize(
    "v, s, text",
    [
        (0.123456789, 0.00123, "0.1235 ± 0.0012"),
        (12.5, 0.0, "12.5 ± 0"),
        (math.nan, 1.0, "nan ± 1"),
        (3.0, 2.0, "3.0 ± 2.0"),
    ],
)
def test_value_stderr(v, s, text):
    assert display.value_stderr(v, s) == text


def test_html_escapes_text():
    out = display.html_table(("a",), [("<b>&</b>",)], caption="x<y")
    assert "<b>" not in re.sub(r"</?(table|tr|td|th|caption)[^>]*>", "", out) and "&lt;b&gt;&amp;" in out
