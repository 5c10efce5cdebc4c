"""Text and HTML views for notebooks and terminals: the pieces behind ``__repr__``/``_repr_html_``.

:class:`~subsurf.result.Result`, :class:`~subsurf.result.Histogram`, :class:`~subsurf.Layer`,
:class:`~subsurf.Stack` and :class:`~subsurf.Material` show their numbers with units and standard
errors through these helpers, so every object is drawn the same way. Standard library only.
"""

from __future__ import annotations

import html
import math
import re

__all__ = ["num", "value_stderr", "html_table", "axis_text"]

_NUMERIC = re.compile(r"^[-+]?(\d|\.\d|inf|nan)")


def num(x, digits: int = 6) -> str:
    """A number in ``digits`` significant digits (``inf``, ``nan`` spelled out)."""
    x = float(x)
    if math.isnan(x):
        return "nan"
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    return f"{x:.{digits}g}"


def value_stderr(v, s) -> str:
    """``v ± s``: the value to the precision its standard error supports (at least 4 digits)."""
    v, s = float(v), float(s)
    if s == 0:
        return f"{num(v)} ± 0"
    if not (math.isfinite(v) and math.isfinite(s)):
        return f"{num(v)} ± {num(s)}"
    # two significant digits of the error, the value to the same decimal place
    place = math.floor(math.log10(abs(s))) - 1
    digits = max(0, -place)
    return f"{v:.{digits}f} ± {s:.{digits}f}" if digits <= 10 else f"{v:.6g} ± {s:.2g}"


def axis_text(name: str, n: int, lo, hi, unit: str) -> str:
    """One axis of a histogram: ``r: 20 bins in [0, 1] mm``."""
    u = "" if unit in ("", "1") else f" {unit}"
    return f"{name}: {n} bins in [{num(lo, 4)}, {num(hi, 4)}]{u}"


def html_table(header, rows, caption: str | None = None) -> str:
    """A small HTML table; cells are escaped text, numbers right-aligned."""

    def cell(tag, x):
        text = html.escape(str(x))
        right = isinstance(x, (int, float)) or bool(_NUMERIC.match(str(x)))
        style = ' style="text-align:right"' if right else ' style="text-align:left"'
        return f"<{tag}{style}>{text}</{tag}>"

    out = ["<table>"]
    if caption:
        out.append(f'<caption style="text-align:left">{html.escape(caption)}</caption>')
    out.append("<tr>" + "".join(cell("th", h) for h in header) + "</tr>")
    for r in rows:
        out.append("<tr>" + "".join(cell("td", x) for x in r) + "</tr>")
    out.append("</table>")
    return "".join(out)


# --- media -------------------------------------------------------------------------------------

_LAYER_HEADER = ("layer", "n", "μa (mm⁻¹)", "μs (mm⁻¹)", "g", "thickness (mm)", "albedo", "μs′ (mm⁻¹)", "τ = μt·d")


def _layer_row(name, l) -> tuple:
    return (
        name,
        num(l.n),
        num(l.mua),
        num(l.mus),
        num(l.g, 4) + ("" if len(l.lobes) == 1 else f" ({len(l.lobes)} HG lobes)"),
        num(l.thickness),
        num(l.albedo, 4),
        num(l.mus_prime, 4),
        num(l.optical_thickness, 4),
    )


def layer_html(layer) -> str:
    """A :class:`subsurf.Layer` as a one-row table with its units and derived properties."""
    return html_table(_LAYER_HEADER, [_layer_row("", layer)], caption="Layer")


def stack_html(stack) -> str:
    """A :class:`subsurf.Stack`: the ambient media and one row per layer, from the top."""
    rows = [_layer_row(str(i), l) for i, l in enumerate(stack.layers)]
    cap = f"Stack of {len(rows)} layer(s), {num(stack.thickness)} mm; n above {num(stack.n_above)}, "
    cap += f"n below {num(stack.n_below)}"
    return html_table(_LAYER_HEADER, rows, caption=cap)


def material_html(m) -> str:
    """A :class:`subsurf.Material`: σa, σs′, albedo and transport mean free path per channel."""
    chans = ["R", "G", "B"] if m.channels == 3 else [str(i) for i in range(m.channels)]
    rows = [
        (c, num(a), num(s), num(al, 4), num(mfp, 4))
        for c, a, s, al, mfp in zip(chans, m.sigma_a, m.sigma_s_prime, m.alpha_prime, m.transport_mfp)
    ]
    g = "unknown" if m.g is None else num(m.g, 4)
    cap = f"Material {m.name or ''}: η = {num(m.eta)}, g = {g}".replace("Material :", "Material:")
    return html_table(("channel", "σa (mm⁻¹)", "σs′ (mm⁻¹)", "α′", "transport mfp (mm)"), rows, caption=cap)
