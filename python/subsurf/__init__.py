"""subsurf — light scattering beneath the surface of translucent, layered materials.

Units are mm and mm⁻¹ throughout. See README.md for an overview.
"""
from __future__ import annotations

from . import _core
from ._core import ParameterError
from .medium import Component, Layer, Stack, mix

__version__ = _core.__version__

__all__ = ["Component", "Layer", "ParameterError", "Stack", "mix", "__version__"]

# Results files (subsurf.io): save / load / merge.
from .io import load, merge, save  # noqa: E402

__all__ += ["load", "merge", "save"]

from . import diffusion, materials  # noqa: E402  (diffusion models and the material library)
from .materials import Material  # noqa: E402

__all__ += ["Material", "diffusion", "materials"]
