"""subsurf — light scattering beneath the surface of translucent, layered materials.

Units are mm and mm⁻¹ throughout. See README.md for an overview.
"""

from __future__ import annotations

from . import _core, bssrdf, diffusion, hk, materials, optics, testing
from ._core import ParameterError
from .materials import Material
from .mc import DiffuseIllumination, PencilBeam, simulate
from .medium import Component, Layer, Stack, mix
from .result import Histogram, Result
from .tallies import Tallies

__version__ = _core.__version__

__all__ = [
    "Component",
    "DiffuseIllumination",
    "Histogram",
    "Layer",
    "Material",
    "ParameterError",
    "PencilBeam",
    "Result",
    "Stack",
    "Tallies",
    "__version__",
    "bssrdf",
    "diffusion",
    "hk",
    "materials",
    "mix",
    "optics",
    "simulate",
    "testing",
]

# Results files (subsurf.io): save / load / merge.
from .io import load, merge, save  # noqa: E402

__all__ += ["load", "merge", "save"]
