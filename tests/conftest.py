"""Shared fixtures of the Python test suite (no test module imports another).

* ``rng`` — the one seeded random generator of the suite: a numpy ``Generator`` seeded from
  ``SUBSURF_TEST_SEED`` (default 0) and the test's id, so every test is reproducible and tests do
  not share streams. Re-run with another ``SUBSURF_TEST_SEED`` to explore.
* ``make_result`` — hand-built, self-consistent :class:`subsurf.Result` objects (``synthetic.py``).
* ``sample_mci`` — the text of a two-run MCML input file.
* ``as_format_1`` — turn a saved results file into one of format version 1 (no checksums).
* ``profile_table`` — the suite's one Monte Carlo :class:`subsurf.bssrdf.ProfileTable` (built once).
* ``worker`` — a separate process running property-test cases (``fuzz_worker.py``), restarted
  after a case that crashes it or outlives its time limit.
* ``cli`` — run the ``subsurf`` command (``python -m subsurf``) in a subprocess; ``one_line_error``
  checks that it failed with exit status 2 and one line on stderr. ``cli_here`` runs it in this
  process (faster) and ``error_here`` checks its one-line error; ``run_here`` runs it in this process
  with ``cli``'s signature and result. Start a process only where the test needs one (signals, kills,
  resource limits, start-up, a crash that must not take pytest down): each costs an interpreter start.
* Markers: ``@pytest.mark.slow`` on a test that takes seconds (measured, ``--durations``); ``make
  test-fast`` leaves those out, so keep some fast test in every module.

Hypothesis settings profiles (``tests/test_properties.py``): ``ci`` (the default: short and
derandomised, for ``make test``) and ``campaign`` (long random exploration), chosen with
``SUBSURF_HYPOTHESIS_PROFILE``.
"""

from __future__ import annotations

import io
import os
import pickle
import select
import struct
import subprocess
import sys
import time
import zlib

import h5py
import numpy as np
import pytest
import synthetic
from hypothesis import HealthCheck, settings

settings.register_profile(
    "ci", max_examples=60, deadline=None, derandomize=True, database=None, suppress_health_check=[HealthCheck.too_slow]
)
settings.register_profile(
    "campaign",
    max_examples=int(os.environ.get("SUBSURF_CAMPAIGN_EXAMPLES", "20000")),
    deadline=None,
    database=None,
    suppress_health_check=[HealthCheck.too_slow],
    print_blob=True,
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


@pytest.fixture(scope="session")
def profile_table():
    """A small Monte Carlo profile table (g = 0, η = 1.3; albedos 0.7–0.99, 2·10⁴ photons each)
    reaching colours 0.2–0.6, built once for the whole suite."""
    from subsurf import bssrdf

    return bssrdf.ProfileTable.build(0.0, 1.3, albedos=[0.7, 0.8, 0.9, 0.95, 0.98, 0.99], photons=20_000)


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
def small_example(tmp_path_factory) -> str:
    """The shipped marble_sphere.toml at 40×30 pixels instead of 200×150 (the CLI paths, at a
    quarter of the cost; the hierarchical set-up does not depend on the image size)."""
    src = os.path.join(os.path.dirname(__file__), "..", "examples", "render", "marble_sphere.toml")
    with open(src) as f:
        text = f.read()
    assert "width = 200\nheight = 150\n" in text
    path = tmp_path_factory.mktemp("example") / "marble_sphere.toml"
    path.write_text(text.replace("width = 200\nheight = 150\n", "width = 40\nheight = 30\n"))
    return str(path)


@pytest.fixture(scope="session")
def sample_mci() -> str:
    """A two-run MCML input (outputs first.mco and second.mco), as MCML's template writes it."""
    return SAMPLE_MCI


def _as_format_1(path) -> None:
    """Rewrite a results file as plain HDF5 without the checksum manifest, format version 1."""
    with h5py.File(io.BytesIO(open(path, "rb").read()), "r") as src, h5py.File(path, "w") as dst:
        for k, v in src.attrs.items():
            dst.attrs[k] = v
        for name in src:
            src.copy(src[name], dst, name=name)
        dst.attrs["format_version"] = 1


@pytest.fixture(scope="session")
def as_format_1():
    """``as_format_1(path)``: make a saved results file look like one written before checksums."""
    return _as_format_1


def _cli(*args, cwd=None, timeout=120, env=None, hook=None, preexec_fn=None):
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
        preexec_fn=preexec_fn,
    )


@pytest.fixture(scope="session")
def cli():
    """``cli(*args, cwd=None, timeout=120, env=None, hook=None, preexec_fn=None) -> CompletedProcess`` of
    ``python -m subsurf``; ``hook`` sets ``SUBSURF_TEST_HOOK`` (see ``subsurf/_testhooks.py``)."""
    return _cli


@pytest.fixture
def cli_here(capsys):
    """``cli_here(*args) -> (status, stdout, stderr)``: ``subsurf ARGS`` run in this process."""
    from subsurf import cli as command

    def run(*args):
        status = command.main([str(a) for a in args])
        out = capsys.readouterr()
        return status, out.out, out.err

    return run


@pytest.fixture
def run_here(capsys, monkeypatch):
    """``run_here(*args, cwd=None, hook=None) -> CompletedProcess``: ``subsurf ARGS`` run in this process,
    in ``cwd``, with ``SUBSURF_TEST_HOOK`` = ``hook`` (see ``subsurf/_testhooks.py``)."""
    from subsurf import cli as command

    def run(*args, cwd=None, hook=None):
        argv = [str(a) for a in args]
        with monkeypatch.context() as m:
            m.delenv("SUBSURF_DEBUG", raising=False)
            m.delenv("SUBSURF_TEST_HOOK", raising=False)
            if hook:
                m.setenv("SUBSURF_TEST_HOOK", hook)
            if cwd is not None:
                m.chdir(cwd)
            try:
                status = command.main(argv)
            except SystemExit as e:  # argparse's usage errors; --version, --help
                status = e.code
        out = capsys.readouterr()
        return subprocess.CompletedProcess(["subsurf", *argv], status, out.out, out.err)

    return run


@pytest.fixture
def error_here(cli_here):
    """``error_here(*args, fragments=()) -> line``: ``subsurf ARGS`` (in this process) fails with exit
    status 2 and one line ``subsurf: error: …`` holding every fragment."""

    def run(*args, fragments=()):
        status, _, err = cli_here(*args)
        assert status == 2, err
        lines = err.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("subsurf: error: "), err
        for f in fragments:
            assert f in lines[0], (f, lines[0])
        return lines[0]

    return run


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


class CaseFailed(Exception):
    """A property-test case crashed its process (a panic, a segfault) or outlived its time limit."""


class Worker:
    """Runs jobs of ``fuzz_worker.py`` in a child process with a time limit per job."""

    SCRIPT = os.path.join(os.path.dirname(__file__), "fuzz_worker.py")

    def __init__(self):
        self.proc = None

    def _start(self):
        self.proc = subprocess.Popen(
            [sys.executable, self.SCRIPT], stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL
        )

    def stop(self):
        if self.proc is not None:
            self.proc.kill()
            self.proc.wait()
            self.proc = None

    def _read(self, n, deadline):
        buf = b""
        while len(buf) < n:
            left = deadline - time.monotonic()
            if left <= 0 or not select.select([self.proc.stdout], [], [], left)[0]:
                self.stop()
                raise CaseFailed("timed out: the case hangs (or is far too slow)")
            chunk = os.read(self.proc.stdout.fileno(), n - len(buf))
            if not chunk:
                code = self.proc.wait()
                self.proc = None
                raise CaseFailed(f"the process died (exit status {code}): a crash, not an error")
            buf += chunk
        return buf

    def __call__(self, job, payload, timeout=30.0):
        """Run one job; returns its reply, or ``("failed", why)`` when it crashed or hung."""
        try:
            return self._call(job, payload, timeout)
        except CaseFailed as e:
            return ("failed", str(e))

    def _call(self, job, payload, timeout):
        if self.proc is None:
            self._start()
            timeout += 30.0  # the first job also starts the process (numpy, h5py, the extension)
        data = pickle.dumps((job, payload))
        self.proc.stdin.write(struct.pack("<Q", len(data)) + data)
        self.proc.stdin.flush()
        deadline = time.monotonic() + timeout
        n = struct.unpack("<Q", self._read(8, deadline))[0]
        return pickle.loads(self._read(n, deadline))


@pytest.fixture(scope="session")
def worker():
    """``worker(job, payload, timeout=30) -> reply`` (see ``tests/fuzz_worker.py``); a case that crashes
    the worker or outlives ``timeout`` seconds replies ``("failed", why)``."""
    w = Worker()
    yield w
    w.stop()


@pytest.fixture(autouse=True, scope="session")
def _adaptive_cache(tmp_path_factory):
    """The adaptive model's table cache in a temporary directory: tests never write to ~/.cache."""
    old = os.environ.get("SUBSURF_CACHE")
    os.environ["SUBSURF_CACHE"] = str(tmp_path_factory.mktemp("subsurf_cache"))
    yield
    if old is None:
        os.environ.pop("SUBSURF_CACHE", None)
    else:
        os.environ["SUBSURF_CACHE"] = old
