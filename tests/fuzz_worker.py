"""Runs the cases of ``tests/test_properties.py`` in a process of its own (started by the ``worker``
fixture of ``conftest.py``), so that a case that crashes or hangs is seen as exactly that — the fixture
kills and restarts this process — instead of taking the test session down.

Protocol: length-prefixed pickles, ``(job, payload)`` on stdin, one reply each on stdout. Jobs:

* ``("simulate", dict)`` — build Layers/Stack/source/Tallies from plain values and simulate;
* ``("estimate", dict)`` — the core's estimate of scattering events per photon for that stack;
* ``("cli", (argv, files))`` — write ``files`` ({name: bytes}) to a fresh directory, run
  ``subsurf.cli.main(argv)`` there, and report status, stdout, stderr and the files it wrote;
* ``("load", (original, damaged))`` — load two results files given as bytes and compare them.

Replies: ``("ok", summary)``, ``("parameter", message)`` for a ``subsurf.ParameterError`` (a
``ValueError`` of subsurf's), ``("cli", …)``, or ``("exception", type, message, traceback)`` for
anything else.
"""

from __future__ import annotations

import contextlib
import io
import math
import os
import pickle
import struct
import sys
import tempfile
import traceback
import warnings

import numpy as np

#: Histograms whose errors are batch means over 256-photon batches (docs/architecture.md).
BATCH_MEANS = ("a_z", "a_rz", "fluence_z", "fluence_rz")


def errors_may_be_nan(name: str, photons: int, errors: bool) -> bool:
    """The documented cases of NaN histogram errors: ``Tallies(errors=False)``, batch means of
    N ≤ 256 photons, per-photon errors of N = 1."""
    return not errors or photons <= (256 if name in BATCH_MEANS else 1)


def summary(res) -> dict:
    """What the properties check about a result."""
    totals = [getattr(res, n) for n in ("specular_reflectance", "diffuse_reflectance", "transmittance", "absorbed")]
    errs = [getattr(res, n + "_stderr") for n in ("specular_reflectance", "diffuse_reflectance", "transmittance")]
    tallies = res.config.get("tallies") or {}
    hist_nan = sorted(
        k
        for k, h in res.histograms.items()
        if not (k.startswith("fluence") or np.isfinite(h.values).all())  # fluence: NaN where μa = 0
        or not (errors_may_be_nan(k, res.photons, tallies.get("errors", True)) or np.isfinite(h.stderr).all())
    )
    return {
        "totals": totals,
        "balance": res.energy_balance,
        "nan": [x for x in totals + errs + list(res.absorbed_per_layer) if not math.isfinite(x)],
        "negative_stderr": [x for x in errs if x < 0],
        "hist_nan": hist_nan,
        "photons": res.photons,
        "partial": res.partial,
        "histograms": {k: np.shape(h.values) for k, h in res.histograms.items()},
    }


def stack_of(p: dict):
    import subsurf

    layers = [subsurf.Layer(*l[:5], phase=l[5]) for l in p["layers"]]
    return subsurf.Stack(layers, n_above=p["n_above"], n_below=p["n_below"])


def estimate(p: dict):
    """The core's estimate of scattering events per photon (its refusal of endless histories)."""
    from subsurf import _core

    return ("ok", _core.mc_expected_events(*stack_of(p)._to_core()))


def simulate(p: dict):
    import subsurf

    stack = stack_of(p)
    src = p["source"]
    source = subsurf.DiffuseIllumination() if src is None else subsurf.PencilBeam(*src)
    tallies = None if p["tallies"] is None else subsurf.Tallies(**p["tallies"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = subsurf.simulate(stack, photons=p["photons"], seed=p["seed"], threads=1, source=source, tallies=tallies)
    return ("ok", summary(res))


def output_summary(path: str):
    import subsurf
    from subsurf import mcml

    if path.endswith(".h5"):
        return summary(subsurf.load(path))
    if path.endswith(".mco"):
        q = mcml.read_mco(path)
        numbers = [np.asarray(v, float) for k, v in q.items() if k not in ("out_fname", "layers")]
        finite = all(np.isfinite(a).all() for a in numbers)
        return {"balance": q["Rsp"] + q["Rd"] + q["A"] + q["Tt"], "photons": q["photons"], "finite": finite}
    return os.path.getsize(path)


def cli(payload):
    from subsurf import cli as command

    argv, files = payload
    with tempfile.TemporaryDirectory() as d:
        for name, data in files.items():
            with open(os.path.join(d, name), "wb") as f:
                f.write(data)
        before = set(os.listdir(d))
        out, err = io.StringIO(), io.StringIO()
        cwd = os.getcwd()
        os.chdir(d)
        try:
            with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err), warnings.catch_warnings():
                warnings.simplefilter("ignore", ResourceWarning)
                try:
                    status = command.main(argv)
                except SystemExit as e:  # argparse: --help or a usage error
                    status = e.code
            written = {n: output_summary(os.path.join(d, n)) for n in sorted(set(os.listdir(d)) - before)}
        finally:
            os.chdir(cwd)
    return ("cli", status, out.getvalue(), err.getvalue(), written)


def load(payload):
    import subsurf
    from subsurf import io as rio

    original, damaged = payload
    with tempfile.TemporaryDirectory() as d:
        a, b = os.path.join(d, "a.h5"), os.path.join(d, "b.h5")
        for path, data in ((a, original), (b, damaged)):
            with open(path, "wb") as f:
                f.write(data)
        ref = subsurf.load(a)
        try:
            back = subsurf.load(b)
        except rio.ResultFileError as e:
            return ("file", str(e))
        return ("ok", {"equal": rio.results_equal(ref, back)})


JOBS = {"estimate": estimate, "simulate": simulate, "cli": cli, "load": load}


def main() -> None:
    proto_in, proto_out = sys.stdin.buffer, sys.stdout.buffer
    sys.stdout = sys.stderr  # stray prints must not corrupt the protocol
    import subsurf

    while True:
        head = proto_in.read(8)
        if len(head) < 8:
            return
        job, payload = pickle.loads(proto_in.read(struct.unpack("<Q", head)[0]))
        try:
            reply = JOBS[job](payload)
        except subsurf.ParameterError as e:
            reply = ("parameter", str(e))
        except Exception as e:  # reported to the test, which decides
            reply = ("exception", type(e).__name__, str(e), traceback.format_exc())
        data = pickle.dumps(reply)
        proto_out.write(struct.pack("<Q", len(data)) + data)
        proto_out.flush()


if __name__ == "__main__":
    main()
