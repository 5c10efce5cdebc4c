"""subsurf.container: the one checksummed HDF5 container of results, profile tables and sweeps.

Regression: a ProfileTable or sweep file with one flipped byte crashed the HDF5 library
(exit 139) because its checksum was checked only after HDF5 had parsed it. Every kind of file now
verifies its SHA-256 manifest before HDF5 reads a byte; damage is refused in one line. The loads
of damaged files run in a child process, so that a regression shows as a crash of that process,
not of the test session."""

from __future__ import annotations

import json
import subprocess
import sys

import h5py
import numpy as np
import pytest
import subsurf
from subsurf import bssrdf, container, sweeps

#: The offsets of the reported reproducers, and the same offsets past the 4096-byte user block
#: (inside the HDF5 structure and data that the manifest covers).
OFFSETS = [849, 1209, 1393, 1705, 1985, 7161, 7769]
OFFSETS += [4096 + k for k in OFFSETS]

_LOAD_ALL = """
import json, sys, warnings
import subsurf
from subsurf import bssrdf, sweeps
kind, paths = sys.argv[1], sys.argv[2:]
load = {"table": bssrdf.ProfileTable.load, "sweep": sweeps.load, "result": subsurf.load}[kind]
for p in paths:
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            load(p)
        print(json.dumps([p, "loaded", ""]), flush=True)
    except subsurf.container.FileFormatError as e:
        print(json.dumps([p, "refused", str(e)]), flush=True)
"""


def _damaged(tmp_path, data: bytes, name: str) -> list:
    paths = []
    for k in OFFSETS:
        if k >= len(data):
            continue
        d = bytearray(data)
        d[k] ^= 0x5A
        p = tmp_path / f"{name}-{k}.h5"
        p.write_bytes(bytes(d))
        paths.append(str(p))
    return paths


def _load_in_child(kind: str, paths: list) -> dict:
    p = subprocess.run(
        [sys.executable, "-c", _LOAD_ALL, kind, *paths], capture_output=True, text=True, timeout=120, check=False
    )
    assert p.returncode == 0 and "Traceback" not in p.stderr, (p.returncode, p.stderr[-2000:])
    return {q: (how, msg) for q, how, msg in map(json.loads, p.stdout.splitlines())}


@pytest.fixture(scope="module")
def table_bytes(profile_table, tmp_path_factory):
    p = tmp_path_factory.mktemp("table") / "t.h5"
    profile_table.save(p)
    return p.read_bytes()


class Square:
    def fingerprint(self):
        return {"kind": "square"}

    def __call__(self, x):
        return {"y": x * x, "v": np.array([x, 2 * x])}


@pytest.fixture(scope="module")
def sweep_bytes(tmp_path_factory):
    p = tmp_path_factory.mktemp("sweep") / "s.h5"
    subsurf.sweep(Square(), {"x": [1.0, 2.0, 3.0]}, p)
    return p.read_bytes()


@pytest.mark.parametrize("kind", ["table", "sweep"])
def test_damaged_tables_and_sweeps_are_refused_in_one_line(kind, table_bytes, sweep_bytes, tmp_path):
    data = table_bytes if kind == "table" else sweep_bytes
    assert data.startswith(f"subsurf-{'profile-table' if kind == 'table' else 'sweep'} manifest 1 ".encode())
    paths = _damaged(tmp_path, data, kind)
    assert len(paths) >= 10
    out = _load_in_child(kind, paths)
    assert sorted(out) == sorted(paths)  # every file answered: none crashed the process
    for p, (how, msg) in out.items():
        assert how == "refused", (p, how)
        assert msg.startswith(p + ": ") and "\n" not in msg and ("checksum" in msg or "check" in msg), msg


def test_fit_with_a_damaged_table_is_one_line(table_bytes, tmp_path, cli, one_line_error):
    bad = bytearray(table_bytes)
    bad[4096 + 849] ^= 0x5A
    (tmp_path / "bad.h5").write_bytes(bytes(bad))
    (tmp_path / "m.csv").write_text("r,rd,sigma\n1,0.01,0.001\n2,0.003,0.0003\n")
    p = cli("fit", tmp_path / "m.csv", "--model", "monte_carlo", "--table", tmp_path / "bad.h5")
    one_line_error(p, "bad.h5: ", "checksum")


def test_tables_and_sweeps_round_trip_and_name_foreign_files(table_bytes, sweep_bytes, profile_table, tmp_path):
    (tmp_path / "t.h5").write_bytes(table_bytes)
    (tmp_path / "s.h5").write_bytes(sweep_bytes)
    t = bssrdf.ProfileTable.load(tmp_path / "t.h5")
    assert t.settings == profile_table.settings
    s = sweeps.load(tmp_path / "s.h5")
    assert s.complete and s["y"].tolist() == [1.0, 4.0, 9.0] and s["v"].shape == (3, 2)
    with pytest.raises(container.FileFormatError, match=r"s.h5: a subsurf-sweep file, not a profile table file"):
        bssrdf.ProfileTable.load(tmp_path / "s.h5")
    with pytest.raises(container.FileFormatError, match=r"t.h5: a subsurf-profile-table file, not a sweep file"):
        sweeps.load(tmp_path / "t.h5")
    with pytest.raises(subsurf.io.ResultFileError, match=r"t.h5: a subsurf-profile-table file, not a results file"):
        subsurf.load(tmp_path / "t.h5")
    assert isinstance(container.FileFormatError("x"), subsurf.ParameterError)


def test_format_1_tables_and_sweeps_are_refused_with_their_version(tmp_path):
    """Plain HDF5 (format 1: a checksum read after HDF5 had parsed the file) is not parsed at all."""
    for name, load, advice in (
        ("t.h5", bssrdf.ProfileTable.load, "rebuild it"),
        ("s.h5", sweeps.load, "run the sweep again"),
    ):
        with h5py.File(tmp_path / name, "w") as f:
            f.attrs["format_version"] = 1
        with pytest.raises(container.FileFormatError, match=f"format version 1, from before .* {advice}"):
            load(tmp_path / name)


def test_a_newer_version_is_refused(tmp_path):
    data = container.to_bytes("subsurf-sweep", 9, lambda f: None)
    (tmp_path / "s.h5").write_bytes(data)
    with pytest.raises(container.FileFormatError, match="sweep format version 9 is newer than this subsurf reads"):
        sweeps.load(tmp_path / "s.h5")


def test_results_equal_is_the_one_bit_comparison(make_result, tmp_path):
    """``results_equal`` compares every number bit for bit; ``provenance=False`` ignores only the
    elapsed time, version and configuration."""
    res, _ = make_result(seed=4)
    back = subsurf.load(subsurf.save(res, tmp_path / "r.h5"))
    assert subsurf.io.results_equal(res, back)
    back.elapsed_s += 1.0
    back.config = {**back.config, "note": 1}
    assert not subsurf.io.results_equal(res, back)
    assert subsurf.io.results_equal(res, back, provenance=False)
    h = back.histograms["rd_r"]
    h.measures[0][0] = np.nextafter(h.measures[0][0], 1.0)  # one ulp of one bin measure
    assert not subsurf.io.results_equal(res, back, provenance=False)
