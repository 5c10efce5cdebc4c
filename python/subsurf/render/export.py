"""Export a :class:`Translucent` material to the renderers users already have, and read the
exports back (the tests check the round trip).

- Mitsuba 3: :func:`to_mitsuba` gives the ``bsdf`` (a smooth ``dielectric`` of index η) and the
  ``interior`` medium (``homogeneous``: ``albedo`` = σs/σt, ``sigma_t`` and an ``hg`` phase) to put
  on a shape's dict (Mitsuba 3 docs, "Media: homogeneous", "BSDFs: dielectric").
- pbrt-v4: :func:`to_pbrt` writes a ``MakeNamedMaterial`` block of type ``subsurface`` with
  ``eta``, ``g``, ``rgb sigma_a``, ``rgb sigma_s`` and ``scale`` (pbrt-v4 user's guide,
  "Materials: subsurface").

Units: subsurf works in mm⁻¹; both renderers take coefficients per *scene unit*. ``unit_mm`` is the
length of one scene unit in mm (1 for a scene in mm, 1000 for metres): σ[1/unit] = σ[1/mm]·unit_mm.
A layered material (a stack of several layers) cannot be expressed by either format: refused.
"""

from __future__ import annotations

import re

from .. import _core
from .scene import Translucent


def _check(m, fmt):
    if not isinstance(m, Translucent):
        raise _core.ParameterError(f"{fmt} export: {m!r} is not a Translucent material")
    if m.layered:
        raise _core.ParameterError(
            f"{fmt} export: material {m.name!r} is layered (a stack of layers per channel); {fmt} has one "
            "homogeneous medium per shape, so it cannot express it (export each layer as a nested shape)"
        )


def to_mitsuba(m: Translucent, unit_mm: float = 1.0) -> dict:
    """{"bsdf": {...}, "interior": {...}} for a Mitsuba 3 shape dict (``mi.load_dict``)."""
    _check(m, "Mitsuba 3")
    st = [(a + s) * unit_mm for a, s in zip(m.sigma_a, m.sigma_s)]
    alb = [s / (a + s) if a + s > 0 else 0.0 for a, s in zip(m.sigma_a, m.sigma_s)]
    return {
        "bsdf": {"type": "dielectric", "int_ior": m.eta, "ext_ior": 1.0},
        "interior": {
            "type": "homogeneous",
            "albedo": {"type": "rgb", "value": alb},
            "sigma_t": {"type": "rgb", "value": st},
            "scale": 1.0,
            "phase": {"type": "hg", "g": m.g},
        },
    }


def from_mitsuba(d: dict, unit_mm: float = 1.0, name=None) -> Translucent:
    """The material of a :func:`to_mitsuba` dict."""
    med, bsdf = d["interior"], d["bsdf"]
    if med.get("type") != "homogeneous" or bsdf.get("type") != "dielectric":
        raise _core.ParameterError("from_mitsuba: expected a homogeneous interior in a dielectric")
    sc = float(med.get("scale", 1.0)) / unit_mm
    st = [x * sc for x in med["sigma_t"]["value"]]
    alb = med["albedo"]["value"]
    return Translucent(
        [t * (1 - a) for t, a in zip(st, alb)],
        [t * a for t, a in zip(st, alb)],
        g=med["phase"]["g"],
        eta=bsdf["int_ior"] / bsdf.get("ext_ior", 1.0),
        name=name,
    )


def to_pbrt(m: Translucent, unit_mm: float = 1.0, name=None) -> str:
    """A pbrt-v4 ``MakeNamedMaterial`` block of type ``subsurface``."""
    _check(m, "pbrt-v4")
    nm = name or m.name or "subsurf_material"
    f = lambda v: " ".join(f"{x * unit_mm:.9g}" for x in v)  # noqa: E731
    return (
        f'MakeNamedMaterial "{nm}"\n'
        f'    "string type" [ "subsurface" ]\n'
        f'    "float eta" [ {m.eta:.9g} ]\n'
        f'    "float g" [ {m.g:.9g} ]\n'
        f'    "rgb sigma_a" [ {f(m.sigma_a)} ]\n'
        f'    "rgb sigma_s" [ {f(m.sigma_s)} ]\n'
        f'    "float scale" [ 1 ]\n'
    )


_PARAM = re.compile(r'"(\w+)\s+(\w+)"\s*\[\s*([^\]]*)\]')


def from_pbrt(text: str, unit_mm: float = 1.0) -> Translucent:
    """Parse a pbrt-v4 ``subsurface`` material block (as :func:`to_pbrt` writes it)."""
    mname = re.search(r'MakeNamedMaterial\s+"([^"]+)"', text)
    params = {}
    for typ, key, vals in _PARAM.findall(text):
        items = re.findall(r'"[^"]*"|[^\s]+', vals)
        params[key] = (typ, [v.strip('"') if typ == "string" else float(v) for v in items])
    if params.get("type", (None, [None]))[1][0] != "subsurface":
        raise _core.ParameterError("from_pbrt: not a subsurface material")
    sc = params.get("scale", ("float", [1.0]))[1][0] / unit_mm
    return Translucent(
        [x * sc for x in params["sigma_a"][1]],
        [x * sc for x in params["sigma_s"][1]],
        g=params.get("g", ("float", [0.0]))[1][0],
        eta=params["eta"][1][0],
        name=mname.group(1) if mname else None,
    )
