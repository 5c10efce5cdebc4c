"""Rendered images: the linear HDR array, OpenEXR (the optional ``openexr`` package, see
:func:`exr_available`) and a tone-mapped sRGB PNG, both written atomically (a temporary file
renamed into place)."""

from __future__ import annotations

import os

import numpy as np

from .. import atomic


class Image:
    """A rendered image: ``array`` (height, width, 3) linear radiance, ``spp`` samples per pixel,
    ``partial`` (interrupted before the requested spp), ``method``, ``seed``, ``elapsed_s``."""

    def __init__(self, array, spp, spp_requested, method, seed, elapsed_s, dropped=0):
        self.array = np.asarray(array, dtype=np.float64)
        self.spp, self.spp_requested = int(spp), int(spp_requested)
        self.partial = self.spp < self.spp_requested
        self.method, self.seed, self.elapsed_s, self.dropped = method, seed, float(elapsed_s), int(dropped)

    def __array__(self, dtype=None, copy=None):
        return self.array if dtype is None else self.array.astype(dtype)

    def metadata(self) -> dict:
        return {
            "method": self.method,
            "spp": str(self.spp),
            "spp_requested": str(self.spp_requested),
            "partial": str(self.partial),
            "seed": str(self.seed),
            "software": "subsurf",
        }

    def save(self, path, exposure=0.0, force=True):
        """Write ``path`` (.exr: linear HDR with metadata; .png: tone-mapped sRGB; .npy: the
        array). An .exr also gets its PNG beside it (same name, .png): the files of
        :func:`output_paths`, written as one group (:func:`subsurf.atomic.write_group`; an existing
        one is replaced only with ``force``). Returns the paths."""
        paths = output_paths(path)
        writers = {
            ".exr": lambda: _exr_writer(self.array, self.metadata()),
            ".png": lambda: _png_writer(self.array, exposure),
            ".npy": lambda: _npy_writer(self.array),
        }
        items = [(p, writers[os.path.splitext(p)[1].lower()]()) for p in paths]
        os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
        return atomic.write_group(items, force=force)


def output_paths(path):
    """The files :meth:`Image.save` writes for ``path``: ``[path]``, and for an .exr also the
    .png beside it. Unknown extensions are refused (``ValueError``)."""
    path = os.fspath(path)
    stem, ext = os.path.splitext(path)
    if ext.lower() == ".exr":
        return [path, stem + ".png"]
    if ext.lower() in (".png", ".npy"):
        return [path]
    raise ValueError(f"{path}: unknown image format {ext!r} (use .exr, .png or .npy)")


#: How to get OpenEXR output (the one optional package of the renderer).
EXR_HINT = "OpenEXR output needs the 'openexr' package: pip install 'subsurf[render]'"


def exr_available() -> bool:
    """Whether the ``openexr`` package can be imported (OpenEXR output; PNG and .npy need nothing)."""
    try:
        import OpenEXR  # noqa: F401
    except ImportError:
        return False
    return True


def _openexr():
    try:
        import OpenEXR
    except ImportError:
        from .. import _core

        raise _core.ParameterError(f"writing {EXR_HINT}") from None
    return OpenEXR


def _npy_writer(array):
    def write(tmp):
        with open(tmp, "xb") as f:
            np.save(f, array)

    return write


def _atomic(path, write):
    """``write(tmp)`` fills a temporary file that replaces ``path`` whole (:func:`subsurf.atomic.write_with`)."""
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    return atomic.write_with(path, write, force=True)


def _exr_writer(array, metadata=None):
    OpenEXR = _openexr()

    rgb = np.ascontiguousarray(np.asarray(array, dtype=np.float32))
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    header.update({k: str(v) for k, v in (metadata or {}).items()})

    def write(tmp):
        with OpenEXR.File(header, {"RGB": rgb}) as f:
            f.write(tmp)

    return write


def write_exr(path, array, metadata=None):
    """Linear float32 RGB OpenEXR with string ``metadata`` in the header (openexr ≥ 3.3 API)."""
    return _atomic(path, _exr_writer(array, metadata))


def read_exr(path):
    """(array (h, w, 3) float32, header dict) of an EXR written by :func:`write_exr`."""
    OpenEXR = _openexr()

    with OpenEXR.File(path) as f:
        ch = f.channels()
        rgb = ch["RGB"].pixels if "RGB" in ch else np.stack([ch[c].pixels for c in "RGB"], axis=-1)
        return np.array(rgb), dict(f.header())


def white_point(array) -> float:
    """The luminance :func:`tonemap` maps to white: the 99.5th percentile of the image's."""
    a = np.nan_to_num(np.asarray(array, dtype=np.float64), nan=0.0, posinf=0.0)
    lum = a @ np.array([0.2126, 0.7152, 0.0722])
    return float(np.percentile(lum, 99.5)) if lum.size else 1.0


def tonemap(array, exposure=0.0, white=None):
    """Linear radiance → 8-bit sRGB: scale by 2^exposure / ``white`` (default
    :func:`white_point` of the image; give one to show several images on the same scale), clip
    to [0, 1], sRGB transfer curve."""
    a = np.nan_to_num(np.asarray(array, dtype=np.float64), nan=0.0, posinf=0.0)
    ref = white_point(a) if white is None else float(white)
    x = a * (2.0**exposure) / (ref if ref > 0 else 1.0)
    x = np.clip(x, 0, 1)
    srgb = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)
    return (np.clip(srgb, 0, 1) * 255 + 0.5).astype(np.uint8)


def _png_writer(array, exposure=0.0):
    import matplotlib.image as mpimg

    return lambda tmp: mpimg.imsave(tmp, tonemap(array, exposure), format="png")


def write_png(path, array, exposure=0.0):
    return _atomic(path, _png_writer(array, exposure))
