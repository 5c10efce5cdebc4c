"""The `subsurf` command and its files: atomic writes under SIGKILL/SIGTERM, Ctrl-C, full disks, output
paths, --force, and outputs that would overwrite an input.

Interruptions are deterministic: the test hooks of ``subsurf/_testhooks.py`` raise Ctrl-C from the
progress callback at a given photon count, or pause a save half-way until the test has signalled.
"""

import os
import pathlib
import resource
import signal
import subprocess
import sys
import time

import pytest
import subsurf
from subsurf import mcml

#: a small slab (tests/data/slab.toml); FAST.format(photons=N)
FAST = (
    (pathlib.Path(__file__).parent / "data" / "slab.toml").read_text().replace("photons = 3000", "photons = {photons}")
)
#: σa/σs = 1e-5 under a strongly reflecting surface: ~15 000 events a photon, seconds per chunk
SLOW = """\
photons = 1000000
[[layers]]
n = 2.5
mua = 0.001
mus = 100.0
"""
#: Ctrl-C once more than one chunk (4096 photons) was traced: with one thread, chunk 0 is complete
AFTER_A_CHUNK = "interrupt_after=4097"
SLOW_MCI = "1.0\n1\nslow.mco A\n10000\n0.01 0.01\n10 10 5\n1\n1.0\n2.5 0.01 1000 0 1e6\n1.0\n"


def leftovers(d):
    """Temporary files of atomic writes left in a directory."""
    return sorted(p.name for p in d.iterdir() if p.name.endswith(".subsurf-tmp"))


def popen(args, hook, cwd=None):
    env = dict(os.environ, SUBSURF_TEST_HOOK=hook, PYTHONUNBUFFERED="1")
    env.pop("SUBSURF_DEBUG", None)
    return subprocess.Popen(
        [sys.executable, "-m", "subsurf", *map(str, args)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=cwd,
        env=env,
    )


def wait_for(path, proc, timeout=60.0):
    """Wait until ``path`` exists (the hook's signal), failing if the process ends first."""
    t0 = time.monotonic()
    while not path.exists():
        if proc.poll() is not None:
            pytest.fail(f"process ended ({proc.returncode}) before {path.name}: {proc.communicate()}")
        assert time.monotonic() - t0 < timeout, f"{path} did not appear"
        time.sleep(0.01)


# --- Ctrl-C ------------------------------------------------------------------------------------


def test_ctrl_c_after_the_first_photons_writes_a_partial_result(tmp_path, cli):
    (tmp_path / "long.toml").write_text(FAST.format(photons=10**9))
    p = cli("simulate", tmp_path / "long.toml", "-o", tmp_path / "p.h5", "--threads", "1", hook=AFTER_A_CHUNK)
    assert p.returncode == 130, (p.stdout, p.stderr)
    assert "Traceback" not in p.stderr
    r = subsurf.load(tmp_path / "p.h5")
    assert r.partial and 0 < r.photons < 10**9 and r.photons_requested == 10**9
    assert abs(r.energy_balance - 1) < 1e-12
    assert f"PARTIAL: {r.photons:,} of 1,000,000,000 photons" in p.stdout and "(partial: interrupted)" in p.stdout


def test_ctrl_c_before_any_photon_writes_nothing(tmp_path, run_here, one_line_error):
    (tmp_path / "slow.toml").write_text(SLOW)
    p = run_here(
        "simulate", tmp_path / "slow.toml", "-o", tmp_path / "s.h5", "--threads", "1", hook="interrupt_after=0"
    )
    one_line_error(p, "interrupted before any photon was traced; nothing written", status=130)
    assert not (tmp_path / "s.h5").exists() and p.stdout == ""
    # the MCML drop-in: no .mco full of NAN
    (tmp_path / "slow.mci").write_text(SLOW_MCI)
    p = run_here("mcml", "slow.mci", "--threads", "1", cwd=tmp_path, hook="interrupt_after=0")
    one_line_error(p, "run 1 (slow.mco): interrupted before any photon", status=130)
    assert not (tmp_path / "slow.mco").exists()


def test_ctrl_c_never_replaces_a_complete_result(tmp_path, run_here):
    (tmp_path / "c.toml").write_text(FAST.format(photons=3000))
    (tmp_path / "long.toml").write_text(FAST.format(photons=10**9))
    out = tmp_path / "r.h5"
    assert run_here("simulate", tmp_path / "c.toml", "-o", out, "-q").returncode == 0
    complete = out.read_bytes()
    p = run_here("simulate", tmp_path / "long.toml", "-o", out, "--force", "-q", "--threads", "1", hook=AFTER_A_CHUNK)
    assert p.returncode == 130, p.stderr
    assert out.read_bytes() == complete
    partial = subsurf.load(tmp_path / "r.partial.h5")
    assert partial.partial and f"wrote {tmp_path / 'r.partial.h5'} (partial: interrupted)" in p.stdout
    # a second interrupted run does not replace the first partial result either
    p = run_here("simulate", tmp_path / "long.toml", "-o", out, "--force", "-q", "--threads", "1", hook=AFTER_A_CHUNK)
    assert p.returncode == 130 and subsurf.load(tmp_path / "r.partial-2.h5").partial
    assert subsurf.io.results_equal(subsurf.load(tmp_path / "r.partial.h5"), partial)


@pytest.mark.slow
def test_resume_finishes_an_interrupted_run_with_the_bits_of_one_run(tmp_path, run_here, cli_here, error_here):
    n = 10**6  # long enough (~1 s on one thread) for the hook's Ctrl-C to come before the end
    (tmp_path / "c.toml").write_text(FAST.format(photons=n))
    p = run_here("simulate", tmp_path / "c.toml", "-o", tmp_path / "p.h5", "-q", "--threads", "1", hook=AFTER_A_CHUNK)
    assert p.returncode == 130, p.stderr
    partial = subsurf.load(tmp_path / "p.h5")
    assert partial.partial and 0 < partial.photons < n
    p = run_here("simulate", tmp_path / "c.toml", "-o", tmp_path / "r.h5", "-q", "--resume", tmp_path / "p.h5")
    assert p.returncode == 0, p.stderr
    assert f"resuming from {tmp_path / 'p.h5'}: {partial.photons:,} photons already traced" in p.stdout
    assert run_here("simulate", tmp_path / "c.toml", "-o", tmp_path / "d.h5", "-q", "--threads", "2").returncode == 0
    resumed, direct = subsurf.load(tmp_path / "r.h5"), subsurf.load(tmp_path / "d.h5")
    assert not resumed.partial and resumed.photons == direct.photons == n
    assert subsurf.io.results_equal(resumed, direct, provenance=False)
    # another configuration's state (another seed) is refused in one line; so is a missing file
    # (checked before saying "resuming from")
    status, out, err = cli_here(
        "simulate", tmp_path / "c.toml", "-o", tmp_path / "x.h5", "--seed", "7", "--resume", tmp_path / "p.h5"
    )
    assert status == 2 and "another configuration" in err and "resuming" not in out, (out, err)
    error_here("simulate", tmp_path / "c.toml", "-o", tmp_path / "x.h5", "--resume", tmp_path / "none.h5")
    assert not (tmp_path / "x.h5").exists()


@pytest.mark.slow
def test_second_ctrl_c_during_the_save_leaves_a_complete_file(tmp_path):
    (tmp_path / "long.toml").write_text(FAST.format(photons=10**9))
    hook = tmp_path / "hook"
    hook.mkdir()
    proc = popen(
        ["simulate", tmp_path / "long.toml", "-o", tmp_path / "p.h5", "-q", "--threads", "1"],
        hook=f"{AFTER_A_CHUNK},pause_in_write={hook}",
    )
    wait_for(hook / "paused", proc)
    proc.send_signal(signal.SIGINT)  # held back until the file is complete
    (hook / "resume").touch()
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 130 and "Traceback" not in err, (out, err)
    r = subsurf.load(tmp_path / "p.h5")
    assert r.partial and abs(r.energy_balance - 1) < 1e-12
    assert leftovers(tmp_path) == []


def test_sigint_during_start_up_is_one_line(cli):
    p = cli("materials", hook="sigint_at_start")
    assert p.returncode == 130 and p.stderr == "subsurf: interrupted\n" and p.stdout == ""


# --- killed while saving -----------------------------------------------------------------------


def _command_writing(tmp_path, name, make_result, sample_mci):
    """(arguments of a command that replaces tmp_path/TARGET with --force, TARGET)."""
    if name == "simulate":
        (tmp_path / "c.toml").write_text(FAST.format(photons=2000))
        return ["simulate", tmp_path / "c.toml", "-o", tmp_path / "t.h5", "-q"], tmp_path / "t.h5"
    if name in ("merge", "plot"):
        for s in (1, 2):
            subsurf.save(make_result(seed=s)[0], tmp_path / f"in{s}.h5")
        if name == "merge":
            return ["merge", tmp_path / "in1.h5", tmp_path / "in2.h5", "-o", tmp_path / "t.h5"], tmp_path / "t.h5"
        return ["plot", tmp_path / "in1.h5", "-o", tmp_path / "t.png", "--no-models"], tmp_path / "t.png"
    (tmp_path / "s.mci").write_text(sample_mci)
    return ["mcml", tmp_path / "s.mci", "--photons", "300", "-q"], tmp_path / "first.mco"


@pytest.mark.slow
@pytest.mark.parametrize(
    "command, sig",
    [
        ("simulate", signal.SIGKILL),
        ("merge", signal.SIGKILL),
        ("plot", signal.SIGKILL),
        ("mcml", signal.SIGKILL),
        ("simulate", signal.SIGTERM),
        ("mcml", signal.SIGTERM),
    ],
)
def test_killed_during_a_save_keeps_the_previous_file(tmp_path, make_result, sample_mci, command, sig):
    args, target = _command_writing(tmp_path, command, make_result, sample_mci)
    target.write_bytes(b"the previous, complete file")
    hook = tmp_path / "hook"
    hook.mkdir()
    proc = popen([*args, "--force"], hook=f"pause_in_write={hook}", cwd=tmp_path)
    wait_for(hook / "paused", proc)  # half of the new file is in its temporary file now
    assert len(leftovers(tmp_path)) == 1
    proc.send_signal(sig)
    out, err = proc.communicate(timeout=60)
    assert target.read_bytes() == b"the previous, complete file"
    if sig == signal.SIGTERM:
        assert proc.returncode == 143 and err.strip().splitlines()[-1] == "subsurf: terminated", err
        assert leftovers(tmp_path) == []  # cleaned up on the way out
    else:
        assert proc.returncode == -signal.SIGKILL
    if command == "simulate":  # and a later run completes the replacement
        p = subprocess.run(
            [sys.executable, "-m", "subsurf", *map(str, args), "--force"], cwd=tmp_path, capture_output=True, text=True
        )
        assert p.returncode == 0, p.stderr
        assert subsurf.load(target).photons == 2000


# --- full disk ---------------------------------------------------------------------------------


def limit_files(limit):
    """A ``preexec_fn`` limiting files to ``limit`` bytes (RLIMIT_FSIZE): writes beyond fail with EFBIG."""

    def limit_files():
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    return limit_files


@pytest.mark.slow
@pytest.mark.parametrize("command", ["simulate", "merge", "mcml"])
def test_full_disk_is_one_line_and_leaves_nothing(tmp_path, cli, make_result, sample_mci, one_line_error, command):
    args, target = _command_writing(tmp_path, command, make_result, sample_mci)
    p = cli(*args, cwd=tmp_path, preexec_fn=limit_files(4096))
    one_line_error(p, f"{target.name}: cannot write (File too large); nothing was written")
    assert not target.exists() and leftovers(tmp_path) == []
    p = cli(*args, cwd=tmp_path, preexec_fn=limit_files(2**30))  # room again: the next run is not refused
    assert p.returncode == 0, p.stderr
    assert target.stat().st_size > 4096


# --- --force and output paths -----------------------------------------------------------------


@pytest.mark.parametrize("command", ["simulate", "merge", "plot", "mcml"])
def test_existing_output_needs_force(tmp_path, error_here, cli_here, monkeypatch, make_result, sample_mci, command):
    args, target = _command_writing(tmp_path, command, make_result, sample_mci)
    monkeypatch.chdir(tmp_path)
    target.write_text("precious")
    error_here(*args, fragments=[f"{target.name}: exists; use --force"])
    assert target.read_text() == "precious"
    status, _, err = cli_here(*args, "--force")
    assert status == 0, err
    assert target.read_bytes()[:8] != b"precious"


@pytest.mark.parametrize("command", ["simulate", "merge", "plot"])
def test_output_paths_are_checked(tmp_path, error_here, make_result, sample_mci, command):
    args, target = _command_writing(tmp_path, command, make_result, sample_mci)
    args = [str(a) for a in args]
    i = args.index(str(target))
    (tmp_path / "afile").write_text("x")
    (tmp_path / "adir").mkdir()
    for out, fragment in (
        (tmp_path / "missing" / "r.out", f"directory {tmp_path / 'missing'} does not exist"),
        (tmp_path / "adir", "adir: is a directory; give a file name"),
        (tmp_path / "afile" / "r.out", f"{tmp_path / 'afile'} is not a directory"),
    ):
        error_here(*args[:i], out, *args[i + 1 :], fragments=[str(out), fragment])
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith("a")) == ["adir", "afile"]


def test_mcml_output_in_a_missing_directory(tmp_path, error_here, monkeypatch, sample_mci):
    (tmp_path / "s.mci").write_text(sample_mci.replace("second.mco A", "nowhere/second.mco A"))
    monkeypatch.chdir(tmp_path)
    error_here("mcml", "s.mci", fragments=["nowhere/second.mco: directory", "does not exist"])
    assert not (tmp_path / "first.mco").exists()  # checked before anything ran


# --- outputs that are inputs ------------------------------------------------------------------


def test_simulate_does_not_overwrite_its_configuration(tmp_path, error_here):
    cfg = tmp_path / "a.toml"
    text = FAST.format(photons=100)
    cfg.write_text(text)
    for extra in ([], ["--force"]):
        error_here("simulate", cfg, "-o", cfg, *extra, fragments=["a.toml: is also an input"])
    error_here("simulate", cfg, "-o", tmp_path / "." / "a.toml", "--force", fragments=["is also an input"])
    cfg.write_text('output = "a.toml"\n' + text)
    error_here("simulate", cfg, "--force", fragments=["a.toml: is also an input"])
    assert cfg.read_text() == 'output = "a.toml"\n' + text


SWEEP = FAST.format(photons=200) + '[[sweep]]\nname = "g"\nvalues = [0.0, 0.5]\nset = "layers[0].g"\n'


def test_sweep_does_not_overwrite_its_configuration(tmp_path, error_here):
    """Regression: ``subsurf sweep X.toml -o X.toml --force`` replaced the TOML with HDF5."""
    cfg = tmp_path / "x.toml"
    cfg.write_text(SWEEP)
    for extra in ([], ["--force"]):
        error_here("sweep", cfg, "-o", cfg, "-q", *extra, fragments=["x.toml: is also an input"])
    assert cfg.read_text() == SWEEP


def test_a_damaged_sweep_file_is_called_damaged(tmp_path, error_here, cli_here):
    """Regression: a damaged sweep file was "something else; use --force" (and, before the
    checksummed container, could crash HDF5). It is named damaged; ``--force`` discards it knowingly."""
    cfg = tmp_path / "s.toml"
    cfg.write_text(SWEEP)
    out = tmp_path / "s.h5"
    assert cli_here("sweep", cfg, "-o", out, "-q")[0] == 0
    data = bytearray(out.read_bytes())
    data[4096 + 849] ^= 0x5A
    out.write_bytes(bytes(data))
    error_here("sweep", cfg, "-o", out, "-q", fragments=["s.h5: ", "damaged", "--force to discard it"])
    assert out.read_bytes() == bytes(data)  # kept until the user says otherwise
    other = tmp_path / "o.toml"
    other.write_text(SWEEP.replace("[0.0, 0.5]", "[0.0, 0.7]"))
    assert cli_here("sweep", other, "-o", tmp_path / "o.h5", "-q")[0] == 0
    error_here("sweep", cfg, "-o", tmp_path / "o.h5", "-q", fragments=["holds another sweep"])
    status, stdout, _ = cli_here("sweep", cfg, "-o", out, "-q", "--force")
    assert status == 0 and subsurf.sweeps.load(out).complete, stdout


def test_merge_and_plot_do_not_overwrite_an_input(tmp_path, error_here, make_result):
    a, b = (subsurf.save(make_result(seed=s)[0], tmp_path / f"{s}.h5") for s in (1, 2))
    before = open(a, "rb").read()
    error_here("merge", a, b, "-o", a, "--force", fragments=["is also an input"])
    error_here("plot", a, "-o", a, "--force", fragments=["is also an input"])
    assert open(a, "rb").read() == before


def test_mcml_runs_writing_the_same_file_are_refused(tmp_path, error_here, monkeypatch, sample_mci):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "s.mci").write_text(sample_mci.replace("first.mco", "same.mco").replace("second.mco", "./same.mco"))
    error_here("mcml", "s.mci", fragments=["s.mci:24: output file ./same.mco is the same file as", "same.mco"])
    (tmp_path / "t.mci").write_text(sample_mci.replace("second.mco", "t.mci"))
    error_here("mcml", "t.mci", "--force", fragments=["t.mci: is also an input"])
    assert not (tmp_path / "same.mco").exists() and not (tmp_path / "first.mco").exists()
    with pytest.raises(mcml.McmlInputError, match="same file"):
        mcml.plan_runs(tmp_path / "s.mci")


def test_mcml_checks_every_run_before_simulating_any(tmp_path, error_here, monkeypatch, sample_mci):
    """An invalid second run is reported before the first is simulated (nothing is written)."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "s.mci").write_text(sample_mci.replace("10 10 5", "100000 100000 5"))
    error_here("mcml", "s.mci", fragments=["s.mci:24: run 2: tallies"])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.mci"]
