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

Layout (``format = "subsurf-result"``, ``format_version = 2``)::

    /                      attrs: format, format_version, software, version, seed, photons,
                                  photons_requested, partial, events, elapsed_s, created,
                                  config (the full configuration as JSON), histograms (their names)
    /totals/<name>         scalar datasets (specular_reflectance, …) and <name>_stderr, units "1"
    /totals/absorbed_per_layer, absorbed_per_layer_stderr
    /histograms/<name>/values, stderr      attrs: units, description, axes, edge_units, overflow
    /histograms/<name>/edges_<i>           attrs: axis, units
    /histograms/<name>/measures_<i>        per-bin measure of axis i (see Histogram.measures)
    /state/<key>           the exact raw state (subsurf.state.TallyState.to_dict(): arrays as
                           datasets, scalars and names as attributes), so a partial run can be
                           resumed from its file; absent for merged results

Integrity (format 2): the file is subsurf's checksummed container (:mod:`subsurf.container`, shared
with profile tables and sweeps): its first bytes — the HDF5 user block, which HDF5 reserves for the
application — hold a checksum manifest: the SHA-256 of every dataset's stored bytes (of each chunk
of a compressed one) and of all the remaining bytes (the structure and every attribute). :func:`load`
checks the whole file against it before HDF5 reads a byte of it, so a damaged file can neither
crash the HDF5 library nor load as a silently different result: it is refused in one line naming
the dataset (or the structure and attributes). Files are written atomically (:func:`save`). A file
edited afterwards (with h5py, say) no longer matches and is refused as such. Version 1 files
(plain HDF5, no manifest) still load, with an :class:`UnverifiedResultWarning`.

Standard errors are recombined by :func:`merge` from per-photon moments: with N photons, mean m
and standard error s (of the mean, from the unbiased sample variance), the sums are
S1 = N·m and S2 = N·(s²·(N − 1) + m²), which add across independent runs.
"""

from __future__ import annotations

import json
import math
import os
import warnings
from typing import Any

import numpy as np

from . import atomic, container
from ._core import ParameterError
from .container import jsonable as _jsonable
from .container import one_line as _one_line
from .container import plain as _plain
from .result import TOTALS, Histogram, Result

FORMAT = "subsurf-result"
#: 2: the checksummed container (:mod:`subsurf.container`); 1 (plain HDF5, no checksums) still loads.
FORMAT_VERSION = 2

__all__ = ["save", "load", "merge", "to_bytes", "results_equal", "ResultFileError", "UnverifiedResultWarning"]


class ResultFileError(container.FileFormatError):
    """A file that is not a subsurf results file, or is damaged; the message is one line naming the
    file and the dataset or attribute."""


class UnverifiedResultWarning(UserWarning):
    """A results file without checksums (format version 1) was loaded: its integrity is unknown."""


def _config_json(config: dict) -> str:
    # Python's json writes inf/nan as Infinity/NaN and reads them back.
    return json.dumps(_jsonable(config), sort_keys=True)


def _fill(result: Result):
    """The writer of ``result``'s contents into an open h5py file (see the module docstring)."""

    def fill(f) -> None:
        f.attrs["version"] = str(result.version)
        f.attrs["seed"] = int(result.seed)
        f.attrs["photons"] = int(result.photons)
        f.attrs["photons_requested"] = int(result.photons_requested)
        f.attrs["partial"] = bool(result.partial)
        f.attrs["events"] = int(result.events)
        f.attrs["elapsed_s"] = float(result.elapsed_s)
        f.attrs["elapsed_s_units"] = "s"
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
            _save_histogram(hg.create_group(name), h)
        for key in ("roulette", "roulette_stderr"):
            t.create_dataset(key, data=float(getattr(result, key))).attrs["units"] = "1"
        if result.state is not None:
            _save_state(f.create_group("state"), result.state)

    return fill


def _save_histogram(g, h: Histogram) -> None:
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


def _save_state(g, state) -> None:
    for k, v in state.to_dict().items():
        if isinstance(v, np.ndarray):
            g.create_dataset(k, data=v, **(dict(compression="gzip", compression_opts=4) if v.size > 4096 else {}))
        elif isinstance(v, list):
            g.attrs[k] = [str(x) for x in v] if k == "names" else np.asarray(v)
        else:
            g.attrs[k] = np.uint64(v) if isinstance(v, int) else v


def to_bytes(result: Result) -> bytes:
    """The bytes of the results file of ``result``: the HDF5 file, its user block holding the
    checksum manifest (:mod:`subsurf.container`)."""
    return container.to_bytes(FORMAT, FORMAT_VERSION, _fill(result))


def save(result: Result, path: str | os.PathLike, force: bool = True) -> str:
    """Write ``result`` to an HDF5 results file at ``path``; returns the path.

    The file is built in memory and written atomically (:mod:`subsurf.atomic`): a crash, a kill
    or a full disk leaves either the previous file or the complete new one. ``force=False``
    refuses to replace an existing file (the command line's default). The directory must exist.
    """
    return atomic.write_bytes(path, to_bytes(result), force=force)


# --- loading ----------------------------------------------------------------------------------


class _Reader:
    """Reads one results file, checking every checksum (format 2) and the shape of everything."""

    def __init__(self, path: str, f, verified: bool):
        self.path, self.f, self.verified = path, f, verified

    def fail(self, where: str, problem: str) -> ResultFileError:
        return ResultFileError(f"{self.path}: {where}: {problem}")

    def member(self, group, name: str, where: str, kind: str):
        import h5py

        obj = group.get(name)
        cls = h5py.Group if kind == "group" else h5py.Dataset
        if not isinstance(obj, cls):
            raise self.fail(where, f"missing (expected a {kind})" if obj is None else f"is not a {kind}")
        return obj

    def array(self, group, name: str, where: str, ndim: int | None = None) -> np.ndarray:
        ds = self.member(group, name, where, "dataset")
        try:
            a = np.asarray(ds[()])
        except container.READ_ERRORS as e:
            raise self.fail(where, f"cannot be read ({_one_line(e)})") from None
        if a.dtype.kind not in "fiu":
            raise self.fail(where, f"expected numbers, found {a.dtype}")
        if ndim is not None and a.ndim != ndim:
            raise self.fail(where, f"expected {ndim} dimension(s), found shape {a.shape}")
        return a.astype(float)

    def attr(self, obj, name: str, where: str, kind: str):
        if name not in obj.attrs:
            raise self.fail(where, f"attribute {name!r} is missing")
        v = _plain(obj.attrs[name])
        ok = {
            "str": isinstance(v, str),
            "int": isinstance(v, int) and not isinstance(v, bool),
            "bool": isinstance(v, bool),
            "float": isinstance(v, (int, float)) and not isinstance(v, bool),
            "strs": isinstance(v, list) and all(isinstance(x, str) for x in v),
            "bools": isinstance(v, list) and all(isinstance(x, bool) for x in v),
        }[kind]
        if kind == "strs" and isinstance(v, str):
            v, ok = [v], True  # one axis written as a scalar string
        if not ok:
            noun = {"str": "a string", "int": "an integer", "bool": "a boolean", "float": "a number"}.get(
                kind, "a list"
            )
            raise self.fail(where, f"attribute {name!r} = {v!r:.60} is not {noun}")
        return v

    def count(self, name: str, hi: int = 2**64) -> int:
        v = self.attr(self.f, name, "/", "int")
        if not 0 <= v < hi:
            raise self.fail("/", f"attribute {name!r} = {v} is out of range")
        return v

    def result(self) -> Result:
        f = self.f
        try:
            config = json.loads(self.attr(f, "config", "/", "str"))
        except ValueError as e:
            raise self.fail("/", f"attribute 'config' is not valid JSON ({e})") from None
        if not isinstance(config, dict):
            raise self.fail("/", f"attribute 'config' is not a JSON object (found {type(config).__name__})")
        t = self.member(f, "totals", "/totals", "group")
        kw: dict[str, Any] = {}
        for name in TOTALS:
            for key in (name, name + "_stderr"):
                kw[key] = float(self.array(t, key, f"/totals/{key}", ndim=0))
        for key in ("absorbed_per_layer", "absorbed_per_layer_stderr"):
            kw[key] = self.array(t, key, f"/totals/{key}", ndim=1)
        if kw["absorbed_per_layer"].shape != kw["absorbed_per_layer_stderr"].shape:
            raise self.fail("/totals/absorbed_per_layer_stderr", "has a different length than absorbed_per_layer")
        for key in ("roulette", "roulette_stderr"):  # absent from files written before it was booked apart
            if key in t:
                kw[key] = float(self.array(t, key, f"/totals/{key}", ndim=0))
        return Result(
            **kw,
            photons=self.count("photons"),
            seed=self.count("seed"),
            elapsed_s=float(self.attr(f, "elapsed_s", "/", "float")),
            events=self.count("events"),
            photons_requested=self.count("photons_requested"),
            partial=self.attr(f, "partial", "/", "bool"),
            histograms=self.histograms(),
            config=config,
            version=self.attr(f, "version", "/", "str"),
            state=self.state() if "state" in f else None,
        )

    def state(self):
        """The run's exact raw state (:class:`subsurf.state.TallyState`), from ``/state``."""
        from ._core import ParameterError
        from .state import TallyState

        g = self.member(self.f, "state", "/state", "group")
        d = {k: self.member(g, k, f"/state/{k}", "dataset")[()] for k in g}
        d.update({k: _plain(v) for k, v in g.attrs.items()})
        try:
            return TallyState(d)
        except ParameterError as e:
            raise self.fail("/state", str(e)) from None

    def histograms(self) -> dict:
        hg = self.member(self.f, "histograms", "/histograms", "group")
        out = {}
        for name in hg:
            where = f"/histograms/{name}"
            g = self.member(hg, name, where, "group")
            axes = tuple(self.attr(g, "axes", where, "strs"))
            edge_units = tuple(self.attr(g, "edge_units", where, "strs"))
            if len(edge_units) != len(axes):
                raise self.fail(where, f"{len(axes)} axes but {len(edge_units)} edge units")
            values = self.array(g, "values", where + "/values", ndim=len(axes))
            stderr = self.array(g, "stderr", where + "/stderr", ndim=len(axes))
            edges = tuple(self.array(g, f"edges_{i}", f"{where}/edges_{i}", ndim=1) for i in range(len(axes)))
            shape = tuple(len(e) - 1 for e in edges)
            if values.shape != shape or stderr.shape != shape:
                raise self.fail(
                    where, f"values {values.shape} and stderr {stderr.shape} do not match the edges {shape}"
                )
            measures, overflow = (), ()
            if "measures_0" in g:  # files written before histograms carried their bin measures have none
                measures = tuple(
                    self.array(g, f"measures_{i}", f"{where}/measures_{i}", ndim=1) for i in range(len(axes))
                )
                if tuple(len(m) for m in measures) != shape:
                    raise self.fail(where, f"bin measures of lengths {[len(m) for m in measures]} for bins {shape}")
                overflow = self.attr(g, "overflow", where, "bools")
                if len(overflow) != len(axes):
                    raise self.fail(where, f"{len(axes)} axes but {len(overflow)} overflow flags")
            out[name] = Histogram(
                values=values,
                stderr=stderr,
                edges=edges,
                axes=axes,
                edge_units=edge_units,
                units=self.attr(g, "units", where, "str"),
                description=self.attr(g, "description", where, "str"),
                measures=measures,
                overflow=tuple(overflow),
            )
        return out


def load(path: str | os.PathLike) -> Result:
    """Read a results file written by :func:`save` back into a :class:`~subsurf.result.Result`.

    The file's bytes are checked against its checksum manifest before HDF5 reads them
    (:mod:`subsurf.container`), then every piece is checked for presence, type and shape: a
    damaged, truncated or foreign file raises :class:`ResultFileError`, one line naming the file
    and the dataset or attribute. Files of format version 1 (before checksums) load with an
    :class:`UnverifiedResultWarning`.
    """
    path = os.fspath(path)
    with container.open_file(path, FORMAT, FORMAT_VERSION, "results", error=ResultFileError, legacy=(1,)) as o:
        result = _Reader(path, o.f, o.verified).result()
    if not o.verified:
        warnings.warn(
            f"{path}: results format version 1 has no checksums; its integrity cannot be verified",
            UnverifiedResultWarning,
            stacklevel=2,
        )
    return result


def _arr_equal(a, b) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and bool(np.array_equal(a, b, equal_nan=a.dtype.kind == "f" and b.dtype.kind == "f"))


def _same(x, y) -> bool:
    return x == y or (isinstance(x, float) and isinstance(y, float) and math.isnan(x) and math.isnan(y))


#: Compared by :func:`results_equal` only with ``provenance=True``.
_PROVENANCE = ("elapsed_s", "version")
_SCALARS = (
    *TOTALS,
    *(n + "_stderr" for n in TOTALS),
    "roulette",
    "roulette_stderr",
    "photons",
    "seed",
    "events",
    "photons_requested",
    "partial",
)
_HISTOGRAM_LABELS = ("axes", "edge_units", "units", "description", "overflow")
_HISTOGRAM_ARRAYS = ("edges", "measures")


def _histograms_equal(a: dict, b: dict) -> bool:
    if set(a) != set(b):
        return False
    for k, ha in a.items():
        hb = b[k]
        if any(_jsonable(getattr(ha, n)) != _jsonable(getattr(hb, n)) for n in _HISTOGRAM_LABELS):
            return False
        if not (_arr_equal(ha.values, hb.values) and _arr_equal(ha.stderr, hb.stderr)):
            return False
        for n in _HISTOGRAM_ARRAYS:
            x, y = getattr(ha, n), getattr(hb, n)
            if len(x) != len(y) or not all(_arr_equal(u, v) for u, v in zip(x, y)):
                return False
    return True


def results_equal(a: Result, b: Result, *, provenance: bool = True) -> bool:
    """True when two results hold the same numbers, bit for bit (NaN equals NaN): every total and
    its standard error, ``roulette``, ``absorbed_per_layer``, photons (done and requested), seed,
    events, ``partial``, every histogram (values, errors, edges, bin measures, labels) and the
    exact state. This is the one bit-identity comparison of subsurf and its tests (file round
    trips, threads, resuming, clusters).

    ``provenance`` (default) also compares what describes the run rather than its numbers: the
    elapsed time, the version and the configuration (as JSON data, as a results file stores it —
    tuples and lists are the same). ``provenance=False`` compares two runs of the same photons made
    differently (other thread counts, resumed, on a cluster).
    """
    names = _SCALARS + (_PROVENANCE if provenance else ())
    if not all(_same(getattr(a, n), getattr(b, n)) for n in names):
        return False
    if not all(_arr_equal(getattr(a, n), getattr(b, n)) for n in ("absorbed_per_layer", "absorbed_per_layer_stderr")):
        return False
    if provenance and _jsonable(a.config) != _jsonable(b.config):
        return False
    return _histograms_equal(a.histograms, b.histograms) and a.state == b.state


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
    err = ParameterError
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
