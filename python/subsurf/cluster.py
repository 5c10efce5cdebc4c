"""Monte Carlo runs on a Dask cluster: :func:`connect` and the photon-range scheduler behind
``subsurf.simulate(..., client=client)`` (docs/cluster.md).

Nothing here is imported by ``import subsurf``; Dask (``pip install 'subsurf[cluster]'``) is
imported only when a cluster is used.

How a run is split (``run_ranges``): photons ``[start, photons)`` are cut into consecutive
ranges, each a Dask task running :func:`subsurf.simulate_range` on a worker and returning its
exact :class:`~subsurf.state.TallyState` (numpy arrays: 9 uint64 words per bin). States are
merged on the client in range order as soon as the prefix they extend is complete; because the
merge is exact (integer sums per 4096-photon chunk, docs/architecture.md) the result has the
bits of a local run with the same seed, whatever the number of workers, the task sizes, the
order in which tasks finish, and the tasks Dask re-runs after losing a worker.

Task size (see :func:`task_photons`): a task should run for about ``task_seconds`` (5 s by
default) — long enough that Dask's per-task cost (a few ms, measured by ``make bench``) and
shipping the state back are negligible, short enough that the progress bar moves, Ctrl-C
answers within seconds and a lost worker costs only seconds of work. Tasks shrink towards the
end of a run (guided self-scheduling: at most half of the remaining photons per worker thread)
so that the workers finish together. The photon rate is measured from the tasks that have
finished (before the first one, guessed from :func:`subsurf._core.mc_expected_events`); task
sizes never change the result.
"""

from __future__ import annotations

import asyncio
import math
import sys
import threading
import time
import uuid

from . import _core, _testhooks
from .state import CHUNK_PHOTONS, TallyState

__all__ = [
    "ClusterError",
    "check_client",
    "connect",
    "task_photons",
    "task_threads",
    "DEFAULT_TASK_SECONDS",
    "CONNECT_TIMEOUT",
    "MAX_CONNECT_TIMEOUT",
    "check_timeout",
    "scheduler_lost",
]

#: Target duration of one photon-range task, seconds.
DEFAULT_TASK_SECONDS = 5.0
#: Seconds to wait for a scheduler to answer in :func:`connect`.
CONNECT_TIMEOUT = 10.0
#: Longest wait :func:`connect` accepts, seconds (a scheduler that is starting comes up in seconds).
MAX_CONNECT_TIMEOUT = 3600.0
#: How often the waiting thread looks for Ctrl-C and SIGTERM while connecting, seconds.
POLL_S = 0.05
#: Scattering events per second per thread assumed before the first task reports its speed.
RATE_GUESS = 1e7
#: Bytes per second assumed for shipping a state to the client and merging it.
SHIP_BYTES_PER_S = 1e8
#: Tasks submitted but not yet merged, per worker thread (bounds the client's memory).
AHEAD_PER_THREAD = 4


class ClusterError(ConnectionError):
    """A scheduler that does not answer, or an address that is not one (one-line message)."""


def _distributed():
    try:
        import distributed
    except ImportError:
        raise ImportError("running on a Dask cluster needs dask.distributed: pip install 'subsurf[cluster]'") from None
    return distributed


async def _identity(address: str, timeout: float) -> dict:
    from distributed.comm import connect as comm_connect

    comm = await comm_connect(address, timeout=timeout)
    try:
        await comm.write({"op": "identity", "reply": True})
        return await comm.read()
    finally:
        comm.abort()


class _ProbeTimeout(Exception):
    pass


def _probe(address: str, timeout: float) -> dict:
    """The scheduler's identity, asked for with a bounded wait. (A ``Client`` waits for ever on a
    server that accepts the connection but never answers the handshake; this does not.)

    The question runs on an event loop of its own in a daemon thread; this thread waits for it in
    steps of :data:`POLL_S`, so Ctrl-C and SIGTERM (as the command line's exception) are handled at
    once, and gives up after ``timeout`` seconds whatever the question is doing (it is then
    cancelled, and never holds the process)."""
    loop = asyncio.new_event_loop()
    box: dict = {}

    def ask() -> None:
        try:
            box["identity"] = loop.run_until_complete(asyncio.wait_for(_identity(address, timeout), timeout))
        except BaseException as e:  # noqa: BLE001 - handed to the waiting thread
            box["error"] = e
        finally:
            loop.close()

    thread = threading.Thread(target=ask, name="subsurf-connect", daemon=True)
    thread.start()
    _testhooks.touch("connecting")  # tests: interrupt here, while the scheduler is awaited
    deadline = time.monotonic() + timeout
    try:
        while thread.is_alive() and time.monotonic() < deadline:
            thread.join(min(POLL_S, max(deadline - time.monotonic(), 0.0)))
    finally:
        if thread.is_alive():  # timed out or interrupted: cancel the question; nobody waits for it
            try:
                loop.call_soon_threadsafe(lambda: [t.cancel() for t in asyncio.all_tasks(loop)])
            except RuntimeError:  # the loop closed meanwhile
                pass
    if "error" in box:
        raise box["error"]
    if "identity" not in box:
        raise _ProbeTimeout
    return box["identity"]


def check_timeout(timeout, name: str = "timeout") -> float:
    """``timeout`` (seconds) if it is in (0, :data:`MAX_CONNECT_TIMEOUT`]; ParameterError otherwise."""
    try:
        t = float(timeout)
    except (TypeError, ValueError):
        t = math.nan
    if not 0 < t <= MAX_CONNECT_TIMEOUT:
        raise _core.ParameterError(
            f"{name} = {timeout!r} is out of range: seconds in (0, {MAX_CONNECT_TIMEOUT:g}] to wait for the scheduler"
        )
    return t


def connect(address: str, timeout: float = CONNECT_TIMEOUT):
    """A ``dask.distributed.Client`` connected to the scheduler at ``address``
    (``tcp://HOST:PORT``). A scheduler that does not answer within ``timeout`` seconds (at most
    :data:`MAX_CONNECT_TIMEOUT`; ParameterError beyond), or an address that is not one, raises
    :class:`ClusterError` with a one-line message; this never hangs, and Ctrl-C or SIGTERM stop
    the wait at once. Close the client when done (``with connect(...) as client:``)."""
    distributed = _distributed()
    timeout = check_timeout(timeout)
    address = str(address)
    try:
        info = _probe(address, timeout)
    except ValueError as e:
        raise ClusterError(f"{address!r} is not a scheduler address (tcp://HOST:PORT): {e}") from None
    except (OSError, asyncio.TimeoutError, asyncio.CancelledError, _ProbeTimeout):
        raise ClusterError(
            f"no Dask scheduler answered at {address} within {timeout:g} s "
            "(start one with `dask scheduler`, see docs/cluster.md)"
        ) from None
    if not (isinstance(info, dict) and info.get("type") == "Scheduler"):
        kind = info.get("type") if isinstance(info, dict) else type(info).__name__
        raise ClusterError(f"{address} is not a Dask scheduler (it says it is a {kind})")
    try:
        return distributed.Client(address, timeout=timeout, set_as_default=False)
    except (OSError, asyncio.TimeoutError) as e:
        raise ClusterError(f"could not connect to the Dask scheduler at {address}: {e}") from None


def check_client(client) -> None:
    """Refuse what is not a ``dask.distributed.Client`` (e.g. an address string) with a clear error."""
    if not all(hasattr(client, a) for a in ("submit", "cancel", "nthreads")):
        raise _core.ParameterError(
            f"client = {client!r} is not a dask.distributed.Client (for an address, use subsurf.cluster.connect)"
        )


def task_threads(threads):
    """Threads for a Monte Carlo run inside a Dask task: 1 unless given (a Dask worker runs one
    task per worker thread, so more would oversubscribe its cores); ``threads`` elsewhere."""
    if threads is None and "distributed" in sys.modules:
        from distributed import get_worker

        try:
            get_worker()
            return 1
        except ValueError:
            pass
    return threads


def task_photons(remaining: int, workers: int, rate: float, state_bytes: int, task_seconds: float) -> int:
    """Photons of the next task (a multiple of the 4096-photon chunk, at least one chunk, at most
    ``remaining``): about ``task_seconds`` of work at ``rate`` photons/s per task, lengthened so
    that shipping a state of ``state_bytes`` takes ≤ 5 % of it, and at most ``remaining / (2 ·
    workers)`` (but not below an eighth of the target) so that the last tasks are short."""
    target = max(task_seconds, 20.0 * state_bytes / SHIP_BYTES_PER_S)
    full = rate * target
    n = min(full, max(remaining / (2.0 * max(workers, 1)), full / 8.0))
    n = CHUNK_PHOTONS * max(1, math.ceil(n / CHUNK_PHOTONS))
    return int(min(n, remaining))


class TaskCancelled(Exception):
    """Stops a photon-range task whose future was cancelled (its result is not wanted)."""


def _cancel_watch():
    """A ``progress`` callback for a run inside a Dask task that stops it (within 50 ms) once the
    task is cancelled — Dask does not interrupt a running task, so a cancelled run would otherwise
    hold its worker thread until it ends. None outside a task (or if the worker's bookkeeping
    cannot be read)."""
    try:
        from distributed import get_worker
        from distributed.worker import thread_state

        worker, key = get_worker(), thread_state.key
        worker.state.tasks  # noqa: B018 - fail here, not in the callback, if the layout differs
    except (ImportError, ValueError, AttributeError):
        return None

    def progress(done, total):
        ts = worker.state.tasks.get(key)
        if ts is None or ts.state in ("cancelled", "released", "forgotten"):
            raise TaskCancelled(key)

    return progress


def _range_task(stack, start, stop, seed, threads, source, tallies):
    """What a worker runs: photons [start, stop) → (exact state, seconds)."""
    from .mc import simulate_range

    t0 = time.perf_counter()
    state = simulate_range(
        stack, start, stop, seed=seed, threads=threads, source=source, tallies=tallies, progress=_cancel_watch()
    )
    return state, time.perf_counter() - t0


def _state_bytes(state: TallyState) -> int:
    return sum(v.nbytes for v in state.to_dict().values() if hasattr(v, "nbytes"))


class _Ranges:
    """The client side of one cluster run: submits ranges, merges finished ones in order."""

    def __init__(self, client, stack, photons, seed, threads, source, tallies, progress, prior, task_seconds, fixed):
        self.client, self.stack, self.photons, self.seed = client, stack, photons, seed
        self.threads = 1 if threads is None else threads
        self.source, self.tallies, self.progress = source, tallies, progress
        self.prefix = prior  # merged state of photons [0, next_merge)
        self.next_merge = prior.stop if prior is not None else 0
        self.next_submit = self.next_merge
        self.total = photons - self.next_merge
        self.task_seconds, self.fixed = float(task_seconds), fixed
        self.pending: dict = {}  # start -> future
        self.finished: dict = {}  # start -> state, waiting for the ranges before it
        self.done_photons = 0
        self.busy_s = 0.0
        self.traced = 0
        self.state_bytes = 0
        self.tag = uuid.uuid4().hex[:10]
        self.submitted = 0
        self.taken = 0
        events = _core.mc_expected_events(*stack._to_core())
        self.rate_guess = RATE_GUESS * self.threads / max(events, 1.0)

    def workers(self) -> int:
        try:
            return max(1, sum(self.client.nthreads().values()))
        except Exception:  # noqa: BLE001 - a scheduler hiccup only affects the task size
            return 1

    def size(self, workers: int) -> int:
        remaining = self.photons - self.next_submit
        if self.fixed is not None:
            return min(self.fixed, remaining)
        rate = self.traced / self.busy_s if self.busy_s > 0 else self.rate_guess
        return task_photons(remaining, workers, rate, self.state_bytes, self.task_seconds)

    def submit(self) -> None:
        if self.client.status != "running":  # the scheduler went away (the client reconnects or closed)
            raise _ClusterGone(f"the client is {self.client.status}")
        workers = self.workers()
        ahead = AHEAD_PER_THREAD * workers
        while self.next_submit < self.photons and len(self.pending) + len(self.finished) < ahead:
            start = self.next_submit
            stop = start + self.size(workers)
            fut = self.client.submit(
                _range_task,
                self.stack,
                start,
                stop,
                self.seed,
                self.threads,
                self.source,
                self.tallies,
                key=f"subsurf-photons-{self.tag}-{start}-{stop}",
                pure=False,
                priority=-self.submitted,  # earlier ranges first: the merged prefix grows steadily
            )
            self.submitted += 1
            self.pending[start] = fut
            self.ac.add(fut)
            self.next_submit = stop

    def take(self, fut) -> None:
        """A finished task: keep its state, merge, report progress."""
        state, seconds = fut.result()
        self.pending.pop(state.start, None)
        self.finished[state.start] = state
        self.done_photons += state.photons
        self.traced += state.photons
        self.busy_s += seconds
        self.state_bytes = max(self.state_bytes, _state_bytes(state))
        self.merge()
        if self.progress is not None:
            self.progress(self.done_photons, self.total)
        self.taken += 1
        _testhooks.after_task(self.taken, self.client)  # tests: lose the scheduler here

    def merge(self) -> None:
        """Append every finished range that now follows the merged prefix (in range order)."""
        run = []
        while self.next_merge in self.finished:
            s = self.finished[self.next_merge]
            run.append(s)
            self.next_merge = s.stop
        if run:
            self.prefix = TallyState.concat(([self.prefix] if self.prefix is not None else []) + run)
            for s in run:
                del self.finished[s.start]

    def run(self) -> str | None:
        """Trace everything; returns None when complete, else why the run stopped early —
        ``"interrupted"`` (Ctrl-C or ``progress`` raising KeyboardInterrupt) or a sentence on the
        lost scheduler (:func:`scheduler_lost`) — in which case the merged prefix is what was completed."""
        distributed = _distributed()
        self.ac = distributed.as_completed(loop=self.client.loop)
        try:
            self.submit()
            while self.pending:
                self.take(next(self.ac))
                self.submit()
            return None
        except KeyboardInterrupt:
            self.stop(collect=True)
            return "interrupted"
        except BaseException as e:
            lost = scheduler_lost(e)
            self.stop(collect=False, cancel=lost is None)  # nobody to cancel with on a lost scheduler
            if lost is None:
                raise
            return lost

    def stop(self, collect: bool, cancel: bool = True) -> None:
        """Cancel what is left (with ``cancel``); with ``collect``, first keep the tasks that
        already finished."""
        futs = list(self.pending.values())
        self.pending.clear()
        if collect:
            for f in futs:
                if f.status == "finished":
                    try:
                        state, _ = f.result(timeout=CONNECT_TIMEOUT)
                        self.finished[state.start] = state
                    except Exception:  # noqa: BLE001 - a state we cannot fetch is just not kept
                        pass
            self.merge()
        if futs and cancel:
            try:
                self.client.cancel(futs)
            except Exception:  # noqa: BLE001 - a scheduler gone away cancels everything anyway
                pass


class _ClusterGone(Exception):
    """The client no longer has a scheduler to talk to."""


def scheduler_lost(e: BaseException) -> str | None:
    """A sentence saying the scheduler went away when ``e`` is how Dask reports it (the
    connection closed, the client reconnecting, or the tasks cancelled by anyone but this run);
    None for anything else (a task's own error, which is raised)."""
    from distributed.client import FutureCancelledError
    from distributed.comm import CommClosedError

    if isinstance(e, (FutureCancelledError, CommClosedError, _ClusterGone)):
        why = getattr(e, "reason", None) or str(e) or type(e).__name__
        return f"the Dask scheduler stopped answering ({why})"
    return None


def run_ranges(
    client,
    stack,
    photons: int,
    seed: int,
    threads,
    source,
    tallies,
    progress,
    prior: TallyState | None,
    task_seconds: float | None = None,
    task_photons: int | None = None,
):
    """Trace photons ``[prior.stop or 0, photons)`` on ``client``'s workers; returns ``(state,
    stopped)`` where ``state`` is the merged state of photons ``[0, N)`` (``None`` if nothing
    was completed) and ``stopped`` None for a complete run, else why it stopped early:
    ``"interrupted"`` (Ctrl-C) or a sentence on the lost scheduler (its finished photons are kept,
    as on Ctrl-C). ``task_seconds`` (default :data:`DEFAULT_TASK_SECONDS`) sets the task
    duration aimed at, ``task_photons`` a fixed task size instead. Arguments are checked by
    :func:`subsurf.simulate`."""
    _distributed()
    check_client(client)
    if task_seconds is None:
        task_seconds = DEFAULT_TASK_SECONDS
    if task_photons is None and _testhooks.get("task_photons"):
        task_photons = int(_testhooks.get("task_photons"))
    if not (task_seconds > 0 and math.isfinite(task_seconds)):
        raise _core.ParameterError(f"task_seconds = {task_seconds!r} is out of range: must be a number > 0")
    if task_photons is not None and (task_photons < 1 or task_photons % CHUNK_PHOTONS):
        raise _core.ParameterError(
            f"task_photons = {task_photons!r} is out of range: must be a positive multiple of {CHUNK_PHOTONS}"
        )
    r = _Ranges(client, stack, photons, seed, threads, source, tallies, progress, prior, task_seconds, task_photons)
    stopped = r.run()
    return r.prefix, stopped
