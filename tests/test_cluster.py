"""Runs on a Dask cluster: bit-identical to local runs, surviving a killed worker, interruptible,
resumable; sweeps and tables on the cluster; the CLI's --scheduler. One LocalCluster of two
worker processes on 127.0.0.1 is shared by the module and closed at its end, and the test checks
that no process it started is left behind. Nothing here touches any other address."""

import os
import signal
import socket
import subprocess
import sys
import threading
import time

import numpy as np
import psutil
import pytest
import subsurf
from distributed import Client, LocalCluster
from subsurf import bssrdf, cluster, config, sweeps
from subsurf.io import results_equal

STACK = subsurf.Stack([subsurf.Layer(1.4, 0.1, 10.0, 0.9, 1.0)], n_above=1.0, n_below=1.33)
#: Every histogram the engine has.
TALLIES = subsurf.Tallies(nr=12, dr=0.1, nz=8, dz=0.1, na=6, nt=5, dt=5.0, brdf=(3, 4), max_order=3)
PHOTONS = 60_000


def _children() -> set:
    """Our live descendant processes, less multiprocessing's resource tracker (started once for
    the whole session, it ends with it); zombies (a killed worker not yet waited for) are reaped."""
    out = set()
    for p in psutil.Process().children(recursive=True):
        try:
            if p.status() == psutil.STATUS_ZOMBIE:
                if p.ppid() == os.getpid():
                    os.waitpid(p.pid, os.WNOHANG)
                continue
            if "multiprocessing.resource_tracker" in " ".join(p.cmdline()):
                continue
        except (psutil.Error, ChildProcessError):
            continue
        out.add(p.pid)
    return out


def _describe(pid):
    try:
        return psutil.Process(pid).cmdline()
    except psutil.Error:
        return pid


@pytest.fixture(scope="module")
def client():
    before = _children()
    lc = LocalCluster(
        n_workers=2,
        threads_per_worker=1,
        processes=True,
        host="127.0.0.1",
        dashboard_address=None,
        worker_dashboard_address=None,
    )
    c = Client(lc, set_as_default=False, timeout=60)
    yield c
    c.close(timeout=30)
    lc.close(timeout=30)
    deadline = time.monotonic() + 20
    while (left := _children() - before) and time.monotonic() < deadline:
        time.sleep(0.2)
    for pid in left:  # (only processes this fixture started)
        os.kill(pid, signal.SIGKILL)
    assert not left, f"processes left behind by the cluster: {[_describe(p) for p in sorted(left)]}"


@pytest.fixture(scope="module")
def local():
    return subsurf.simulate(STACK, photons=PHOTONS, seed=7, tallies=TALLIES)


@pytest.fixture(scope="module")
def local4():
    """4× the photons: the runs that must still have ranges in flight when the first report comes
    (on a loaded machine one worker may finish several ranges before it)."""
    return subsurf.simulate(STACK, photons=4 * PHOTONS, seed=7, tallies=TALLIES)


def assert_same_bits(a, b):
    assert len(a.histograms) >= 15 and results_equal(a, b, provenance=False)


def _ranges(client, progress=None, task_photons=8192, photons=PHOTONS, prior=None):
    return cluster.run_ranges(
        client, STACK, photons, 7, None, subsurf.PencilBeam(), TALLIES, progress, prior, task_photons=task_photons
    )


def test_import_subsurf_does_not_import_dask():
    code = "import subsurf, sys; print(sorted({m.split('.')[0] for m in sys.modules} & {'dask', 'distributed'}))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0 and out.stdout.strip() == "[]", out.stdout + out.stderr


@pytest.mark.slow
def test_cluster_run_is_bit_identical(client, local):
    calls = []
    r = subsurf.simulate(
        STACK, photons=PHOTONS, seed=7, tallies=TALLIES, client=client, progress=lambda d, t: calls.append((d, t))
    )
    assert not r.partial and r.photons == PHOTONS
    assert_same_bits(r, local)
    assert calls[-1] == (PHOTONS, PHOTONS)
    # many small tasks finishing in any order, on both workers and on one
    state, interrupted = _ranges(client)
    assert not interrupted and state == local.state
    with _one_worker(client):
        state, _ = _ranges(client, task_photons=16384)
    assert state == local.state


def test_task_sizes():
    c = subsurf.state.CHUNK_PHOTONS
    # about task_seconds of work, whole chunks
    assert cluster.task_photons(10**9, 4, 1e5, 0, 5.0) == c * int(np.ceil(5e5 / c))
    # the tail shrinks (half the remainder per worker thread), but not below an eighth of the target
    assert cluster.task_photons(10**6, 4, 1e5, 0, 5.0) == c * int(np.ceil(10**6 / 8 / c))
    assert cluster.task_photons(10**5, 4, 1e5, 0, 5.0) == c * int(np.ceil(5e5 / 8 / c))
    # never more than what is left, never less than a chunk
    assert cluster.task_photons(100, 4, 1e5, 0, 5.0) == 100
    assert cluster.task_photons(10**9, 4, 1.0, 0, 5.0) == c
    # a large state lengthens the task so that shipping it is ≤ 5 % of it
    assert cluster.task_photons(10**12, 1, 1e5, 10**9, 5.0) == c * int(np.ceil(1e5 * 200 / c))


@pytest.mark.slow
def test_worker_killed_mid_run(client, local4):
    pids = client.run(os.getpid)
    killed = {}

    def kill_a_busy_worker(done, total):
        # at the first report that finds a worker busy (on a loaded machine the first reports may
        # come when no task is running)
        busy = {w: keys for w, keys in client.processing().items() if keys} if not killed and done < total else {}
        if busy:
            worker = sorted(busy)[0]
            os.kill(pids[worker], signal.SIGKILL)
            killed.update(worker=worker, pid=pids[worker], keys=busy[worker])

    state, interrupted = _ranges(client, progress=kill_a_busy_worker, photons=4 * PHOTONS)
    assert killed and not interrupted
    assert state == local4.state  # the same bits although Dask re-ran the lost worker's tasks
    assert not psutil.pid_exists(killed["pid"]) or psutil.Process(killed["pid"]).status() == psutil.STATUS_ZOMBIE
    # the scheduler saw the worker go and gave its tasks to a worker again
    stories = client.run_on_scheduler(_stories, killed["keys"])
    assert any(sum(1 for ev in s if ev[2] == "processing") >= 2 for s in stories), stories
    client.wait_for_workers(2, timeout=60)


def _one_worker(client):
    """Tasks on one worker thread: they run, and finish, in range order."""
    import dask

    return dask.annotate(workers=[sorted(client.nthreads())[0]], allow_other_workers=False)


@pytest.fixture
def one_worker(client):
    with _one_worker(client):
        yield


def _stop(done, total):
    raise KeyboardInterrupt


def _stories(keys, dask_scheduler=None):
    return [dask_scheduler.story(k) for k in keys]


@pytest.mark.slow
def test_interrupt_returns_resumable_prefix(client, local, local4, one_worker, monkeypatch):
    state, interrupted = _ranges(client, progress=_stop, photons=4 * PHOTONS)
    assert interrupted and state.start == 0 and 0 < state.stop < 4 * PHOTONS and state.stop % 4096 == 0
    # through simulate(): partial, warned, resumable with or without the cluster
    monkeypatch.setattr(cluster, "DEFAULT_TASK_SECONDS", 1e-3)  # one-chunk tasks
    with pytest.warns(RuntimeWarning, match="interrupted"):
        part = subsurf.simulate(STACK, PHOTONS, 7, tallies=TALLIES, client=client, progress=_stop)
    assert part.partial and 0 < part.photons < PHOTONS and part.photons % 4096 == 0
    assert_same_bits(subsurf.simulate(STACK, PHOTONS, 7, tallies=TALLIES, client=client, resume=part), local)
    assert_same_bits(subsurf.simulate(STACK, 4 * PHOTONS, 7, tallies=TALLIES, resume=state), local4)


#: A scheduler and one single-threaded worker in one process of their own (killing it loses both).
ONE_PROCESS_CLUSTER = """
import threading
from distributed import LocalCluster
lc = LocalCluster(n_workers=1, threads_per_worker=1, processes=False, protocol="tcp", host="127.0.0.1",
                  dashboard_address=None, worker_dashboard_address=None)
print(lc.scheduler_address, flush=True)
threading.Event().wait()
"""


@pytest.fixture
def cluster_process():
    """``(address, process)``: a cluster (scheduler and one worker thread) in a child process."""
    proc = subprocess.Popen([sys.executable, "-c", ONE_PROCESS_CLUSTER], stdout=subprocess.PIPE, text=True)
    try:
        yield proc.stdout.readline().strip(), proc
    finally:
        proc.kill()
        proc.wait()


@pytest.fixture
def doomed_cluster(cluster_process):
    """``(client, kill)``: a client of ``cluster_process``, and ``kill()``, which SIGKILLs that
    process (scheduler and worker) and returns once the client has seen it go."""
    address, proc = cluster_process
    c = Client(address, set_as_default=False, timeout=10)

    def kill():
        proc.kill()
        proc.wait()
        for _ in range(6000):  # the client notices the closed connection at once (a cap, not a timing)
            if c.status != "running":
                return
            time.sleep(0.01)
        pytest.fail("the client never noticed that its scheduler was killed")

    yield c, kill
    c.close(timeout=10)


@pytest.mark.slow
def test_lost_scheduler_keeps_the_finished_photons(doomed_cluster, local, monkeypatch):
    """Regression: a scheduler killed mid-run (``kill -9``) used to end in a
    ``FutureCancelledError`` traceback with nothing kept. The photons merged before the loss are
    returned as a partial result, with a warning saying why, and resuming it (here, locally) gives
    the bits of an uninterrupted run. The kill comes from the progress hook after the third
    finished range: deterministic, no fixed sleeps."""
    c, kill = doomed_cluster
    monkeypatch.setattr(cluster, "DEFAULT_TASK_SECONDS", 1e-3)  # one-chunk tasks, run in range order
    calls = []

    def kill_after_three_ranges(done, total):
        calls.append(done)
        if len(calls) == 3:
            kill()

    with pytest.warns(RuntimeWarning, match=r"the Dask scheduler stopped answering \(.*\): returning the \d+ of"):
        part = subsurf.simulate(STACK, PHOTONS, 7, tallies=TALLIES, client=c, progress=kill_after_three_ranges)
    # every photon reported done before the loss is kept (one worker thread: ranges finish in order)
    assert len(calls) == 3 and part.partial and part.photons == calls[-1] < PHOTONS and part.photons % 4096 == 0
    assert_same_bits(subsurf.simulate(STACK, PHOTONS, 7, tallies=TALLIES, resume=part), local)


@pytest.mark.slow
def test_cli_keeps_a_partial_when_the_scheduler_is_lost(cluster_process, tmp_path):
    """The same from the command line: one warning line, the partial written, exit 130, and
    ``--resume`` (locally) finishes it to the bits of a local run. Test hooks fix the ranges at
    4096 photons and kill the scheduler after the second one."""
    address, proc = cluster_process
    (tmp_path / "c.toml").write_text(CONFIG.replace("photons = 3000", "photons = 40000"))
    env = dict(os.environ, SUBSURF_TEST_HOOK=f"task_photons=4096,kill_scheduler_after=2:{proc.pid}")
    run = [sys.executable, "-m", "subsurf", "simulate", tmp_path / "c.toml", "-q"]
    p = subprocess.run([*run, "-o", tmp_path / "p.h5", "--scheduler", address],
                       capture_output=True, text=True, timeout=120, env=env)  # fmt: skip
    lines = p.stderr.strip().splitlines()
    assert p.returncode == 130 and len(lines) == 1, p.stderr
    assert lines[0].startswith("subsurf: warning: subsurf.simulate: the Dask scheduler stopped answering")
    part = subsurf.load(tmp_path / "p.h5")
    assert part.partial and part.photons == 2 * 4096 and "wrote" in p.stdout
    for args in (["-o", tmp_path / "r.h5", "--resume", tmp_path / "p.h5"], ["-o", tmp_path / "d.h5"]):
        assert subprocess.run([*run, *args], capture_output=True, timeout=120).returncode == 0
    resumed, direct = subsurf.load(tmp_path / "r.h5"), subsurf.load(tmp_path / "d.h5")
    assert not resumed.partial and results_equal(resumed, direct, provenance=False)


@pytest.mark.slow
def test_cli_sweep_keeps_its_points_when_the_scheduler_is_lost(cluster_process, tmp_path):
    """A sweep on a lost scheduler: one error line (exit 2), the finished point kept in the file,
    and the same command run locally computes only the rest."""
    address, proc = cluster_process
    (tmp_path / "s.toml").write_text(SWEEP_TOML)
    env = dict(os.environ, SUBSURF_TEST_HOOK=f"kill_scheduler_after=1:{proc.pid}")
    run = [sys.executable, "-m", "subsurf", "sweep", tmp_path / "s.toml", "-o", tmp_path / "s.h5", "-q"]
    p = subprocess.run([*run, "--scheduler", address], capture_output=True, text=True, timeout=120, env=env)
    lines = p.stderr.strip().splitlines()
    assert p.returncode == 2 and len(lines) == 1 and "Traceback" not in p.stderr, p.stderr
    assert "sweep: the Dask scheduler stopped answering" in lines[0] and "kept" in lines[0]
    assert sweeps.load(tmp_path / "s.h5").points_done == 1
    p = subprocess.run(run[:-1], capture_output=True, text=True, timeout=120)  # not quiet: says it resumes
    assert p.returncode == 0 and "1 of 4 points already done" in p.stdout, p.stdout + p.stderr
    assert sweeps.load(tmp_path / "s.h5").complete


def test_scheduler_lost_before_any_range_is_an_error(doomed_cluster):
    c, kill = doomed_cluster
    kill()
    with pytest.raises(cluster.ClusterError, match="scheduler stopped answering .* before any photon range"):
        subsurf.simulate(STACK, PHOTONS, 7, client=c)


@pytest.mark.slow
def test_ctrl_c_cancels_running_tasks(client, monkeypatch):
    """A real SIGINT while every task is still running: KeyboardInterrupt (nothing completed),
    and the cancelled tasks stop on the workers instead of running to their end. (Waiting for the
    10⁹ photons would end in a result, not in KeyboardInterrupt.) The tasks are 4096² photons
    (3–7 s here): sized from the engine's guessed speed, the first ones took about 0.5 s on an idle
    machine and sometimes finished before the SIGINT (a partial result, no KeyboardInterrupt)."""
    monkeypatch.setenv("SUBSURF_TEST_HOOK", f"task_photons={4096 * 4096}")
    # a shell's background job without job control ignores SIGINT: fail here rather than run 10⁹ photons
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler, "SIGINT is ignored in this process"
    threading.Timer(0.5, os.kill, (os.getpid(), signal.SIGINT)).start()
    with pytest.raises(KeyboardInterrupt):  # tasks of seconds each
        subsurf.simulate(STACK, photons=10**9, seed=1, client=client, progress=None, tallies=None)
    deadline = time.monotonic() + 10
    while any(client.processing().values()) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not any(client.processing().values())
    assert client.submit(sum, [1, 2], pure=False).result(timeout=10) == 3


@pytest.mark.slow
def test_sweep_on_cluster_matches_local(client, tmp_path):
    cfg = config.parse_sweep(SWEEP_TOML, str(tmp_path / "s.toml"))
    here = subsurf.sweep(cfg, cfg.grid())
    there = subsurf.sweep(cfg, cfg.grid(), tmp_path / "s.h5", client=client, units=cfg.units())
    assert there.complete and there.shape == (2, 2)
    for k in here.data:
        assert np.array_equal(here[k], there[k], equal_nan=True), k
    assert np.array_equal(sweeps.load(tmp_path / "s.h5")["rd_r"], here["rd_r"])


SWEEP_TOML = """
photons = 3000
seed = 2
[[layers]]
n = 1.4
mua = 0.1
mus = 10.0
g = 0.9
thickness = 1.0
[tallies]
nr = 5
dr = 0.2
[[sweep]]
name = "g"
values = [0.0, 0.9]
set = "layers[0].g"
[[sweep]]
name = "mua"
values = [0.1, 1.0]
set = "layers[0].mua"
"""


@pytest.mark.slow
def test_tables_on_cluster_match_local(client):
    settings = dict(n_albedos=3, photons=2000, r_max=50.0)
    a = bssrdf.ProfileTable.build(0.0, 1.3, **settings)
    b = bssrdf.ProfileTable.build(0.0, 1.3, client=client, **settings)
    for p, q in zip(a._t.points(), b._t.points()):
        assert all(np.array_equal(p[k], q[k]) for k in p)
    grid = dict(albedos=[0.5, 0.9], taus=[0.5, 2.0], photons=2000, seed=3)
    s1, s2 = bssrdf.SlabTable(0.0, 1.4, **grid), bssrdf.SlabTable(0.0, 1.4, client=client, **grid)
    assert s1.totals(0.7, 1.0) == s2.totals(0.7, 1.0)


def run_cli(*args, timeout=120):
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    env.pop("SUBSURF_DEBUG", None)
    return subprocess.run(
        [sys.executable, "-m", "subsurf.cli", *map(str, args)], capture_output=True, text=True, timeout=timeout, env=env
    )


CONFIG = SWEEP_TOML[: SWEEP_TOML.index("[[sweep]]")]


@pytest.mark.slow
def test_cli_simulate_and_sweep_with_scheduler(client, tmp_path):
    address = client.scheduler.address
    (tmp_path / "c.toml").write_text(CONFIG)
    p = run_cli("simulate", tmp_path / "c.toml", "-o", tmp_path / "c.h5", "-q", "--scheduler", address)
    assert p.returncode == 0, p.stderr
    cfg = config.load_config(tmp_path / "c.toml")
    ref = subsurf.simulate(cfg.stack, **cfg.simulate_kwargs())
    assert subsurf.load(tmp_path / "c.h5").state == ref.state
    (tmp_path / "s.toml").write_text(SWEEP_TOML)
    p = run_cli("sweep", tmp_path / "s.toml", "-o", tmp_path / "s.h5", "--scheduler", address)
    assert p.returncode == 0, p.stderr
    assert "wrote" in p.stdout and sweeps.load(tmp_path / "s.h5").complete


@pytest.fixture
def silent_port():
    """A loopback port that accepts connections and never answers (a hung scheduler)."""
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    s.listen(8)
    yield s.getsockname()[1]
    s.close()


@pytest.fixture
def closed_port():
    """A loopback port nobody listens on (bound, so no one else takes it meanwhile)."""
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    yield s.getsockname()[1]
    s.close()


@pytest.mark.parametrize("port_fixture", ["silent_port", "closed_port"])
def test_scheduler_that_does_not_answer(port_fixture, request):
    port = request.getfixturevalue(port_fixture)
    with pytest.raises(cluster.ClusterError, match=f"no Dask scheduler answered at tcp://127.0.0.1:{port} within 1 s"):
        cluster.connect(f"tcp://127.0.0.1:{port}", timeout=1.0)


@pytest.mark.slow
def test_cli_scheduler_that_does_not_answer(silent_port, tmp_path):
    """The hard case (a server that accepts and never speaks): one line, bounded time, no file."""
    (tmp_path / "c.toml").write_text(CONFIG)
    (tmp_path / "s.toml").write_text(SWEEP_TOML)
    for cmd, cfg in (("simulate", "c.toml"), ("sweep", "s.toml")):
        p = run_cli(cmd, tmp_path / cfg, "-o", tmp_path / "o.h5", "--scheduler", f"tcp://127.0.0.1:{silent_port}",
                    "--connect-timeout", "1", timeout=60)  # fmt: skip
        assert p.returncode == 2 and "Traceback" not in p.stderr, p.stderr
        lines = p.stderr.strip().splitlines()
        assert len(lines) == 1 and "no Dask scheduler answered" in lines[0], p.stderr
        assert not (tmp_path / "o.h5").exists()


@pytest.mark.parametrize("value", ["inf", "1e308", "nan", "0", "3601"])
def test_connect_timeout_is_bounded(value, tmp_path, closed_port):
    """Regression: ``--connect-timeout 1e308`` waited for ever, ``inf`` ended in a KeyError
    traceback. The wait is bounded: (0, 3600] s."""
    (tmp_path / "c.toml").write_text(CONFIG)
    p = run_cli("simulate", tmp_path / "c.toml", "-o", tmp_path / "o.h5", "--scheduler",
                f"tcp://127.0.0.1:{closed_port}", "--connect-timeout", value)  # fmt: skip
    lines = p.stderr.strip().splitlines()
    assert p.returncode == 2 and len(lines) == 1 and "Traceback" not in p.stderr, p.stderr
    assert f"--connect-timeout = {float(value)!r} is out of range: seconds in (0, 3600]" in lines[0]
    with pytest.raises(subsurf.ParameterError, match="timeout = inf is out of range"):
        cluster.connect(f"tcp://127.0.0.1:{closed_port}", timeout=float("inf"))


@pytest.mark.parametrize("sig, status", [(signal.SIGTERM, 143), (signal.SIGINT, 130)])
def test_waiting_for_a_scheduler_is_interruptible(sig, status, silent_port, tmp_path):
    """Regression: SIGTERM was ignored while waiting for a scheduler (for the whole
    timeout). The test hook says when the command waits; the signal then ends it at once."""
    (tmp_path / "c.toml").write_text(CONFIG)
    env = dict(os.environ, SUBSURF_TEST_HOOK=f"connecting={tmp_path}", PYTHONUNBUFFERED="1")
    args = ["simulate", tmp_path / "c.toml", "-o", tmp_path / "o.h5", "--scheduler", f"tcp://127.0.0.1:{silent_port}"]
    proc = subprocess.Popen(
        [sys.executable, "-m", "subsurf", *map(str, args), "--connect-timeout", "3600"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
    )  # fmt: skip
    try:
        for _ in range(6000):  # start-up takes seconds (a cap against a hang, not a timing)
            if (tmp_path / "connecting").exists():
                break
            assert proc.poll() is None, proc.communicate()
            time.sleep(0.01)
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=60)  # far below the 3600 s it would otherwise wait
    finally:
        proc.kill()
    assert proc.returncode == status and "Traceback" not in err, err
    assert not (tmp_path / "o.h5").exists()


def test_bad_scheduler_address():
    with pytest.raises(cluster.ClusterError, match="not a scheduler address"):
        cluster.connect("nowhere", timeout=1.0)


@pytest.mark.slow
def test_worker_threads_inside_tasks(client):
    assert cluster.task_threads(None) is None  # here: the caller's default
    assert client.submit(cluster.task_threads, None, pure=False).result() == 1
    assert client.submit(cluster.task_threads, 3, pure=False).result() == 3


def test_states_travel_as_arrays(local):
    """What a task sends back pickles (protocol 5, as Dask sends it) into a few out-of-band array
    buffers, 72 bytes per bin, and a small in-band header — not an object per bin."""
    import pickle

    buffers = []
    head = pickle.dumps(local.state, protocol=5, buffer_callback=buffers.append)
    bins = sum(n for _, n in local.state.layout)
    assert len(head) < 4096 and len(buffers) == 4
    extremes = len(local.state.to_dict()["min"])  # per-photon min/max of the totals
    assert sum(b.raw().nbytes for b in buffers) == 72 * bins + 16 * extremes
    assert pickle.loads(head, buffers=buffers) == local.state


def test_client_must_be_a_client():
    with pytest.raises(subsurf.ParameterError, match="is not a dask.distributed.Client"):
        subsurf.simulate(STACK, 4096, client="tcp://127.0.0.1:8786")
    with pytest.raises(subsurf.ParameterError, match="is not a dask.distributed.Client"):
        subsurf.sweep(sweeps_point, {"a": [1]}, client="tcp://127.0.0.1:8786")


def sweeps_point(a):
    return {"a": a}


@pytest.mark.slow
def test_run_ranges_checks_task_options(client):
    with pytest.raises(subsurf.ParameterError, match="task_photons"):
        _ranges(client, task_photons=1000)
    with pytest.raises(subsurf.ParameterError, match="task_seconds"):
        cluster.run_ranges(client, STACK, 10, 0, None, subsurf.PencilBeam(), None, None, None, task_seconds=0.0)
