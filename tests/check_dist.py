"""Install the built wheel into a fresh virtual environment outside the source tree and run the
demo's quick mode there (``make dist-check``; not collected by pytest: it builds a venv).

Usage: ``python tests/check_dist.py DIST_DIR``. Checks the wheel's tags (cp39-abi3, manylinux) and
that the sdist is there, then ``python -m venv`` in a temporary directory, ``pip install`` of the
wheel alone, without extras (its dependencies come from the registry or the local pip cache), and
from a working directory outside the tree: ``import subsurf`` must load the installed copy,
``subsurf render`` of each ``examples/render/*.toml`` (1 spp) must write its PNG, and
``subsurf demo --quick`` must exit 0 and write its PNGs. Prints the times of each step.
"""

from __future__ import annotations

import glob
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def step(what: str, cmd: list, **kw) -> subprocess.CompletedProcess:
    t0 = time.monotonic()
    proc = subprocess.run(cmd, capture_output=True, text=True, **kw)
    print(f"{what}: {time.monotonic() - t0:.1f} s (exit {proc.returncode})")
    if proc.returncode != 0:
        sys.stdout.write(proc.stdout[-4000:])
        sys.stderr.write(proc.stderr[-4000:])
        raise SystemExit(f"check_dist: {what} failed")
    return proc


def main(dist: str) -> int:
    wheels = sorted(glob.glob(os.path.join(dist, "subsurf-*.whl")))
    sdists = sorted(glob.glob(os.path.join(dist, "subsurf-*.tar.gz")))
    if len(wheels) != 1 or len(sdists) != 1:
        raise SystemExit(f"check_dist: expected one wheel and one sdist in {dist}, found {wheels + sdists}")
    wheel = os.path.abspath(wheels[0])
    tags = os.path.basename(wheel)[:-4].split("-")[-3:]  # python, abi, platform
    print(f"wheel: {os.path.basename(wheel)} ({os.path.getsize(wheel) / 1e6:.1f} MB); sdist: {sdists[0]}")
    if tags[1] != "abi3" or not any(p.startswith("manylinux") for p in tags[2].split(".")):
        raise SystemExit(f"check_dist: the wheel must be tagged abi3 and manylinux, not {tags}")
    with tempfile.TemporaryDirectory(prefix="subsurf-dist-") as tmp:
        env_dir, work = os.path.join(tmp, "venv"), os.path.join(tmp, "work")
        os.mkdir(work)
        py, subsurf = os.path.join(env_dir, "bin", "python"), os.path.join(env_dir, "bin", "subsurf")
        env = {k: v for k, v in os.environ.items() if k not in ("VIRTUAL_ENV", "PYTHONPATH", "PYTHONHOME")}
        env["PATH"] = os.path.join(env_dir, "bin") + os.pathsep + env.get("PATH", "")
        env["MPLBACKEND"] = "Agg"
        step("python -m venv", [sys.executable, "-m", "venv", env_dir])
        step("pip install the wheel", [py, "-m", "pip", "install", "-q", wheel], cwd=work, env=env)
        where = step(
            "import subsurf",
            [py, "-c", "import subsurf, subsurf._core; print(subsurf._core.__file__)"],
            cwd=work,
            env=env,
        )
        if str(ROOT) in where.stdout:
            raise SystemExit(f"check_dist: subsurf was imported from the source tree: {where.stdout.strip()}")
        scenes = Path(work, "render")  # the README's render flow, without the render extra
        shutil.copytree(ROOT / "examples" / "render", scenes)
        for scene in sorted(scenes.glob("*.toml")):
            out = f"{scene.stem}.png"
            step(
                f"subsurf render {scene.name}",
                [subsurf, "render", scene.name, "-o", out, "--spp", "1"],
                cwd=scenes,
                env=env,
            )
            if not (scenes / out).is_file():
                raise SystemExit(f"check_dist: subsurf render {scene.name} wrote no {out}")
        demo = step("subsurf demo --quick", [subsurf, "demo", "--quick"], cwd=work, env=env)
        sys.stdout.write(demo.stdout[-1500:])
        pngs = sorted(Path(work, "out").glob("*.png"))
        if not pngs:
            raise SystemExit("check_dist: the demo wrote no PNG under out/")
        print("wrote:", ", ".join(p.name for p in pngs))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1] if len(sys.argv) > 1 else "dist"))
