#!/usr/bin/env python3
"""Regenerate the figures and numbers of README.md and docs/ (``make figures``; slow: tens of
minutes on 2 cores, so not part of ``make test``, which runs this script with ``--quick``):

- ``docs/diffusion_vs_mc.png`` and its tables fragment (``compare_diffusion_mc.py``);
- ``docs/profiles_total.png``, ``docs/profiles_shape.png``, ``docs/profiles_tables.md``
  (``compare_profiles.py``);
- the README's validation table (``validation_table.py``);
- ``docs/render.png``: the image of the rendering demo (``subsurf.render.demo``, the scene that
  ``subsurf demo`` renders to ``out/render.png``), copied from a run of the demo's own code.

Not regenerated here: ``docs/render_reference_*.png`` (``render_reference.py``, an hour per
material; run it by hand) and the README's speed table (``make bench``, machine-dependent).

Usage: python docs/scripts/figures.py [--quick] [--out DIR]
(``--quick``: tiny photon counts and the demo's quick image, written to ``--out`` — default a
temporary directory — never over the committed figures.)
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
DOCS = os.path.dirname(HERE)
sys.path.insert(0, HERE)

import compare_diffusion_mc  # noqa: E402
import compare_profiles  # noqa: E402
import validation_table  # noqa: E402


def render_demo_png(out: str, quick: bool) -> str:
    """The demo's image (its own scene and settings), copied to ``out/render.png``."""
    from subsurf.render.demo import run

    with tempfile.TemporaryDirectory() as tmp:
        img = run(tmp, quiet=True, quick=quick)
        if img.partial:
            raise SystemExit("the demo render was interrupted: docs/render.png left as it was")
        dest = os.path.join(out, "render.png")
        shutil.copyfile(os.path.join(tmp, "render.png"), dest)
    return dest


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="tiny runs into --out (checks the pipeline)")
    ap.add_argument(
        "--out", default=None, help="directory for the figures (default: docs/, or a temp dir with --quick)"
    )
    args = ap.parse_args(argv)
    out = args.out or (tempfile.mkdtemp(prefix="subsurf-figures-") if args.quick else DOCS)
    os.makedirs(out, exist_ok=True)
    mc = ["--photons", "300"] if args.quick else []
    compare_diffusion_mc.main([*mc, "--out", out])
    compare_profiles.main([*mc, *(["--quick"] if args.quick else []), "--out", out])
    validation_table.main(["--quick"] if args.quick else ["--readme"])
    print(f"wrote {render_demo_png(out, args.quick)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
