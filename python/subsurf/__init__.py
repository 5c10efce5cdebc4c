"""subsurf — light scattering beneath the surface of translucent, layered materials.

Units are mm and mm⁻¹ throughout. See README.md for an overview.

The public names below are loaded on first use (PEP 562 ``__getattr__``): ``import subsurf`` is
instant, and the ``subsurf`` command can install its Ctrl-C handling before numpy and the extension
load (a Ctrl-C then ends it with one line, never a traceback). Every name resolves to the object its
module defines, so ``subsurf.Layer is subsurf.medium.Layer``.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

#: Public name → the submodule that defines it.
_EXPORTS = {
    "ParameterError": "_core",
    "__version__": "_core",
    "Component": "medium",
    "Layer": "medium",
    "Stack": "medium",
    "mix": "medium",
    "Material": "materials",
    "DiffuseIllumination": "mc",
    "PencilBeam": "mc",
    "simulate": "mc",
    "simulate_range": "mc",
    "TallyState": "state",
    "SweepResult": "sweeps",
    "sweep": "sweeps",
    "Histogram": "result",
    "Result": "result",
    "Tallies": "tallies",
    "load": "io",
    "merge": "io",
    "save": "io",
}
#: Submodules reachable as attributes (``subsurf.diffusion``) without importing them first.
_SUBMODULES = (
    *("bssrdf", "diffusion", "hk", "materials", "optics", "testing", "io", "plot", "mcml", "config", "state"),
    *("render", "sweeps", "cluster"),
)

__all__ = sorted(set(_EXPORTS) | {"bssrdf", "diffusion", "hk", "materials", "optics", "testing"})


def __getattr__(name: str) -> Any:
    if name in _EXPORTS:
        value = getattr(importlib.import_module(f".{_EXPORTS[name]}", __name__), name)
    elif name in _SUBMODULES:
        value = importlib.import_module(f".{name}", __name__)
    else:
        raise AttributeError(f"module 'subsurf' has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_EXPORTS) | set(_SUBMODULES))


if TYPE_CHECKING:  # for type checkers and IDEs: the same names, imported eagerly
    from . import bssrdf, diffusion, hk, materials, optics, testing  # noqa: F401
    from ._core import ParameterError, __version__  # noqa: F401
    from .io import load, merge, save  # noqa: F401
    from .materials import Material  # noqa: F401
    from .mc import DiffuseIllumination, PencilBeam, simulate, simulate_range  # noqa: F401
    from .medium import Component, Layer, Stack, mix  # noqa: F401
    from .result import Histogram, Result  # noqa: F401
    from .state import TallyState  # noqa: F401
    from .sweeps import SweepResult, sweep  # noqa: F401
    from .tallies import Tallies  # noqa: F401
