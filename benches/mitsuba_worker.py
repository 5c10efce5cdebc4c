"""Mitsuba 3 side of the render comparison (benches/render_compare.py), run as a child process so
that a missing or crashing Mitsuba never takes the subsurf benchmark down with it.

Protocol: one JSON object per line on stdin, one JSON reply per line on stdout.
- ``{"cmd": "load", "scene": {...}}``: build the scene (``render_compare.mitsuba_description``: a
  PLY path, material dict of ``subsurf.render.export.to_mitsuba``, lights, environment, camera)
  and render it once at 1 spp so that Dr.Jit compiles its kernels; replies with the seconds of
  that first render (JIT compilation included), which the timed renders do not pay.
- ``{"cmd": "render", "spp": N, "seed": S, "out": "path.npy"}``: render, write the (H, W, 3)
  float64 image to ``out``; replies ``{"wall": s, "cpu": s}`` (wall clock and CPU time of the
  render, the image's evaluation included; a render during which Dr.Jit compiled a kernel, by its
  kernel history, is timed again with the kernels cached) and the compilation seconds.
- ``{"cmd": "quit"}``.
The first line written is ``{"ready": true, "mitsuba": version, "drjit": version, "variant": v,
"threads": n}`` or ``{"ready": false, "error": "..."}``.

Usage: python benches/mitsuba_worker.py THREADS (DRJIT_LIBLLVM_PATH in the environment).
"""

from __future__ import annotations

import json
import sys
import time

import numpy as np

VARIANTS = ("llvm_ad_rgb", "llvm_rgb")


def reply(obj):
    sys.stdout.write(json.dumps(obj) + "\n")
    sys.stdout.flush()


def start(threads: int):
    import drjit as dr
    import mitsuba as mi

    have = mi.variants()
    variant = next((v for v in VARIANTS if v in have), None)
    if variant is None:
        raise RuntimeError(f"no LLVM RGB variant among {have}")
    mi.set_variant(variant)
    dr.set_thread_count(threads)
    mi.set_log_level(mi.LogLevel.Warn)
    dr.set_flag(dr.JitFlag.KernelHistory, True)
    return mi, dr, variant


def compile_seconds(dr) -> float:
    """Seconds Dr.Jit spent generating and compiling kernels since the last call (0 on cache hits)."""
    return sum(k.get("codegen_time", 0.0) + k.get("backend_time", 0.0) for k in dr.kernel_history()) / 1000.0


def transform(mi, m):
    return mi.ScalarTransform4f(np.asarray(m, dtype=np.float64).tolist())


def build(mi, sc: dict):
    """The Mitsuba scene of a plain description (see render_compare.mitsuba_description)."""
    cam = sc["camera"]
    d = {
        "type": "scene",
        "integrator": {"type": "volpathmis", "max_depth": -1, "rr_depth": int(sc["rr_depth"])},
        "sensor": {
            "type": "perspective",
            "fov": cam["fov"],
            "fov_axis": "y",
            "to_world": mi.ScalarTransform4f().look_at(origin=cam["position"], target=cam["look_at"], up=cam["up"]),
            "film": {
                "type": "hdrfilm",
                "width": cam["width"],
                "height": cam["height"],
                "rfilter": {"type": "box"},
                "pixel_format": "rgb",
                "component_format": "float32",
            },
            "sampler": {"type": "independent", "sample_count": 1},
        },
        "object": {
            "type": "ply",
            "filename": sc["ply"],
            "face_normals": True,
            "bsdf": sc["material"]["bsdf"],
            "interior": sc["material"]["interior"],
        },
    }
    if any(sc["environment"]):
        d["environment"] = {"type": "constant", "radiance": {"type": "rgb", "value": sc["environment"]}}
    for i, light in enumerate(sc["rects"]):
        d[f"rect{i}"] = {
            "type": "rectangle",
            "to_world": transform(mi, light["to_world"]),
            "emitter": {"type": "area", "radiance": {"type": "rgb", "value": light["radiance"]}},
            "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.0, 0.0, 0.0]}},
        }
    return mi.load_dict(d)


def timed_render(mi, dr, scene, spp, seed):
    """(image, wall s, CPU s, compile s): a render that compiled a kernel (a new sample count can
    need one) is rendered again, kernels cached, and the second one's times are returned (same
    seed: the same image)."""
    compile_seconds(dr)
    jit = 0.0
    for _ in range(2):
        w0, c0 = time.monotonic(), time.process_time()
        img = np.asarray(mi.render(scene, spp=spp, seed=seed), dtype=np.float64)
        w, c = time.monotonic() - w0, time.process_time() - c0
        new = compile_seconds(dr)
        if new == 0.0:
            break
        jit += new
    return img, w, c, jit


def main():
    threads = int(sys.argv[1])
    try:
        mi, dr, variant = start(threads)
    except Exception as e:  # noqa: BLE001 -- any failure to start is reported, never raised
        reply({"ready": False, "error": f"{type(e).__name__}: {e}"})
        return 0
    reply({"ready": True, "mitsuba": mi.__version__, "drjit": dr.__version__, "variant": variant, "threads": threads})
    scene = None
    for line in sys.stdin:
        cmd = json.loads(line)
        try:
            if cmd["cmd"] == "quit":
                break
            if cmd["cmd"] == "load":
                t0 = time.monotonic()
                scene = build(mi, cmd["scene"])
                t1 = time.monotonic()
                np.asarray(mi.render(scene, spp=1, seed=0))
                reply({"build": t1 - t0, "wall": time.monotonic() - t1, "compile": compile_seconds(dr)})
            elif cmd["cmd"] == "render":
                img, w, c, jit = timed_render(mi, dr, scene, int(cmd["spp"]), int(cmd["seed"]))
                np.save(cmd["out"], img)
                reply({"wall": w, "cpu": c, "compile": jit})
        except Exception as e:  # noqa: BLE001 -- reported to the parent, which prints it
            reply({"error": f"{type(e).__name__}: {e}"})
    return 0


if __name__ == "__main__":
    sys.exit(main())
