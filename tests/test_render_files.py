"""``subsurf render`` follows the command line's file rules (:mod:`subsurf.atomic`): ``--force``,
every output (the .exr and its .png) checked before the render, a partial image never over a file,
the files of one image published together."""

from __future__ import annotations

import fcntl
import threading

import pytest
from subsurf import atomic

SCENE = """
[render]
spp = 2
[camera]
position = [0, -30, 5]
width = 6
height = 6
[[lights]]
type = "point"
position = [0, -20, 20]
power = 3000
[[objects]]
shape = "sphere"
radius = 3
subdivisions = 1
material = "marble"
"""


@pytest.fixture
def scene(tmp_path):
    p = tmp_path / "s.toml"
    p.write_text(SCENE)
    return p


def test_existing_image_needs_force(tmp_path, scene, cli_here, error_here):
    out = tmp_path / "o.png"
    out.write_bytes(b"previous")
    error_here("render", scene, "-o", out, "-q", fragments=[f"{out}: exists; use --force"])
    assert out.read_bytes() == b"previous"
    status, stdout, _ = cli_here("render", scene, "-o", out, "-q", "--force")
    assert status == 0 and out.read_bytes()[:4] == b"\x89PNG" and f"wrote {out}" in stdout


def test_sibling_outputs_are_checked_before_anything(tmp_path, scene, error_here):
    """``-o note.exr`` also writes note.png: an unrelated note.png is not replaced without --force,
    and nothing is written (the check comes before the render)."""
    note = tmp_path / "note.png"
    note.write_bytes(b"my notes")
    error_here("render", scene, "-o", tmp_path / "note.exr", "-q", fragments=[f"{note}: exists; use --force"])
    assert note.read_bytes() == b"my notes" and not (tmp_path / "note.exr").exists()
    (tmp_path / "x.png").mkdir()
    error_here("render", scene, "-o", tmp_path / "x.exr", "-q", "--force", fragments=["x.png: is a directory"])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["note.png", "s.toml", "x.png"]
    error_here("render", scene, "-o", tmp_path / "x.tiff", "-q", fragments=["unknown image format '.tiff'"])


def test_a_partial_render_never_replaces_a_complete_image(tmp_path, scene, cli):
    """Ctrl-C (the test hook raises it at the first progress call) with a complete full.exr and
    full.png in place, even with --force: the partial image goes to full.partial.exr/.png."""
    full = tmp_path / "full.exr"
    r = cli("render", scene, "-o", full, "-q")
    assert r.returncode == 0, r.stderr
    before = {p.name: p.read_bytes() for p in tmp_path.glob("full.*")}
    assert sorted(before) == ["full.exr", "full.png"]
    r = cli("render", scene, "-o", full, "-q", "--force", "--spp", "64", hook="interrupt_after=1")
    assert r.returncode == 130, r.stderr
    assert "partial" in r.stdout and "full.partial.exr" in r.stdout and "Traceback" not in r.stderr
    assert {p.name: p.read_bytes() for p in tmp_path.glob("full.*") if "partial" not in p.name} == before
    assert sorted(p.name for p in tmp_path.glob("full.partial.*")) == ["full.partial.exr", "full.partial.png"]
    assert not list(tmp_path.glob(".*subsurf-tmp"))


def test_write_group_publishes_a_group_as_one(tmp_path, monkeypatch):
    """Two writers of the same group (two renders to one -o, --force): the second waits for the
    first's whole group, so the files always come from one run. A pauses between its two files;
    had B not waited on the directory lock, it would finish meanwhile and A's .png would follow B's
    .exr."""
    paths = [str(tmp_path / "x.exr"), str(tmp_path / "x.png")]
    real_publish, real_flock = atomic._publish, fcntl.flock
    a_between, a_go, b_locking = threading.Event(), threading.Event(), threading.Event()

    def publish(tmp, path, force):
        real_publish(tmp, path, force)
        if threading.current_thread().name == "A" and path.endswith(".exr"):
            a_between.set()
            assert a_go.wait(30)

    def flock(fd, op):
        if threading.current_thread().name == "B":
            b_locking.set()
        return real_flock(fd, op)

    monkeypatch.setattr(atomic, "_publish", publish)
    monkeypatch.setattr(fcntl, "flock", flock)

    def group(tag):
        return [(p, lambda tmp, tag=tag: open(tmp, "x").write(tag)) for p in paths]

    a = threading.Thread(target=atomic.write_group, args=(group("A"),), kwargs={"force": True}, name="A")
    a.start()
    assert a_between.wait(30)
    b = threading.Thread(target=atomic.write_group, args=(group("B"),), kwargs={"force": True}, name="B")
    b.start()
    assert b_locking.wait(30)
    b.join(1.0)  # B is held at the lock (or, were the lock broken, would finish here)
    a_go.set()
    a.join(30)
    b.join(30)
    assert [open(p).read() for p in paths] == ["B", "B"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.exr", "x.png"]


def test_write_group_without_force_publishes_nothing_when_one_exists(tmp_path):
    (tmp_path / "x.png").write_text("keep")
    items = [(str(tmp_path / n), lambda tmp: open(tmp, "x").write("new")) for n in ("x.exr", "x.png")]
    with pytest.raises(FileExistsError, match="x.png: exists; use --force"):
        atomic.write_group(items)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.png"] and (tmp_path / "x.png").read_text() == "keep"
    assert atomic.partial_paths([str(tmp_path / "x.exr"), str(tmp_path / "x.png")]) == [
        str(tmp_path / "x.partial.exr"),
        str(tmp_path / "x.partial.png"),
    ]
