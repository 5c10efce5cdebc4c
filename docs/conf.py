"""Sphinx configuration of subsurf's site (`make docs`; docs/building.md says why Sphinx and how).

Needs the compiled extension: run ``make build`` first (``make docs`` does). Environment:
``SUBSURF_DOCS_GALLERY`` — a regular expression of the gallery scripts to run, for the quick
check of ``make docs-check`` (then the gallery is built into ``gallery-check/``, leaving the full
gallery's images alone, and the chosen scripts run every time); unset: every script runs
(sphinx-gallery skips those unchanged since the last build).
"""

import os
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "_ext"))

import subsurf  # noqa: E402  (the installed package, with its compiled core)

project = "subsurf"
author = "the subsurf developers"
copyright = "the subsurf developers, MIT licence"
release = version = subsurf.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "myst_parser",
    "sphinx_gallery.gen_gallery",
    "subsurf_docs",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
_quick = os.environ.get("SUBSURF_DOCS_GALLERY")
_gallery_dir = "gallery-check" if _quick else "gallery"
exclude_patterns = [
    "_build",
    "_ext",
    "scripts",
    "gallery" if _quick else "gallery-check",
    "**/sg_execution_times.rst",
    "sg_execution_times.rst",
]

# autodoc reads the installed package; the names of the package root load lazily (PEP 562), and
# the API pages (written by _ext/subsurf_docs.py) name each one explicitly.
autodoc_member_order = "bysource"
autodoc_typehints = "description"
autodoc_typehints_description_target = "documented"
autodoc_default_options = {"members": True, "undoc-members": True}
napoleon_google_docstring = False
napoleon_numpy_docstring = True
napoleon_use_ivar = True  # "Attributes" as a field list: dataclass fields are documented once
napoleon_use_rtype = False

myst_heading_anchors = 3

sphinx_gallery_conf = {
    "examples_dirs": "../examples/gallery",
    "gallery_dirs": _gallery_dir,
    "filename_pattern": _quick or r"/plot_",
    "download_all_examples": False,
    "remove_config_comments": True,
    "within_subsection_order": "FileNameSortKey",
    "image_scrapers": ("matplotlib",),
    "matplotlib_animations": False,
    "write_computation_times": False,
    "show_memory": False,
    "plot_gallery": "True",
    "abort_on_example_error": True,
    "run_stale_examples": bool(_quick),  # the check runs its script every time, changed or not
}

html_theme = "furo"
html_title = f"subsurf {release}"
html_static_path: list = []
html_show_sourcelink = False
