"""Monte Carlo tallies: the `subsurf.Tallies` configuration and (with the engine) the
histograms' normalisation identities, reciprocity, thread invariance and single scattering."""
from __future__ import annotations

import math

import pytest

import subsurf
from subsurf import ParameterError, Tallies


def test_defaults_match_architecture():
    t = Tallies()
    assert (t.nr, t.dr, t.nz, t.dz, t.na, t.nt, t.dt) == (100, 0.01, 100, 0.01, 30, 0, 1.0)
    assert t.brdf is None and t.max_order is None and t.spatial and t.angular


def test_round_trip_plain_values():
    t = Tallies(nr=5, dr=0.1, nz=7, dz=0.2, na=9, nt=4, dt=2.5, brdf=(8, 3), max_order=4, spatial=False)
    d = t.to_dict()
    assert d["brdf"] == [8, 3] and d["max_order"] == 4 and d["spatial"] is False
    assert all(isinstance(v, (int, float, bool, list, type(None))) for v in d.values())
    assert Tallies.from_dict(d) == t
    assert Tallies.from_dict({}) == Tallies()
    import json

    assert Tallies.from_dict(json.loads(json.dumps(d))) == t


@pytest.mark.parametrize(
    "kw, field",
    [
        ({"nr": 0}, "tallies.nr"),
        ({"nr": 2.0}, "tallies.nr"),
        ({"nr": True}, "tallies.nr"),
        ({"dr": 0.0}, "tallies.dr"),
        ({"dr": math.nan}, "tallies.dr"),
        ({"dz": -1}, "tallies.dz"),
        ({"dz": "x"}, "tallies.dz"),
        ({"na": 0}, "tallies.na"),
        ({"nt": -1}, "tallies.nt"),
        ({"dt": math.inf}, "tallies.dt"),
        ({"brdf": (0, 4)}, "tallies.brdf[0]"),
        ({"brdf": (4, 0)}, "tallies.brdf[1]"),
        ({"brdf": 5}, "tallies.brdf"),
        ({"max_order": -1}, "tallies.max_order"),
        ({"max_order": 1.5}, "tallies.max_order"),
        ({"spatial": 1}, "tallies.spatial"),
        ({"nr": 10_000, "nz": 10_000}, "a_rz"),
    ],
)
def test_validation_names_the_field(kw, field):
    with pytest.raises(ParameterError, match=field.replace("[", r"\[").replace("]", r"\]")):
        Tallies(**kw)
    assert issubclass(ParameterError, ValueError)


def test_from_dict_refuses_unknown_keys():
    with pytest.raises(ParameterError, match="unknown"):
        Tallies.from_dict({"nrr": 3})


def test_numpy_integers_accepted():
    np = pytest.importorskip("numpy")
    t = Tallies(nr=np.int64(3), brdf=(np.int32(2), 5), max_order=np.int64(2))
    assert t.nr == 3 and type(t.nr) is int and t.brdf == (2, 5) and t.max_order == 2


def test_exported():
    assert subsurf.Tallies is Tallies
