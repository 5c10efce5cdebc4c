"""The rendering part of ``subsurf demo``: examples/render/marble_sphere.toml's scene (a marble sphere
under a rectangular area light and a constant environment), written to ``out/render.png``."""

from __future__ import annotations

import os

from . import Camera, DirectionalLight, Lambertian, Object, RectLight, Scene, Translucent, render  # noqa: F401


def marble_scene(width=320, height=240):
    marble = Translucent.library("marble", model="dipole")
    return Scene(
        [
            Object.sphere(marble, center=(0, 0, 10), radius=10, subdivisions=4),
            Object.plane(Lambertian(0.5), size=(200, 200)),
        ],
        [RectLight((-25, -25, 60), (8, 0, 0), (0, -5, 5), 3e4)],
        (0.03, 0.035, 0.045),
        Camera((0, -70, 28), look_at=(0, 0, 8), fov=28, width=width, height=height),
    )


def run(out_dir="out", spp=8, threads=None, quiet=False, quick=False):
    """Render the marble scene to ``out_dir/render.exr`` and ``render.png`` (``quick``: 80×60, 1 spp,
    for a fast check of the pipeline)."""
    from ..progress import ProgressBar

    bar = ProgressBar(label="render marble", quiet=quiet)
    scene = marble_scene(80, 60) if quick else marble_scene()
    try:
        img = render(scene, "hierarchical", spp=1 if quick else spp, seed=1, threads=threads, progress=bar)
    finally:
        bar.close()
    paths = img.save(os.path.join(out_dir, "render.exr"))
    print(f"wrote {', '.join(paths)} (hierarchical, {img.spp} spp, {img.elapsed_s:.1f} s)")
    return img
