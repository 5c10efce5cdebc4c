"""Heterogeneous media for the random walk: :class:`MediumGrid`, σa and σs per voxel.

A grid is given to a material, ``Translucent(..., grid=MediumGrid(sigma_a, sigma_s, bounds))``:
inside the box ``bounds`` (object space: the mesh's own coordinates, before the object's
``scale``/``rotate``/``translate``, so the medium moves with the object) the voxels' σa, σs
apply, looked up at the nearest voxel; outside it the material's own σa, σs. ``random_walk``
and :func:`subsurf.render.simulate_walk` sample it by delta tracking (the core's
``render/grid.rs``); the BSSRDF methods refuse it.
"""

from __future__ import annotations

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
        unknown = sorted(set(d) - {"sigma_a", "sigma_s", "bounds"})
        if unknown:
            raise _err(f"{key}: unknown keys {unknown} (allowed: ['bounds', 'sigma_a', 'sigma_s'])")
        missing = [k for k in ("sigma_a", "sigma_s", "bounds") if k not in d]
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
