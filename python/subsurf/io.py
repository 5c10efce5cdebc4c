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

Integrity (format 2): the file's first bytes — the HDF5 user block, which HDF5 reserves for the
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

import datetime
import hashlib
import io
import json
import math
import os
import warnings
from typing import Any

import numpy as np

from . import atomic
from ._core import ParameterError
from .result import TOTALS, Histogram, Result

FORMAT = "subsurf-result"
#: 2: a checksum manifest in the HDF5 user block; 1 (plain HDF5, no checksums) still loads.
FORMAT_VERSION = 2
MAGIC = b"subsurf-result manifest 1 "
HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"

__all__ = ["save", "load", "merge", "to_bytes", "results_equal", "ResultFileError", "UnverifiedResultWarning"]


class ResultFileError(ValueError):
    """A file that is not a subsurf results file, or is damaged; the message is one line naming the
    file and the dataset or attribute."""


class UnverifiedResultWarning(UserWarning):
    """A results file without checksums (format version 1) was loaded: its integrity is unknown."""


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


def _image(result: Result, userblock: int) -> bytes:
    """The HDF5 file of ``result`` (built in memory), with ``userblock`` bytes reserved at its start."""
    import h5py

    buf = io.BytesIO()
    with h5py.File(buf, "w", userblock_size=userblock) as f:
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
    return buf.getvalue()


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
    checksum manifest (see the module docstring)."""
    userblock = 4096
    while True:
        image = _image(result, userblock)
        manifest = _manifest(image, userblock)
        if len(manifest) <= userblock:
            return manifest.ljust(userblock, b"\n") + image[userblock:]
        userblock *= 4


def save(result: Result, path: str | os.PathLike, force: bool = True) -> str:
    """Write ``result`` to an HDF5 results file at ``path``; returns the path.

    The file is built in memory and written atomically (:mod:`subsurf.atomic`): a crash, a kill
    or a full disk leaves either the previous file or the complete new one. ``force=False``
    refuses to replace an existing file (the command line's default). The directory must exist.
    """
    return atomic.write_bytes(path, to_bytes(result), force=force)


# --- checksums ------------------------------------------------------------------------------


def _sha(data) -> str:
    return hashlib.sha256(data).hexdigest()


def _regions(image: bytes) -> dict:
    """Where each dataset's stored bytes lie in an HDF5 image: {path: [(offset, length)]} (one
    range for a contiguous dataset, one per chunk of a compressed one)."""
    import h5py

    out = {}
    with h5py.File(io.BytesIO(image), "r") as f:

        def visit(name, obj):
            if not isinstance(obj, h5py.Dataset):
                return
            if obj.chunks is None:
                off = obj.id.get_offset()
                if off is not None:
                    out["/" + name] = [(off, obj.id.get_storage_size())]
            else:
                infos = (obj.id.get_chunk_info(i) for i in range(obj.id.get_num_chunks()))
                out["/" + name] = [(c.byte_offset, c.size) for c in infos]

        f.visititems(visit)
    return out


def _rest(data, userblock: int, regions: dict) -> str:
    """SHA-256 of every byte after the user block that is not a dataset's data: the structure and
    all attributes."""
    h = hashlib.sha256()
    pos = userblock
    for off, n in sorted(r for rs in regions.values() for r in rs):
        h.update(data[pos:off])
        pos = max(pos, off + n)
    h.update(data[pos:])
    return h.hexdigest()


def _manifest(image: bytes, userblock: int) -> bytes:
    regions = _regions(image)
    body = {
        "size": len(image),
        "userblock": userblock,
        "datasets": {k: [[off, n, _sha(image[off : off + n])] for off, n in rs] for k, rs in regions.items()},
        "rest": _rest(image, userblock, regions),
    }
    text = json.dumps(body, sort_keys=True, separators=(",", ":")).encode()
    return MAGIC + _sha(text).encode() + b"\n" + text + b"\n"


def _verify(path: str, data: bytes) -> bool:
    """Check a file's bytes against its manifest before HDF5 reads any of them; False for a file of
    format version 1 (plain HDF5, no manifest)."""
    if data[:8] == HDF5_SIGNATURE:
        return False
    if not data.startswith(MAGIC):
        raise ResultFileError(f"{path}: not an HDF5 results file")
    head, _, rest = data[len(MAGIC) :].partition(b"\n")
    text = rest.partition(b"\n")[0]
    if _sha(text).encode() != head:
        raise ResultFileError(f"{path}: its checksum manifest is damaged")
    m = json.loads(text)
    if len(data) != m["size"]:
        raise ResultFileError(f"{path}: {len(data)} bytes where {m['size']} were written (truncated or extended)")
    regions = {}
    for name, rs in m["datasets"].items():
        regions[name] = [(off, n) for off, n, _ in rs]
        if any(_sha(data[off : off + n]) != want for off, n, want in rs):
            raise ResultFileError(f"{path}: {name}: fails its checksum (the file is damaged or was edited)")
    if _rest(data, m["userblock"], regions) != m["rest"]:
        raise ResultFileError(
            f"{path}: its structure or attributes fail their checksum (the file is damaged or was edited)"
        )
    return True


# --- loading ----------------------------------------------------------------------------------


def _plain(v):
    """An HDF5 attribute value as plain Python data (str, int, float, bool, lists of them)."""
    if isinstance(v, bytes):
        return v.decode("utf-8", "surrogateescape")
    if isinstance(v, np.ndarray):
        return [_plain(x) for x in v.tolist()]
    if isinstance(v, (list, tuple)):
        return [_plain(x) for x in v]
    if isinstance(v, np.generic):
        return _plain(v.item())
    return v


def _str(x) -> str:
    return x.decode() if isinstance(x, bytes) else str(x)


_NOUNS = {"str": "a string", "int": "an integer", "bool": "a boolean", "float": "a number"}
_NOUNS.update(strs="a list of strings", bools="a list of booleans")


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
        except _READ_ERRORS as e:
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
        if _str(_plain(f.attrs.get("format", ""))) != FORMAT:
            raise ResultFileError(f"{self.path}: not a subsurf results file (no format = {FORMAT!r} attribute)")
        ver = self.attr(f, "format_version", "/", "int")
        if ver > FORMAT_VERSION:
            raise ResultFileError(
                f"{self.path}: results format version {ver} is newer than this subsurf reads ({FORMAT_VERSION})"
            )
        if ver < 1:
            raise self.fail("/", f"format_version = {ver} is not a results format version")
        if ver >= 2 and not self.verified:
            raise self.fail("/", f"format version {ver} without its checksum manifest (the file was rewritten)")
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


#: What h5py raises on a damaged file, besides the checks above (caught only around reading a file).
_READ_ERRORS = (OSError, KeyError, ValueError, TypeError, IndexError, AttributeError, RuntimeError, OverflowError)


def load(path: str | os.PathLike) -> Result:
    """Read a results file written by :func:`save` back into a :class:`~subsurf.result.Result`.

    The file's bytes are checked against its checksum manifest before HDF5 reads them, then every
    piece is checked for presence, type and shape: a damaged, truncated or foreign file raises
    :class:`ResultFileError`, one line naming the file and the dataset or attribute. Files of format
    version 1 (before checksums) load with an :class:`UnverifiedResultWarning`.
    """
    import h5py

    path = os.fspath(path)
    try:
        with open(path, "rb") as fh:
            data = fh.read()
    except FileNotFoundError:
        raise ResultFileError(f"{path}: no such file") from None
    except IsADirectoryError:
        raise ResultFileError(f"{path}: is a directory, not a results file") from None
    except OSError as e:
        raise ResultFileError(f"{path}: cannot read ({e.strerror})") from None
    try:
        verified = _verify(path, data)
    except (ValueError, KeyError, TypeError) as e:  # a manifest that parses but is not ours
        if isinstance(e, ResultFileError):
            raise
        raise ResultFileError(f"{path}: its checksum manifest is damaged ({_one_line(e)})") from None
    try:
        f = h5py.File(io.BytesIO(data), "r")
    except _READ_ERRORS as e:
        raise ResultFileError(f"{path}: not an HDF5 results file ({_one_line(e)})") from None
    reader = _Reader(path, f, verified)
    try:
        with f:
            result = reader.result()
    except ResultFileError:
        raise
    except _READ_ERRORS as e:
        raise ResultFileError(f"{path}: damaged results file ({type(e).__name__}: {_one_line(e)})") from None
    if not verified:
        warnings.warn(
            f"{path}: results format version 1 has no checksums; its integrity cannot be verified",
            UnverifiedResultWarning,
            stacklevel=2,
        )
    return result


def _one_line(e: BaseException) -> str:
    return " ".join(str(e).split())


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
