"""The scripts that regenerate the docs' figures and numbers (``make figures``, slow) stay runnable:
every script in docs/scripts imports, and ``figures.py --quick`` runs the whole pipeline with tiny
photon counts into a temporary directory (never over the committed figures)."""

import importlib.util
import pathlib
import sys

import numpy as np
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


def test_validation_matrix_errors_are_against_the_truth(monkeypatch):
    """The validation matrix's efficiency uses each image's error against the truth: a biased,
    noisy image against the mean of two noisy references recovers its known MSE within 4σ, and
    one reference's variance is what was put in (the raw error against the reference is far
    above both)."""
    monkeypatch.syspath_prepend(str(SCRIPTS))
    import adaptive_validation as v

    rng = np.random.default_rng(5)
    truth = np.ones((64, 64, 3))
    refs = tuple(truth + rng.normal(0, 0.1, truth.shape) for _ in range(2))
    img = truth + 0.05 + rng.normal(0, 0.02, truth.shape)
    mk = np.ones((64, 64), bool)
    (m, e), (var, e_var) = v.truth_mse(img, refs, mk), v.reference_variance(refs, mk)
    assert abs(m - (0.05**2 + 0.02**2)) < 4 * e and abs(var - 0.01) < 4 * e_var
    assert np.mean((img - 0.5 * (refs[0] + refs[1])) ** 2) > 2 * m


def test_validation_matrix_averages_the_model_over_its_seeds(monkeypatch):
    """A BSSRDF row is the mean over its seeds' images: images whose object means are off by
    +1 % and +3 % give +2 % with σ of the mean 1 % (the spread / √2), and their mean MSE."""
    monkeypatch.syspath_prepend(str(SCRIPTS))
    import adaptive_validation as v

    ref, mk = np.ones((8, 8, 3)), np.ones((8, 8), bool)
    per_seed = [(v.stats(ref * (1 + b), ref, mk), s, [b * b, 0.0]) for b, s in ((0.01, 1.0), (0.03, 3.0))]
    r = v.seeds_row(per_seed)
    assert np.allclose(r["bias"], 0.02) and np.allclose(r["bias_sigma"], 0.01) and r["seeds"] == 2
    assert np.isclose(r["s"], 2.0) and np.isclose(r["mse"][0], (0.01**2 + 0.03**2) / 2)
    assert np.isclose(r["rmse"], 0.02)
