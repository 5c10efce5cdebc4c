"""Results files: :func:`save`, :func:`load` and :func:`merge`.

Format: HDF5 (via ``h5py``), one file per run. Why HDF5 rather than netCDF:

* it is self-describing — every array carries its name, shape, dtype and, as attributes, its units,
  axis names, bin-edge units and a one-line description, so the file explains itself;
* it gives random access to large arrays (a 1000 × 1000 A(r, z) or a per-order BRDF is read without
  reading the rest of the file) and compresses them;
* it is read natively by MATLAB (``h5read``), Julia (HDF5.jl), C/C++/Fortran (libhdf5), R and
  Python, so results leave subsurf easily;
* netCDF-4 *is* HDF5 underneath; using it would add the netCDF library and its conventions as a
  dependency layer without giving us anything we need (our histograms have ragged per-axis edges,
  which netCDF's shared-dimension model fits less naturally than plain HDF5 datasets).

Layout (``format = "subsurf-result"``, ``format_version = 1``)::

    /                      attrs: format, format_version, software, version, seed, photons,
                                  photons_requested, partial, events, elapsed_s, created,
                                  config (the full configuration as JSON)
    /totals/<name>         scalar datasets (specular_reflectance, …) and <name>_stderr, units "1"
    /totals/absorbed_per_layer, absorbed_per_layer_stderr
    /histograms/<name>/values, stderr      attrs: units, description, axes, edge_units, overflow
    /histograms/<name>/edges_<i>           attrs: axis, units
    /histograms/<name>/measures_<i>        per-bin measure of axis i (see Histogram.measures)
    /state/<key>           the exact raw state (subsurf.state.TallyState.to_dict(): arrays as
                           datasets, scalars and names as attributes), so a partial run can be
                           resumed from its file; absent for merged results

Standard errors are recombined by :func:`merge` from per-photon moments: with N photons, mean m
and standard error s (of the mean, from the unbiased sample variance), the sums are
S1 = N·m and S2 = N·(s²·(N − 1) + m²), which add across independent runs.
"""

from __future__ import annotations

import datetime
import json
import math
import os
from typing import Any

import numpy as np

from .result import TOTALS, Histogram, Result

FORMAT = "subsurf-result"
FORMAT_VERSION = 1

__all__ = ["save", "load", "merge", "results_equal", "ResultFileError"]


def _parameter_error():
    from . import _core

    return _core.ParameterError


class ResultFileError(ValueError):
    """A file that is not a subsurf results file (or is damaged)."""


def _jsonable(obj: Any) -> Any:
    """Plain JSON-friendly data from configs holding numpy scalars/arrays, tuples, inf."""
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _jsonable(obj.tolist())
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, (np.floating,)):
        return float(obj)
    if isinstance(obj, (np.bool_,)):
        return bool(obj)
    if hasattr(obj, "to_dict"):
        return _jsonable(obj.to_dict())
    return obj


def _config_json(config: dict) -> str:
    # Python's json writes inf/nan as Infinity/NaN and reads them back.
    return json.dumps(_jsonable(config), sort_keys=True)


def save(result: Result, path: str | os.PathLike) -> str:
    """Write ``result`` to an HDF5 results file at ``path`` (overwritten if present); returns the path."""
    import h5py

    path = os.fspath(path)
    d = os.path.dirname(path)
    if d:
        os.makedirs(d, exist_ok=True)
    with h5py.File(path, "w") as f:
        f.attrs["format"] = FORMAT
        f.attrs["format_version"] = FORMAT_VERSION
        f.attrs["software"] = "subsurf"
        f.attrs["version"] = str(result.version)
        f.attrs["seed"] = int(result.seed)
        f.attrs["photons"] = int(result.photons)
        f.attrs["photons_requested"] = int(result.photons_requested)
        f.attrs["partial"] = bool(result.partial)
        f.attrs["events"] = int(result.events)
        f.attrs["elapsed_s"] = float(result.elapsed_s)
        f.attrs["elapsed_s_units"] = "s"
        f.attrs["created"] = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
        f.attrs["config"] = _config_json(result.config)
        t = f.create_group("totals")
        t.attrs["description"] = "fractions of the incident power, each with its standard error"
        for name in TOTALS:
            for key in (name, name + "_stderr"):
                ds = t.create_dataset(key, data=float(getattr(result, key)))
                ds.attrs["units"] = "1"
        for key in ("absorbed_per_layer", "absorbed_per_layer_stderr"):
            ds = t.create_dataset(key, data=np.asarray(getattr(result, key), dtype=float))
            ds.attrs["units"] = "1"
            ds.attrs["axes"] = "layer"
        hg = f.create_group("histograms")
        for name, h in result.histograms.items():
            g = hg.create_group(name)
            kw = dict(compression="gzip", compression_opts=4) if np.size(h.values) > 4096 else {}
            g.create_dataset("values", data=np.asarray(h.values, dtype=float), **kw)
            g.create_dataset("stderr", data=np.asarray(h.stderr, dtype=float), **kw)
            g.attrs["units"] = str(h.units)
            g.attrs["description"] = str(h.description)
            g.attrs["axes"] = [str(a) for a in h.axes]
            g.attrs["edge_units"] = [str(u) for u in h.edge_units]
            for i, (e, a, u) in enumerate(zip(h.edges, h.axes, h.edge_units)):
                ds = g.create_dataset(f"edges_{i}", data=np.asarray(e, dtype=float))
                ds.attrs["axis"] = str(a)
                ds.attrs["units"] = str(u)
            if len(h.measures) == len(h.edges):
                g.attrs["overflow"] = [bool(o) for o in h.overflow]
                for i, m in enumerate(h.measures):
                    g.create_dataset(f"measures_{i}", data=np.asarray(m, dtype=float))
        for key in ("roulette", "roulette_stderr"):
            t.create_dataset(key, data=float(getattr(result, key))).attrs["units"] = "1"
        if result.state is not None:
            _save_state(f.create_group("state"), result.state)
    return path


def _save_state(g, state) -> None:
    for k, v in state.to_dict().items():
        if isinstance(v, np.ndarray):
            g.create_dataset(k, data=v, **(dict(compression="gzip", compression_opts=4) if v.size > 4096 else {}))
        elif isinstance(v, list):
            g.attrs[k] = [str(x) for x in v] if k == "names" else np.asarray(v)
        else:
            g.attrs[k] = np.uint64(v) if isinstance(v, int) else v


def _load_state(g):
    from .state import TallyState

    d = {k: g[k][()] for k in g}
    d.update({k: (v.item() if isinstance(v, np.generic) else v) for k, v in g.attrs.items()})
    d["names"] = [_str(n) for n in d["names"]]
    d["scheme"] = _str(d["scheme"])
    return TallyState(d)


def _str(x) -> str:
    return x.decode() if isinstance(x, bytes) else str(x)


def load(path: str | os.PathLike) -> Result:
    """Read a results file written by :func:`save` back into a :class:`~subsurf.result.Result`."""
    import h5py

    path = os.fspath(path)
    try:
        f = h5py.File(path, "r")
    except FileNotFoundError:
        raise ResultFileError(f"{path}: no such file") from None
    except OSError as e:
        raise ResultFileError(f"{path}: not an HDF5 results file ({e})") from None
    with f:
        if _str(f.attrs.get("format", "")) != FORMAT:
            raise ResultFileError(f"{path}: not a subsurf results file (no format = {FORMAT!r} attribute)")
        ver = int(f.attrs["format_version"])
        if ver > FORMAT_VERSION:
            raise ResultFileError(
                f"{path}: results format version {ver} is newer than this subsurf reads ({FORMAT_VERSION})"
            )
        t = f["totals"]
        kw: dict[str, Any] = {}
        for name in TOTALS:
            kw[name] = float(t[name][()])
            kw[name + "_stderr"] = float(t[name + "_stderr"][()])
        kw["absorbed_per_layer"] = np.asarray(t["absorbed_per_layer"][()], dtype=float)
        kw["absorbed_per_layer_stderr"] = np.asarray(t["absorbed_per_layer_stderr"][()], dtype=float)
        hists = {}
        for name, g in f["histograms"].items():
            axes = tuple(_str(a) for a in g.attrs["axes"])
            edges = tuple(np.asarray(g[f"edges_{i}"][()], dtype=float) for i in range(len(axes)))
            measured = all(f"measures_{i}" in g for i in range(len(axes)))
            hists[name] = Histogram(
                values=np.asarray(g["values"][()]),
                stderr=np.asarray(g["stderr"][()]),
                edges=edges,
                axes=axes,
                edge_units=tuple(_str(u) for u in g.attrs["edge_units"]),
                units=_str(g.attrs["units"]),
                description=_str(g.attrs["description"]),
                measures=tuple(np.asarray(g[f"measures_{i}"][()], dtype=float) for i in range(len(axes)))
                if measured
                else (),
                overflow=tuple(bool(o) for o in g.attrs["overflow"]) if "overflow" in g.attrs else (),
            )
        extra = {k: float(t[k][()]) for k in ("roulette", "roulette_stderr") if k in t}
        return Result(
            **kw,
            photons=int(f.attrs["photons"]),
            seed=int(f.attrs["seed"]),
            elapsed_s=float(f.attrs["elapsed_s"]),
            events=int(f.attrs["events"]),
            photons_requested=int(f.attrs["photons_requested"]),
            partial=bool(f.attrs["partial"]),
            histograms=hists,
            config=json.loads(_str(f.attrs["config"])),
            version=_str(f.attrs["version"]),
            state=_load_state(f["state"]) if "state" in f else None,
            **extra,
        )


def _arr_equal(a, b) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and bool(np.array_equal(a, b, equal_nan=a.dtype.kind == "f" and b.dtype.kind == "f"))


def results_equal(a: Result, b: Result) -> bool:
    """True when two results hold the same numbers, histograms, provenance and configuration.

    Configurations are compared as JSON data (tuples and lists are the same), as a results file
    stores them.
    """
    scalars = (
        [n for n in TOTALS]
        + [n + "_stderr" for n in TOTALS]
        + ["photons", "seed", "elapsed_s", "events", "photons_requested", "partial", "version"]
    )
    for n in scalars:
        if getattr(a, n) != getattr(b, n) and not (
            isinstance(getattr(a, n), float) and math.isnan(getattr(a, n)) and math.isnan(getattr(b, n))
        ):
            return False
    for n in ("absorbed_per_layer", "absorbed_per_layer_stderr"):
        if not _arr_equal(getattr(a, n), getattr(b, n)):
            return False
    if _jsonable(a.config) != _jsonable(b.config):
        return False
    if set(a.histograms) != set(b.histograms):
        return False
    for k, ha in a.histograms.items():
        hb = b.histograms[k]
        if (
            tuple(ha.axes) != tuple(hb.axes)
            or tuple(ha.edge_units) != tuple(hb.edge_units)
            or ha.units != hb.units
            or ha.description != hb.description
        ):
            return False
        if not (_arr_equal(ha.values, hb.values) and _arr_equal(ha.stderr, hb.stderr)):
            return False
        if len(ha.edges) != len(hb.edges) or not all(_arr_equal(x, y) for x, y in zip(ha.edges, hb.edges)):
            return False
    return True


#: Config keys that may differ between runs that are merged.
_RUN_KEYS = ("seed", "seeds", "photons", "photons_requested", "threads", "config_file")


def _seeds(r: Result) -> list[int]:
    return [int(s) for s in r.config.get("seeds", [r.seed])] if isinstance(r.config, dict) else [int(r.seed)]


def _moments(mean, stderr, n: int):
    """Per-photon sums S1 = N·m, S2 = N·(s²(N−1) + m²) from a mean and its standard error."""
    mean = np.asarray(mean, dtype=float)
    stderr = np.asarray(stderr, dtype=float)
    s1 = n * mean
    s2 = n * (stderr**2 * (n - 1) + mean**2) if n > 1 else n * mean**2
    return s1, s2


def _combine(ma, sa, na: int, mb, sb, nb: int):
    """Mean and standard error of the union of two independent samples given their summaries."""
    a1, a2 = _moments(ma, sa, na)
    b1, b2 = _moments(mb, sb, nb)
    n = na + nb
    m = (a1 + b1) / n
    if n > 1:
        var = np.maximum((a2 + b2) / n - m**2, 0.0) * n / (n - 1)
        s = np.sqrt(var / n)
    else:
        s = np.zeros_like(m)
    return m, s


def merge(a: Result, b: Result) -> Result:
    """Combine two results of the same configuration traced with different seeds.

    Means are weighted by photon counts; standard errors are recombined exactly from the
    per-photon moments (see the module docstring). Photons, requested photons, events and
    elapsed time add; the merged ``config["seeds"]`` lists every seed that went in.
    Raises :class:`subsurf.ParameterError` when configurations, histograms or grids differ, or
    when a seed is used twice (the histories would be the same photons, not independent ones).
    """
    err = _parameter_error()
    ca = {k: v for k, v in _jsonable(a.config).items() if k not in _RUN_KEYS}
    cb = {k: v for k, v in _jsonable(b.config).items() if k not in _RUN_KEYS}
    if ca != cb:
        diff = sorted(k for k in set(ca) | set(cb) if ca.get(k) != cb.get(k))
        raise err(f"merge: the two results have different configurations (differ in: {', '.join(diff)})")
    common = set(_seeds(a)) & set(_seeds(b))
    if common:
        raise err(
            f"merge: both results were traced with seed {sorted(common)[0]}; merging needs "
            "different seeds (same seed = same photon histories)"
        )
    if set(a.histograms) != set(b.histograms):
        raise err(f"merge: different histograms: {sorted(a.histograms)} vs {sorted(b.histograms)}")
    if a.photons < 1 or b.photons < 1:
        raise err("merge: a result with no photons cannot be merged")
    na, nb = int(a.photons), int(b.photons)
    kw: dict[str, Any] = {}
    for name in TOTALS + ("roulette", "absorbed_per_layer"):
        ma, sa = getattr(a, name), getattr(a, name + "_stderr")
        mb, sb = getattr(b, name), getattr(b, name + "_stderr")
        if np.shape(ma) != np.shape(mb):
            raise err(f"merge: {name} has different shapes {np.shape(ma)} and {np.shape(mb)}")
        m, s = _combine(ma, sa, na, mb, sb, nb)
        if name == "absorbed_per_layer":
            kw[name], kw[name + "_stderr"] = np.asarray(m), np.asarray(s)
        else:
            kw[name], kw[name + "_stderr"] = float(m), float(s)
    hists = {}
    for k, ha in a.histograms.items():
        hb = b.histograms[k]
        same = (
            np.shape(ha.values) == np.shape(hb.values)
            and tuple(ha.axes) == tuple(hb.axes)
            and len(ha.edges) == len(hb.edges)
            and all(np.shape(x) == np.shape(y) and np.allclose(x, y) for x, y in zip(ha.edges, hb.edges))
        )
        if not same:
            raise err(f"merge: histogram {k!r} has different bins in the two results")
        m, s = _combine(ha.values, ha.stderr, na, hb.values, hb.stderr, nb)
        hists[k] = Histogram(
            values=m,
            stderr=s,
            edges=ha.edges,
            axes=ha.axes,
            edge_units=ha.edge_units,
            units=ha.units,
            description=ha.description,
            measures=ha.measures,
            overflow=ha.overflow,
        )
    config = dict(a.config) if isinstance(a.config, dict) else {}
    config["seeds"] = sorted(set(_seeds(a)) | set(_seeds(b)))
    if "photons" in config:
        config["photons"] = na + nb
    requested = int(a.photons_requested or na) + int(b.photons_requested or nb)
    return Result(
        **kw,
        photons=na + nb,
        seed=int(a.seed),
        elapsed_s=float(a.elapsed_s) + float(b.elapsed_s),
        events=int(a.events) + int(b.events),
        photons_requested=requested,
        partial=(na + nb) < requested,
        histograms=hists,
        config=config,
        version=a.version if a.version == b.version else f"{a.version}+{b.version}",
    )
