"""One list per concept, owned by the core: every Python-side list (models, render methods, light
types and their parameters, tally fields, the hierarchical and Monte Carlo profile defaults, argparse
choices, configuration and scene keys) is compared here with the list ``_core`` exports, so that a
name added on one side only fails this test."""

from __future__ import annotations

import dataclasses
import inspect

import subsurf.bssrdf as bssrdf
import subsurf.config as config
import subsurf.render as render
import subsurf.render.scene as scene
import subsurf.tallies as tallies
from subsurf import _core
from subsurf.cli import build_parser


def _choices(command: str, option: str):
    sub = next(a for a in build_parser()._actions if a.dest == "command").choices[command]
    return next(a for a in sub._actions if option in a.option_strings).choices


def test_models():
    assert list(_core.BSSRDF_MODELS) == list(_core.bssrdf_models())
    assert list(bssrdf.MODELS) == list(_core.BSSRDF_MODELS)
    assert list(scene.MODELS) == list(_core.BSSRDF_MODELS)
    assert list(render.MODELS) == list(_core.BSSRDF_MODELS)


def test_methods():
    assert list(render.METHODS) == list(_core.RENDER_METHODS)
    assert list(_choices("render", "--method")) == list(_core.RENDER_METHODS)


def test_lights():
    kinds = {k: tuple(v) for k, v in _core.RENDER_LIGHTS.items()}
    assert scene.LIGHT_PARAMS == kinds
    classes = {cls.kind: cls for cls in render.LIGHTS}
    assert list(classes) == list(kinds), "one light class per core light type, in the core's order"
    for kind, cls in classes.items():
        params = tuple(inspect.signature(cls).parameters)
        assert params == kinds[kind], (cls.__name__, params, kinds[kind])


def test_tally_fields():
    fields = [(n, d) for n, _, d in _core.MC_TALLY_FIELDS]
    assert [(f.name, f.default) for f in dataclasses.fields(tallies.Tallies)] == fields
    assert tallies.KINDS == {n: k for n, k, _ in _core.MC_TALLY_FIELDS}
    assert config.TALLY_KEYS == tallies.KINDS
    # the core reads every field back (a field it did not know would be refused)
    assert tallies.Tallies.from_dict(tallies.Tallies().to_dict()) == tallies.Tallies()


def test_hierarchical_defaults():
    assert render.HIERARCHICAL_DEFAULTS == dict(_core.RENDER_HIERARCHICAL_DEFAULTS)


def test_monte_carlo_profile_defaults():
    mc = _core.BSSRDF_MC_DEFAULTS
    sig = inspect.signature(bssrdf.Profile.from_monte_carlo).parameters
    for name in ("photons", "seed", "per_decade", "max_rel_err", "r_min", "r_max"):
        assert sig[name].default == mc[name], name
    t = inspect.signature(scene.Translucent).parameters
    assert (t["mc_photons"].default, t["mc_seed"].default) == (mc["photons"], mc["seed"])


def test_every_tally_field_is_a_config_key(tmp_path):
    """``[tallies]`` takes every field of ``subsurf.Tallies`` (``errors = false`` was refused)."""
    p = tmp_path / "c.toml"
    p.write_text(
        "photons = 1000\n[[layers]]\nn = 1.4\nmua = 0.1\nmus = 10\nthickness = 1\n"
        "[tallies]\nerrors = false\nnr = 7\nmax_order = 3\nbrdf = [2, 3]\nspatial = true\n"
    )
    cfg = config.load_config(str(p))
    assert cfg.tallies == tallies.Tallies(errors=False, nr=7, max_order=3, brdf=(2, 3))
