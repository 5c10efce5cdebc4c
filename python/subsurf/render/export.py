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

import math
import re

from .. import _core
from .scene import Translucent


def _err(msg: str):
    return _core.ParameterError(msg)


def _unit(fmt: str, unit_mm) -> float:
    try:
        u = float(unit_mm)
    except (TypeError, ValueError):
        u = math.nan
    if not (math.isfinite(u) and u > 0):
        raise _err(
            f"{fmt}: unit_mm = {unit_mm!r} is out of range: the length of one scene unit, a finite number > 0 (mm)"
        )
    return u


def _check(m, fmt, unit_mm) -> float:
    """The scene unit after checking that ``m`` is a homogeneous medium both formats can hold."""
    if not isinstance(m, Translucent):
        raise _err(f"{fmt} export: {m!r} is not a Translucent material")
    if m.layered:
        raise _err(
            f"{fmt} export: material {m.name!r} is layered (a stack of layers per channel); {fmt} has one "
            "homogeneous medium per shape, so it cannot express it (export each layer as a nested shape)"
        )
    if m.grid is not None or m.texture is not None:
        what = "a medium grid" if m.grid is not None else "a colour map (texture)"
        raise _err(
            f"{fmt} export: material {m.name!r} has {what}; this export writes one homogeneous "
            "medium per shape (a grid or a map would need the format's textured media, not written here)"
        )
    for i, (a, s) in enumerate(zip(m.sigma_a, m.sigma_s)):
        try:
            _core.bssrdf_check_medium(a, s, m.g, m.eta)
        except _core.ParameterError as e:
            raise _err(f"{fmt} export: material {m.name!r}, channel {i}: {e}") from None
    u = _unit(f"{fmt} export", unit_mm)
    big = max(a + s for a, s in zip(m.sigma_a, m.sigma_s)) * u
    if not math.isfinite(big):
        raise _err(f"{fmt} export: unit_mm = {unit_mm!r} makes sigma_t = {big} per scene unit (not finite)")
    return u


def to_mitsuba(m: Translucent, unit_mm: float = 1.0) -> dict:
    """{"bsdf": {...}, "interior": {...}} for a Mitsuba 3 shape dict (``mi.load_dict``).

    Mitsuba 3 (3.9.1) reads an ``rgb`` value as a reflectance and refuses components above 1, so
    σt is written as σt / max σt with the medium's ``scale`` = max σt (per scene unit)."""
    unit_mm = _check(m, "Mitsuba 3", unit_mm)
    st_full = [(a + s) * unit_mm for a, s in zip(m.sigma_a, m.sigma_s)]
    top = max(st_full)
    st = [x / top for x in st_full]
    alb = [s / (a + s) for a, s in zip(m.sigma_a, m.sigma_s)]
    return {
        "bsdf": {"type": "dielectric", "int_ior": m.eta, "ext_ior": 1.0},
        "interior": {
            "type": "homogeneous",
            "albedo": {"type": "rgb", "value": alb},
            "sigma_t": {"type": "rgb", "value": st},
            "scale": top,
            "phase": {"type": "hg", "g": m.g},
        },
    }


def from_mitsuba(d: dict, unit_mm: float = 1.0, name=None) -> Translucent:
    """The material of a :func:`to_mitsuba` dict."""
    sc = 1.0 / _unit("from_mitsuba", unit_mm)
    try:
        med, bsdf = d["interior"], d["bsdf"]
        if med.get("type") != "homogeneous" or bsdf.get("type") != "dielectric":
            raise _err("from_mitsuba: expected a homogeneous interior in a dielectric")
        sc *= float(med.get("scale", 1.0))
        st = [float(x) * sc for x in med["sigma_t"]["value"]]
        alb = [float(x) for x in med["albedo"]["value"]]
        g, eta = float(med["phase"]["g"]), float(bsdf["int_ior"]) / float(bsdf.get("ext_ior", 1.0))
    except (KeyError, TypeError, ValueError, AttributeError) as e:
        if isinstance(e, _core.ParameterError):
            raise
        raise _err(f"from_mitsuba: not a to_mitsuba dict ({type(e).__name__}: {e})") from None
    return Translucent(
        [t * (1 - a) for t, a in zip(st, alb)], [t * a for t, a in zip(st, alb)], g=g, eta=eta, name=name
    )


#: Characters a pbrt-v4 string cannot hold as written here (quotes end it; no escapes are written).
_PBRT_BAD = re.compile(r'["\\\x00-\x1f\x7f]')


def to_pbrt(m: Translucent, unit_mm: float = 1.0, name=None) -> str:
    """A pbrt-v4 ``MakeNamedMaterial`` block of type ``subsurface``."""
    unit_mm = _check(m, "pbrt-v4", unit_mm)
    nm = str(name or m.name or "subsurf_material")
    if _PBRT_BAD.search(nm):
        raise _err(
            f"pbrt-v4 export: name = {nm!r}: a pbrt-v4 name cannot hold quotes, backslashes or control characters"
        )
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
_NAMED = re.compile(r'MakeNamedMaterial\s+"([^"]*)"')


def _pbrt_blocks(text: str) -> list[tuple]:
    """(name, parameter text) of each ``MakeNamedMaterial`` block; the whole text when it has none."""
    starts = list(_NAMED.finditer(text))
    if not starts:
        return [(None, text)]
    ends = [m.start() for m in starts[1:]] + [len(text)]
    return [(m.group(1), text[m.end() : e]) for m, e in zip(starts, ends)]


def _pbrt_params(body: str, where: str) -> dict:
    params = {}
    for typ, key, vals in _PARAM.findall(body):
        if key in params:
            raise _err(f"from_pbrt: {where}: parameter {key!r} is given twice")
        items = re.findall(r'"[^"]*"|[^\s]+', vals)
        try:
            params[key] = [v.strip('"') if typ == "string" else float(v) for v in items]
        except ValueError as e:
            raise _err(f"from_pbrt: {where}: parameter {key!r}: {e}") from None
    return params


def from_pbrt(text: str, unit_mm: float = 1.0, name=None) -> Translucent:
    """Parse a pbrt-v4 ``subsurface`` material block (as :func:`to_pbrt` writes it). A text with
    several ``MakeNamedMaterial`` blocks needs ``name``, the one to read."""
    sc = 1.0 / _unit("from_pbrt", unit_mm)
    blocks = _pbrt_blocks(text)
    if name is not None:
        blocks = [b for b in blocks if b[0] == name]
        if not blocks:
            raise _err(f"from_pbrt: no material named {name!r} in the text")
    if len(blocks) > 1:
        names = [b[0] for b in blocks]
        raise _err(f"from_pbrt: the text holds {len(names)} materials {names}; choose one with name=")
    mname, body = blocks[0]
    where = f"material {mname!r}"
    params = _pbrt_params(body, where)
    if params.get("type", [None])[:1] != ["subsurface"]:
        raise _err(f"from_pbrt: {where} is not a subsurface material")
    try:
        sc *= params.get("scale", [1.0])[0]
        sigma_a, sigma_s = [x * sc for x in params["sigma_a"]], [x * sc for x in params["sigma_s"]]
        g, eta = params.get("g", [0.0])[0], params["eta"][0]
    except (KeyError, IndexError, TypeError) as e:
        raise _err(f"from_pbrt: {where} lacks a usable parameter ({type(e).__name__}: {e})") from None
    return Translucent(sigma_a, sigma_s, g=g, eta=eta, name=mname)
