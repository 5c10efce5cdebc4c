"""subsurf — light scattering beneath the surface of translucent, layered materials.

Units are mm and mm⁻¹ throughout. See README.md for an overview.
"""
from __future__ import annotations

from . import _core
from ._core import ParameterError
from .medium import Component, Layer, Stack, mix
from .mc import DiffuseIllumination, PencilBeam, simulate
from .tallies import Tallies
from .result import Histogram, Result
from . import diffusion, materials
from .materials import Material
from . import hk, optics, testing

__version__ = _core.__version__

__all__ = [
    "Component", "DiffuseIllumination", "Histogram", "Layer", "Material", "ParameterError", "PencilBeam",
    "Result", "Stack", "Tallies", "__version__", "diffusion", "hk", "materials", "mix", "optics", "simulate",
    "testing",
]

# Results files (subsurf.io): save / load / merge.
from .io import load, merge, save  # noqa: E402

__all__ += ["load", "merge", "save"]
