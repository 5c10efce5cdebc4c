"""The rendering part of ``subsurf demo``: five translucent materials side by side — marble,
skin, whole milk, ketchup (Jensen et al. 2001's measurements) and a jade made from a colour —
each a sphere in front of a thin upright slab, lit from behind and above by an area light and
from the front by a weaker one. Rendered twice with the same camera and lights: with the
random walk (volumetric path tracing in the media, exact for every shape) and with opaque
Lambertian materials of the same colours. The thin slabs glow where light passes through them,
the spheres' rims light up and their shadows are coloured; the opaque twins show none of it.

Writes ``out_dir/render.png`` (both images side by side, labelled) and, with the ``openexr``
package, the translucent image in linear HDR as ``render.exr``.
"""

from __future__ import annotations

import os

from . import Camera, Lambertian, Object, RectLight, Scene, Translucent

#: (label, library name or None for the colour-made jade), left to right.
MATERIALS = (("marble", "marble"), ("skin", "skin1"), ("whole milk", "wholemilk"), ("ketchup", "ketchup"))
#: The jade: a surface colour (diffuse reflectance per channel) and mean free paths 1/σt (mm).
JADE_COLOUR, JADE_MFP = (0.30, 0.62, 0.38), (1.0, 1.0, 1.0)
SPACING = 24.0  # mm between the objects' centres
#: The integrator (chosen by measurement: docs/render.md, "The demo").
METHOD = "probe"
FULL = dict(width=480, height=180, spp=144)
QUICK = dict(width=96, height=36, spp=1)


def jade() -> Translucent:
    """The demo's jade: the one place it calls the colour → material inversion (reflectance per
    incident power, mean free path 1/σt)."""
    return Translucent.from_reflectance(JADE_COLOUR, JADE_MFP, eta=1.6, name="jade")


def materials() -> list[tuple[str, Translucent]]:
    """(label, material) of each object, left to right."""
    out = [(label, Translucent.library(name)) for label, name in MATERIALS]
    return [*out, ("jade (from a colour)", jade())]


def colour(m: Translucent) -> list[float]:
    """The colour of the material's opaque twin: its total diffuse reflectance per channel under
    its own (dipole) model — for the jade, the colour it was made from."""
    from ..bssrdf import Profile

    return [Profile.from_model(m.model, a, s, m.g, m.eta).total() for a, s in zip(m.sigma_a, m.sigma_s)]


def scene(opaque=False, width=FULL["width"], height=FULL["height"]) -> Scene:
    """The demo scene; ``opaque``: every translucent material replaced by a Lambertian one of its colour."""
    mats = materials()
    floor = Lambertian(0.25, name="floor")
    objects = [Object.plane(floor, size=(600, 600))]
    x0 = -SPACING * (len(mats) - 1) / 2
    for i, (label, m) in enumerate(mats):
        mat = Lambertian(colour(m), name=f"{m.name}_opaque") if opaque else m
        x = x0 + i * SPACING
        objects.append(Object.sphere(mat, center=(x - 2, -6, 6), radius=6, subdivisions=4, name=f"{label} sphere"))
        disc = dict(scale=(9, 1.2, 9), translate=(x + 2, 6, 13))  # a lens 2.4 mm thick at its centre
        objects.append(Object.sphere(mat, radius=1, subdivisions=4, name=f"{label} disc", **disc))
    lights = [
        RectLight((0, 40, 55), (70, 0, 0), (0, -6, 10), 5e5),  # behind, above: faces the camera and down
        RectLight((-50, -80, 60), (-20, 0, 0), (0, 10, 10), 2.5e4),  # front left, weaker
    ]
    cam = Camera((0, -150, 36), look_at=(0, 0, 10), fov=16.5, width=width, height=height)
    return Scene(objects, lights, (0.015, 0.017, 0.022), cam)


def check_exr() -> bool:
    """Whether ``render.exr`` can be written; if not, one line on stderr says how (call it before
    any long work, so that a missing package never fails a finished run)."""
    import sys

    from .image import EXR_HINT, exr_available

    if exr_available():
        return True
    sys.stderr.write(f"subsurf: note: {EXR_HINT}; the demo writes render.png only\n")
    return False


def run(out_dir="out", threads=None, quiet=False, quick=False, exr=None):
    """Render the scene translucent and opaque; write ``out_dir/render.png`` (both, labelled, on
    one exposure) and, when ``exr`` (default: :func:`check_exr`), ``render.exr`` (the translucent
    image, linear). ``quick``: a tiny image at 1 spp, to check the pipeline. Returns the
    translucent :class:`Image` (``spp`` 0 when Ctrl-C came before its first pass)."""
    from .cli import render_with_bars
    from .image import write_exr

    exr = check_exr() if exr is None else exr
    size = QUICK if quick else FULL
    w, h, spp = size["width"], size["height"], size["spp"]
    imgs = {}
    for key, label in (("translucent", "render translucent"), ("opaque", "render opaque")):
        img = render_with_bars(scene(key == "opaque", w, h), METHOD, spp, 1, threads, quiet, label=label)
        imgs[key] = img
        if img.spp == 0 or img.partial:
            break
    img = imgs["translucent"]
    if img.spp == 0:
        print("render: interrupted before the first pass finished; nothing written")
        return img
    paths = [_figure(imgs, os.path.join(out_dir, "render.png"))]
    if exr:
        paths.insert(0, write_exr(os.path.join(out_dir, "render.exr"), img.array, img.metadata()))
    secs = sum(i.elapsed_s for i in imgs.values())
    tag = " (partial: interrupted)" if any(i.partial for i in imgs.values()) or len(imgs) < 2 else ""
    print(f"wrote {', '.join(paths)} ({METHOD}, {img.spp} spp, {secs:.1f} s){tag}")
    if tag:
        img.partial = True
    return img


def _figure(imgs, path):
    """Both images one above the other on the translucent one's exposure, with titles."""
    from matplotlib.figure import Figure

    from ..plot import save_figure
    from .image import tonemap, white_point

    t = imgs["translucent"]
    white = white_point(t.array)
    labels = ", ".join(label for label, _ in materials())
    h, w = t.array.shape[:2]
    fig = Figure(figsize=(w / 60, 2 * h / 60 + 0.9), dpi=100, layout="constrained")
    rows = [("translucent", f"translucent ({METHOD}, {t.spp} spp)")]
    rows.append(("opaque", "the same colours as opaque Lambertian surfaces"))
    for k, (key, title) in enumerate(rows):
        ax = fig.add_subplot(2, 1, k + 1)
        if key in imgs:
            ax.imshow(tonemap(imgs[key].array, white=white), interpolation="bilinear")
        ax.set_title(title, fontsize=9)
        ax.set_axis_off()
    fig.suptitle(f"subsurf demo, left to right: {labels}; lit from behind", fontsize=9)
    return save_figure(fig, path, dpi=100)
