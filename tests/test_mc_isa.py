"""The lane kernel's instruction-set paths from Python: SUBSURF_ISA forces one (read at each run), every
path this machine runs gives the same bits, and a path it cannot run, or an unknown name, is refused with a
ParameterError naming the variable and the paths it can run."""

import numpy as np
import pytest
from subsurf import Layer, ParameterError, Stack, Tallies, _core, simulate

STACK = Stack([Layer(1.4, 0.5, 10.0, 0.9, 0.3), Layer(1.37, 0.1, 20.0, 0.8, 2.0)], 1.0, 1.52)


def run_bits(monkeypatch, isa):
    monkeypatch.setenv("SUBSURF_ISA", isa)
    assert _core.mc_isa() == isa
    r = simulate(STACK, photons=3000, seed=5, threads=1, tallies=Tallies(nr=20, dr=0.05, nz=20, dz=0.05, na=6))
    totals = [r.diffuse_reflectance, r.transmittance, r.absorbed, r.roulette, r.diffuse_reflectance_stderr]
    hists = [np.ravel(h.values) for h in r.histograms.values()] + [np.ravel(h.stderr) for h in r.histograms.values()]
    return np.concatenate([np.array(totals, dtype=float)] + hists).view(np.uint64), r.events


def test_every_path_gives_the_same_bits(monkeypatch):
    paths = _core.mc_isas()
    assert paths[-1] == "scalar" and len(paths) == len(set(paths))
    ref, events = run_bits(monkeypatch, paths[0])
    for isa in paths[1:]:
        bits, ev = run_bits(monkeypatch, isa)
        assert ev == events, isa
        np.testing.assert_array_equal(bits, ref, err_msg=isa)


def test_baseline_is_an_alias_and_empty_means_best(monkeypatch):
    monkeypatch.setenv("SUBSURF_ISA", "Baseline")
    assert _core.mc_isa() == "scalar"
    monkeypatch.setenv("SUBSURF_ISA", "")
    assert _core.mc_isa() == _core.mc_isas()[0]


@pytest.mark.parametrize("name", ["avx1024", "neon" if _core.mc_isas()[0] != "neon" else "avx512"])
def test_unknown_or_unsupported_path_is_refused(monkeypatch, name):
    monkeypatch.setenv("SUBSURF_ISA", name)
    here = ", ".join(_core.mc_isas())
    with pytest.raises(ParameterError, match=f'^SUBSURF_ISA: "{name}".*{here}'):
        _core.mc_isa()
    with pytest.raises(ParameterError, match="^SUBSURF_ISA"):
        simulate(STACK, photons=10, seed=1)
