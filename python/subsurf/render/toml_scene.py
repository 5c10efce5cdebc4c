"""Scenes from TOML files (``subsurf render SCENE.toml``); see examples/render/marble_sphere.toml.

Top-level ``environment`` (RGB radiance), tables ``[render]`` (method, spp, seed, output),
``[camera]``, ``[materials.NAME]`` (``library = "marble"``, or ``sigma_a``/``sigma_s``/``g``/``eta``,
or ``reflectance`` + ``mfp`` (+ ``power``, ``mfp_kind``; ``color`` + ``mean_free_path`` is the deprecated spelling;
either may be an image file name, a surface map: ``mfp_scale`` mm per unit of a mean-free-path image), or
``type = "lambertian"``; plus ``model``), and arrays of
tables ``[[objects]]`` (``mesh = "file.obj"`` relative to the TOML file, or ``shape = "sphere" |
"box" | "plane" | "torus"`` with its sizes; ``material``; ``translate``/``scale``/``rotate``) and
``[[lights]]`` (``type = "point" | "directional" | "sphere" | "rect"``). Errors name the key.
"""

from __future__ import annotations

import os
import sys

from .. import _core
from .media import Texture
from .scene import LIGHT_PARAMS, LIGHTS, Camera, Object, Scene, material

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

SHAPE_KEYS = {
    "sphere": ("center", "radius", "subdivisions"),
    "box": ("lo", "hi"),
    "plane": ("center", "size"),
    "torus": ("center", "major", "minor"),
}


def _err(path, msg):
    return _core.ParameterError(f"{path}: {msg}")


def _take(d, key, where, path, cast=None, default=...):
    if key not in d:
        if default is ...:
            raise _err(path, f"{where}: missing key {key!r}")
        return default
    v = d[key]
    if cast is not None:
        try:
            return cast(v)
        except (TypeError, ValueError):
            raise _err(path, f"{where}.{key} = {v!r} is not valid") from None
    return v


#: Keys of the ``[render]`` table.
RENDER_KEYS = ("method", "spp", "seed", "output")
#: Keys of the ``[camera]`` table.
CAMERA_KEYS = ("position", "look_at", "up", "fov", "width", "height")


def _table(doc, key, path, default):
    """``doc[key]`` when it is a table (dict), ``default`` when absent."""
    v = doc.get(key, default)
    if not isinstance(v, dict):
        raise _err(path, f"{key} = {v!r}: expected a table [{key}]")
    return v


def _tables(doc, key, path):
    """``doc[key]`` when it is an array of tables ``[[key]]``, [] when absent."""
    v = doc.get(key, [])
    if not (isinstance(v, list) and all(isinstance(x, dict) for x in v)):
        raise _err(path, f"{key} = {v!r}: expected an array of tables [[{key}]]")
    return v


def load_scene(path):
    """Read a TOML scene; returns (Scene, settings dict with method, spp, seed, output)."""
    path = os.fspath(path)
    if not os.path.exists(path):
        raise FileNotFoundError(f"{path}: scene file does not exist")
    with open(path, "rb") as f:
        try:
            doc = tomllib.load(f)
        except tomllib.TOMLDecodeError as e:
            raise _err(path, f"not valid TOML: {e}") from None
    base = os.path.dirname(os.path.abspath(path))
    known = {"render", "camera", "materials", "objects", "lights", "environment"}
    unknown = set(doc) - known
    if unknown:
        raise _err(path, f"unknown top-level keys {sorted(unknown)} (allowed: {sorted(known)})")
    mats = {}
    for name, spec in _table(doc, "materials", path, {}).items():
        try:
            spec = _grid_files(spec, base)
            m = material(spec, key=f"materials.{name}")
        except FileNotFoundError as e:
            raise FileNotFoundError(f"{path}: materials.{name}.{e}") from None
        except _core.ParameterError as e:
            msg = str(e)
            raise _err(path, msg if msg.startswith("materials.") else f"materials.{name}.{msg}") from None
        m.name = name
        mats[name] = m
    objects = []
    for i, o in enumerate(_tables(doc, "objects", path)):
        where = f"objects[{i}]"
        o = dict(o)
        mname = _take(o, "material", where, path)
        if isinstance(mname, str) and mname in mats:
            mat = mats[mname]
        else:
            try:
                mat = material(mname, key=f"{where}.material")
            except _core.ParameterError:
                raise _err(
                    path,
                    f"{where}.material = {mname!r} is unknown: not in [materials] ({sorted(mats)}) "
                    "nor the library (subsurf materials)",
                ) from None
            mats[str(mname)] = mat
        kw = {k: o[k] for k in ("translate", "scale", "rotate") if k in o}
        name = o.get("name", where)
        try:
            if "mesh" in o:
                src = o["mesh"]
                src = src if os.path.isabs(src) else os.path.join(base, src)
                objects.append(Object.mesh(src, mat, name=name, **kw))
            elif "shape" in o:
                shape = o["shape"]
                if shape not in SHAPE_KEYS:
                    raise _err(path, f"{where}.shape = {shape!r}: must be one of {sorted(SHAPE_KEYS)}")
                args = {k: o[k] for k in SHAPE_KEYS[shape] if k in o}
                extra = set(o) - set(SHAPE_KEYS[shape]) - {"shape", "material", "name", "translate", "scale", "rotate"}
                if extra:
                    raise _err(path, f"{where}: unknown keys {sorted(extra)} for shape {shape!r}")
                objects.append(getattr(Object, shape)(mat, name=name, **args, **kw))
            else:
                raise _err(path, f"{where}: give 'mesh' (a file) or 'shape'")
        except FileNotFoundError as e:
            raise FileNotFoundError(f"{path}: {where}.mesh: {e}") from None
        except _core.ParameterError as e:
            msg = str(e)
            raise _core.ParameterError(msg if msg.startswith(path) else f"{path}: {where}: {msg}") from None
    lights = []
    classes = {cls.kind: cls for cls in LIGHTS}
    for i, l in enumerate(_tables(doc, "lights", path)):
        where = f"lights[{i}]"
        kind = _take(l, "type", where, path)
        if kind not in LIGHT_PARAMS:
            raise _err(path, f"{where}.type = {kind!r}: must be one of {list(LIGHT_PARAMS)}")
        _known(l, ("type", *LIGHT_PARAMS[kind]), where, path)
        lights.append(classes[kind](*[_take(l, k, where, path) for k in LIGHT_PARAMS[kind]]))
    camera = None
    if "camera" in doc:
        cam = _table(doc, "camera", path, None)
        _known(cam, CAMERA_KEYS, "camera", path)
        kw = {k: cam[k] for k in CAMERA_KEYS[1:] if k in cam}
        try:
            camera = Camera(_take(cam, "position", "camera", path), **kw)
        except _core.ParameterError as e:
            raise _err(path, str(e)) from None
    r = _table(doc, "render", path, {})
    _known(r, RENDER_KEYS, "render", path)
    try:
        spp, seed = _core.render_check_settings(r.get("spp", 16), r.get("seed", 0))
    except _core.ParameterError as e:
        raise _err(path, f"render.{e}") from None
    output = r.get("output")
    if output is not None and not isinstance(output, str):
        raise _err(path, f"render.output = {output!r}: expected a file name")
    method = r.get("method", "hierarchical")
    if method not in _core.RENDER_METHODS:
        raise _err(path, f"render.method = {method!r}: must be one of {list(_core.RENDER_METHODS)}")
    settings = {"method": method, "spp": spp, "seed": seed, "output": output}
    return Scene(objects, lights, doc.get("environment", (0, 0, 0)), camera), settings


def _grid_files(spec, base):
    """``spec`` with the grid's file names (``[materials.NAME.grid]`` sigma_a, sigma_s) taken
    relative to the scene file's folder, and a ``reflectance`` given as an image file name read
    as a :class:`~subsurf.render.Texture`."""
    if isinstance(spec, dict):
        spec = _map_files(spec, base)
    if not (isinstance(spec, dict) and isinstance(spec.get("grid"), dict)):
        return spec
    grid = dict(spec["grid"])
    for k in ("sigma_a", "sigma_s"):
        v = grid.get(k)
        if isinstance(v, str) and not os.path.isabs(v):
            grid[k] = os.path.join(base, v)
    return {**spec, "grid": grid}


def _map_files(spec, base):
    """``spec`` with a ``reflectance`` or ``mfp`` given as a file name (relative to the scene's
    folder) read as a :class:`~subsurf.render.Texture`: a colour map sRGB-decoded (8-bit images),
    a mean-free-path map linear (an image times ``mfp_scale``, mm per unit, default 1; or a
    ``.npy`` array of mm)."""
    spec = dict(spec)
    scale = spec.pop("mfp_scale", None)
    if scale is not None and not isinstance(spec.get("mfp"), str):
        raise _core.ParameterError("mfp_scale: only with mfp given as an image file (a mean-free-path map)")
    for key, kw in (("reflectance", {}), ("mfp", {"srgb": False, "scale": 1.0 if scale is None else scale})):
        img = spec.get(key)
        if not isinstance(img, str):
            continue
        try:
            spec[key] = Texture(img if os.path.isabs(img) else os.path.join(base, img), **kw)
        except FileNotFoundError as e:
            raise FileNotFoundError(f"{key}: {e}") from None
    return spec


def _known(d, allowed, where, path):
    extra = set(d) - set(allowed)
    if extra:
        raise _err(path, f"{where}: unknown keys {sorted(extra)} (allowed: {sorted(allowed)})")
