"""Render translucent objects: the seed's eq. (1.10) on triangle meshes.

``render(scene, method="hierarchical", spp=16, seed=0, threads=None, progress=None)`` returns an
:class:`Image`; methods: ``hierarchical`` (Jensen & Buhler 2002, the fast default), ``probe``
(pbrt-v4's probe rays, unbiased) and ``random_walk`` (volumetric path tracing inside the closed
meshes, the ground truth). Scenes: :class:`Scene` with :class:`Object` (meshes via trimesh or
built-in shapes), :class:`Translucent`/:class:`Lambertian` materials (a :class:`MediumGrid` makes a
translucent medium heterogeneous for the random walk), lights, a constant
environment and a :class:`Camera`; or :func:`load_scene` from TOML. :func:`simulate_walk` runs the
random walk as a tissue-optics simulation. :mod:`subsurf.render.export` writes Mitsuba 3 and
pbrt-v4 materials.
"""

from __future__ import annotations

import time
import warnings

import numpy as np

from .. import _core
from .image import Image, read_exr, tonemap, write_exr, write_png
from .media import MediumGrid, Texture
from .scene import (
    LIGHTS,
    MODELS,
    Camera,
    DirectionalLight,
    Lambertian,
    Object,
    PointLight,
    RectLight,
    Scene,
    SphereLight,
    Translucent,
)
from .toml_scene import load_scene
from .walk import simulate_walk

#: The render methods (the core's ``render::Method``).
METHODS = tuple(_core.RENDER_METHODS)
#: Settings of the hierarchical method and their defaults (the core's ``HierarchicalParams``).
HIERARCHICAL_DEFAULTS = dict(_core.RENDER_HIERARCHICAL_DEFAULTS)


def render(
    scene,
    method="hierarchical",
    spp=16,
    seed=0,
    threads=None,
    progress=None,
    pass_spp=None,
    hierarchical=None,
    setup_progress=None,
):
    """Render ``scene`` with ``method`` at ``spp`` samples per pixel; progressive in passes of
    ``pass_spp`` (default: from 1 spp, doubling while a pass takes under 0.5 s, at most spp/16).
    ``progress(done, total)`` is called before the first pass (done = 0) and after each;
    ``setup_progress(stage, done, total)`` during the set-up: stage ``"profiles"`` (photons of
    ``monte_carlo`` profiles; ``random_walk`` builds none) and ``"irradiance"`` (the
    hierarchical method's irradiance samples), for the stages that have work. Ctrl-C
    (KeyboardInterrupt) ends the render after the current pass and returns the image so far with
    ``partial = True`` (during the set-up: an image of 0 spp). The same seed gives the same image
    for any ``threads``.
    ``hierarchical`` = dict(spacing=, epsilon=, env_samples=, light_samples=, samples_per_exitance=)
    tunes that method (``samples_per_exitance``, default 16: consecutive samples of a pixel that
    share one evaluation of the exitance, each applying its own direction, and rays after a bounce
    share it per cell of two sample spacings; 1 evaluates it for every sample and ray)."""
    if method not in METHODS:
        raise _core.ParameterError(f"method = {method!r} is not a render method: must be one of {list(METHODS)}")
    spp, _ = _core.render_check_settings(spp, seed)
    if scene.camera is None:
        raise _core.ParameterError("camera: the scene has no camera")
    hp = None
    if hierarchical:
        unknown = set(hierarchical) - set(HIERARCHICAL_DEFAULTS)
        if unknown:
            raise _core.ParameterError(
                f"hierarchical: unknown settings {sorted(unknown)} (allowed: {sorted(HIERARCHICAL_DEFAULTS)})"
            )
        hp = {**HIERARCHICAL_DEFAULTS, **hierarchical}
    t0 = time.monotonic()
    try:
        job = _core.RenderJob(scene._to_core(method), method, seed, threads, hp, setup_progress)
    except KeyboardInterrupt:
        shape = (scene.camera.height, scene.camera.width, 3)
        return Image(np.zeros(shape), 0, spp, method, seed, time.monotonic() - t0)
    for w in job.warnings:
        warnings.warn(w, RuntimeWarning, stacklevel=2)
    cap = int(pass_spp) if pass_spp else max(1, spp // 16)
    step = cap if pass_spp else 1  # passes grow from 1 spp while they take under half a second
    done = 0
    try:
        if progress is not None:
            progress(0, spp)  # the set-up is over: the passes start
        while done < spp:
            t1 = time.monotonic()
            done = job.render_pass(min(step, spp - done))
            if progress is not None:
                progress(done, spp)
            if time.monotonic() - t1 < 0.5:
                step = min(2 * step, cap)
    except KeyboardInterrupt:
        done = job.spp
    return Image(job.image(), job.spp, spp, method, seed, time.monotonic() - t0, job.dropped)


__all__ = [
    "HIERARCHICAL_DEFAULTS",
    "LIGHTS",
    "METHODS",
    "MODELS",
    "Camera",
    "DirectionalLight",
    "Image",
    "Lambertian",
    "MediumGrid",
    "Object",
    "PointLight",
    "RectLight",
    "Scene",
    "SphereLight",
    "Texture",
    "Translucent",
    "load_scene",
    "read_exr",
    "render",
    "simulate_walk",
    "tonemap",
    "write_exr",
    "write_png",
]
