"""Files written whole or not at all: :func:`write_bytes`, :func:`write_with`, :func:`write_group`,
:func:`check_target`, :func:`hold_sigint`.

Results (``.h5``), MCML ``.mco`` files and figures are serialised in memory first, then written to a
temporary file in the target's directory (``.NAME.XXXXXXXX.subsurf-tmp``; writers that need a file
name — OpenEXR, image libraries, sweep files — fill it themselves through :func:`write_with`),
flushed to the disk (``fsync``) and renamed onto the target. Whatever happens meanwhile — SIGKILL, SIGTERM, a full disk,
a second Ctrl-C — the target holds either its previous content or the complete new file, never a
truncated one. An existing target is replaced only with ``force=True``; without it the temporary
file is published by a hard link, which fails if the target appeared in the meantime (no race
between the check and the write). A process killed with SIGKILL can leave its hidden temporary
file behind; it never replaces anything.

A group of files that belong together (a rendered image's ``.exr`` and its ``.png``) is written by
:func:`write_group`: every file is filled first, then all targets are checked and all are published
while an exclusive lock (``flock``) on their directory is held, so two processes writing the same
group never leave files of different runs side by side, and without ``force`` nothing is published
when any target exists.

Every error is an ``OSError`` whose message is one line naming the file: a missing directory, a
target that is a directory, an existing file, or a failed write (``No space left on device``).
"""

from __future__ import annotations

import contextlib
import errno
import os
import secrets
import signal
import threading

from . import _testhooks

__all__ = ["write_bytes", "write_with", "write_group", "check_target", "hold_sigint", "partial_path", "partial_paths"]

_TMP_SUFFIX = ".subsurf-tmp"


def _same_file(a: str, b: str) -> bool:
    if os.path.realpath(a) == os.path.realpath(b):
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:
        return False


def check_target(path: str | os.PathLike, force: bool = False, inputs=()) -> str:
    """Check that ``path`` can receive a new file; returns it as a str.

    Raises (one-line messages naming the path) ``FileNotFoundError`` when its directory is missing,
    ``NotADirectoryError`` when a parent is a file, ``IsADirectoryError`` when it is a directory,
    ``FileExistsError`` when it exists and ``force`` is False, and ``FileExistsError`` when it is
    one of ``inputs`` (the files the command reads), whatever ``force`` says.
    """
    path = os.fspath(path)
    if not path or path.endswith(("/", os.sep)):
        raise IsADirectoryError(f"{path or repr(path)}: not a file name")
    for inp in inputs:
        if _same_file(path, os.fspath(inp)):
            raise FileExistsError(
                f"{path}: is also an input of this command ({os.fspath(inp)}); choose another output name"
            )
    parent = os.path.dirname(os.path.abspath(path))
    if not os.path.exists(parent):
        raise FileNotFoundError(f"{path}: directory {parent} does not exist")
    if not os.path.isdir(parent):
        raise NotADirectoryError(f"{path}: {parent} is not a directory")
    if os.path.isdir(path):
        raise IsADirectoryError(f"{path}: is a directory; give a file name")
    if os.path.lexists(path) and not force:
        raise FileExistsError(f"{path}: exists; use --force (force=True) to overwrite")
    return path


def partial_path(path: str | os.PathLike) -> str:
    """Where an interrupted run's partial result goes: ``path`` itself when no file is there, else
    the first free ``STEM.partial.EXT``, ``STEM.partial-2.EXT``, … beside it — so a partial result
    never replaces a file (least of all a complete result of the same run)."""
    path = os.fspath(path)
    if not os.path.lexists(path):
        return path
    stem, ext = os.path.splitext(path)
    k = 1
    while True:
        cand = f"{stem}.partial{'' if k == 1 else f'-{k}'}{ext}"
        if not os.path.lexists(cand):
            return cand
        k += 1


def partial_paths(paths) -> list[str]:
    """:func:`partial_path` for a group of files written together: ``paths`` themselves when none
    exists, else the first ``.partial`` / ``.partial-K`` suffix free for every one of them (so the
    group keeps matching names)."""
    paths = [os.fspath(p) for p in paths]
    if not any(os.path.lexists(p) for p in paths):
        return paths
    k = 1
    while True:
        tag = f".partial{'' if k == 1 else f'-{k}'}"
        cand = [f"{stem}{tag}{ext}" for stem, ext in map(os.path.splitext, paths)]
        if not any(os.path.lexists(c) for c in cand):
            return cand
        k += 1


class _Held:
    received = False


@contextlib.contextmanager
def hold_sigint():
    """Hold back Ctrl-C (SIGINT) inside the block; yields an object whose ``received`` says if one came.

    Only on the main thread and while Python's default SIGINT handler is installed (elsewhere it
    does nothing). The caller decides what a held Ctrl-C means once the block has finished.
    """
    held = _Held()
    if threading.current_thread() is not threading.main_thread() or (
        signal.getsignal(signal.SIGINT) is not signal.default_int_handler
    ):
        yield held
        return

    def note(signum, frame):
        held.received = True

    signal.signal(signal.SIGINT, note)
    try:
        yield held
    finally:
        signal.signal(signal.SIGINT, signal.default_int_handler)


def _write_all(fd: int, data) -> None:
    view = memoryview(data).cast("B")
    pause = len(view) // 2 if _testhooks.get("pause_in_write") else None
    pos = 0
    while pos < len(view):
        end = len(view) if pause is None else pause
        pos += os.write(fd, view[pos:end])
        if pause is not None and pos >= pause:
            _testhooks.pause_in_write()  # tests: kill or interrupt here, half of the file written
            pause = None


def _publish(tmp: str, path: str, force: bool) -> None:
    if force:
        os.replace(tmp, path)
        return
    try:
        os.link(tmp, path)
    except FileExistsError:
        raise FileExistsError(f"{path}: exists; use --force (force=True) to overwrite") from None
    except OSError as e:
        if e.errno not in (errno.EPERM, errno.EOPNOTSUPP, errno.ENOTSUP, errno.EMLINK, errno.ENOSYS, errno.EXDEV):
            raise
        # a file system without hard links: check, then rename
        if os.path.lexists(path):
            raise FileExistsError(f"{path}: exists; use --force (force=True) to overwrite") from None
        os.replace(tmp, path)
        return
    os.unlink(tmp)


def _fsync_file(path: str) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _fsync_dir(d: str) -> None:
    try:
        fd = os.open(d, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def write_bytes(path: str | os.PathLike, data, force: bool = False, inputs=()) -> str:
    """Write ``data`` (bytes-like) to ``path`` atomically (see the module docstring); returns the path.

    Ctrl-C is held back while the file is written and renamed, then raised as ``KeyboardInterrupt``
    once the target is complete.
    """

    def write(tmp: str) -> None:
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_CLOEXEC", 0), 0o666)
        try:
            _write_all(fd, data)
        finally:
            os.close(fd)

    return write_with(path, write, force, inputs)


def write_with(path: str | os.PathLike, write, force: bool = False, inputs=(), verify=None) -> str:
    """Create ``path`` atomically with ``write(tmp)``, a writer that needs a file name: it fills the
    temporary file ``tmp`` (in the target's directory, not yet existing); ``verify(tmp)``, if
    given, may check it; the file is then flushed and published as :func:`write_bytes` does.
    Returns the path."""
    path = check_target(path, force, inputs)
    d = os.path.dirname(os.path.abspath(path))
    tmp = os.path.join(d, f".{os.path.basename(path)}.{secrets.token_hex(4)}{_TMP_SUFFIX}")
    with hold_sigint() as held:
        try:
            write(tmp)
            if verify is not None:
                verify(tmp)
            _fsync_file(tmp)
            _publish(tmp, path, force)
        except BaseException as e:
            with contextlib.suppress(OSError):
                os.unlink(tmp)
            if isinstance(e, OSError) and not isinstance(e, FileExistsError):
                raise _write_error(path, e) from None
            raise
        _fsync_dir(d)
    if held.received:
        raise KeyboardInterrupt
    return path


@contextlib.contextmanager
def _dir_lock(d: str):
    """An exclusive ``flock`` on directory ``d`` (nothing where directories cannot be locked)."""
    try:
        import fcntl

        fd = os.open(d, os.O_RDONLY)
    except (ImportError, OSError):
        yield
        return
    try:
        with contextlib.suppress(OSError):
            fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)  # closing releases the lock


def write_group(items, force: bool = False, inputs=()) -> list[str]:
    """Create the files of a group, ``items`` = [(path, write)] with ``write(tmp)`` as in
    :func:`write_with`, all in one directory: each is filled and flushed first; then, under a lock
    on the directory, every target is checked (:func:`check_target`; without ``force`` an existing
    one refuses the whole group) and all are published. Ctrl-C is held back meanwhile. Returns
    the paths."""
    items = [(check_target(p, force, inputs), w) for p, w in items]
    dirs = {os.path.dirname(os.path.abspath(p)) for p, _ in items}
    if len(dirs) != 1:
        raise ValueError(f"write_group: the files {[p for p, _ in items]} must share a directory")
    d = dirs.pop()
    tmps: list[str] = []
    with hold_sigint() as held:
        try:
            for path, write in items:
                tmps.append(os.path.join(d, f".{os.path.basename(path)}.{secrets.token_hex(4)}{_TMP_SUFFIX}"))
                try:
                    write(tmps[-1])
                    _fsync_file(tmps[-1])
                except OSError as e:
                    raise _write_error(path, e) from None
            with _dir_lock(d):
                for path, _ in items:
                    check_target(path, force, inputs)
                for (path, _), tmp in zip(items, tmps):
                    _publish(tmp, path, force)
        finally:
            for tmp in tmps:
                with contextlib.suppress(OSError):
                    os.unlink(tmp)
        _fsync_dir(d)
    if held.received:
        raise KeyboardInterrupt
    return [p for p, _ in items]


def _write_error(path: str, e: OSError) -> OSError:
    err = OSError(f"{path}: cannot write ({e.strerror or e}); nothing was written")
    err.errno = e.errno
    return err
