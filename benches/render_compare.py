"""subsurf ``random_walk`` against Mitsuba 3 ``volpathmis`` on the same scenes (part of `make bench`,
through benches/render_bench.py; docs/render.md, "Benchmark against Mitsuba 3").

Scenes: three objects, each in a constant environment (radiance 1) and under a one-sided
rectangular area light (no environment):
- ``marble``: a sphere of radius 10 mm (icosphere, 5,120 triangles), Jensen's marble (albedo
  ≈ 0.999, η = 1.5);
- ``skin``: a tilted torus whose tube radius varies from 1.2 to 3.6 mm around the ring
  (non-convex, with thin parts; 4,096 triangles), Jensen's skin1 (albedo 0.68–0.96, η = 1.3);
- ``ear``: a thin cupped ellipsoid 22 × 16 mm, 3 mm thick at the centre (5,120 triangles), Jensen's
  skin2, lit from behind by the rectangle (out of the camera's view).

What is made identical (and how):
- geometry: the very triangles subsurf renders, written to a binary PLY (trimesh) and read by
  Mitsuba with ``face_normals = true`` (flat triangles, as subsurf's walk sees them);
- camera: pinhole at the same position, look-at and up; vertical field of view (``fov_axis =
  "y"``); pixel (x, y) covers [x, x+1) × [y, y+1) with row 0 at the top in both; one uniformly
  jittered sample per pixel sample: subsurf's sampler, Mitsuba's ``box`` reconstruction filter
  (radius 0.5 px, so a sample counts only in its own pixel, with weight 1);
- boundary and medium: ``subsurf.render.export.to_mitsuba`` (smooth ``dielectric`` of η,
  ``homogeneous`` medium with albedo σs/σt, σt per channel in mm⁻¹, ``hg`` phase of g; the scene
  unit is the mm);
- lights: subsurf's rectangle centre ± u ± v of power Φ emits radiance L = Φ/(π·4|u×v|) along
  u × v from its front (crates/subsurf-core/src/render/light.rs, ``Light::rect``); in Mitsuba a
  ``rectangle`` with ``to_world`` = [u, v, n̂, centre] (so it spans centre ± u ± v, its normal is
  n̂ = u×v/|u×v| and its area 4|u×v|) and an ``area`` emitter of that radiance, with a black
  diffuse BSDF (subsurf's light is transparent from behind and Mitsuba's is black there; with no
  environment in these scenes both give 0 through it). The environment is a ``constant`` emitter
  of the same radiance;
- path length: Mitsuba ``max_depth = -1`` (unbounded; its Russian roulette from depth 5); subsurf
  follows every scattering and at most ``MAX_DEPTH`` = 6 specular bounces outside the medium;
- threads: 2 in both (Dr.Jit's LLVM backend ``set_thread_count``, subsurf ``threads=2``).

Statistics: each renderer renders each scene ``K`` times with independent seeds; the pixels of
one render are independent, so the variance of an object-pixel mean is Σᵢ sᵢ²/(K n²), sᵢ² the
sample variance of pixel i over the K renders (σ of the mean of the K renders). Object pixels: the
pixels whose centre ray hits the mesh (the same set for both renderers).
"""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import sys
import time

import numpy as np
import subsurf.render as R

HERE = os.path.dirname(os.path.abspath(__file__))
THREADS = 2
LLVM_CANDIDATES = (
    "/usr/lib/x86_64-linux-gnu/libLLVM-19.so",
    "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1",
    "/usr/lib/llvm-19/lib/libLLVM-19.so",
    "/usr/lib/llvm-19/lib/libLLVM.so",
)


# --- scenes ----------------------------------------------------------------------------------


def rect_facing(center, target, half_w, half_h, power):
    """A RectLight at ``center`` of half-edges (half_w, half_h) mm facing ``target``."""
    c, t = np.asarray(center, float), np.asarray(target, float)
    n = (t - c) / np.linalg.norm(t - c)
    a = np.cross(n, [0.0, 0.0, 1.0])
    if np.linalg.norm(a) < 1e-6:
        a = np.cross(n, [1.0, 0.0, 0.0])
    u = a / np.linalg.norm(a) * half_w
    v = np.cross(n, u) / np.linalg.norm(np.cross(n, u)) * half_h  # u × v ∥ n
    return R.RectLight(tuple(c), tuple(u), tuple(v), power)


def marble_object():
    return R.Object.sphere(R.Translucent.library("marble"), radius=10, subdivisions=4, name="marble")


def skin_object():
    """A torus (ring radius 7 mm) whose tube radius varies 1.2–3.6 mm around the ring, tilted."""
    o = R.Object.torus(R.Translucent.library("skin1"), major=7.0, minor=1.0, name="skin")
    p = o.positions.copy()
    phi = np.arctan2(p[:, 1], p[:, 0])
    ring = 7.0 * np.stack([np.cos(phi), np.sin(phi), np.zeros_like(phi)], axis=1)
    tube = 2.4 + 1.2 * np.sin(phi + 0.5)
    p = ring + (p - ring) * tube[:, None]
    return R.Object(p, o.triangles, o.material, name="skin", rotate=(55, 0, 25))


def ear_object():
    """A thin cupped ellipsoid (22 × 16 mm, 3 mm thick at the centre) facing −y (the camera)."""
    o = R.Object.sphere(R.Translucent.library("skin2"), radius=1.0, subdivisions=4)
    p = o.positions * np.array([11.0, 1.5, 8.0])
    p[:, 1] += 0.02 * (p[:, 0] ** 2 + p[:, 2] ** 2)  # cupped away from the camera
    return R.Object(p, o.triangles, o.material, name="ear")


CAMERA = dict(position=(0, -60, 10), look_at=(0, 0, 0), up=(0, 0, 1), fov=24)
EAR_CAMERA = dict(position=(0, -60, 0), look_at=(0, 0, 0), up=(0, 0, 1), fov=24)
#: (object, camera, area light) per object; the lights are out of the camera's view.
OBJECTS = {
    "marble": (marble_object, CAMERA, lambda: rect_facing((-20, -25, 35), (0, 0, 0), 8, 8, 2e4)),
    "skin": (skin_object, CAMERA, lambda: rect_facing((-20, -25, 35), (0, 0, 0), 8, 8, 2e4)),
    "ear": (ear_object, EAR_CAMERA, lambda: rect_facing((0, 30, 35), (0, 0, 0), 8, 8, 2e4)),
}
LIGHTS = ("env", "rect")
ENV = (1.0, 1.0, 1.0)


def scene(obj: str, light: str, size: int) -> R.Scene:
    make, cam, rect = OBJECTS[obj]
    camera = R.Camera(width=size, height=size, **cam)
    if light == "env":
        return R.Scene([make()], [], ENV, camera)
    return R.Scene([make()], [rect()], (0, 0, 0), camera)


# --- the same scene for Mitsuba ----------------------------------------------------------------


def rect_to_mitsuba(light: R.RectLight) -> dict:
    """to_world and radiance of subsurf's RectLight (light.rs: L = Φ / (π · 4|u × v|))."""
    c, u, v = (np.asarray(x, float) for x in (light.position, light.u, light.v))
    uv = np.cross(u, v)
    area = 4.0 * np.linalg.norm(uv)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = u, v, uv / np.linalg.norm(uv), c
    power = np.broadcast_to(np.asarray(light.power, float), (3,))
    return {"to_world": m.tolist(), "radiance": (power / (math.pi * area)).tolist()}


def mitsuba_description(sc: R.Scene, ply: str, rr_depth: int) -> dict:
    """A plain (JSON) description of ``sc`` for benches/mitsuba_worker.py; writes the mesh to ``ply``."""
    import trimesh
    from subsurf.render.export import to_mitsuba

    (o,) = sc.objects
    trimesh.Trimesh(o.positions, o.triangles, process=False).export(ply)
    c = sc.camera
    for light in sc.lights:
        if not isinstance(light, R.RectLight):
            raise ValueError(f"only rectangular lights are converted here, not {light!r}")
    return {
        "ply": ply,
        "rr_depth": rr_depth,
        "material": to_mitsuba(o.material),
        "environment": [float(x) for x in np.broadcast_to(np.asarray(sc.environment, float), (3,))],
        "rects": [rect_to_mitsuba(light) for light in sc.lights],
        "camera": {
            "position": list(map(float, c.position)),
            "look_at": list(map(float, c.look_at)),
            "up": list(map(float, c.up)),
            "fov": c.fov,
            "width": c.width,
            "height": c.height,
        },
    }


# --- object pixels -----------------------------------------------------------------------------


def camera_rays(cam: R.Camera):
    """Unit directions through the pixel centres (subsurf's camera.rs), shape (H, W, 3)."""
    pos, at, up = (np.asarray(x, float) for x in (cam.position, cam.look_at, cam.up))
    f = (at - pos) / np.linalg.norm(at - pos)
    r = np.cross(f, up)
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    th = math.tan(math.radians(cam.fov) / 2)
    x = (2 * (np.arange(cam.width) + 0.5) / cam.width - 1) * th * cam.width / cam.height
    y = (1 - 2 * (np.arange(cam.height) + 0.5) / cam.height) * th
    d = f + x[None, :, None] * r + y[:, None, None] * u
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def object_mask(sc: R.Scene) -> np.ndarray:
    """Pixels whose centre ray hits the (single) object: Möller–Trumbore over all triangles."""
    (o,) = sc.objects
    d = camera_rays(sc.camera).reshape(-1, 3)
    org = np.asarray(sc.camera.position, float)
    tri = o.positions[o.triangles]
    hit = np.zeros(len(d), bool)
    for k in range(0, len(tri), 512):
        t = tri[k : k + 512]
        e1, e2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
        p = np.cross(d[:, None, :], e2[None])
        det = np.einsum("rtk,tk->rt", p, e1)
        inv = 1.0 / np.where(np.abs(det) > 1e-12, det, np.inf)
        s = org - t[:, 0]
        a = np.einsum("rtk,tk->rt", p, s) * inv
        q = np.cross(s, e1)
        b = (d @ q.T) * inv
        dist = (q * e2).sum(-1)[None] * inv
        hit |= ((a >= 0) & (b >= 0) & (a + b <= 1) & (dist > 0)).any(axis=1)
    return hit.reshape(sc.camera.height, sc.camera.width)


# --- statistics --------------------------------------------------------------------------------


def mean_and_sigma(images, mask):
    """Object-pixel mean per channel of the mean of ``images`` (K independent renders) and its σ:
    pixels are independent, so var(mean) = Σᵢ sᵢ² / (K n²), sᵢ² the per-pixel sample variance."""
    a = np.stack([im[mask] for im in images])  # (K, n, 3)
    k, n = a.shape[0], a.shape[1]
    return a.mean(axis=(0, 1)), np.sqrt(a.var(axis=0, ddof=1).sum(axis=0) / (k * n * n))


def rmse(img, ref, mask):
    """RMSE over the object pixels and channels."""
    return float(np.sqrt(np.mean((img[mask] - ref[mask]) ** 2)))


# --- Mitsuba 3 ---------------------------------------------------------------------------------


def llvm_library():
    """DRJIT_LIBLLVM_PATH if set, else the first libLLVM 19 found (Debian's libllvm19)."""
    env = os.environ.get("DRJIT_LIBLLVM_PATH")
    if env:
        return env
    return next((p for p in LLVM_CANDIDATES if os.path.exists(p)), None)


def install_mitsuba(python: str, log):
    """``pip install mitsuba`` into ``python`` and, as root with apt-get, Debian's libllvm19."""
    if subprocess.run([python, "-c", "import mitsuba"], capture_output=True).returncode != 0:
        log("installing Mitsuba 3: pip install mitsuba")
        subprocess.run([python, "-m", "pip", "install", "-q", "mitsuba"], capture_output=True)
    if llvm_library() is None and shutil.which("apt-get") and os.geteuid() == 0:
        log("installing LLVM for Dr.Jit: apt-get install -y libllvm19")
        subprocess.run(
            ["apt-get", "install", "-y", "-qq", "libllvm19"],
            capture_output=True,
            env={**os.environ, "DEBIAN_FRONTEND": "noninteractive"},
        )


class Mitsuba:
    """A persistent benches/mitsuba_worker.py child (one JIT compilation per scene)."""

    def __init__(self, python: str, threads: int, allow_install: bool, log=print):
        self.proc, self.info, self.why = None, {}, ""
        if allow_install:
            install_mitsuba(python, log)
        lib = llvm_library()
        if lib is None:
            self.why = "no libLLVM for Dr.Jit's LLVM backend (apt-get install libllvm19, or set DRJIT_LIBLLVM_PATH)"
            return
        env = {**os.environ, "DRJIT_LIBLLVM_PATH": lib}
        self.proc = subprocess.Popen(
            [python, os.path.join(HERE, "mitsuba_worker.py"), str(threads)],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env=env,
        )
        first = self._read()
        if not first.get("ready"):
            self.why = f"Mitsuba 3 does not start: {first.get('error', 'no reply')}"
            self.close()
            return
        self.info = {**first, "libllvm": lib}

    @property
    def ok(self) -> bool:
        return self.proc is not None

    def _read(self) -> dict:
        line = self.proc.stdout.readline()
        if not line:
            err = self.proc.stderr.read()[-400:] if self.proc.poll() is not None else ""
            return {"error": f"the Mitsuba worker ended ({err.strip() or 'no message'})"}
        return json.loads(line)

    def _ask(self, cmd: dict) -> dict:
        self.proc.stdin.write(json.dumps(cmd) + "\n")
        self.proc.stdin.flush()
        r = self._read()
        if "error" in r:
            raise RuntimeError(r["error"])
        return r

    def load(self, description: dict) -> dict:
        """``build``: seconds of ``load_dict`` (the scene and its BVH); ``wall``: the first render
        of 1 spp (the kernels' compilation)."""
        return self._ask({"cmd": "load", "scene": description})

    def render(self, spp: int, seed: int, out: str):
        """(image, wall s, CPU s)."""
        r = self._ask({"cmd": "render", "spp": spp, "seed": seed, "out": out})
        return np.load(out), r["wall"], r["cpu"]

    def close(self):
        if self.proc is not None:
            try:
                self.proc.stdin.write(json.dumps({"cmd": "quit"}) + "\n")
                self.proc.stdin.flush()
                self.proc.wait(timeout=30)
            except (OSError, subprocess.TimeoutExpired):
                self.proc.kill()
            self.proc = None


def subsurf_render(sc, spp, seed):
    """(image, wall s, CPU s, set-up wall s) of subsurf's random_walk on THREADS threads. The wall
    and CPU seconds are the render's passes, from the end of its set-up (``progress(0, spp)``) on:
    like Mitsuba's, whose renders start from a loaded scene (``load_dict`` builds its BVH) with
    compiled kernels. The set-up (the scene's conversion, BVH, distance grids, cell and pixel
    lists) is returned apart."""
    start = []

    def progress(done, total):
        if done == 0:
            start.append((time.monotonic(), time.process_time()))

    w0 = time.monotonic()
    img = R.render(sc, "random_walk", spp=spp, seed=seed, threads=THREADS, pass_spp=spp, progress=progress)
    w1, c1 = start[0]
    return img.array, time.monotonic() - w1, time.process_time() - c1, w1 - w0


# --- the comparison ----------------------------------------------------------------------------

#: Renders per renderer and scene at each setting (independent seeds): the references (2N spp
#: each), the equal-spp tests (N spp) and Mitsuba's equal-time tests.
K = 4


def plan_spp(budget_cpu: float, per_spp_sub: float, per_spp_mit) -> int:
    """The equal-spp N (a power of 2 in [4, 1024]) whose whole case fits ``budget_cpu`` CPU
    seconds: per renderer K references of 2N and K tests of N spp, plus Mitsuba's K equal-time
    renders (≈ N·t_subsurf/t_Mitsuba spp each, so ≈ K·N spp of subsurf's time)."""
    cost = 3 * K * per_spp_sub + (K * per_spp_sub + 3 * K * per_spp_mit if per_spp_mit else 0)
    n = budget_cpu / max(cost, 1e-9)
    return int(min(max(2 ** math.floor(math.log2(max(n, 1))), 4), 1024))


def run_case(obj: str, light: str, args, mit, tmp: str) -> dict:
    """Every render of one scene, interleaved subsurf / Mitsuba so that the machine's drifting
    load falls on both alike. Returns the images' statistics (see :func:`summarize`)."""
    sc = scene(obj, light, args.compare_size)
    mask = object_mask(sc)
    out = os.path.join(tmp, "m.npy")
    r = {"obj": obj, "light": light, "pixels": int(mask.sum()), "mitsuba": mit is not None}
    if mit is not None:
        loaded = mit.load(mitsuba_description(sc, os.path.join(tmp, f"{obj}.ply"), args.mitsuba_rr_depth))
        r["jit"], r["setup_m"] = loaded["wall"], loaded["build"]
    pilot_s = subsurf_render(sc, 2, 9)[2] / 2
    pilot_m = mit.render(2, 9, out)[2] / 2 if mit is not None else None
    n = args.spp or plan_spp(args.budget, pilot_s, pilot_m)
    r["spp"] = n
    runs = {key: [] for key in ("ref_s", "ref_m", "test_s", "test_m", "eq_m")}
    for k in range(K):
        runs["ref_s"].append(subsurf_render(sc, 2 * n, 100 + k))
        runs["test_s"].append(subsurf_render(sc, n, 200 + k))
        if mit is not None:
            runs["ref_m"].append(mit.render(2 * n, 100 + k, out))
            runs["test_m"].append(mit.render(n, 200 + k, out))
    if mit is not None:
        ts, tm = (np.mean([x[1] for x in runs[key]]) for key in ("test_s", "test_m"))
        r["eq_spp"] = max(1, int(round(n * ts / tm)))
        for k in range(K):
            runs["eq_m"].append(mit.render(r["eq_spp"], 300 + k, out))
    return summarize(r, runs, mask)


def pooled_reference(refs: dict, mask):
    """The reference: each renderer's mean of its K references, combined per channel with
    inverse-variance weights (the average per-pixel variance of each mean over the object
    pixels), so that the noisier renderer does not add its noise to the other's error. Unbiased
    when both are (the parity check). Returns (image, per-pixel variance over the mask)."""
    means = {k: np.mean(v, axis=0) for k, v in refs.items()}
    var = {k: np.stack(v)[:, mask].var(axis=0, ddof=1) / len(v) for k, v in refs.items()}
    if len(refs) == 1:
        (k,) = refs
        return means[k], var[k]
    a_s, a_m = var["ref_s"].mean(axis=0), var["ref_m"].mean(axis=0)
    w = a_m / np.maximum(a_s + a_m, 1e-300)  # subsurf's weight per channel
    ref = w * means["ref_s"] + (1 - w) * means["ref_m"]
    return ref, w**2 * var["ref_s"] + (1 - w) ** 2 * var["ref_m"]


def summarize(r: dict, runs: dict, mask) -> dict:
    """Parity (object means ± σ of each renderer's references), the reference, and per test
    setting: mean wall and CPU seconds; the RMSE against the truth over the object pixels,
    estimated as the mean squared error against the reference over the K renders less the
    reference's own variance (the renders are independent of it: E(T − ref)² = E(T − truth)² +
    var ref); the raw RMSE against the reference beside it; efficiency 1/(RMSE² s)."""
    refs = {key: [x[0] for x in runs[key]] for key in ("ref_s", "ref_m") if runs[key]}
    r["mean_s"], r["sigma_s"] = mean_and_sigma(refs["ref_s"], mask)
    if "ref_m" in refs:
        r["mean_m"], r["sigma_m"] = mean_and_sigma(refs["ref_m"], mask)
        r["z"] = (r["mean_s"] - r["mean_m"]) / np.sqrt(r["sigma_s"] ** 2 + r["sigma_m"] ** 2)
    r["setup_s"] = float(np.median([x[3] for x in runs["test_s"] + runs["ref_s"]]))
    ref, ref_var = pooled_reference(refs, mask)
    r["ref_rmse"] = float(np.sqrt(ref_var.mean()))
    for key in ("test_s", "test_m", "eq_m"):
        if runs[key]:
            raw = float(np.mean([rmse(x[0], ref, mask) ** 2 for x in runs[key]]))
            e = float(np.sqrt(max(raw - ref_var.mean(), 1e-300)))
            wall, cpu = (float(np.mean([x[i] for x in runs[key]])) for i in (1, 2))
            r[key] = {"rmse": e, "raw": raw**0.5, "wall": wall, "cpu": cpu}
            r[key].update(eff=1 / (e * e * wall), eff_cpu=1 / (e * e * cpu))
    return r


def fmt3(v, digits=4):
    return "(" + ", ".join(f"{x:.{digits}f}" for x in v) + ")"


def print_parity(results, log=print):
    log("\nparity: object-pixel mean per channel (R, G, B) of each renderer's references (K x 2N spp), ± σ")
    log(f"  {'scene':<12} {'subsurf random_walk':<44} {'Mitsuba 3 volpathmis':<44} {'z = diff / σ':<24} 4σ")
    for r in results:
        s = " ".join(f"{m:.4f}±{e:.4f}" for m, e in zip(r["mean_s"], r["sigma_s"]))
        if "mean_m" not in r:
            log(f"  {r['obj'] + ' ' + r['light']:<12} {s:<44} (Mitsuba unavailable)")
            continue
        m = " ".join(f"{a:.4f}±{e:.4f}" for a, e in zip(r["mean_m"], r["sigma_m"]))
        z = " ".join(f"{x:+.1f}" for x in r["z"])
        ok = "ok" if np.all(np.abs(r["z"]) <= 4) else "DIFFERS"
        log(f"  {r['obj'] + ' ' + r['light']:<12} {s:<44} {m:<44} {z:<24} {ok}")


def _cell(t: dict) -> str:
    return f"{t['wall']:7.2f} {t['cpu']:7.2f} {t['rmse']:9.3e} {t['raw']:9.3e} {t['eff']:9.3g}"


def print_efficiency(results, log=print):
    log(
        "\nefficiency = 1/(RMSE² · s): RMSE over the object pixels against the truth, estimated from the "
        "squared error against the reference less the reference's variance ('raw': against the reference); "
        "s = wall seconds (CPU seconds beside them) of rendering a loaded scene (Mitsuba: mi.render after "
        "load_dict, kernels compiled; subsurf: the passes after its set-up); ratio = subsurf / Mitsuba (wall; "
        "CPU in brackets)"
    )
    log(
        "  the set-ups, not in s (wall seconds): "
        + ", ".join(
            f"{r['obj']} {r['light']} subsurf {r['setup_s']:.3f} per render"
            + (f", Mitsuba load_dict {r['setup_m']:.3f}" if "setup_m" in r else "")
            for r in results
        )
    )
    log(
        "  the reference's own noise (RMSE against the truth, from the per-pixel variances): "
        + ", ".join(f"{r['obj']} {r['light']} {r['ref_rmse']:.2e}" for r in results)
    )
    head = f"{'wall s':>7} {'CPU s':>7} {'RMSE':>9} {'raw':>9} {'eff.':>9}"
    for title, key in (("equal spp", "test_m"), ("equal time", "eq_m")):
        log(f"  {title}:")
        log(f"  {'scene':<12} {'spp':>5} {head}  | {'spp':>5} {head}  | {'ratio':>13}")
        for r in results:
            s = r["test_s"]
            row = f"  {r['obj'] + ' ' + r['light']:<12} {r['spp']:>5} {_cell(s)}  |"
            if key in r:
                m = r[key]
                spp = r["spp"] if key == "test_m" else r["eq_spp"]
                ratio = f"{s['eff'] / m['eff']:.2f}x [{s['eff_cpu'] / m['eff_cpu']:.2f}x]"
                row += f" {spp:>5} {_cell(m)}  | {ratio:>13}"
            else:
                row += " (Mitsuba unavailable)"
            log(row)


if __name__ == "__main__":
    sys.exit("run benches/render_bench.py")
