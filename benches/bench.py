"""Monte Carlo engine benchmark (`make bench`): subsurf side by side with real peers, in one run.

Prints, for the cases (a), (c), (d) below:
1. subsurf, on each instruction-set path of the lane kernel this machine runs (``--isa``; default every
   one: avx512, avx2, sse — 128-bit lanes, standing in for NEON — as ``_core.mc_isas()`` lists; a path
   is forced with the environment variable ``SUBSURF_ISA``, as for any run): scattering events/s and
   photons/s on 1 thread (and, on the best path, on all cores), with the totals only,
   with MCML's tally set (R(r), R(α), R(r,α), T(…), A(z), A(r,z) on MCML's grids, batch-means
   errors) and with that set without errors; wall-clock rates and rates per CPU-second (what a
   core delivers when it is not shared: the machine may be busy);
2. MCML (Wang, Jacques & Zheng 1995) on the same cases and grids, when ``MCML_BIN`` names a build
   of it: photons/s per CPU-second of the MCML process, the ratio subsurf / MCML per core, and the
   machine's own multi-core ceiling (as many MCML processes at once as there are cores, against one);
   each case runs in rounds (``--reps``), subsurf's configurations and MCML back to back in each, so
   that the machine's drifting speed (±25 % over minutes on a shared VM) cancels in each round's
   ratio: medians and [min-max] over the rounds are printed;
3. MCX (Fang & Boas 2009) through ``pmcxcl`` (PyPI) on the CPU through PoCL (Debian
   ``pocl-opencl-icd``), the same cases as voxel media: its photon count, the kernel time it
   reports, photons/s, and the ratio subsurf (all cores) / pmcxcl (all cores).
Missing peers are installed when possible (``pip install pmcxcl`` into this Python, ``apt-get
install pocl-opencl-icd`` as root; ``--no-install`` forbids it) and otherwise reported as
unavailable with the reason. A benchmark, not a test: the numbers depend on the machine and its load.

Cases (cm in the MCML files; here mm and mm⁻¹):
  (a) slab n=1 in n=1, μa=1, μs=9 /mm, g=0.75, d=0.2 mm (the van de Hulst slab; short histories);
  (c) three layers n=1.4 in air: (μa, μs, g, d) = (0.1, 10, 0.9, 0.1), (0.05, 15, 0.85, 2),
      (0.02, 12, 0.9, 10);
  (d) n=1.4 in air, μa=0.01, μs=10 /mm, g=0.9, d=100 mm (long histories).

Then a path × case table: events/s per CPU-second (totals, 1 thread) and the ratios to MCML per core
(totals, MCML's tally set, the same without errors) of every path.

Usage: python benches/bench.py [--seconds S] [--cases acd] [--reps R] [--isa all|best|avx2,sse,...]
                               [--no-peers] [--no-install]
"""

from __future__ import annotations

import argparse
import os
import re
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

import subsurf
from subsurf import Layer, Stack, Tallies, _core

CASES = {
    "a": ("(a) slab g=0.75 tau=2", Stack([Layer(1.0, 1.0, 9.0, 0.75, 0.2)], 1.0, 1.0)),
    "c": (
        "(c) 3 layers n=1.4",
        Stack(
            [Layer(1.4, 0.1, 10.0, 0.9, 0.1), Layer(1.4, 0.05, 15.0, 0.85, 2.0), Layer(1.4, 0.02, 12.0, 0.9, 10.0)],
            1.0,
            1.0,
        ),
    ),
    "d": ("(d) thick n=1.4 g=0.9", Stack([Layer(1.4, 0.01, 10.0, 0.9, 100.0)], 1.0, 1.0)),
}

#: MCML's grids for every case (its tally set): nr × dr, nz × dz in mm, na angles.
GRID = dict(nr=100, dr=0.01, nz=100, dz=0.01, na=30)
TALLY_SETS = {
    "totals": None,
    "mcml": Tallies(**GRID),
    "mcml-noerr": Tallies(**GRID, errors=False),
}
#: Voxel media of the pmcxcl runs: voxel size (mm) and lateral extent (voxels) per case.
VOXELS = {"a": (0.02, 300), "c": (0.1, 300), "d": (1.0, 200)}

TARGETS = "targets: totals >= 10x MCML events/s per core; MCML's tally set >= 5x; >= 1.9x on 2 cores"


def cpu_children() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def measure(stack, threads, tallies, seconds):
    """Run long enough to last about `seconds` (after pilot runs to size it); returns the result and
    the CPU time of this process (all threads) during the run."""
    n = 2000
    while True:
        r, cpu = run_ours(stack, n, threads, tallies)
        if r.elapsed_s >= 0.6 * seconds:
            return r, cpu
        n = int(n * min(100.0, 1.2 * seconds / max(r.elapsed_s, 1e-3)))


def run_ours(stack, n, threads, tallies):
    """One run of `n` photons (seed 1): the result and the CPU time of this process during it."""
    c0 = time.process_time()
    r = subsurf.simulate(stack, photons=n, seed=1, threads=threads, tallies=tallies)
    return r, time.process_time() - c0


def force_isa(isa: str) -> None:
    """Force the lane kernel's instruction-set path for the next runs (``SUBSURF_ISA``)."""
    os.environ["SUBSURF_ISA"] = isa
    if _core.mc_isa() != isa:
        raise RuntimeError(f"SUBSURF_ISA={isa} ran {_core.mc_isa()}")


def pick_isas(spec: str) -> list[str]:
    """The paths `--isa` names, best first: 'all' (every path this machine runs but the baseline,
    which is another 128-bit path on x86-64), 'best', or a comma-separated list."""
    here = _core.mc_isas()
    if spec == "all":
        vector = [i for i in here if i != "scalar"]
        return vector or here
    if spec == "best":
        return here[:1]
    names = [n.strip().lower().replace("baseline", "scalar") for n in spec.split(",") if n.strip()]
    bad = [n for n in names if n not in here]
    if bad or not names:
        raise SystemExit(f"--isa: {spec!r} is not allowed (all, best, or some of {', '.join(here)} on this machine)")
    return [i for i in here if i in names]


def spread(xs) -> str:
    """Median and range of repeated ratios, e.g. '3.41 [3.10-3.62]'."""
    xs = sorted(xs)
    return f"{statistics.median(xs):.2f} [{xs[0]:.2f}-{xs[-1]:.2f}]"


# ------------------------------------------------------------------------------------------------
# MCML
# ------------------------------------------------------------------------------------------------


def mci_text(stack: Stack, photons: int, out: str) -> str:
    """An MCML input file (cm) for `stack` on MCML's grid `GRID`."""
    cm = 0.1
    lines = [
        "1.0",
        "1",
        f"{out} A",
        str(photons),
        f"{GRID['dz'] * cm} {GRID['dr'] * cm}",
        f"{GRID['nz']} {GRID['nr']} {GRID['na']}",
        str(len(stack.layers)),
        f"{stack.n_above}",
    ]
    for lay in stack.layers:
        lines.append(f"{lay.n} {lay.mua / cm} {lay.mus / cm} {lay.g} {lay.thickness * cm}")
    lines.append(f"{stack.n_below}")
    return "\n".join(lines) + "\n"


def mcml_once(binary: str, stack: Stack, n: int, tmp: str, copies: int = 1):
    """`copies` MCML processes of `n` photons each, started together in `tmp`: (CPU seconds of
    all of them, wall seconds, Rd of the first)."""
    procs = []
    c0, w0 = cpu_children(), time.perf_counter()
    for k in range(copies):
        path = os.path.join(tmp, f"run{k}.mci")
        with open(path, "w") as f:
            f.write(mci_text(stack, n, f"run{k}.mco"))
        procs.append(
            subprocess.Popen(
                [binary, path], cwd=tmp, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
            )
        )
    for p in procs:
        if p.wait() != 0:
            raise RuntimeError(f"MCML exited with status {p.returncode}")
    wall, cpu = time.perf_counter() - w0, cpu_children() - c0
    text = open(os.path.join(tmp, "run0.mco")).read()
    m = re.search(r"^RAT[^\n]*\n\s*\S+[^\n]*\n\s*(\S+)", text, re.M)
    return cpu, wall, float(m.group(1)) if m else float("nan")


def size_mcml(binary: str, stack: Stack, seconds: float, tmp: str) -> int:
    """Photons for an MCML run of about `seconds` of CPU on `stack`."""
    n = 2000
    while True:
        cpu, _, _ = mcml_once(binary, stack, n, tmp)
        if cpu >= 0.6 * seconds:
            return n
        n = int(n * min(100.0, 1.2 * seconds / max(cpu, 1e-2)))


# ------------------------------------------------------------------------------------------------
# pmcxcl (MCX through OpenCL, on the CPU through PoCL)
# ------------------------------------------------------------------------------------------------

PMCX_SCRIPT = r"""
import sys, numpy as np, pmcxcl
unit, nxy, nz_list, media, nmed, n_photons = eval(sys.argv[1])
nz = sum(nz_list)
vol = np.zeros((nxy, nxy, nz), dtype="uint8")
z = 0
for i, k in enumerate(nz_list):
    vol[:, :, z:z + k] = i + 1
    z += k
cfg = {"nphoton": n_photons, "vol": vol, "tstart": 0, "tend": 1e-6, "tstep": 1e-6,
       "srcpos": [nxy / 2, nxy / 2, 0], "srcdir": [0, 0, 1], "unitinmm": unit,
       "prop": [[0, 0, 1, nmed[0]]] + media, "isreflect": 1, "isspecular": 1, "issave2pt": 0,
       "seed": 1, "autopilot": 1}
pmcxcl.run(cfg)
"""


def pmcx_args(key: str, stack: Stack, photons: int):
    unit, nxy = VOXELS[key]
    nz_list = [max(1, round(lay.thickness / unit)) for lay in stack.layers]
    media = [[lay.mua, lay.mus, lay.g, lay.n] for lay in stack.layers]
    return repr((unit, nxy, nz_list, media, [stack.n_above], photons))


def pmcx_available(python: str, allow_install: bool) -> tuple[bool, str, dict]:
    """Whether pmcxcl runs on an OpenCL CPU device here; installs it when allowed."""
    env = dict(os.environ)
    probe = "import pmcxcl; print([d['name'] for d in pmcxcl.gpuinfo()])"

    def try_run(e):
        p = subprocess.run([python, "-c", probe], capture_output=True, text=True, env=e)
        return p.returncode == 0 and "[]" not in p.stdout, (p.stdout + p.stderr).strip()[-300:]

    if subprocess.run([python, "-c", "import pmcxcl"], capture_output=True).returncode != 0:
        if not allow_install:
            return False, "pmcxcl is not installed (pip install pmcxcl)", env
        subprocess.run([python, "-m", "pip", "install", "-q", "pmcxcl"], capture_output=True)
    if not shutil.which("clinfo") and not os.path.exists("/etc/OpenCL/vendors/pocl.icd"):
        if allow_install and shutil.which("apt-get") and os.geteuid() == 0:
            subprocess.run(
                ["apt-get", "install", "-y", "-qq", "pocl-opencl-icd", "ocl-icd-libopencl1"],
                capture_output=True,
                env={**env, "DEBIAN_FRONTEND": "noninteractive"},
            )
    ok, why = try_run(env)
    libstdcxx = "/usr/lib/x86_64-linux-gnu/libstdc++.so.6"
    if os.path.exists(libstdcxx):
        # The wheel's own libstdc++ is older than the one PoCL was built against: preload the
        # system library (needed on Debian to build the OpenCL program).
        env = {**env, "LD_PRELOAD": libstdcxx}
        ok, why = try_run(env)
    if not ok:
        return False, f"pmcxcl finds no OpenCL device ({why or 'no output'}); apt-get install pocl-opencl-icd", env
    return True, "", env


def run_pmcx(python: str, env: dict, key: str, stack: Stack, seconds: float):
    """pmcxcl on `stack`: a pilot of 500 photons, then a run whose kernel time exceeds the
    pilot's by about `seconds`. Returns (photons, kernel seconds) of both runs and the device;
    the rate is taken from the difference, so a fixed per-launch cost (PoCL's thread start-up,
    which grows with the machine's load) does not count as photon time."""

    def one(n):
        p = subprocess.run(
            [python, "-c", PMCX_SCRIPT, pmcx_args(key, stack, n)], capture_output=True, text=True, env=env
        )
        out = p.stdout + p.stderr
        km = re.search(r"kernel complete:\s*(\d+)\s*ms", out)
        sm = re.search(r"simulated\s+(\d+)\s+photons", out)
        dm = re.search(r"\[device \d+\(\d+\):\s*([^\]]+)\]", out)
        if p.returncode != 0 or not (km and sm):
            raise RuntimeError(f"pmcxcl failed: {out.strip()[-400:]}")
        return int(sm.group(1)), int(km.group(1)) / 1000.0, dm.group(1) if dm else "?"

    n0, t0, dev = one(500)
    n = 5000
    while True:
        done, secs, dev = one(n)
        if secs - t0 >= 0.6 * seconds or secs >= 5 * seconds or n >= 10**8:
            return (n0, t0), (done, secs), dev
        # (at most 10x per step: under load the pilot's start-up time varies by seconds, and a
        # difference near 0 once sized a run of 5e7 photons and 226 s)
        rate = max(done - n0, 1) / max(secs - t0, 1e-3)
        n = int(min(10 * n, max(2 * n, n0 + 1.2 * seconds * rate)))


# ------------------------------------------------------------------------------------------------


def bench_case(key, args, cores, mcml, tmp, peers, isas):
    """Rounds of case `key` (see main) on the paths `isas` (best first; all cores on the first
    only); prints subsurf's rows, fills `peers[key]` with MCML's figures (ratios per path) and
    returns subsurf's medians keyed (case, tallies, threads, path)."""
    name, stack = CASES[key]
    sizes = {}
    for isa in isas:
        force_isa(isa)
        for t, tallies in TALLY_SETS.items():
            sizes[(t, isa)] = measure(stack, 1, tallies, args.seconds)[0].photons
    n_mcml = size_mcml(mcml, stack, args.seconds, tmp) if mcml else 0
    configs = [(isa, th) for isa in isas for th in (1,)] + ([(isas[0], cores)] if cores > 1 else [])
    runs = {(t, isa, th): [] for t in TALLY_SETS for isa, th in configs}
    mc = []
    for _ in range(args.reps):
        for isa, th in configs:
            force_isa(isa)
            for t, tallies in TALLY_SETS.items():
                r, cpu = run_ours(stack, sizes[(t, isa)] * th, 1 if th == 1 else None, tallies)
                runs[(t, isa, th)].append((r, cpu))
        if mcml:
            cpu, wall, rd = mcml_once(mcml, stack, n_mcml, tmp)
            _, wall_n, _ = mcml_once(mcml, stack, n_mcml, tmp, copies=cores)
            mc.append((n_mcml / cpu, cores * wall / wall_n, rd))
    med = statistics.median
    out = {}
    for (t, isa, th), rs in runs.items():
        out[(key, t, th, isa)] = dict(
            ev=med(r.events / r.elapsed_s for r, _ in rs),
            ph=med(r.photons / r.elapsed_s for r, _ in rs),
            ev_cpu=med(r.events / c for r, c in rs),
            ph_cpu=[r.photons / c for r, c in rs],
            ev_per_ph=rs[0][0].events / rs[0][0].photons,
            n=rs[0][0].photons,
        )
    for isa, th in configs:
        for t in TALLY_SETS:
            o = out[(key, t, th, isa)]
            sc = ""
            if th > 1:
                one, all_ = runs[(t, isa, 1)], runs[(t, isa, th)]
                sc = spread(
                    [(ra.photons / ra.elapsed_s) / (r1.photons / r1.elapsed_s) for (r1, _), (ra, _) in zip(one, all_)]
                )
            print(
                f"{name:<24} {isa:<7} {t:<11} {th:>7} {o['n']:>9} {o['ev']:>10.3e} {o['ph']:>10.3e} "
                f"{o['ev_cpu']:>10.3e} {med(o['ph_cpu']):>10.3e} {sc:>17}"
            )
    if mcml:
        ph = [m[0] for m in mc]
        peers[key] = dict(
            n=n_mcml,
            ph=med(ph),
            ev=med(ph) * out[(key, "totals", 1, isas[0])]["ev_per_ph"],
            rd=mc[0][2],
            x={
                (t, isa): [o / m for o, m in zip(out[(key, t, 1, isa)]["ph_cpu"], ph)]
                for t in TALLY_SETS
                for isa in isas
            },
            ceiling=[m[1] for m in mc],
        )
    return out


def path_table(keys, isas, ours, peers, have_mcml):
    """The path × case table: events per CPU-second (totals, 1 thread) and, with MCML, the ratios
    subsurf / MCML per core (totals, MCML's tally set, the same without errors; medians over the
    rounds)."""
    print(
        "\npath x case, 1 thread: events/CPU-s with the totals; x MCML per core: totals / MCML's tally set / no errors"
    )
    print(f"{'path':<7} " + " ".join(f"{CASES[k][0]:>36}" for k in keys))
    for isa in isas:
        cells = []
        for k in keys:
            ev = ours[(k, "totals", 1, isa)]["ev_cpu"]
            if have_mcml:
                x = peers[k]["x"]
                ratios = "/".join(f"{statistics.median(x[(t, isa)]):.1f}" for t in TALLY_SETS)
                cells.append(f"{ev:.2e} x {ratios}")
            else:
                cells.append(f"{ev:.2e}")
        print(f"{isa:<7} " + " ".join(f"{c:>36}" for c in cells))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=2.0, help="duration of each measurement (s)")
    ap.add_argument("--cases", default="acd", help="which cases to run (letters of a, c, d)")
    ap.add_argument("--no-peers", action="store_true", help="skip MCML and pmcxcl")
    ap.add_argument("--no-install", action="store_true", help="never install a missing peer")
    ap.add_argument("--reps", type=int, default=3, help="rounds per case (ratios: median and range)")
    ap.add_argument(
        "--isa", default="all", help="lane kernel paths: all (every vector path here), best, or a list like avx2,sse"
    )
    args = ap.parse_args(argv)
    if args.reps < 1:
        ap.error(f"--reps: {args.reps} is not allowed (an integer >= 1)")
    if not args.seconds > 0:
        ap.error(f"--seconds: {args.seconds} is not allowed (a number > 0)")
    cores = os.cpu_count() or 1
    keys = [k for k in "acd" if k in args.cases]
    forced = os.environ.get("SUBSURF_ISA")
    isas = pick_isas(args.isa) if not forced else [_core.mc_isa()]
    print(
        f"subsurf {subsurf.__version__} Monte Carlo benchmark; {cores} cores; lane kernel paths {', '.join(isas)} "
        f"(this machine runs {', '.join(_core.mc_isas())}; SUBSURF_ISA={forced!r}); "
        f"load average {os.getloadavg()[0]:.2f} at start (other processes slow these figures)"
    )
    print("rates: wall-clock; 'per CPU-s' = per second of CPU time used (what a core delivers when not shared)")
    print(
        f"each case: {args.reps} rounds, each running every configuration of subsurf (1 thread, then all cores) "
        "and MCML back to back, so that the machine's drifting speed cancels in each round's ratios; "
        "figures are medians over the rounds, [min-max] for ratios"
    )
    mcml = os.environ.get("MCML_BIN")
    have_mcml = bool(mcml) and os.access(mcml, os.X_OK) and not args.no_peers
    print(
        f"{'case':<24} {'path':<7} {'tallies':<11} {'threads':>7} {'photons':>9} {'events/s':>10} {'photons/s':>10} "
        f"{'ev/CPU-s':>10} {'ph/CPU-s':>10} {'scaling':>17}"
    )
    ours, peers = {}, {}
    with tempfile.TemporaryDirectory() as tmp:
        for key in keys:
            ours.update(bench_case(key, args, cores, mcml if have_mcml else None, tmp, peers, isas))
    print(f"load average {os.getloadavg()[0]:.2f} after the subsurf (and MCML) runs")
    path_table(keys, isas, ours, peers, have_mcml)
    if args.no_peers:
        print(TARGETS)
        return 0
    print(
        f"\nMCML (per core; CPU time of the MCML process; events/s = photons/s x subsurf's events per photon; "
        f"ratios on the {isas[0]} path)"
    )
    if not have_mcml:
        print(f"  MCML unavailable: set MCML_BIN to an MCML 1.2.x executable (MCML_BIN={mcml!r})")
    else:
        print(
            f"{'case':<24} {'photons':>9} {'photons/s':>10} {'events/s':>10} {'Rd':>8} {'x totals':>17} "
            f"{'x mcml':>17} {'x noerr':>17} {'MCML x' + str(cores):>17}"
        )
        for key in keys:
            p = peers[key]
            print(
                f"{CASES[key][0]:<24} {p['n']:>9} {p['ph']:>10.3e} {p['ev']:>10.3e} {p['rd']:>8.5f} "
                f"{spread(p['x'][('totals', isas[0])]):>17} {spread(p['x'][('mcml', isas[0])]):>17} "
                f"{spread(p['x'][('mcml-noerr', isas[0])]):>17} "
                f"{spread(p['ceiling']):>17}"
            )
        print(
            f"'MCML x{cores}': {cores} MCML processes at once deliver this many times the photons/s of one "
            "(the machine's own multi-core ceiling, to read subsurf's scaling against)"
        )

    print(
        f"\nMCX through pmcxcl on the CPU (PoCL), all cores; photons/s = (photons - pilot's) / (kernel time - "
        f"pilot's), the kernel times MCX reports; ratio = subsurf on {cores} cores (wall) / pmcxcl"
    )
    ok, why, env = pmcx_available(sys.executable, not args.no_install)
    if not ok:
        print(f"  pmcxcl unavailable: {why}")
    else:
        print(
            f"{'case':<24} {'photons':>9} {'kernel s':>8} {'pilot':>14} {'photons/s':>10} {'x totals':>8} "
            f"{'x mcml':>7}  device"
        )
        for key in keys:
            name, stack = CASES[key]
            try:
                (n0, t0), (n, secs), dev = run_pmcx(sys.executable, env, key, stack, args.seconds)
            except RuntimeError as e:
                print(f"{name:<24} failed: {e}")
                continue
            ph = (n - n0) / max(secs - t0, 1e-9)

            def ratio(t, key=key, ph=ph):
                return ours[(key, t, cores, isas[0])]["ph"] / ph

            pilot = f"{n0} in {t0:.2f}s"
            print(
                f"{name:<24} {n:>9} {secs:>8.2f} {pilot:>14} {ph:>10.3e} {ratio('totals'):>8.2f} "
                f"{ratio('mcml'):>7.2f}  {dev}"
            )
    print(f"load average {os.getloadavg()[0]:.2f} at the end")
    print(TARGETS)
    return 0


if __name__ == "__main__":
    sys.exit(main())
