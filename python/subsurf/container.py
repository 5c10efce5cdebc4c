"""The one file container of subsurf: checksummed HDF5, shared by results files (:mod:`subsurf.io`),
profile tables (:class:`subsurf.bssrdf.ProfileTable`) and sweep files (:mod:`subsurf.sweeps`).

A file is an HDF5 file whose user block (the first bytes, which HDF5 reserves for the
application) holds a checksum manifest::

    <format> manifest 1 <SHA-256 of the JSON line>\\n
    {"datasets": {path: [[offset, length, SHA-256], …]}, "rest": SHA-256, "size": N, "userblock": U}\\n

— the SHA-256 of every dataset's stored bytes (of each chunk of a compressed one) and of all the
remaining bytes (the structure and every attribute); the rest of the user block is newlines. So
every byte of the file is checked. The root group carries the attributes
``format`` (e.g. ``"subsurf-sweep"``), ``format_version``, ``software`` and ``created``.

:func:`open_file` checks the whole file against its manifest *before* HDF5 reads a byte of it (a
damaged file can crash the HDF5 library, so it must never reach it), then opens it from memory and
checks its format and version: a damaged, truncated, edited or foreign file is refused with a
:class:`FileFormatError`, one line naming the file and the dataset (or the structure and
attributes). Plain HDF5 files without a manifest — files written before their format was
checksummed — are read only where the format says its old versions are still readable
(``legacy``); otherwise they are refused, naming the version that is no longer read.

:func:`to_bytes` builds such a file in memory (h5py on a ``BytesIO``); callers publish it with
:func:`subsurf.atomic.write_bytes`.
"""

from __future__ import annotations

import contextlib
import datetime
import hashlib
import io
import json
import os
from typing import Any, Callable

import numpy as np

from ._core import ParameterError

__all__ = ["FileFormatError", "to_bytes", "open_file", "jsonable", "plain", "one_line"]

HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"
#: The manifest's first line starts with ``<format>`` and this tag.
MANIFEST_TAG = b" manifest 1 "
#: What h5py raises on a malformed file besides the checks here (caught only around reading).
READ_ERRORS = (OSError, KeyError, ValueError, TypeError, IndexError, AttributeError, RuntimeError, OverflowError)


class FileFormatError(ParameterError):
    """A file that is not the subsurf file it should be, or is damaged; the message is one line
    naming the file and the dataset or attribute."""


def jsonable(obj: Any) -> Any:
    """Plain JSON-friendly data from configs holding numpy scalars/arrays, tuples, inf."""
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.floating):
        return float(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    if hasattr(obj, "to_dict"):
        return jsonable(obj.to_dict())
    return obj


def plain(v):
    """An HDF5 attribute value as plain Python data (str, int, float, bool, lists of them)."""
    if isinstance(v, bytes):
        return v.decode("utf-8", "surrogateescape")
    if isinstance(v, np.ndarray):
        return [plain(x) for x in v.tolist()]
    if isinstance(v, (list, tuple)):
        return [plain(x) for x in v]
    if isinstance(v, np.generic):
        return plain(v.item())
    return v


def one_line(e: BaseException) -> str:
    return " ".join(str(e).split())


# --- writing --------------------------------------------------------------------------------------


def to_bytes(fmt: str, version: int, fill: Callable) -> bytes:
    """The bytes of a container file of format ``fmt``, version ``version``: ``fill(f)`` writes the
    contents into the h5py ``File`` ``f`` (the root attributes ``format``, ``format_version``,
    ``software``, ``version`` (subsurf's) and ``created`` are set first; ``fill`` may add or
    override attributes)."""
    userblock = 4096
    while True:
        image = _image(fmt, version, fill, userblock)
        manifest = _manifest(fmt, image, userblock)
        if len(manifest) <= userblock:
            return manifest.ljust(userblock, b"\n") + image[userblock:]
        # HDF5 wants a power of two; a quarter more room covers the longer offsets of a larger block,
        # so a file with many datasets is built twice, not once per doubling.
        while userblock < len(manifest) * 5 // 4:
            userblock *= 2


def _image(fmt: str, version: int, fill: Callable, userblock: int) -> bytes:
    import h5py

    from ._core import __version__

    buf = io.BytesIO()
    with h5py.File(buf, "w", userblock_size=userblock) as f:
        f.attrs["format"] = fmt
        f.attrs["format_version"] = version
        f.attrs["software"] = "subsurf"
        f.attrs["version"] = __version__
        f.attrs["created"] = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
        fill(f)
    return buf.getvalue()


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


def _manifest(fmt: str, image: bytes, userblock: int) -> bytes:
    regions = _regions(image)
    body = {
        "size": len(image),
        "userblock": userblock,
        "datasets": {k: [[off, n, _sha(image[off : off + n])] for off, n in rs] for k, rs in regions.items()},
        "rest": _rest(image, userblock, regions),
    }
    text = json.dumps(body, sort_keys=True, separators=(",", ":")).encode()
    return fmt.encode() + MANIFEST_TAG + _sha(text).encode() + b"\n" + text + b"\n"


# --- reading --------------------------------------------------------------------------------------


def _read(path: str, noun: str, error) -> bytes:
    try:
        with open(path, "rb") as fh:
            return fh.read()
    except FileNotFoundError:
        raise error(f"{path}: no such file") from None
    except IsADirectoryError:
        raise error(f"{path}: is a directory, not a {noun} file") from None
    except OSError as e:
        raise error(f"{path}: cannot read ({e.strerror})") from None


def _verify(path: str, data: bytes, fmt: str, noun: str, error) -> bool:
    """Check a file's bytes against its manifest before HDF5 reads any of them; False for plain
    HDF5 (no manifest)."""
    if data[:8] == HDF5_SIGNATURE:
        return False
    head, tag, rest = data.partition(MANIFEST_TAG)
    if not tag or len(head) > 64 or head != fmt.encode():
        other = head.decode("ascii", "replace") if tag and head.startswith(b"subsurf-") and len(head) <= 64 else None
        raise error(f"{path}: a {other} file, not a {noun} file" if other else f"{path}: not an HDF5 {noun} file")
    digest, _, rest = rest.partition(b"\n")
    text = rest.partition(b"\n")[0]
    if _sha(text).encode() != digest:
        raise error(f"{path}: its checksum manifest is damaged (the file is damaged or was edited)")
    try:
        m = json.loads(text)
        size, userblock = int(m["size"]), int(m["userblock"])
        regions = {name: [(int(off), int(n), str(want)) for off, n, want in rs] for name, rs in m["datasets"].items()}
        rest_sha = str(m["rest"])
    except (ValueError, KeyError, TypeError, AttributeError) as e:
        raise error(f"{path}: its checksum manifest is damaged ({one_line(e)})") from None
    if len(data) != size:
        raise error(f"{path}: {len(data)} bytes where {size} were written (truncated or extended)")
    end = len(head) + len(tag) + len(digest) + 1 + len(text) + 1
    if not end <= userblock <= size or data[end:userblock].strip(b"\n"):
        raise error(f"{path}: its user block fails its check (the file is damaged or was edited)")
    for name, rs in regions.items():
        if any(_sha(data[off : off + n]) != want for off, n, want in rs):
            raise error(f"{path}: {name}: fails its checksum (the file is damaged or was edited)")
    if _rest(data, userblock, {k: [(o, n) for o, n, _ in rs] for k, rs in regions.items()}) != rest_sha:
        raise error(f"{path}: its structure or attributes fail their checksum (the file is damaged or was edited)")
    return True


class Opened:
    """An open container file: ``f`` (h5py ``File`` over the verified bytes in memory),
    ``version`` (its format version) and ``verified`` (False for a legacy file without a manifest)."""

    def __init__(self, f, version: int, verified: bool):
        self.f, self.version, self.verified = f, version, verified


@contextlib.contextmanager
def open_file(
    path: str | os.PathLike,
    fmt: str,
    newest: int,
    noun: str,
    *,
    error=FileFormatError,
    legacy: tuple = (),
    advice: str = "",
):
    """Open the container file ``path`` of format ``fmt`` (versions 1 … ``newest``) for reading;
    yields an :class:`Opened`. ``noun`` names the kind of file in messages ("results", "sweep");
    ``legacy``: the format versions written as plain HDF5 (no manifest) that are still read —
    HDF5 parses them unverified, and the caller checks what it can; ``advice`` ends the message
    that refuses any other plain HDF5 file. Errors raised inside the block by h5py on a malformed
    file become ``error``, one line naming the file."""
    import h5py

    path = os.fspath(path)
    data = _read(path, noun, error)
    verified = _verify(path, data, fmt, noun, error)
    if not verified and not legacy:
        raise error(
            f"{path}: plain HDF5 without a checksum manifest: not a {noun} file of this subsurf "
            f"(format version 1, from before {noun} files were checksummed, is no longer read{advice})"
        )
    try:
        f = h5py.File(io.BytesIO(data), "r")
    except READ_ERRORS as e:
        raise error(f"{path}: not a {noun} file ({one_line(e)})") from None
    with f:
        try:
            version = _check_format(path, f, fmt, newest, noun, verified, legacy, error)
            yield Opened(f, version, verified)
        except FileFormatError:
            raise
        except READ_ERRORS as e:
            if isinstance(e, ParameterError):
                raise
            raise error(f"{path}: damaged {noun} file ({type(e).__name__}: {one_line(e)})") from None


def _check_format(path, f, fmt, newest, noun, verified, legacy, error) -> int:
    if plain(f.attrs.get("format", "")) != fmt:
        raise error(f"{path}: not a subsurf {noun} file (no format = {fmt!r} attribute)")
    if "format_version" not in f.attrs:
        raise error(f"{path}: /: attribute 'format_version' is missing")
    ver = plain(f.attrs["format_version"])
    if not isinstance(ver, int) or isinstance(ver, bool):
        raise error(f"{path}: /: attribute 'format_version' = {ver!r:.60} is not an integer")
    if ver > newest:
        raise error(f"{path}: {noun} format version {ver} is newer than this subsurf reads ({newest})")
    if ver < 1:
        raise error(f"{path}: /: format_version = {ver} is not a {noun} format version")
    if not verified and ver not in legacy:
        raise error(f"{path}: /: format version {ver} without its checksum manifest (the file was rewritten)")
    return ver
