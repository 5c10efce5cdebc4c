"""``subsurf render SCENE.toml -o IMAGE.exr``: the renderer's command (:mod:`subsurf.render.cli`)."""

from __future__ import annotations


def add_parser(sub) -> None:
    from ..render.cli import add_parser as add_render_parser
    from ..runner import EXIT_INTERRUPTED

    add_render_parser(sub, EXIT_INTERRUPTED)
