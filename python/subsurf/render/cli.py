"""``subsurf render SCENE.toml -o IMAGE.exr [--method NAME] [--spp N] [--force]``: registered by
:func:`add_parser` from ``subsurf.cli.build_parser``.

File rules (as every command, :mod:`subsurf.atomic`): the image files (``IMAGE.exr`` and its
``IMAGE.png``, :func:`subsurf.render.image.output_paths`) are all checked before the render starts
— an existing one is replaced only with ``--force``, a directory or a missing folder is refused —
and written as one group, atomically. An interrupted render (Ctrl-C) keeps the passes completed
and writes them, marked partial, to names that replace nothing (``IMAGE.partial.exr`` … when
``IMAGE.exr`` or its PNG exists), never over a complete image; exit status 130.
"""

from __future__ import annotations

import os


def add_parser(sub, exit_interrupted=130):
    from .. import _core
    from ..commands import U64_MAX, integer

    r = sub.add_parser("render", help="render a scene (TOML) to an OpenEXR + PNG image")
    r.add_argument("scene", metavar="SCENE.toml")
    r.add_argument(
        "-o", "--output", metavar="IMAGE.exr", help="image file (.exr, .png or .npy; default from the scene)"
    )
    r.add_argument("--method", choices=list(_core.RENDER_METHODS), help="override the scene's method")
    r.add_argument("--spp", type=integer("--spp", 1, 2**32 - 1), help="samples per pixel")
    r.add_argument("--seed", type=integer("--seed", 0, U64_MAX))
    r.add_argument("--threads", type=integer("--threads", 1, _core.MC_MAX_THREADS))
    r.add_argument("--force", action="store_true", help="replace existing image files")
    r.add_argument("-q", "--quiet", action="store_true")
    r.set_defaults(func=lambda a: cmd_render(a, exit_interrupted))
    return r


def cmd_render(a, exit_interrupted=130) -> int:
    from .. import atomic
    from . import load_scene
    from .image import output_paths

    scene, st = load_scene(a.scene)
    method = a.method or st["method"]
    spp = a.spp if a.spp is not None else st["spp"]
    seed = a.seed if a.seed is not None else st["seed"]
    out = a.output or st["output"] or os.path.splitext(os.path.basename(a.scene))[0] + ".exr"
    if not a.output and st["output"] and not os.path.isabs(out):
        out = os.path.join(os.path.dirname(a.scene), out)
    out = output_without_openexr(out)
    paths = output_paths(out)
    for p in paths:  # before the render: a refusal costs nothing
        atomic.check_target(p, force=a.force, inputs=(a.scene,))
    img = render_with_bars(scene, method, spp, seed, a.threads, a.quiet)
    if img.spp == 0:
        import sys

        sys.stderr.write("subsurf: interrupted before the first pass finished; nothing written\n")
        return exit_interrupted
    force = a.force
    if img.partial:  # never over an existing file, least of all a complete image
        out, force = atomic.partial_paths(paths)[0], False
    with atomic.hold_sigint() as held:
        written = img.save(out, force=force)
    tag = f" (partial: {img.spp} of {img.spp_requested} spp, interrupted)" if img.partial else ""
    print(f"wrote {', '.join(written)}: {method}, {img.spp} spp, {img.elapsed_s:.1f} s{tag}")
    return exit_interrupted if (img.partial or held.received) else 0


def output_without_openexr(out: str) -> str:
    """``out``, or its .png when it is an .exr and the ``openexr`` package is missing (saying so in
    one line on stderr) — decided before the render, so a missing package never fails a finished one."""
    from .image import EXR_HINT, exr_available

    if os.path.splitext(out)[1].lower() != ".exr" or exr_available():
        return out
    import sys

    png = os.path.splitext(out)[0] + ".png"
    sys.stderr.write(f"subsurf: note: {EXR_HINT}; writing {png} only\n")
    return png


#: Progress-bar label and unit of each set-up stage of :func:`subsurf.render.render`.
SETUP_STAGES = {"profiles": ("Monte Carlo profiles", "photons"), "irradiance": ("irradiance samples", "samples")}


def render_with_bars(scene, method, spp, seed, threads=None, quiet=False, label="render"):
    """:func:`subsurf.render.render` under progress bars on stderr — one per set-up stage that
    lasts over a second, then the passes (spp) — with the test hooks of :mod:`subsurf._testhooks`
    (``interrupt_after`` stops the passes as Ctrl-C does, ``setup_interrupt_after`` the set-up).
    Returns the image."""
    from .. import _testhooks
    from ..progress import ProgressBar
    from . import render

    bars = []

    def bar(text, unit, hooks=""):
        while bars:
            bars.pop().close()
        b = ProgressBar(label=f"{label} {text}", quiet=quiet, unit=unit)
        bars.append(b)
        return _testhooks.wrap_progress(b, hooks)

    stages = {}

    def setup(stage, done, total):
        if stage not in stages:
            stages[stage] = bar(*SETUP_STAGES.get(stage, (stage, "items")), hooks="setup_")
        stages[stage](done, total)

    try:
        return render(
            scene,
            method=method,
            spp=spp,
            seed=seed,
            threads=threads,
            progress=_LazyBar(lambda: bar(method, "spp")),
            setup_progress=setup,
        )
    finally:
        while bars:
            bars.pop().close()


class _LazyBar:
    """A progress callable made on its first call (``render`` makes it when the set-up is over, so
    the passes' bar and rate start then)."""

    def __init__(self, make):
        self.make, self.fn = make, None

    def __call__(self, done, total):
        if self.fn is None:
            self.fn = self.make()
        self.fn(done, total)
