"""Figures of Monte Carlo results (matplotlib, no display needed).

Every function takes a :class:`~subsurf.result.Result` and an optional matplotlib ``Axes`` and
returns the axes it drew on; :func:`figure` lays out every panel a result supports and
:func:`save_figure` writes it to a PNG (or any format matplotlib knows). Figures are built with
:class:`matplotlib.figure.Figure` directly (Agg canvas), so nothing depends on a GUI backend.

* :func:`reflectance_profile` — R(r) on log axes with standard-error bars and, on request, the
  dipole and better-dipole R_d(r) of the top layer (Jensen et al. 2001 eq. 4; d'Eon 2012).
* :func:`absorption_depth` — A(z) with the layer boundaries marked.
* :func:`hemisphere_map` — BRDF/BTDF on its equal-solid-angle bins, drawn over the hemisphere
  (radius sin θ, i.e. the orthographic projection of the hemisphere onto the surface).
* :func:`in_plane` — the BRDF/BTDF in the plane of incidence (φ = 0 and φ = π bins) vs θ.
* :func:`orders` — totals by scattering order 0…K, >K.
"""

from __future__ import annotations

import math
import os

import numpy as np

__all__ = [
    "reflectance_profile",
    "absorption_depth",
    "hemisphere_map",
    "in_plane",
    "orders",
    "figure",
    "save_figure",
    "top_layer_optics",
    "layer_boundaries",
    "histogram",
]

_UNITS = {
    "mm^-1": "mm$^{-1}$",
    "mm^-2": "mm$^{-2}$",
    "mm^-3": "mm$^{-3}$",
    "sr^-1": "sr$^{-1}$",
    "mm^-2 sr^-1": "mm$^{-2}$ sr$^{-1}$",
    "1": "1",
}


def _u(units: str) -> str:
    return _UNITS.get(units, units)


def _visible(h) -> slice:
    """Bins to draw: all but an overflow bin (the tallies' last r/z bin holds everything beyond the
    grid, as in MCML — ``Histogram.overflow`` — so it is not a density at its centre and is left out
    of the plots)."""
    over = bool(h.overflow) and h.overflow[0]
    return slice(0, -1) if over and np.shape(h.values)[0] > 1 else slice(None)


def _new_axes(ax, **kw):
    if ax is not None:
        return ax
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6, 4.5), layout="constrained")
    return fig.add_subplot(**kw)


def _layers_from_config(config: dict):
    stack = config.get("stack", config) if isinstance(config, dict) else {}
    layers = stack.get("layers") if isinstance(stack, dict) else None
    return layers if isinstance(layers, list) else [], stack if isinstance(stack, dict) else {}


def layer_boundaries(result) -> list:
    """Depths (mm) of the interfaces below the surface, from the result's configuration."""
    layers, _ = _layers_from_config(result.config)
    z, out = 0.0, []
    for l in layers:
        d = l.get("thickness", math.inf) if isinstance(l, dict) else (l[4] if len(l) > 4 else math.inf)
        d = float(d) if not isinstance(d, str) else math.inf
        if not math.isfinite(d):
            break
        z += d
        out.append(z)
    return out


def top_layer_optics(result):
    """(σa, σs′, η) of the top layer from the configuration (mm⁻¹, relative index n/n_above), or None."""
    layers, stack = _layers_from_config(result.config)
    if not layers:
        return None
    l = layers[0]
    if not isinstance(l, dict):
        return None
    try:
        g = float(l.get("g", 0.0))
        if "lobes" in l or "phase" in l:
            lobes = l.get("lobes", l.get("phase"))
            g = sum(float(w) * float(gg) for w, gg in lobes)
        mua, mus, n = float(l["mua"]), float(l["mus"]), float(l["n"])
    except (KeyError, TypeError, ValueError):
        return None
    return mua, mus * (1 - g), n / float(stack.get("n_above", 1.0))


#: The diffusion models :func:`reflectance_profile` can overlay: colour, line style, legend.
_MODEL_STYLES = {
    "dipole": ("C0", "-", "dipole (Jensen et al. 2001)"),
    "better_dipole": ("C3", "--", "better dipole (d'Eon 2012)"),
}


def reflectance_profile(result, ax=None, name: str = "rd_r", models=("dipole", "better_dipole"), optics=None):
    """R(r) (or T(r) with ``name="tt_r"``) on log–log axes with ±1σ error bars.

    ``models`` names diffusion profiles drawn over the data for ``optics = (σa, σs′, η)`` (default:
    the top layer of the configuration); pass ``models=()`` for none. They are exact only for a
    semi-infinite medium and trustworthy at high albedo and r of several mean free paths.
    """
    ax = _new_axes(ax)
    h = result.histograms[name]
    keep = _visible(h)
    r = h.centers(0)[keep]
    v, s = np.asarray(h.values, float)[keep], np.asarray(h.stderr, float)[keep]
    ok = v > 0
    label = "Monte Carlo" + (f" ({result.photons:.3g} photons)" if result.photons else "")
    ax.errorbar(
        r[ok], v[ok], yerr=np.minimum(s[ok], v[ok] * 0.999), fmt="o", ms=3, lw=0.8, capsize=1.5, color="k", label=label
    )
    if models and name == "rd_r":
        optics = optics if optics is not None else top_layer_optics(result)
        if optics is not None:
            from . import diffusion

            rr = np.geomspace(max(r[0], 1e-4), r[-1], 200)
            for m in models:
                c, ls, lab = _MODEL_STYLES.get(m, (None, ":", m))
                ax.plot(rr, diffusion.rd(rr, *optics, model=m), color=c, ls=ls, lw=1.5, label=lab)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(f"radius r ({h.edge_units[0]})")
    what = "diffuse reflectance" if name.startswith("rd") else "transmittance"
    ax.set_ylabel(f"{what} {'R' if name.startswith('rd') else 'T'}(r) ({_u(h.units)})")
    ax.legend(fontsize=8)
    ax.grid(True, which="both", alpha=0.25)
    return ax


def absorption_depth(result, ax=None, name: str = "a_z"):
    """A(z) vs depth with ±1σ bands and dashed lines at the layer boundaries."""
    ax = _new_axes(ax)
    h = result.histograms[name]
    keep = _visible(h)
    z = h.centers(0)[keep]
    v, s = np.asarray(h.values, float)[keep], np.asarray(h.stderr, float)[keep]
    ax.step(z, v, where="mid", color="k", lw=1.2, label="Monte Carlo")
    ax.fill_between(z, v - s, v + s, step="mid", color="k", alpha=0.2, lw=0, label="±1 standard error")
    zmax = float(np.asarray(h.edges[0])[keep.stop if keep.stop is not None else len(h.edges[0]) - 1])
    first = True
    for zb in layer_boundaries(result):
        if zb < zmax:
            ax.axvline(zb, color="C1", ls="--", lw=1, label="layer boundary" if first else None)
            first = False
    if np.all(v[v != 0] > 0) and np.any(v > 0):
        ax.set_yscale("log")
    ax.set_xlabel(f"depth z ({h.edge_units[0]})")
    ax.set_ylabel(f"absorbed per unit depth A(z) ({_u(h.units)})")
    ax.legend(fontsize=8)
    ax.grid(True, alpha=0.25)
    return ax


def hemisphere_map(result, ax=None, name: str = "brdf", fig=None):
    """The BRDF (or BTDF) on its (cos θ, φ) bins as a map over the hemisphere (radius sin θ)."""
    if ax is None:
        from matplotlib.figure import Figure

        fig = Figure(figsize=(5.2, 4.5), layout="constrained")
        ax = fig.add_subplot(projection="polar")
    fig = fig or ax.figure
    h = result.histograms[name]
    ce, pe = (np.asarray(e, float) for e in h.edges[:2])
    rad = np.sqrt(np.clip(1 - ce**2, 0, 1))  # sin θ at each cos θ edge
    v = np.asarray(h.values, float)
    k = max(1, 96 // max(len(pe) - 1, 1))  # subdivide each φ bin so its edges draw as arcs
    pe_fine = np.concatenate([np.linspace(pe[j], pe[j + 1], k + 1)[:-1] for j in range(len(pe) - 1)] + [pe[-1:]])
    mesh = ax.pcolormesh(pe_fine, rad, np.repeat(v, k, axis=1), cmap="magma", shading="flat")
    cb = fig.colorbar(mesh, ax=ax, shrink=0.85)
    cb.set_label(f"{name.upper()} f ({_u(h.units)})")
    ax.set_ylim(0, 1)
    ticks = [10, 30, 50, 70]
    ax.set_yticks([math.sin(math.radians(t)) for t in ticks])
    ax.set_yticklabels([f"{t}°" for t in ticks], fontsize=7)
    ax.set_xlabel("azimuth φ (deg), polar angle θ (deg) on the radius (sin θ scale)")
    side = "reflection" if name.startswith("brdf") else "transmission"
    ax.set_title(f"{name.upper()} over the {side} hemisphere", fontsize=10)
    return ax


def in_plane(result, ax=None, name: str = "brdf"):
    """The BRDF (or BTDF) in the plane of incidence: the φ bins nearest 0 (θ > 0) and π (θ < 0)."""
    ax = _new_axes(ax)
    h = result.histograms[name]
    ce, pe = (np.asarray(e, float) for e in h.edges[:2])
    v, s = np.asarray(h.values, float), np.asarray(h.stderr, float)
    pc = 0.5 * (pe[1:] + pe[:-1])
    theta = np.degrees(np.arccos(0.5 * (ce[1:] + ce[:-1])))
    for target, sign, lab, c in (
        (0.0, 1, "φ ≈ 0 (forward, θ > 0)", "C0"),
        (math.pi, -1, "φ ≈ π (backward, θ < 0)", "C3"),
    ):
        j = int(np.argmin(np.abs(np.angle(np.exp(1j * (pc - target))))))
        ax.errorbar(
            sign * theta,
            v[:, j],
            yerr=s[:, j],
            fmt="o-",
            ms=3,
            lw=1,
            capsize=1.5,
            color=c,
            label=f"{lab}, bin φ = {math.degrees(pc[j]):.0f}°",
        )
    ax.set_xlabel("exit polar angle θ (deg), signed by side of the plane of incidence")
    ax.set_ylabel(f"{name.upper()} f ({_u(h.units)})")
    ax.set_xlim(-90, 90)
    ax.legend(fontsize=8)
    ax.grid(True, alpha=0.25)
    return ax


def orders(result, ax=None, names=("rd_order", "tt_order")):
    """Totals by scattering order 0…K and >K, as grouped bars with ±1σ error bars."""
    ax = _new_axes(ax)
    present = [n for n in names if n in result.histograms]
    width = 0.8 / max(len(present), 1)
    labels = None
    for k, n in enumerate(present):
        h = result.histograms[n]
        v, s = np.asarray(h.values, float), np.asarray(h.stderr, float)
        x = np.arange(len(v))
        lab = {"rd_order": "diffuse reflectance", "tt_order": "transmittance"}.get(n, n)
        ax.bar(x + (k - (len(present) - 1) / 2) * width, v, width, yerr=s, capsize=2, label=lab, color=f"C{k}")
        labels = [str(i) for i in range(len(v) - 1)] + [f">{len(v) - 2}"]
    if labels:
        ax.set_xticks(np.arange(len(labels)))
        ax.set_xticklabels(labels)
    ax.set_xlabel("scattering order (number of scattering events)")
    ax.set_ylabel("fraction of incident power (1)")
    ax.legend(fontsize=8)
    ax.grid(True, axis="y", alpha=0.25)
    return ax


def figure(result, models=("dipole", "better_dipole"), optics=None):
    """A figure with every panel the result supports (R(r), A(z), BRDF map and slice, orders)."""
    from matplotlib.figure import Figure

    panels = []
    hs = result.histograms
    if "rd_r" in hs:
        panels.append(lambda ax: reflectance_profile(result, ax, models=models, optics=optics))
    if "a_z" in hs:
        panels.append(lambda ax: absorption_depth(result, ax))
    if "brdf" in hs:
        panels.append("polar")
        panels.append(lambda ax: in_plane(result, ax))
    if "rd_order" in hs or "tt_order" in hs:
        panels.append(lambda ax: orders(result, ax))
    n = max(len(panels), 1)
    cols = 2 if n > 1 else 1
    rows = (n + cols - 1) // cols
    fig = Figure(figsize=(6 * cols, 4.5 * rows), layout="constrained")
    for i, p in enumerate(panels, 1):
        if p == "polar":
            hemisphere_map(result, fig.add_subplot(rows, cols, i, projection="polar"), fig=fig)
        else:
            p(fig.add_subplot(rows, cols, i))
    if not panels:
        ax = fig.add_subplot()
        ax.text(0.5, 0.5, "no histograms in this result", ha="center", va="center")
        ax.set_axis_off()
    state = ", PARTIAL" if result.partial else ""
    fig.suptitle(
        f"subsurf: R_d = {result.diffuse_reflectance:.4f} ± {result.diffuse_reflectance_stderr:.1g}, "
        f"T = {result.transmittance:.4f}, A = {result.absorbed:.4f}  "
        f"({result.photons:.3g} photons, seed {result.seed}{state})",
        fontsize=10,
    )
    return fig


def histogram(h, ax=None, log: bool | None = None, label: str | None = None):
    """Draw one :class:`~subsurf.result.Histogram` and return the axes (``Histogram.plot`` calls this).

    1-D: the bin values as steps with a ±1 standard-error band; 2-D: an image over the bin edges
    (first axis horizontal, a depth axis ``z`` pointing down) with a colour bar. Axis labels give
    the axis names and units, the value label the histogram's units; overflow bins (everything beyond
    the grid, ``Histogram.overflow``) are left out. ``log`` chooses a logarithmic
    value scale (default: when the positive values span more than three decades). Histograms with
    more axes are drawn one slice at a time: ``h.take("order", k).plot()``.
    """
    v, s = np.asarray(h.values, float), np.asarray(h.stderr, float)
    edges = [np.asarray(e, float) for e in h.edges]
    for i, over in enumerate(h.overflow):  # an overflow bin holds everything beyond the grid: not drawn
        if over and v.shape[i] > 1:
            v, s, edges[i] = np.delete(v, -1, axis=i), np.delete(s, -1, axis=i), edges[i][:-1]
    if v.ndim not in (1, 2):
        raise ValueError(
            f"a histogram with {v.ndim} axes {tuple(h.axes)} cannot be drawn at once; "
            f"draw one slice, e.g. h.take({h.axes[0]!r}, 0).plot()"
        )
    pos = v[np.isfinite(v) & (v > 0)]
    if log is None:
        log = bool(pos.size) and pos.max() > 1e3 * pos.min() and np.all(v[np.isfinite(v)] >= 0)
    names = [f"{a} ({u})" if u not in ("", "1") else str(a) for a, u in zip(h.axes, h.edge_units)]
    what = f"{h.description or 'value'} ({_u(h.units)})"
    if v.ndim == 1:
        ax = _new_axes(ax)
        e = edges[0]
        ax.stairs(v, e, color="k", lw=1.2, label=label or "Monte Carlo")
        ax.stairs(v + s, e, baseline=v - s, fill=True, color="k", alpha=0.2, lw=0, label="±1 standard error")
        ax.set_xlabel(names[0])
        ax.set_ylabel(what)
        ax.legend(fontsize=8)
        ax.grid(True, alpha=0.25)
        if log:
            ax.set_yscale("log")
        return ax
    from matplotlib.colors import LogNorm

    if ax is None:
        from matplotlib.figure import Figure

        ax = Figure(figsize=(6.4, 4.8), layout="constrained").add_subplot()
    x, y = edges[:2]
    norm = LogNorm(vmin=pos.min(), vmax=pos.max()) if log and pos.size else None
    mesh = ax.pcolormesh(x, y, np.ma.masked_invalid(v.T), cmap="magma", shading="flat", norm=norm)
    ax.figure.colorbar(mesh, ax=ax, label=what)
    ax.set_xlabel(names[0])
    ax.set_ylabel(names[1])
    if h.axes[1] == "z":
        ax.invert_yaxis()
    return ax


def save_figure(fig, path: str | os.PathLike, dpi: int = 130, force: bool = True) -> str:
    """Write a figure (PNG, PDF, SVG … by extension) atomically; returns the path.

    The image is rendered in memory and written with :func:`subsurf.atomic.write_bytes`, so an
    interrupted or failed save never leaves a truncated file; ``force=False`` refuses to replace an
    existing file. The directory must exist.
    """
    import io

    from . import atomic

    path = os.fspath(path)
    fmt = os.path.splitext(path)[1].lstrip(".").lower() or "png"
    buf = io.BytesIO()
    fig.savefig(buf, dpi=dpi, format=fmt)
    return atomic.write_bytes(path, buf.getvalue(), force=force)
