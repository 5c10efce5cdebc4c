"""TOML run configurations: parsing, defaults, and one-line errors naming file, line and key."""

import math

import pytest
import subsurf
from subsurf.config import ConfigError, load_config, parse_config

GOOD = """\
description = "two layers"
photons = 5000
seed = 7
threads = 2
n_above = 1.0
n_below = 1.33

[[layers]]
name = "top"
n = 1.4
mua = 0.1
mus = 10.0
g = 0.9
thickness = 0.5

[[layers]]
n = 1.4
mua = 0.02
mus = 12.0
g = 0.8
thickness = "inf"

[source]
type = "pencil"
theta_deg = 30.0
phi_deg = 0.0

[tallies]
nr = 50
dr = 0.02
na = 10
brdf = [4, 8]
max_order = 3
"""


def test_good_config(tmp_path):
    p = tmp_path / "c.toml"
    p.write_text(GOOD)
    c = load_config(p)
    assert (c.photons, c.seed, c.threads) == (5000, 7, 2)
    assert len(c.stack) == 2 and c.stack.n_below == 1.33
    assert c.stack[0].thickness == 0.5 and c.stack[1].thickness == math.inf
    assert c.stack[0].mua == 0.1 and c.stack[1].g == pytest.approx(0.8)
    assert c.data["source"] == {"type": "pencil", "theta_deg": 30.0, "phi_deg": 0.0}
    assert c.data["tallies"]["brdf"] == (4, 8) and c.data["tallies"]["max_order"] == 3
    assert c.tallies == subsurf.Tallies(nr=50, dr=0.02, na=10, brdf=(4, 8), max_order=3)
    assert c.source == subsurf.PencilBeam(math.radians(30), 0.0)
    kw = c.simulate_kwargs()
    assert kw["photons"] == 5000 and kw["seed"] == 7


def test_defaults():
    c = parse_config("[[layers]]\nn = 1.0\nmua = 1\nmus = 9\n")
    assert c.photons == 100_000 and c.seed == 0 and c.threads is None
    assert c.stack[0].thickness == math.inf and c.stack[0].g == 0.0
    assert c.data["source"]["type"] == "pencil"
    d = parse_config('[[layers]]\nn = 1.0\nmua = 1\nmus = 9\n[source]\ntype = "diffuse"\n')
    assert d.data["source"] == {"type": "diffuse"} and d.source == subsurf.DiffuseIllumination()
    assert c.tallies == subsurf.Tallies() and c.source == subsurf.PencilBeam()


def _err(text, path="cfg.toml"):
    with pytest.raises(ConfigError) as e:
        parse_config(text, path)
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith(path)
    return msg


BASE = "[[layers]]\nn = 1.4\nmua = 0.1\nmus = 10\n"


@pytest.mark.parametrize(
    "text, expect",
    [
        ("photons = 10\nphoton = 3\n" + BASE, "cfg.toml:2: photon: unknown key"),
        ("photons = -5\n" + BASE, "cfg.toml:1: photons: -5 is out of range"),
        ("photons = 1.5\n" + BASE, "photons: expected an integer"),
        ('seed = "x"\n' + BASE, "cfg.toml:1: seed: expected an integer"),
        ("n_above = 0.5\n" + BASE, "cfg.toml:1: n_above: 0.5 is out of range: must be a finite number >= 1"),
        (BASE + "g = 1.5\n", "cfg.toml:5: layers[0].g: 1.5 is out of range"),
        (BASE + "mu_a = 1\n", "cfg.toml:5: layers[0].mu_a: unknown key"),
        (BASE + "thickness = -1\n", "cfg.toml:5: layers[0].thickness: -1.0 is out of range"),
        (BASE + 'thickness = "big"\n', 'layers[0].thickness: expected a number or "inf"'),
        (BASE + BASE.replace("mua = 0.1", "mua = -2"), "cfg.toml:7: layers[1].mua: -2.0 is out of range"),
        (BASE + BASE, "cfg.toml:1: layers[0].thickness: inf is out of range"),
        ("[[layers]]\nn = 1.4\nmus = 10\n", "layers[0].mua: missing"),
        ("photons = 3\n", "layers: missing"),
        (BASE + '[source]\ntype = "laser"\n', "cfg.toml:6: source.type: 'laser' is not a source type"),
        (BASE + "[source]\ntheta_deg = 90\n", "cfg.toml:6: source.theta_deg: 90 is out of range"),
        (BASE + '[source]\ntype = "diffuse"\ntheta_deg = 10\n', "source.theta_deg: only a pencil beam"),
        (BASE + "[tallies]\nnr = 0\n", "cfg.toml:6: tallies.nr: 0 is out of range"),
        (BASE + "[tallies]\ndr = -0.1\n", "cfg.toml:6: tallies.dr: -0.1 is out of range"),
        (BASE + "[tallies]\nbrdf = [3]\n", "tallies.brdf: expected [n_cos_theta, n_phi]"),
        (BASE + "[tallies]\nbins = 3\n", "cfg.toml:6: tallies.bins: unknown key"),
        (BASE + "[tallies]\nspatial = 1\n", "tallies.spatial: expected true or false"),
        ("photons = [\n", "cfg.toml:1: invalid TOML"),
        ("photons = 1\nphotons = 2\n" + BASE, "cfg.toml:2: invalid TOML"),
        ("photons = 18446744073709551616\n" + BASE, "cfg.toml:1: photons: 18446744073709551616 is out of range"),
        ("threads = 18446744073709551616\n" + BASE, "cfg.toml:1: threads: 18446744073709551616 is out of range"),
        ("photons = " + "[" * 20_000 + "]" * 20_000 + "\n", "cfg.toml: invalid TOML: arrays or tables nested too"),
        (BASE + "[source]\nphi_deg = inf\n", "cfg.toml:6: source.phi_deg: inf is out of range (in radians: source.phi"),
        (BASE + "[tallies]\nnr = 100000000000\n", "cfg.toml:6: tallies.nr: 100000000000 is out of range"),
        (BASE + "[tallies]\ndr = 1e400\n", "cfg.toml:6: tallies.dr: inf is out of range"),
    ],
)
def test_errors_are_one_clear_line(text, expect):
    assert expect in _err(text)


def test_file_errors(tmp_path):
    with pytest.raises(ConfigError, match="no such file"):
        load_config(tmp_path / "missing.toml")
    p = tmp_path / "bin.toml"
    p.write_bytes(b"\xff\xfe photons")
    with pytest.raises(ConfigError, match="not UTF-8"):
        load_config(p)
