"""subsurf — light scattering beneath the surface of translucent, layered materials.

Units are mm and mm⁻¹ throughout. See README.md for an overview.
"""

from __future__ import annotations

from . import _core, bssrdf, diffusion, hk, materials, optics, testing
from ._core import ParameterError
from .materials import Material
from .mc import DiffuseIllumination, PencilBeam, simulate, simulate_range
from .medium import Component, Layer, Stack, mix
from .result import Histogram, Result
from .state import TallyState
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
    "TallyState",
    "__version__",
    "bssrdf",
    "diffusion",
    "hk",
    "materials",
    "mix",
    "optics",
    "simulate",
    "simulate_range",
    "testing",
]

# Results files (subsurf.io): save / load / merge.
from .io import load, merge, save  # noqa: E402

__all__ += ["load", "merge", "save"]
