"""Hand-built :class:`subsurf.result.Result` objects for the I/O, MCML, CLI and plot tests.

Histogram values are bin weights (fractions of N photons) divided by the exact bin measures the
tallies use (annulus area, ring solid angle, area × projected solid angle for R(r, θ), depth),
computed by the core (``_core.mc_axis_measures``), which the histograms carry as ``measures``.
"""

from __future__ import annotations

import math

import numpy as np
from subsurf import _core
from subsurf.result import Histogram, Result


def _measure(kind, edges):
    return _core.mc_axis_measures(kind, np.asarray(edges, dtype=float))


def _area(e):
    return _measure("r", e)


def _solid(a):
    return _measure("theta", a)


def _proj(a):
    return _measure("theta_projected", a)


def make_result(
    seed=1,
    photons=10_000,
    nr=20,
    dr=0.05,
    nz=15,
    dz=0.04,
    na=6,
    layers=2,
    brdf=(4, 8),
    max_order=3,
    rng=None,
    config=None,
):
    """A self-consistent synthetic result; returns (result, raw) with raw bin weights for checks."""
    rng = np.random.default_rng(seed) if rng is None else rng
    re_ = np.arange(nr + 1) * dr
    ze = np.arange(nz + 1) * dz
    ae = np.linspace(0, math.pi / 2, na + 1)
    raw = {}
    rd, tt, ab = 0.35, 0.15, 0.45
    rsp = 0.05
    raw["rd_ra"] = rng.dirichlet(np.ones(nr * na)).reshape(nr, na) * rd
    raw["tt_ra"] = rng.dirichlet(np.ones(nr * na)).reshape(nr, na) * tt
    raw["a_rz"] = rng.dirichlet(np.ones(nr * nz)).reshape(nr, nz) * ab
    hist = {}

    def h(name, raw_vals, measure, edges, axes, eu, units, desc, kinds):
        v = raw_vals / measure
        measures = tuple(_measure(k, e) for k, e in zip(kinds, edges))
        overflow = tuple(k in ("r", "z") for k in kinds)
        hist[name] = Histogram(
            v, v * 0.05 + 1e-6, tuple(edges), tuple(axes), tuple(eu), units, desc, measures, overflow
        )

    for side in ("rd", "tt"):
        ra = raw[f"{side}_ra"]
        h(
            f"{side}_ra",
            ra,
            _area(re_)[:, None] * _proj(ae)[None, :],
            (re_, ae),
            ("r", "theta"),
            ("mm", "rad"),
            "mm^-2 sr^-1",
            f"{side} per area and solid angle",
            ("r", "theta_projected"),
        )
        h(f"{side}_r", ra.sum(1), _area(re_), (re_,), ("r",), ("mm",), "mm^-2", f"{side} per unit area", ("r",))
        h(
            f"{side}_a",
            ra.sum(0),
            _solid(ae),
            (ae,),
            ("theta",),
            ("rad",),
            "sr^-1",
            f"{side} per solid angle",
            ("theta",),
        )
        raw[f"{side}_r"], raw[f"{side}_a"] = ra.sum(1), ra.sum(0)
    h(
        "a_rz",
        raw["a_rz"],
        _area(re_)[:, None] * dz,
        (re_, ze),
        ("r", "z"),
        ("mm", "mm"),
        "mm^-3",
        "absorbed/volume",
        ("r", "z"),
    )
    h("a_z", raw["a_rz"].sum(0), dz, (ze,), ("z",), ("mm",), "mm^-1", "absorbed per unit depth", ("z",))
    raw["a_z"] = raw["a_rz"].sum(0)
    if brdf:
        nc, nphi = brdf
        ce = np.linspace(0, 1, nc + 1)
        pe = np.linspace(0, 2 * math.pi, nphi + 1)
        v = 1 / math.pi * (1 + 0.2 * rng.standard_normal((nc, nphi)))
        hist["brdf"] = Histogram(v * rd, v * 0.01, (ce, pe), ("cos_theta", "phi"), ("1", "rad"), "sr^-1", "BRDF")
        hist["btdf"] = Histogram(v * tt, v * 0.01, (ce, pe), ("cos_theta", "phi"), ("1", "rad"), "sr^-1", "BTDF")
    if max_order is not None:
        oe = np.arange(max_order + 3, dtype=float)
        w = rng.dirichlet(np.ones(max_order + 2))
        hist["rd_order"] = Histogram(w * rd, w * 0.01, (oe,), ("order",), ("1",), "1", "Rd by order")
        hist["tt_order"] = Histogram(w * tt, w * 0.01, (oe,), ("order",), ("1",), "1", "Tt by order")
    split = rng.dirichlet(np.ones(layers)) * ab
    cfg = (
        config
        if config is not None
        else {
            "stack": {
                "layers": [
                    {"n": 1.4, "mua": 0.1, "mus": 10.0, "g": 0.9, "thickness": 0.5 if i < layers - 1 else math.inf}
                    for i in range(layers)
                ],
                "n_above": 1.0,
                "n_below": 1.0,
            },
            "source": {"type": "pencil", "theta": 0.0, "phi": 0.0},
            "tallies": {
                "nr": nr,
                "dr": dr,
                "nz": nz,
                "dz": dz,
                "na": na,
                "brdf": list(brdf) if brdf else None,
                "max_order": max_order,
            },
            "seed": seed,
            "photons": photons,
        }
    )
    res = Result(
        specular_reflectance=rsp,
        specular_reflectance_stderr=0.0,
        diffuse_reflectance=rd,
        diffuse_reflectance_stderr=0.004,
        transmittance=tt,
        transmittance_stderr=0.003,
        unscattered_transmittance=0.01,
        unscattered_transmittance_stderr=0.001,
        absorbed=ab,
        absorbed_stderr=0.004,
        absorbed_per_layer=split,
        absorbed_per_layer_stderr=split * 0.01,
        photons=photons,
        seed=seed,
        elapsed_s=1.25,
        events=photons * 40,
        photons_requested=photons,
        partial=False,
        histograms=hist,
        config=cfg,
        version="0.1.0-test",
    )
    return res, raw
