"""Property-based tests (hypothesis) of the Python API, the command line and the file readers.

Every case ends in a clean ``subsurf.ParameterError`` (the command line: one line on stderr and exit
status 2), or in a result whose energy balance holds to 1e-12 with no NaN; never a traceback, a crash
or a hang. Cases run in a separate process (the ``worker`` fixture), so a crash or a hang is reported
as a failing case with its time limit, not as a dead test session.

Profiles (``SUBSURF_HYPOTHESIS_PROFILE``): ``ci`` — the default, short and derandomised, over the
inputs the engine is expected to finish quickly; ``campaign`` — long and random, over every float
including subnormals, 1e308, infinities and NaN, grazing beams and tiny bins. With
``SUBSURF_FUZZ_RECORD=FILE`` failures are appended to FILE (JSON lines) instead of stopping the run,
so a campaign collects all of them.
"""

from __future__ import annotations

import json
import math
import os

import h5py
import pytest
from hypothesis import event, given, settings
from hypothesis import strategies as st

CAMPAIGN = os.environ.get("SUBSURF_HYPOTHESIS_PROFILE", "ci") == "campaign"
RECORD = os.environ.get("SUBSURF_FUZZ_RECORD")
TIME_LIMIT = 10.0 if CAMPAIGN else 30.0  # seconds a case may take (a few photons: milliseconds)
#: Runs the core expects to take more than ~3 s (1e8 events) are not run: they are long, not hung;
#: a run the estimate calls short that outlives TIME_LIMIT is a failure (a hang, or a wrong estimate).
LONG_EVENTS = 1e8


def check(ok: bool, what: str, case) -> None:
    """Assert, or in record mode append the failure to SUBSURF_FUZZ_RECORD and go on."""
    if ok:
        return
    if RECORD:
        with open(RECORD, "a") as f:
            f.write(json.dumps({"failure": what, "case": repr(case)[:4000]}) + "\n")
        return
    pytest.fail(f"{what}\ncase: {case!r}")


def run(worker, job, payload):
    """The worker's reply, or ("failed", why) for a crash or a hang; its kind is counted in the
    statistics (``pytest --hypothesis-show-statistics``)."""
    reply = worker(job, payload, timeout=TIME_LIMIT)
    event(f"{reply[0]}" + (f" (exit status {reply[1]})" if reply[0] == "cli" else ""))
    return reply


def check_result(s: dict, case, photons: int) -> None:
    check(s["nan"] == [] and s["hist_nan"] == [], f"NaN or inf in the result: {s['nan']} {s['hist_nan']}", case)
    check(abs(s["balance"] - 1.0) <= 1e-12, f"energy balance {s['balance']!r} is not 1 to 1e-12", case)
    check(s["negative_stderr"] == [], "a negative standard error", case)
    check(s["photons"] == photons and not s["partial"], f"{s['photons']} photons of {photons}", case)


# --- the Python API ----------------------------------------------------------------------------

WILD = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0.0, -0.0, 5e-324, 1e-320, 1e-310, 1e-200, 1e-12, 1e155, 1e300, 1e308, math.inf, math.nan]),
)
INVALID = st.sampled_from([-1.0, -1e-300, math.nan, -math.inf])
EXTREME = st.sampled_from([5e-324, 1e-310, 1e-200, 1e155, 1e308, math.inf])


def real(lo, hi, *special, hostile=True):
    """Floats in [lo, hi] and a few special values; ``hostile``: also extreme and invalid ones
    (campaign: any float)."""
    sane = st.one_of(st.floats(lo, hi), st.sampled_from(special or (lo, hi)))
    if not hostile:
        return sane
    base = st.one_of(sane, INVALID, EXTREME)
    return st.one_of(base, WILD) if CAMPAIGN else base


@st.composite
def layers(draw, last: bool, hostile: bool):
    n = draw(real(1.0, 2.5, 1.0, 1.33, 1.5, hostile=hostile))
    mua, mus = draw(real(0.0, 50.0, 0.0, 1e-3, hostile=hostile)), draw(real(0.0, 200.0, 0.0, 100.0, hostile=hostile))
    g = real(-0.99, 0.99, 0.0, 0.9, -0.5, hostile=hostile)
    g = draw(st.one_of(g, st.sampled_from([1.0, -1.0, 0.999999])) if hostile else g)
    d = real(1e-3, 20.0, 1e-9, 1.0, hostile=hostile)
    d = draw(st.one_of(d, st.just(math.inf)) if last else d)
    lobe = st.tuples(real(0.0, 1.0, 0.5, hostile=hostile), real(-0.95, 0.95, 0.0, hostile=hostile))
    phase = draw(st.none() | st.lists(lobe, min_size=0 if hostile else 1, max_size=3))
    valid = all(isinstance(x, float) and math.isfinite(x) and x >= 0 for x in (mua, mus, 1.0 if d == math.inf else d))
    if valid and not CAMPAIGN:  # tamed to histories that end quickly (the campaign explores the rest)
        sigma_t = mua + mus
        if d == math.inf and mua < 0.01 * sigma_t:
            mua = 0.011 * sigma_t
        elif d < math.inf and sigma_t * d > 60:
            d = 60 / sigma_t
    return (n, mua, mus, g, d, phase)


@st.composite
def tallies(draw, hostile: bool):
    if draw(st.booleans()):
        return None
    count = st.integers(1, 6) | st.sampled_from([0, -1, 10**30]) if hostile else st.integers(1, 6)
    width = real(1e-4, 5.0, 0.01, 1.0, hostile=hostile)
    if CAMPAIGN and hostile:
        width = st.one_of(width, st.just(1e-200))
    kw = {"nr": count, "dr": width, "nz": count, "dz": width, "na": count, "nt": st.integers(0, 3), "dt": width}
    out = {k: draw(v) for k, v in kw.items() if draw(st.booleans())}
    if draw(st.booleans()):
        brdf = st.tuples(st.integers(1, 4), st.integers(1, 5))
        out["brdf"] = draw(brdf | st.tuples(st.integers(0, 4), st.integers(0, 5)) | st.just(5) if hostile else brdf)
    if draw(st.booleans()):
        out["max_order"] = draw(st.integers(-1 if hostile else 0, 4))
    for k in ("spatial", "angular", "errors"):
        if draw(st.booleans()):
            out[k] = draw(st.booleans() | st.just(1) if hostile else st.booleans())
    return out


def sources(hostile: bool):
    top = math.pi / 2 if CAMPAIGN else 1.5
    theta = real(0.0, top, 0.0, 1.0, math.radians(89.9999999) if CAMPAIGN else 1.0, hostile=hostile)
    return st.none() | st.tuples(theta, real(-10.0, 10.0, 0.0, hostile=hostile))


@st.composite
def run_cases(draw):
    """Arguments of a run; a third of the cases are hostile (invalid, extreme or — in the campaign —
    any floats, counts and flags), the rest valid, so that both outcomes are explored."""
    hostile = draw(st.integers(0, 2)) == 0
    stack = draw(st.lists(layers(False, hostile), max_size=2)) + [draw(layers(True, hostile))]
    return dict(
        layers=stack,
        n_above=draw(real(1.0, 2.0, 1.0, hostile=hostile)),
        n_below=draw(real(1.0, 2.0, 1.0, hostile=hostile)),
        source=draw(sources(hostile)),
        tallies=draw(tallies(hostile)),
        photons=draw(st.integers(1, 40)),
        seed=draw(st.integers(0, 2**64 - 1)),
    )


@pytest.mark.slow
@given(case=run_cases())
def test_simulate_ends_in_a_result_or_a_parameter_error(worker, case):
    photons = case["photons"]
    cost = worker("estimate", case, timeout=TIME_LIMIT)
    if cost[0] == "ok" and cost[1] * photons > LONG_EVENTS:
        event("long by the core's estimate: not run")  # a long run, not a hang (Ctrl-C stops it)
        return
    reply = run(worker, "simulate", case)
    if reply[0] == "parameter":
        msg = reply[1]
        check("\n" not in msg and (" = " in msg or ": " in msg), f"unclear error {msg!r}", case)
        return
    check(reply[0] == "ok", f"not a result nor a ParameterError: {reply}", case)
    if reply[0] == "ok":
        check_result(reply[1], case, photons)


# --- the command line and its readers --------------------------------------------------------------


def toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return "nan" if math.isnan(v) else ("inf" if v == math.inf else "-inf" if v == -math.inf else repr(v))
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    return str(v)


def toml_text(doc: dict) -> str:
    """TOML for the configuration's shape: top-level values, [source], [tallies], [[layers]]."""
    lines = [f"{k} = {toml_value(v)}" for k, v in doc.items() if not isinstance(v, (dict, list)) or k == "junk"]
    for table in ("source", "tallies"):
        if isinstance(doc.get(table), dict):
            lines += [f"[{table}]"] + [f"{k} = {toml_value(v)}" for k, v in doc[table].items()]
    for layer in doc.get("layers", []):
        lines += ["[[layers]]"] + [f"{k} = {toml_value(v)}" for k, v in layer.items()]
    return "\n".join(lines) + "\n"


ANY_VALUE = st.one_of(
    st.integers(-(2**70), 2**70),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=8),
    st.booleans(),
    st.lists(st.integers(-3, 10**8), max_size=3),
)
NAMES = st.sampled_from(["r.h5", "c.toml", "", ".", "/", "missing/r.h5", "r.h5/x", "sub/../r.h5", "r.partial.h5"])


@st.composite
def config_docs(draw):
    """(TOML document as a dict, hostile): a third hostile (any values, missing keys, bad names)."""
    hostile = draw(st.integers(0, 2)) == 0

    def val(strategy):
        return draw(st.one_of(strategy, ANY_VALUE) if hostile and draw(st.integers(0, 4)) == 0 else strategy)

    doc = {}
    for key, strategy in (
        ("photons", st.integers(1, 10**6)),
        ("seed", st.integers(0, 2**64 - 1)),
        ("threads", st.just(1)),
        ("n_above", st.floats(1, 2)),
        ("n_below", st.floats(1, 2)),
        ("output", NAMES if hostile else st.sampled_from(["r.h5", "out.h5"])),
        ("description", st.text(max_size=10)),
    ):
        if draw(st.booleans()):
            doc[key] = val(strategy)
    layer_keys = {
        "n": real(1, 2, hostile=hostile),
        "mua": real(0, 5, hostile=hostile),
        "mus": real(0, 50, hostile=hostile),
        "g": real(-0.9, 0.9, hostile=hostile),
        "thickness": real(0.01, 3, hostile=hostile),
    }
    doc["layers"] = [
        {k: val(v) for k, v in layer_keys.items() if not hostile or draw(st.integers(0, 5)) > 0}
        for _ in range(draw(st.integers(0 if hostile else 1, 3)))
    ]
    if draw(st.booleans()):
        doc["source"] = {
            "type": val(st.sampled_from(["pencil", "diffuse"])),
            "theta_deg": val(real(0, 89, hostile=hostile)),
        }
        if doc["source"]["type"] == "diffuse" and not hostile:
            del doc["source"]["theta_deg"]
    if draw(st.booleans()):
        keys = (("nr", st.integers(1, 5)), ("dr", real(0.01, 1, hostile=hostile)), ("na", st.integers(1, 4)))
        doc["tallies"] = {k: val(v) for k, v in keys}
    return doc, hostile


def mutate(text: str, ops) -> str:
    for kind, pos, char in ops:
        i = pos % (len(text) + 1)
        if kind == 0:
            text = text[:i] + text[i + 1 :]
        elif kind == 1:
            text = text[:i] + char + text[i:]
        else:
            text = text[:i]
    return text


MUTATIONS = st.lists(
    st.tuples(st.integers(0, 2), st.integers(0, 10**6), st.sampled_from(list("[]{}=\"'#\n.,0x- \\"))), max_size=3
)


def check_cli(reply, case, photons):
    """A command's reply: exit 0 with outputs that are sound results, or one error line and status 2."""
    if reply[0] != "cli":
        check(False, f"the command did not return: {reply}", case)
        return
    _, status, out, err, written = reply
    check("Traceback" not in err, f"a traceback: {err[-2000:]}", case)
    if status == 2:
        lines = err.strip().splitlines()
        check(len(lines) == 1 and lines[0].startswith("subsurf: error: "), f"not one error line: {err!r}", case)
        check(not any(k.endswith((".h5", ".mco", ".png")) for k in written), f"an error, yet wrote {written}", case)
        return
    check(status == 0, f"exit status {status}: {err!r}", case)
    for name, s in written.items():
        if name.endswith(".h5"):
            check_result(s, case, s["photons"] if photons is None else photons)
        elif name.endswith(".mco"):  # MCML's A leaves out the roulette term (zero mean): balance ≈ 1
            check(s["finite"] and abs(s["balance"] - 1) < 0.01 and s["photons"] == photons, f"{name}: {s}", case)
    check(bool(written), f"exit 0 but no output: {written}", case)


@pytest.mark.slow
@given(doc=config_docs(), ops=MUTATIONS, override=st.booleans())
def test_simulate_command_on_any_configuration(worker, doc, ops, override):
    doc, hostile = doc
    text = mutate(toml_text(doc), ops if hostile else [])
    argv = ["simulate", "c.toml", "--photons", "20", "--threads", "1", "-q"] + (["-o", "r.h5"] if override else [])
    case = {"c.toml": text, "argv": argv}
    check_cli(run(worker, "cli", (argv, {"c.toml": text.encode()})), case, 20)


MCI_TOKENS = st.sampled_from(
    [
        "0",
        "-1",
        "1",
        "2",
        "3",
        "1e400",
        "-1e400",
        "nan",
        "inf",
        "1e-320",
        "0.5",
        "18446744073709551616",
        "x",
        "first.mco",
        "./first.mco",
        "c.mci",
        "sub/x.mco",
        "A",
        "B",
        "#",
        "1.0",
    ]
)


@given(edits=st.lists(st.tuples(st.integers(0, 10**6), st.integers(0, 3), MCI_TOKENS), max_size=3))
def test_mcml_command_on_any_input(worker, sample_mci, edits):
    lines = sample_mci.splitlines()
    for pos, kind, token in edits:
        data = [i for i, l in enumerate(lines) if l.split("#")[0].strip()]
        if not data:
            break
        i = data[pos % len(data)]
        fields = lines[i].split("#")[0].split()
        if kind == 0:  # replace a field
            fields[pos % len(fields)] = token
            lines[i] = " ".join(fields)
        elif kind == 1:
            del lines[i]
        elif kind == 2:
            lines.insert(i, lines[i])
        else:
            lines = lines[: i + 1]
    text = "\n".join(lines) + "\n"
    argv = ["mcml", "c.mci", "--photons", "20", "--threads", "1", "-q"]
    check_cli(run(worker, "cli", (argv, {"c.mci": text.encode()})), {"c.mci": text}, 20)


# --- results files: random corruption and missing pieces --------------------------------------------


class Blob(bytes):
    """File contents that print as their length (hypothesis prints the arguments of a failing case)."""

    def __repr__(self):
        return f"<{len(self)} bytes>"


@pytest.fixture(scope="module")
def h5_file(make_result):
    from subsurf import io as rio

    res, _ = make_result(seed=3, nr=4, nz=3, na=2, brdf=(2, 3), max_order=1)
    return Blob(rio.to_bytes(res))


@pytest.mark.slow
@given(
    flips=st.lists(st.tuples(st.floats(0, 1, exclude_max=True), st.integers(1, 255)), min_size=1, max_size=8),
    truncate=st.none() | st.floats(0, 1),
)
def test_damaged_results_files_are_refused_or_identical(worker, h5_file, flips, truncate):
    data = bytearray(h5_file)
    for where, xor in flips:
        data[int(where * len(data))] ^= xor
    if truncate is not None:
        data = data[: int(truncate * len(data))]
    reply = run(worker, "load", (h5_file, bytes(data)))
    case = {"flips": flips, "truncate": truncate}
    if reply[0] == "file":
        check("\n" not in reply[1] and reply[1].split(": ")[0].endswith("b.h5"), f"unclear: {reply[1]!r}", case)
    else:
        check(reply == ("ok", {"equal": True}), f"a damaged file loaded as a different result: {reply}", case)


EDITS = st.sampled_from(["delete", "set_attr", "del_attr"])
ATTR_VALUES = st.one_of(
    st.integers(-(2**63), 2**63 - 1),
    st.floats(),
    st.text(
        st.characters(blacklist_categories=("Cs",), blacklist_characters="\x00"), max_size=6
    ),  # HDF5: UTF-8, no NUL
    st.sampled_from(["[1,2]", "{}", "null"]),
)


@pytest.mark.slow
@given(edits=st.lists(st.tuples(EDITS, st.integers(0, 10**6), ATTR_VALUES), min_size=1, max_size=3), v1=st.booleans())
@(lambda f: f if CAMPAIGN else settings(max_examples=25)(f))  # ~0.1 s a case (h5py edits and a save)
def test_edited_results_files_merge_cleanly(worker, h5_file, as_format_1, tmp_path_factory, edits, v1):
    """Missing datasets and attributes, wrong types (format 1: no checksums to catch them first);
    ``merge`` of one file loads it whole and writes it back."""
    path = tmp_path_factory.mktemp("edit") / "a.h5"
    path.write_bytes(h5_file)
    if v1:
        as_format_1(path)
    with h5py.File(path, "r+") as f:
        for kind, k, value in edits:
            objs = [f]
            f.visititems(lambda n, o, objs=objs: objs.append(o))
            obj = objs[k % len(objs)]
            keys = list(obj.attrs)
            if kind == "delete" and obj.name != "/":
                del f[obj.name]
            elif kind == "del_attr" and keys:
                del obj.attrs[keys[k % len(keys)]]
            elif kind == "set_attr" and keys:
                obj.attrs[keys[k % len(keys)]] = value
    argv = ["merge", "a.h5", "-o", "m.h5"]
    check_cli(run(worker, "cli", (argv, {"a.h5": path.read_bytes()})), {"edits": edits, "v1": v1}, None)
