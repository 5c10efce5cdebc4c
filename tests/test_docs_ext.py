"""The docstring normaliser of the documentation build (docs/_ext/subsurf_docs.py); `make docs-check`
runs the whole build."""

import importlib.util
from pathlib import Path

_SPEC = importlib.util.spec_from_file_location(
    "subsurf_docs", Path(__file__).resolve().parent.parent / "docs" / "_ext" / "subsurf_docs.py"
)
sd = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(sd)


def test_parameters_become_numpydoc_fields_and_the_prose_after_them_stays_prose():
    doc = [
        "A layer.",
        "",
        "Parameters",
        "----------",
        "n : refractive index (≥ 1).",
        "nr, dr : bins and width,",
        "    in mm.",
        "",
        "The specular part is scored.",
    ]
    assert sd.normalise_docstring(doc) == [
        "A layer.",
        "",
        "Parameters",
        "----------",
        "n",
        "    refractive index (≥ 1).",
        "nr, dr",
        "    bins and width,",
        "    in mm.",
        "",
        "",
        "",
        "The specular part is scored.",
    ]


def test_free_text_returns_and_unknown_sections():
    doc = ["Returns", "-------", ":class:`Result` with totals", "and errors.", "", "Notes", "-----", "text"]
    assert sd.normalise_docstring(doc) == [
        ":returns: :class:`Result` with totals",
        "    and errors.",
        "",
        "Notes",
        "-----",
        "text",
    ]
    assert sd.normalise_docstring(["Conventions", "-----------", "- a"]) == [".. rubric:: Conventions", "", "- a"]


def test_absolute_value_bars_are_escaped_outside_literals():
    assert sd.escape_bars("HG g (|g| < 1), ``a|b``") == "HG g (\\|g\\| < 1), ``a|b``"


def test_the_api_reference_must_cover_root_names_modules_and_module_constants():
    names = sd.public_names()
    assert {"subsurf.Layer", "subsurf.simulate", "subsurf.ParameterError", "subsurf.render"} <= names
    assert {"subsurf.sweeps.FORMAT", "subsurf.render.Translucent", "subsurf.render.export.to_mitsuba"} <= names
    assert "subsurf.io.load" not in names  # documented as subsurf.load
