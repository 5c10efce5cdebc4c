"""Heterogeneous media for the random walk: :class:`MediumGrid`, σa and σs per voxel.

A grid is given to a material, ``Translucent(..., grid=MediumGrid(sigma_a, sigma_s, bounds))``:
inside the box ``bounds`` (object space: the mesh's own coordinates, before the object's
``scale``/``rotate``/``translate``, so the medium moves with the object) the voxels' σa, σs
apply, looked up at the nearest voxel; outside it the material's own σa, σs. ``random_walk``
and :func:`subsurf.render.simulate_walk` sample it by delta tracking (the core's
``render/grid.rs``); the BSSRDF methods refuse it.
"""

from __future__ import annotations

import math
import os

import numpy as np

from .. import _core


def _err(msg):
    return _core.ParameterError(msg)


def _voxels(name, v):
    """An (nx, ny, nz, 3) float64 array from an array of shape (nx, ny, nz) (every channel the
    same), (nx, ny, nz, 3), or the path of a ``.npy`` file holding one."""
    if isinstance(v, (str, os.PathLike)):
        path = os.fspath(v)
        if not path.endswith(".npy"):
            raise _err(f"grid.{name} = {path!r}: a grid file must be a NumPy .npy file")
        if not os.path.exists(path):
            raise FileNotFoundError(f"grid.{name}: grid file {path!r} does not exist")
        try:
            v = np.load(path, allow_pickle=False)
        except (OSError, ValueError) as e:
            raise _err(f"grid.{name}: cannot read {path!r} as a .npy array: {e}") from None
    try:
        a = np.asarray(v, dtype=np.float64)
    except (TypeError, ValueError):
        raise _err(f"grid.{name}: expected an array of numbers (mm^-1)") from None
    if a.ndim == 3:
        a = np.repeat(a[..., None], 3, axis=3)
    if a.ndim != 4 or a.shape[3] != 3 or a.size == 0:
        raise _err(f"grid.{name}: expected shape (nx, ny, nz) or (nx, ny, nz, 3) with every count >= 1, got {a.shape}")
    return np.ascontiguousarray(a)


#: The keys of a ``[materials.NAME.grid]`` table: :class:`MediumGrid`'s parameters.
_GRID_KEYS = ("sigma_a", "sigma_s", "bounds")


class MediumGrid:
    """σa and σs (mm⁻¹) on a voxel grid over the box ``bounds`` = ((x0, y0, z0), (x1, y1, z1))
    of the object's space (mm).

    ``sigma_a``, ``sigma_s``: arrays of shape (nx, ny, nz) (the same in every colour channel,
    e.g. one tissue property for :func:`~subsurf.render.simulate_walk`) or (nx, ny, nz, 3) (RGB),
    index [i, j, k] the voxel at x = x0 + (i + ½)(x1 − x0)/nx, …; or the path of a ``.npy``
    file (``numpy.save``) holding one. Values finite and ≥ 0; 1 … 1024 voxels per axis. Looked up
    at the nearest voxel (piecewise constant, as MCX's voxel volumes: sharp tissue boundaries stay
    sharp, and the optical depth of a segment is exact)."""

    def __init__(self, sigma_a, sigma_s, bounds):
        self.sigma_a = _voxels("sigma_a", sigma_a)
        self.sigma_s = _voxels("sigma_s", sigma_s)
        try:
            b = np.asarray(bounds, dtype=np.float64)
        except (TypeError, ValueError):
            b = np.zeros(0)
        if b.shape != (2, 3):
            raise _err(f"grid.bounds = {bounds!r}: expected [[x0, y0, z0], [x1, y1, z1]] (mm, object space)")
        self.lo, self.hi = [float(x) for x in b[0]], [float(x) for x in b[1]]  # the core checks lo < hi

    @classmethod
    def from_dict(cls, d, key="grid"):
        """From a TOML table: ``sigma_a``, ``sigma_s`` (file names or nested lists), ``bounds``."""
        if not isinstance(d, dict):
            raise _err(f"{key} = {d!r}: expected a table with sigma_a, sigma_s and bounds")
        unknown = sorted(set(d) - set(_GRID_KEYS))
        if unknown:
            raise _err(f"{key}: unknown keys {unknown} (allowed: {sorted(_GRID_KEYS)})")
        missing = [k for k in _GRID_KEYS if k not in d]
        if missing:
            raise _err(f"{key}: missing {missing[0]!r}")
        return cls(d["sigma_a"], d["sigma_s"], d["bounds"])

    @property
    def shape(self):
        """(nx, ny, nz)."""
        return self.sigma_a.shape[:3]

    def _to_core(self, to_object):
        return {
            "sigma_a": self.sigma_a,
            "sigma_s": self.sigma_s,
            "lo": self.lo,
            "hi": self.hi,
            "to_object": to_object,
        }

    def __repr__(self):
        return f"MediumGrid(shape={self.shape}, bounds=({self.lo}, {self.hi}))"


def to_object_map(transform):
    """The world → object affine map, 3 rows of (A | b), of an object placed by ``transform``
    (a function applying its scale, rotation and translation to an (n, 3) array)."""
    pts = transform(np.vstack([np.zeros(3), np.eye(3)]))
    t = pts[0]
    lin = (pts[1:] - t).T
    try:
        a = np.linalg.inv(lin)
    except np.linalg.LinAlgError:
        raise _err("scale: a zero scale flattens the object; its medium grid cannot be placed") from None
    return np.hstack([a, (-a @ t)[:, None]]).tolist()


def _srgb_to_linear(c):
    """IEC 61966-2-1 sRGB decoding of values in [0, 1]."""
    return np.where(c <= 0.04045, c / 12.92, np.power((c + 0.055) / 1.055, 2.4))


class Texture:
    """A surface map: an image file (PNG, JPEG, … read with Pillow; or a NumPy ``.npy`` array) or an
    array of shape (height, width, 3) (or (height, width): the same in every channel) of finite
    values ≥ 0 (uint8 arrays are / 255). Row 0 is the image's top (v = 1). ``srgb``: decode the
    sRGB transfer curve (the default for 8-bit image files, whose colours are sRGB-encoded; arrays
    and ``.npy`` files are taken as linear). ``scale`` multiplies every value (after decoding),
    e.g. the mean free path in mm of a white texel of a mean-free-path image.

    Give it to :meth:`Translucent.from_reflectance` as the ``reflectance`` (a colour map: values in
    [0, 1]) and/or the ``mfp`` (a mean-free-path map, mm: values > 0); the mesh needs texture
    coordinates (an OBJ/PLY/GLB with UVs, or ``Object(..., uv=)``). Both maps given must have the
    same shape."""

    def __init__(self, image, srgb=None, scale=1.0):
        if isinstance(image, (str, os.PathLike)):
            a, srgb, self.source = _read_image(os.fspath(image), srgb)
        else:
            a = np.asarray(image)
            if a.dtype == np.uint8:
                a = a / 255.0
            try:
                a = np.asarray(a, dtype=np.float64)
            except (TypeError, ValueError):
                raise _err("texture: expected an image array of numbers") from None
            srgb = bool(srgb)
            self.source = "array"
        if a.ndim == 2:
            a = np.repeat(a[..., None], 3, axis=2)
        if a.ndim != 3 or a.shape[2] not in (3, 4) or a.shape[0] == 0 or a.shape[1] == 0:
            raise _err(f"texture: expected an image of shape (height, width, 3), got {a.shape}")
        a = a[..., :3]
        bad = ~(np.isfinite(a) & (a >= 0))
        if bad.any():
            i = tuple(int(x) for x in np.argwhere(bad)[0])
            raise _err(f"texture[{i[0]}, {i[1]}, {i[2]}] = {a[i]} is out of range: must be finite and >= 0")
        try:
            scale = float(scale)
        except (TypeError, ValueError):
            scale = float("nan")
        if not (math.isfinite(scale) and scale > 0):
            raise _err(f"texture.scale = {scale!r}: must be a finite number > 0")
        self.scale = scale
        self.values = np.ascontiguousarray((_srgb_to_linear(a) if srgb else a) * scale)

    @property
    def shape(self):
        """(height, width)."""
        return self.values.shape[:2]

    @property
    def reflectance(self):
        """The values as reflectances (a colour map), checked in [0, 1]."""
        bad = self.values > 1
        if bad.any():
            i = tuple(int(x) for x in np.argwhere(bad)[0])
            v = self.values[i]
            raise _err(f"texture[{i[0]}, {i[1]}, {i[2]}] = {v} is out of range: must be a reflectance in [0, 1]")
        return self.values

    @property
    def mfp(self):
        """The values as mean free paths (mm, a mean-free-path map), checked > 0."""
        bad = ~(self.values > 0)
        if bad.any():
            i = tuple(int(x) for x in np.argwhere(bad)[0])
            raise _err(
                f"mfp texture[{i[0]}, {i[1]}, {i[2]}] = {self.values[i]} is out of range: a mean free path "
                "must be > 0 (mm)"
            )
        return self.values

    def mean(self):
        """The mean value per channel."""
        return [float(x) for x in self.values.reshape(-1, 3).mean(axis=0)]

    def __repr__(self):
        return f"Texture({self.source!r}, shape={self.shape})"


def _read_image(path, srgb):
    """(values (h, w, 3) or (h, w), srgb, source) of an image file or a ``.npy`` array."""
    if not os.path.exists(path):
        raise FileNotFoundError(f"texture: image file {path!r} does not exist")
    if path.endswith(".npy"):
        try:
            return np.load(path, allow_pickle=False), bool(srgb), path
        except (OSError, ValueError) as e:
            raise _err(f"texture: cannot read {path!r} as a .npy array: {e}") from None
    try:
        from PIL import Image as _PIL
    except ImportError:  # pragma: no cover - Pillow comes with matplotlib
        raise _err("texture: reading image files needs Pillow (pip install pillow)") from None
    try:
        with _PIL.open(path) as im:
            a = np.asarray(im.convert("RGB"), dtype=np.float64) / 255.0
    except Exception as e:  # Pillow raises many kinds on unreadable files
        raise _err(f"texture: cannot read image file {path!r}: {e}") from None
    return a, True if srgb is None else bool(srgb), path


def invert_maps(refl, mfp, invert, mfp_ref):
    """σa, σs (mm⁻¹) per texel, each (height, width, 3), of the reflectance ``refl`` at the mean
    free path ``mfp`` (both (height, width, 3)). ``invert(k, values, mfp_k)`` gives (σa, σs) of
    channel k for an array of reflectances at the mean free path ``mfp_k`` (the core's
    inversion). Each channel's distinct reflectances are inverted once at ``mfp_ref[k]`` (an 8-bit
    image has at most 256; beyond 4096 distinct values each texel takes the nearest of 4096
    evenly spaced reflectances between the least and the largest, an error ≤ range/8190, so the
    BSSRDF methods build at most 4096 profiles per channel) and scaled to each texel's mean free
    path: the inversion is exact under scaling (every coefficient ∝ 1/mfp at a fixed reflectance,
    for every model and kind of mean free path)."""
    out_a, out_s = np.empty_like(refl), np.empty_like(refl)
    for k in range(3):
        ch = refl[..., k]
        values, inverse = np.unique(ch, return_inverse=True)
        scale = mfp_ref[k] / mfp[..., k]
        if values.size <= 4096:
            a, s = (np.asarray(x) for x in invert(k, values, mfp_ref[k]))
            out_a[..., k] = a[inverse].reshape(ch.shape) * scale
            out_s[..., k] = s[inverse].reshape(ch.shape) * scale
        else:
            grid = np.linspace(values[0], values[-1], 4096)
            a, s = (np.asarray(x) for x in invert(k, grid, mfp_ref[k]))
            nearest = np.rint((ch - values[0]) / (grid[1] - grid[0])).astype(np.int64).clip(0, 4095)
            out_a[..., k] = a[nearest] * scale
            out_s[..., k] = s[nearest] * scale
    return out_a, out_s
