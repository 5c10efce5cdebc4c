"""Parameter sweeps: :func:`sweep` runs a function on every point of a grid of configurations,
locally or on a Dask cluster, and returns a labelled result set (:class:`SweepResult`) that is
also its own checkpoint file.

A sweep is ``sweep(point, axes, path)``:

- ``axes``: ``{name: values}`` — the grid is the Cartesian product, the first axis outermost
  (C order); point k has flat index k.
- ``point``: a callable ``point(**coords)`` returning ``{quantity: number or array}`` with the
  same quantities and shapes at every point. It may also have ``describe()`` → ``(attrs,
  static)`` — per-quantity attributes (units, description, dims) and arrays shared by every
  point (histogram edges) — and ``fingerprint()``, a JSON-able description identifying what it
  computes (otherwise its pickle identifies it). On a cluster it must pickle (a module-level
  function, a ``functools.partial`` of one, or an instance of a module-level class).
  :class:`subsurf.config.SweepConfig` (``subsurf sweep SWEEP.toml``) is such a point for Monte
  Carlo runs; :func:`result_data` turns any :class:`~subsurf.result.Result` into point data.

Why an HDF5 file rather than an xarray Dataset: restarting a sweep needs a durable record of
the points already done, so the labelled result *is* that record — one self-describing file
with the grid coordinates, a ``done`` mask and one array per quantity shaped ``grid +
quantity``, readable from MATLAB, Julia or C like the results files (:mod:`subsurf.io`); it
needs only h5py, already a dependency, so sweeps run without the cluster extra. (An xarray user
wraps it in a few lines: ``xr.DataArray(s[name], coords=s.coords, dims=...)``.)

Layout (``format = "subsurf-sweep"``, ``format_version = 2``: subsurf's checksummed container,
:mod:`subsurf.container`, as results files and profile tables)::

    /            attrs: format, format_version, software, version, created, axes (names),
                        shape, fingerprint, spec (JSON: what is computed + the axes), complete,
                        points_done
    /coords/<axis>    the axis values             attrs: units
    /done             bool, grid shape: points computed
    /data/<quantity>  grid shape + quantity shape (NaN where not done)   attrs: units, …
    /static/<name>    arrays shared by every point (e.g. histogram edges)

Integrity: the file's bytes are checked against the SHA-256 manifest in its user block before
HDF5 reads them, so a damaged file is refused in one line (never a crash of the HDF5 library).
Format version 1 (plain HDF5 with a ``checksum`` attribute, verified only after HDF5 had parsed
the file) is refused, naming its version.

Restarts: with ``path`` given, finished points are written to it atomically (built in memory,
written to a temporary file renamed over it) while the sweep runs — at the end,
on Ctrl-C or an error, and at most every few seconds in between — and a sweep started again
with the same ``path`` and the same point and axes skips the points already done. A file of
another sweep is never overwritten (ParameterError), nor is a damaged one.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import os
import pickle
import time
import uuid
import warnings
from typing import Any

import numpy as np

from . import _core, _testhooks, atomic, container
from .container import jsonable as _jsonable

__all__ = ["sweep", "SweepResult", "load", "same_sweep", "result_data", "FORMAT", "FORMAT_VERSION"]

FORMAT = "subsurf-sweep"
#: 2: the checksummed container (:mod:`subsurf.container`); 1 (plain HDF5) is refused.
FORMAT_VERSION = 2
#: Shortest time between two checkpoint writes, seconds (also at least 10× the last write's time).
CHECKPOINT_S = 2.0


def _error(msg: str):
    return _core.ParameterError(msg)


def _axes(axes) -> dict[str, np.ndarray]:
    if not isinstance(axes, dict) or not axes:
        raise _error(f"axes = {axes!r}: give a dict {{name: values}} with at least one axis")
    out = {}
    for name, values in axes.items():
        if not isinstance(name, str) or not name.isidentifier():
            raise _error(f"axes: {name!r} is not an axis name (a Python identifier)")
        try:
            v = np.asarray(values)
        except (TypeError, ValueError):
            v = np.asarray([], dtype=object)
        if v.ndim != 1 or v.size == 0 or v.dtype.kind not in "iuf" or not np.all(np.isfinite(v)):
            raise _error(f"axes.{name}: give a non-empty list of finite numbers, got {values!r}")
        if len(np.unique(v)) != v.size:
            raise _error(f"axes.{name}: values repeat ({values!r})")
        out[name] = v.astype(np.int64 if v.dtype.kind in "iu" else np.float64)
    return out


def _coords_at(axes: dict, index: tuple) -> dict:
    return {name: v[i].item() for (name, v), i in zip(axes.items(), index)}


def _identity(point) -> Any:
    """What identifies the computation: ``point.fingerprint()`` or the SHA-256 of its pickle."""
    fp = getattr(point, "fingerprint", None)
    if callable(fp):
        return _jsonable(fp())
    try:
        return {"pickle_sha256": hashlib.sha256(pickle.dumps(point, protocol=4)).hexdigest()}
    except (pickle.PicklingError, AttributeError, TypeError) as e:
        raise _error(
            f"point = {point!r} cannot be pickled ({e}); give a module-level function, a functools.partial "
            "of one, or an object with a fingerprint() method"
        ) from None


class SweepResult:
    """A labelled result set: the grid's ``axes`` (names → coordinate arrays, also ``coords``),
    ``data`` (quantity → array of shape ``shape + quantity shape``, NaN where not done), the
    ``done`` mask, ``attrs`` (quantity → dict of units, description, dims), ``static`` (arrays
    shared by every point), ``spec`` (what was computed) and ``complete``.

    ``result[name]`` is ``data[name]``; :meth:`sel` gives every quantity at one point by
    coordinates, :meth:`at` by grid index."""

    def __init__(self, axes, data=None, done=None, attrs=None, static=None, spec=None, units=None):
        self.axes = {k: np.asarray(v) for k, v in axes.items()}
        self.data: dict[str, np.ndarray] = dict(data or {})
        self.done = np.zeros(self.shape, dtype=bool) if done is None else np.asarray(done, dtype=bool)
        self.attrs: dict[str, dict] = dict(attrs or {})
        self.static: dict[str, np.ndarray] = dict(static or {})
        self.spec = spec if spec is not None else {}
        self.units = dict(units or {})

    @property
    def coords(self) -> dict:
        return self.axes

    @property
    def shape(self) -> tuple:
        return tuple(len(v) for v in self.axes.values())

    @property
    def complete(self) -> bool:
        return bool(self.done.all())

    @property
    def points_done(self) -> int:
        return int(self.done.sum())

    def __getitem__(self, name) -> np.ndarray:
        return self.data[name]

    def __contains__(self, name) -> bool:
        return name in self.data

    def at(self, index) -> dict:
        """Every quantity at grid index ``index`` (a tuple, or a flat index)."""
        idx = np.unravel_index(index, self.shape) if np.ndim(index) == 0 else tuple(index)
        if not self.done[idx]:
            raise _error(f"point {tuple(int(i) for i in idx)} of the sweep has not been computed")
        return {k: (v[idx].item() if v[idx].ndim == 0 else v[idx]) for k, v in self.data.items()}

    def sel(self, **coords) -> dict:
        """Every quantity at the point with these coordinates (one per axis, exact values)."""
        if set(coords) != set(self.axes):
            raise _error(f"sel: give one value for each axis {list(self.axes)}, got {sorted(coords)}")
        idx = []
        for name, v in self.axes.items():
            hit = np.flatnonzero(v == coords[name])
            if hit.size == 0:
                raise _error(f"sel: {name} = {coords[name]!r} is not on the axis {v.tolist()}")
            idx.append(int(hit[0]))
        return self.at(tuple(idx))

    def _record(self, index: tuple, values: dict) -> None:
        if not self.data:
            for k, v in values.items():
                self.data[k] = np.full(self.shape + np.shape(v), np.nan)
        if set(values) != set(self.data):
            raise _error(
                f"point {index}: returned quantities {sorted(values)}, other points {sorted(self.data)} "
                "(every point must return the same quantities)"
            )
        for k, v in values.items():
            a = self.data[k]
            if np.shape(v) != a.shape[len(self.shape) :]:
                raise _error(f"point {index}: {k} has shape {np.shape(v)}, other points {a.shape[len(self.shape) :]}")
            a[index] = v
        self.done[index] = True

    def __repr__(self) -> str:
        grid = " × ".join(f"{k}[{len(v)}]" for k, v in self.axes.items())
        return f"SweepResult({grid}, {self.points_done}/{self.done.size} points, {len(self.data)} quantities)"

    # ---- file -------------------------------------------------------------------------------

    def to_bytes(self) -> bytes:
        """The bytes of the sweep file (see the module docstring)."""

        def fill(f) -> None:
            f.attrs["axes"] = list(self.axes)
            f.attrs["shape"] = list(self.shape)
            f.attrs["spec"] = json.dumps(self.spec, sort_keys=True)
            f.attrs["fingerprint"] = _fingerprint(self.spec)
            f.attrs["complete"] = self.complete
            f.attrs["points_done"] = self.points_done
            for name, v in self.axes.items():
                f.create_dataset(f"coords/{name}", data=v).attrs["units"] = self.units.get(name, "")
            f.create_dataset("done", data=self.done)
            for k, v in self.data.items():
                kw = dict(compression="gzip", compression_opts=4) if v.size > 4096 else {}
                ds = f.create_dataset(f"data/{k}", data=v, **kw)
                for a, x in self.attrs.get(k, {}).items():
                    ds.attrs[a] = json.dumps(_jsonable(x)) if isinstance(x, (list, tuple, dict)) else x
            for k, v in self.static.items():
                f.create_dataset(f"static/{k}", data=np.asarray(v, dtype=np.float64))

        return container.to_bytes(FORMAT, FORMAT_VERSION, fill)

    def save(self, path) -> str:
        """Write the sweep file atomically (:mod:`subsurf.atomic`), creating its directory."""
        path = os.fspath(path)
        os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
        return atomic.write_bytes(path, self.to_bytes(), force=True)


def _spec(point, grid: dict) -> dict:
    return {"point": _identity(point), "axes": {k: v.tolist() for k, v in grid.items()}}


def same_sweep(result: SweepResult, point, axes) -> bool:
    """Whether ``result`` (e.g. a loaded sweep file) was computed by ``point`` on the grid ``axes``."""
    return _fingerprint(result.spec) == _fingerprint(_spec(point, _axes(axes)))


def _fingerprint(spec) -> str:
    return hashlib.sha256(json.dumps(spec, sort_keys=True).encode()).hexdigest()


def _str(x) -> str:
    return x.decode() if isinstance(x, bytes) else str(x)


def _attr(x):
    x = x.item() if isinstance(x, np.generic) else x
    if isinstance(x, (str, bytes)):
        s = _str(x)
        if s[:1] in "[{":
            try:
                return json.loads(s)
            except ValueError:
                return s
        return s
    return x


def load(path) -> SweepResult:
    """Read a sweep file written by :meth:`SweepResult.save`; a file that is not one, is damaged
    or was altered raises :class:`subsurf.container.FileFormatError` (a
    :class:`subsurf.ParameterError`), one line naming the file."""
    path = os.fspath(path)
    with container.open_file(path, FORMAT, FORMAT_VERSION, "sweep", advice="; run the sweep again") as o:
        return _read(path, o.f)


def _read(path: str, f) -> SweepResult:
    def fail(problem):
        return container.FileFormatError(f"{path}: {problem}")

    names = [_str(a) for a in np.atleast_1d(f.attrs["axes"])]
    axes = {n: np.asarray(f[f"coords/{n}"][()]) for n in names}
    units = {n: _str(f[f"coords/{n}"].attrs.get("units", "")) for n in names}
    shape = tuple(len(v) for v in axes.values())
    if any(v.ndim != 1 for v in axes.values()):
        raise fail("/coords: an axis is not a list of values")
    done = np.asarray(f["done"][()])
    if done.dtype != bool or done.shape != shape:
        raise fail(f"/done: expected booleans of shape {shape}, found {done.dtype} {done.shape}")
    data, attrs, static = {}, {}, {}
    for group, out in (("data", data), ("static", static)):
        if group in f:
            f[group].visititems(lambda k, o, out=out: out.__setitem__(k, o[()]) if hasattr(o, "shape") else None)
    for k, v in data.items():
        if np.shape(v)[: len(shape)] != shape:
            raise fail(f"/data/{k}: shape {np.shape(v)} does not start with the grid's {shape}")
        attrs[k] = {a: _attr(x) for a, x in f[f"data/{k}"].attrs.items()}
    spec = json.loads(_str(f.attrs["spec"]))
    if not isinstance(spec, dict):
        raise fail("/: attribute 'spec' is not a JSON object")
    return SweepResult(axes, data, done, attrs, static, spec=spec, units=units)


def result_data(result) -> tuple[dict, dict, dict]:
    """A Monte Carlo :class:`~subsurf.result.Result` as sweep point data: ``(values, attrs,
    static)`` — the totals and their ``*_stderr``, ``roulette``, ``absorbed_per_layer``,
    ``photons``, ``events``, and per histogram ``<name>`` and ``<name>_stderr``; attributes give
    units, descriptions and the histogram axes, whose edges are the static arrays
    ``edges/<name>/<axis>``."""
    from .result import TOTALS

    values: dict[str, Any] = {}
    attrs: dict[str, dict] = {}
    for name in (*TOTALS, "roulette"):
        values[name] = float(getattr(result, name))
        values[name + "_stderr"] = float(getattr(result, name + "_stderr"))
        attrs[name] = attrs[name + "_stderr"] = {"units": "1"}
    for name in ("absorbed_per_layer", "absorbed_per_layer_stderr"):
        values[name] = np.asarray(getattr(result, name), dtype=float)
        attrs[name] = {"units": "1", "dims": ["layer"]}
    values["photons"], values["events"] = float(result.photons), float(result.events)
    attrs["photons"] = attrs["events"] = {"units": "1"}
    static = {}
    for name, h in result.histograms.items():
        values[name], values[name + "_stderr"] = np.asarray(h.values), np.asarray(h.stderr)
        a = {"units": h.units, "description": h.description, "dims": list(h.axes), "edge_units": list(h.edge_units)}
        attrs[name] = attrs[name + "_stderr"] = a
        for axis, e in zip(h.axes, h.edges):
            static[f"edges/{name}/{axis}"] = np.asarray(e, dtype=float)
    return values, attrs, static


def _split(out):
    """A point's return value as (values, attrs, static)."""
    if isinstance(out, tuple) and len(out) == 3:
        return out
    if not isinstance(out, dict):
        raise _error(f"a sweep point must return a dict {{quantity: value}}, got {type(out).__name__}")
    return out, {}, {}


def _call_point(point, coords):
    """What a worker runs for one point."""
    return _split(point(**coords))


def sweep(point, axes, path=None, *, client=None, progress=None, units=None) -> SweepResult:
    """Compute ``point(**coords)`` on every point of the grid ``axes`` (see the module docs).

    Parameters
    ----------
    point : callable ``point(**coords) -> {quantity: number or array}`` (or ``(values, attrs,
        static)`` as :func:`result_data` gives), same quantities and shapes at every point.
    axes : ``{name: values}``: the grid is their Cartesian product, the first axis outermost.
    path : optional sweep file (HDF5): points already done there are skipped, finished points are
        saved as the sweep goes (atomically), and the complete set is written at the end.
    client : optional ``dask.distributed.Client``: one task per point, run on its workers
        (Monte Carlo points then run single-threaded: one task per worker thread).
    progress : optional ``progress(done, total)`` (points), called as points finish.
    units : optional ``{axis: unit}`` stored with the coordinates.

    Ctrl-C (or ``progress`` raising KeyboardInterrupt) stops the sweep: finished points are
    saved to ``path`` and the partial set is returned (``complete`` False) with a
    RuntimeWarning; running the same sweep again finishes it without recomputing them.
    """
    grid = _axes(axes)
    if progress is not None and not callable(progress):
        raise _error(f"progress = {progress!r} is not callable")
    spec = _spec(point, grid)
    res = SweepResult(grid, spec=spec, units=units)
    if path is not None and os.path.exists(os.fspath(path)):
        old = load(path)
        if _fingerprint(old.spec) != _fingerprint(spec):
            raise _error(
                f"{os.fspath(path)}: holds another sweep (a different point function or grid); "
                "remove it or choose another path"
            )
        res = old
    todo = [idx for idx in itertools.product(*(range(n) for n in res.shape)) if not res.done[idx]]
    saver = _Saver(res, path)
    total = res.done.size
    described = False

    def record(idx, out):
        nonlocal described
        values, attrs, static = out
        res._record(idx, values)
        if not described:
            res.attrs.update({k: dict(v) for k, v in attrs.items()})
            res.static.update({k: np.asarray(v, dtype=float) for k, v in static.items()})
            described = True
        saver.maybe()
        if progress is not None:
            progress(res.points_done, total)

    try:
        if client is None:
            for idx in todo:
                record(idx, _call_point(point, _coords_at(grid, idx)))
        else:
            _on_cluster(client, point, grid, todo, record)
    except KeyboardInterrupt:
        saver.now()
        if res.points_done == 0 and path is None:
            raise
        warnings.warn(
            f"subsurf.sweep interrupted: {res.points_done} of {total} points done"
            + (f", saved in {os.fspath(path)}; run it again to finish" if path is not None else ""),
            RuntimeWarning,
            stacklevel=2,
        )
        return res
    except BaseException:
        saver.now()
        raise
    saver.now()
    return res


def _on_cluster(client, point, grid, todo, record) -> None:
    """One Dask task per point; results are recorded as they come back. A scheduler that goes
    away raises :class:`subsurf.cluster.ClusterError` (the points recorded so far are kept)."""
    from .cluster import ClusterError, _distributed, check_client, scheduler_lost

    distributed = _distributed()
    check_client(client)
    futures, tag = {}, uuid.uuid4().hex[:10]
    for idx in todo:
        key = f"subsurf-point-{tag}-{'-'.join(map(str, idx))}"
        futures[client.submit(_call_point, point, _coords_at(grid, idx), key=key, pure=False)] = idx
    try:
        for taken, fut in enumerate(distributed.as_completed(list(futures), loop=client.loop), 1):
            record(futures.pop(fut), fut.result())
            _testhooks.after_task(taken, client)  # tests: lose the scheduler here
    except Exception as e:
        lost = scheduler_lost(e)
        if lost is None:
            raise
        raise ClusterError(f"sweep: {lost}; the points finished before are kept") from None
    finally:
        if futures and client.status == "running":  # a lost scheduler has nothing left to cancel
            try:
                client.cancel(list(futures))
            except Exception:  # noqa: BLE001 - a scheduler gone away cancels everything anyway
                pass


class _Saver:
    """Writes the sweep file at most every ``max(CHECKPOINT_S, 10 × last write)`` seconds."""

    def __init__(self, res: SweepResult, path):
        self.res, self.path = res, path
        self.last, self.cost = time.monotonic(), 0.0
        self.dirty = False

    def maybe(self) -> None:
        self.dirty = True
        if self.path is not None and time.monotonic() - self.last >= max(CHECKPOINT_S, 10 * self.cost):
            self.now()

    def now(self) -> None:
        if self.path is None or not (self.dirty or not os.path.exists(os.fspath(self.path))):
            return
        if not self.res.data and not self.res.done.any():
            return
        t0 = time.monotonic()
        self.res.save(self.path)
        self.last = time.monotonic()
        self.cost = self.last - t0
        self.dirty = False
