"""The random walk as a simulation for tissue optics (no camera): a pencil beam or a uniform
collimated illumination on the closed meshes of a scene, scoring the exitance per triangle and
the absorption on a voxel grid. Same physics as ``render(method="random_walk")`` and the Monte
Carlo engine (HG, Fresnel on the triangle normal, implicit capture, Russian roulette)."""

from __future__ import annotations

import numpy as np

from .. import _core


def simulate_walk(
    scene,
    photons=100_000,
    seed=0,
    source="pencil",
    origin=None,
    direction=(0, 0, -1),
    channel=0,
    voxels=None,
    threads=None,
):
    """Trace ``photons`` packets of one colour ``channel`` (0, 1, 2) of the translucent materials
    (a material's :class:`~subsurf.render.MediumGrid` gives voxel media, MCX-style, sampled by delta
    tracking; a colour map, :class:`~subsurf.render.Texture`, the medium of each packet's entry texel).

    ``source``: ``"pencil"`` from ``origin`` along ``direction``, or ``"collimated"`` (uniform over
    the scene along ``direction``). ``voxels`` = (lo, hi, (nx, ny, nz)) in mm scores absorption.
    Returns a dict: ``exitance`` (total fraction) and ``exitance_stderr``,
    ``exitance_per_triangle`` (one array per object, fraction per triangle), ``specular``,
    ``absorbed`` (physical deposits + ``roulette``, as :func:`subsurf.simulate` counts them),
    ``roulette`` (the zero-mean control term of Russian roulette, booked apart as the engine
    does), ``lost``, ``voxels`` (physical absorbed fraction per voxel, never negative, shape
    (nx, ny, nz), or None), ``photons``. specular + exitance + absorbed + lost = 1 to rounding."""
    if source not in ("pencil", "collimated"):
        raise _core.ParameterError(f"source = {source!r}: must be 'pencil' or 'collimated'")
    if source == "pencil" and origin is None:
        raise _core.ParameterError("origin: a pencil beam needs an origin (mm, outside the objects)")
    o = [float(x) for x in (origin if origin is not None else (0, 0, 0))]
    d = [float(x) for x in direction]
    vox = None
    if voxels is not None:
        lo, hi, n = voxels
        vox = ([float(x) for x in lo], [float(x) for x in hi], list(n))  # counts: the core checks them
    out = _core.render_walk_simulate(
        scene._to_core("random_walk"), (source, o, d), photons, seed, channel, vox, threads
    )
    out["voxels"] = np.asarray(out["voxels"]).reshape(vox[2]) if vox else None
    return out
