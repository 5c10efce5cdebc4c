"""``subsurf render SCENE.toml -o IMAGE.exr [--method NAME] [--spp N]``: registered by
:func:`add_parser` from ``subsurf.cli.build_parser``."""

from __future__ import annotations

import os


def add_parser(sub, exit_interrupted=130):
    r = sub.add_parser("render", help="render a scene (TOML) to an OpenEXR + PNG image")
    r.add_argument("scene", metavar="SCENE.toml")
    r.add_argument(
        "-o", "--output", metavar="IMAGE.exr", help="image file (.exr, .png or .npy; default from the scene)"
    )
    r.add_argument("--method", choices=["hierarchical", "probe", "random_walk"], help="override the scene's method")
    r.add_argument("--spp", type=int, help="samples per pixel")
    r.add_argument("--seed", type=int)
    r.add_argument("--threads", type=int)
    r.add_argument("-q", "--quiet", action="store_true")
    r.set_defaults(func=lambda a: cmd_render(a, exit_interrupted))
    return r


def cmd_render(a, exit_interrupted=130) -> int:
    from .. import _testhooks
    from ..progress import ProgressBar
    from . import load_scene, render

    scene, st = load_scene(a.scene)
    method = a.method or st["method"]
    spp = a.spp if a.spp is not None else st["spp"]
    seed = a.seed if a.seed is not None else st["seed"]
    out = a.output or st["output"] or os.path.splitext(os.path.basename(a.scene))[0] + ".exr"
    if not a.output and st["output"] and not os.path.isabs(out):
        out = os.path.join(os.path.dirname(a.scene), out)
    bar = ProgressBar(label=f"render {method}", quiet=a.quiet)
    bar.line = _spp_line(bar)
    try:
        img = render(
            scene, method=method, spp=spp, seed=seed, threads=a.threads, progress=_testhooks.wrap_progress(bar)
        )
    finally:
        bar.close()
    if img.spp == 0:
        import sys

        sys.stderr.write("subsurf: interrupted before the first pass finished; nothing written\n")
        return exit_interrupted
    paths = img.save(out)
    tag = f" (partial: {img.spp} of {img.spp_requested} spp, interrupted)" if img.partial else ""
    print(f"wrote {', '.join(paths)}: {method}, {img.spp} spp, {img.elapsed_s:.1f} s{tag}")
    return exit_interrupted if img.partial else 0


def _spp_line(bar):
    base = bar.line

    def line(done, total, now=None):
        return base(done, total, now).replace("photons/s", "spp/s")

    return line
