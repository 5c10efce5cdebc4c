"""The scripts that regenerate the docs' figures and numbers (``make figures``, slow) stay runnable:
every script in docs/scripts imports, and ``figures.py --quick`` runs the whole pipeline with tiny
photon counts into a temporary directory (never over the committed figures)."""

import importlib.util
import pathlib
import sys

import pytest

SCRIPTS = pathlib.Path(__file__).resolve().parent.parent / "docs" / "scripts"


@pytest.mark.parametrize("path", sorted(SCRIPTS.glob("*.py")), ids=lambda p: p.name)
def test_script_imports(path, monkeypatch):
    monkeypatch.syspath_prepend(str(SCRIPTS))
    spec = importlib.util.spec_from_file_location(f"docs_script_{path.stem}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert callable(getattr(module, "main", None)), f"{path.name} has no main()"


@pytest.mark.slow
def test_figures_quick(tmp_path, monkeypatch, capsys):
    monkeypatch.syspath_prepend(str(SCRIPTS))
    readme = (SCRIPTS.parent.parent / "README.md").read_bytes()
    import figures

    assert figures.main(["--quick", "--out", str(tmp_path)]) == 0
    names = {"diffusion_vs_mc.png", "profiles_total.png", "profiles_shape.png", "profiles_tables.md", "render.png"}
    assert names <= {p.name for p in tmp_path.iterdir()}
    assert all((tmp_path / n).stat().st_size > 0 for n in names)
    out = capsys.readouterr().out
    assert "| van de Hulst slab" in out and "| order-1 Rd" in out
    assert (SCRIPTS.parent.parent / "README.md").read_bytes() == readme  # --quick never writes the README
    for name in ("figures", "compare_diffusion_mc", "compare_profiles", "validation_table"):
        sys.modules.pop(name, None)


def test_validation_table_replaces_only_the_table(tmp_path, monkeypatch):
    monkeypatch.syspath_prepend(str(SCRIPTS))
    import validation_table as v

    readme = tmp_path / "README.md"
    head = "# x\n\n## Validation (all in the test suite)\n\n| check | reference | result |\n|---|---|---|\n"
    readme.write_text(head + "| a | b | c |\n\nafter\n")
    v.write_readme(v.HEADER + "| new | row | here |\n", readme)
    assert readme.read_text() == head + "| new | row | here |\n\nafter\n"
