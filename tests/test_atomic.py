"""subsurf.atomic: whole-or-nothing writes, --force, targets checked, Ctrl-C held back while writing."""

import errno
import os
import signal

import pytest
from subsurf import atomic


def test_write_creates_replaces_only_with_force(tmp_path):
    p = tmp_path / "f.bin"
    assert atomic.write_bytes(p, b"one") == str(p) and p.read_bytes() == b"one"
    with pytest.raises(FileExistsError, match=f"{p}: exists; use --force"):
        atomic.write_bytes(p, b"two")
    assert p.read_bytes() == b"one"
    atomic.write_bytes(p, b"two", force=True)
    assert p.read_bytes() == b"two"
    assert os.stat(p).st_mode & 0o777 == 0o666 & ~_umask()
    assert sorted(x.name for x in tmp_path.iterdir()) == ["f.bin"]


def _umask():
    m = os.umask(0)
    os.umask(m)
    return m


def test_a_failed_write_leaves_the_previous_file_and_no_temporary(tmp_path, monkeypatch):
    p = tmp_path / "f.bin"
    p.write_bytes(b"previous")
    real_write = os.write
    calls = []

    def full_disk(fd, data):
        calls.append(len(data))
        if len(calls) > 1:
            raise OSError(errno.ENOSPC, "No space left on device")
        return real_write(fd, data[:100])  # a short write first, then the disk is full

    monkeypatch.setattr(os, "write", full_disk)
    with pytest.raises(OSError) as e:
        atomic.write_bytes(p, b"x" * 10_000, force=True)
    assert str(e.value) == f"{p}: cannot write (No space left on device); nothing was written"
    assert e.value.errno == errno.ENOSPC
    assert p.read_bytes() == b"previous" and sorted(x.name for x in tmp_path.iterdir()) == ["f.bin"]


def test_targets_are_checked(tmp_path):
    (tmp_path / "d").mkdir()
    (tmp_path / "f").write_text("x")
    cases = [
        (tmp_path / "no" / "x", FileNotFoundError, "does not exist"),
        (tmp_path / "d", IsADirectoryError, "is a directory"),
        (tmp_path / "f" / "x", NotADirectoryError, "is not a directory"),
        (str(tmp_path) + "/", IsADirectoryError, "not a file name"),
    ]
    for target, cls, text in cases:
        with pytest.raises(cls, match=text):
            atomic.write_bytes(target, b"data", force=True)
    # an input, by any name: a symbolic link, a hard link, a path with ./
    os.symlink(tmp_path / "f", tmp_path / "sym")
    os.link(tmp_path / "f", tmp_path / "hard")
    for alias in (tmp_path / "sym", tmp_path / "hard", tmp_path / "." / "f"):
        with pytest.raises(FileExistsError, match="is also an input"):
            atomic.check_target(alias, force=True, inputs=[tmp_path / "f"])
    assert (tmp_path / "f").read_text() == "x"


def test_partial_path_never_names_an_existing_file(tmp_path):
    p = tmp_path / "r.h5"
    assert atomic.partial_path(p) == str(p)
    p.write_text("complete")
    assert atomic.partial_path(p) == str(tmp_path / "r.partial.h5")
    (tmp_path / "r.partial.h5").write_text("1")
    (tmp_path / "r.partial-2.h5").write_text("2")
    assert atomic.partial_path(p) == str(tmp_path / "r.partial-3.h5")


def test_ctrl_c_is_held_back_until_the_file_is_complete(tmp_path, monkeypatch):
    p = tmp_path / "f.bin"
    real_write = os.write

    def write_and_interrupt(fd, data):
        os.kill(os.getpid(), signal.SIGINT)  # Ctrl-C in the middle of the write
        return real_write(fd, data)

    monkeypatch.setattr(os, "write", write_and_interrupt)
    with pytest.raises(KeyboardInterrupt):
        atomic.write_bytes(p, b"complete")
    assert p.read_bytes() == b"complete"  # written whole before the interrupt was raised
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    with atomic.hold_sigint() as held:
        pass
    assert not held.received


def test_files_written_by_name_are_atomic_with_the_usual_mode(tmp_path):
    """Writers that need a file name (images, sweep files) go through write_with: the usual mode,
    no temporary left, and a writer or check that fails leaves the previous file."""
    import numpy as np
    import subsurf
    from subsurf.render import Image

    img = Image(np.full((4, 5, 3), 0.25, dtype=np.float32), 1, 1, "hierarchical", 0, 0.1)
    paths = img.save(tmp_path / "i.exr") + img.save(tmp_path / "i.npy")
    res = subsurf.sweep(_Double(), {"a": [1.0, 2.0]}, tmp_path / "s.h5")
    assert res.complete
    for p in paths + [str(tmp_path / "s.h5")]:
        assert os.stat(p).st_mode & 0o777 == 0o666 & ~_umask(), p
    assert np.array_equal(np.load(tmp_path / "i.npy"), img.array)
    assert sorted(x.name for x in tmp_path.iterdir()) == ["i.exr", "i.npy", "i.png", "s.h5"]
    p = tmp_path / "i.npy"

    def bad_check(tmp):
        raise ValueError("checksum mismatch")

    with pytest.raises(ValueError, match="checksum"):
        atomic.write_with(p, lambda tmp: open(tmp, "xb").close(), force=True, verify=bad_check)
    assert np.array_equal(np.load(p), img.array)
    assert sorted(x.name for x in tmp_path.iterdir()) == ["i.exr", "i.npy", "i.png", "s.h5"]


class _Double:
    """A sweep point: x = 2a."""

    def fingerprint(self):
        return {"kind": "test.double"}

    def __call__(self, a):
        return {"x": 2.0 * a}
