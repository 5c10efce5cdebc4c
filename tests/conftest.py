"""Shared fixtures of the Python test suite (no test module imports another).

* ``rng`` — the one seeded random generator of the suite: a numpy ``Generator`` seeded from
  ``SUBSURF_TEST_SEED`` (default 0) and the test's id, so every test is reproducible and tests do
  not share streams. Re-run with another ``SUBSURF_TEST_SEED`` to explore.
* ``make_result`` — hand-built, self-consistent :class:`subsurf.Result` objects (``synthetic.py``).
* ``sample_mci`` — the text of a two-run MCML input file.
* ``as_format_1`` — turn a saved results file into one of format version 1 (no checksums).
* ``cli`` — run the ``subsurf`` command (``python -m subsurf``) in a subprocess; ``one_line_error``
  checks that it failed with exit status 2 and one line on stderr.

Hypothesis settings profiles (``tests/test_properties.py``): ``ci`` (the default: short and
derandomised, for ``make test``) and ``campaign`` (long random exploration), chosen with
``SUBSURF_HYPOTHESIS_PROFILE``.
"""

from __future__ import annotations

import os
import subprocess
import sys
import zlib

import h5py
import numpy as np
import pytest
import synthetic
from hypothesis import HealthCheck, settings

settings.register_profile(
    "ci", max_examples=60, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow]
)
settings.register_profile(
    "campaign", max_examples=20_000, deadline=None, suppress_health_check=[HealthCheck.too_slow], print_blob=True
)
settings.load_profile(os.environ.get("SUBSURF_HYPOTHESIS_PROFILE", "ci"))

SEED = int(os.environ.get("SUBSURF_TEST_SEED", "0"))


@pytest.fixture
def rng(request) -> np.random.Generator:
    """The suite's seeded generator, one independent stream per test."""
    return np.random.default_rng([SEED, zlib.crc32(request.node.nodeid.encode())])


@pytest.fixture(scope="session")
def make_result():
    """``make_result(seed=1, photons=10_000, nr=20, …) -> (Result, raw bin weights)``."""
    return synthetic.make_result


SAMPLE_MCI = """\
####
# Template of input files for Monte Carlo simulation (mcml).
# Anything in a line after "#" is ignored as comments.
####

1.0                      # file version
2                        # number of runs

#### SPECIFY DATA FOR RUN 1
#InParm                  # Input parameters. cm is used.
first.mco    A           # output file name, ASCII.
1000                     # No. of photons
0.0025  0.005            # dz, dr [cm]
15      20      6        # No. of dz, dr, da.

2                        # Number of layers
#n      mua     mus     g       d       # One line for each layer
1.0                      # n for medium above
1.37    1       100     0.9     0.1     # layer 1
1.37    0.5     150     0.8     0.2     # layer 2
1.0                      # n for medium below

#### SPECIFY DATA FOR RUN 2
second.mco A
500
0.01 0.01
10 10 5
1
1.0
1.4 10 90 0.75 0.02
1.0
"""


@pytest.fixture(scope="session")
def sample_mci() -> str:
    """A two-run MCML input (outputs first.mco and second.mco), as MCML's template writes it."""
    return SAMPLE_MCI


def _as_format_1(path) -> None:
    with h5py.File(path, "r+") as f:
        objs = [f]
        f.visititems(lambda name, obj: objs.append(obj))
        for obj in objs:
            del obj.attrs["sha256"]
        f.attrs["format_version"] = 1
        del f.attrs["histograms"]


@pytest.fixture(scope="session")
def as_format_1():
    """``as_format_1(path)``: make a saved results file look like one written before checksums."""
    return _as_format_1


def _cli(*args, cwd=None, timeout=120, env=None, hook=None):
    e = dict(os.environ, PYTHONUNBUFFERED="1", **(env or {}))
    e.pop("SUBSURF_DEBUG", None)
    e.pop("SUBSURF_TEST_HOOK", None)
    if hook:
        e["SUBSURF_TEST_HOOK"] = hook
    return subprocess.run(
        [sys.executable, "-m", "subsurf", *map(str, args)],
        capture_output=True,
        text=True,
        cwd=cwd,
        timeout=timeout,
        env=e,
    )


@pytest.fixture(scope="session")
def cli():
    """``cli(*args, cwd=None, timeout=120, env=None, hook=None) -> CompletedProcess`` of ``python -m subsurf``;
    ``hook`` sets ``SUBSURF_TEST_HOOK`` (see ``subsurf/_testhooks.py``)."""
    return _cli


def _one_line_error(p, *fragments, status=2):
    assert p.returncode == status, (p.returncode, p.stdout, p.stderr)
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1, p.stderr
    assert "Traceback" not in p.stderr
    for f in fragments:
        assert f in lines[0], (f, lines[0])
    return lines[0]


@pytest.fixture(scope="session")
def one_line_error():
    """``one_line_error(completed_process, *fragments, status=2)``: the command failed with ``status`` and
    one line on stderr containing every fragment; returns the line."""
    return _one_line_error
