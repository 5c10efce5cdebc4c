"""Monte Carlo engine benchmark (`make bench`): subsurf side by side with real peers, in one run.

Prints, for the cases (a), (c), (d) below:
1. subsurf: scattering events/s and photons/s on 1 thread and on all cores, with the totals only,
   with MCML's tally set (R(r), R(α), R(r,α), T(…), A(z), A(r,z) on MCML's grids, batch-means
   errors) and with that set without errors; wall-clock rates and rates per CPU-second (what a
   core delivers when it is not shared: the machine may be busy);
2. MCML (Wang, Jacques & Zheng 1995) on the same cases and grids, when ``MCML_BIN`` names a build
   of it: photons/s per CPU-second of the MCML process, and the ratio subsurf / MCML per core;
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

Usage: python benches/bench.py [--seconds S] [--cases acd] [--no-peers] [--no-install]
"""

from __future__ import annotations

import argparse
import os
import re
import resource
import shutil
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
        c0 = time.process_time()
        r = subsurf.simulate(stack, photons=n, seed=1, threads=threads, tallies=tallies)
        cpu = time.process_time() - c0
        if r.elapsed_s >= 0.6 * seconds:
            return r, cpu
        n = int(n * min(100.0, 1.2 * seconds / max(r.elapsed_s, 1e-3)))


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


def run_mcml(binary: str, stack: Stack, seconds: float):
    """(photons, CPU seconds, Rd) of MCML on `stack`, sized to about `seconds` of CPU."""
    with tempfile.TemporaryDirectory() as tmp:
        n = 2000
        while True:
            path = os.path.join(tmp, "run.mci")
            with open(path, "w") as f:
                f.write(mci_text(stack, n, "run.mco"))
            c0 = cpu_children()
            subprocess.run(
                [binary, path],
                cwd=tmp,
                stdin=subprocess.DEVNULL,
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
                check=True,
                timeout=30 * seconds + 60,
            )
            cpu = cpu_children() - c0
            if cpu >= 0.6 * seconds:
                text = open(os.path.join(tmp, "run.mco")).read()
                m = re.search(r"^RAT[^\n]*\n\s*\S+[^\n]*\n\s*(\S+)", text, re.M)
                return n, cpu, float(m.group(1)) if m else float("nan")
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
        if secs - t0 >= 0.6 * seconds or n >= 10**8:
            return (n0, t0), (done, secs), dev
        rate = max(done - n0, 1) / max(secs - t0, 1e-3)
        n = int(min(100 * n, max(2 * n, n0 + 1.2 * seconds * rate)))


# ------------------------------------------------------------------------------------------------


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=2.0, help="duration of each measurement (s)")
    ap.add_argument("--cases", default="acd", help="which cases to run (letters of a, c, d)")
    ap.add_argument("--no-peers", action="store_true", help="skip MCML and pmcxcl")
    ap.add_argument("--no-install", action="store_true", help="never install a missing peer")
    args = ap.parse_args(argv)
    cores = os.cpu_count() or 1
    keys = [k for k in "acd" if k in args.cases]
    print(
        f"subsurf {subsurf.__version__} Monte Carlo benchmark; {cores} cores; lane kernel on {_core.mc_isa()}; "
        f"load average {os.getloadavg()[0]:.2f} at start (other processes slow these figures)"
    )
    print("rates: wall-clock; 'per CPU-s' = per second of CPU time used (what a core delivers when not shared)")
    print(
        f"{'case':<24} {'tallies':<11} {'threads':>7} {'photons':>9} {'events/s':>10} {'photons/s':>10} "
        f"{'ev/CPU-s':>10} {'ph/CPU-s':>10} {'scaling':>7}"
    )
    ours = {}
    for key in keys:
        name, stack = CASES[key]
        for tname, tallies in TALLY_SETS.items():
            one = None
            for threads in (1, None):
                r, cpu = measure(stack, threads, tallies, args.seconds)
                t = 1 if threads == 1 else cores
                ev = r.events / r.elapsed_s
                one = ev if threads == 1 else one
                per_cpu = r.events / cpu if cpu > 0 else float("nan")
                ph_cpu = r.photons / cpu if cpu > 0 else float("nan")
                ours[(key, tname, t)] = dict(
                    ev=ev,
                    ph=r.photons / r.elapsed_s,
                    ev_cpu=per_cpu,
                    ph_cpu=ph_cpu,
                    ev_per_ph=r.events / r.photons,
                    rd=r.diffuse_reflectance,
                )
                print(
                    f"{name:<24} {tname:<11} {t:>7} {r.photons:>9} {ev:>10.3e} {r.photons / r.elapsed_s:>10.3e} "
                    f"{per_cpu:>10.3e} {ph_cpu:>10.3e} {ev / one:>7.2f}"
                )
    print(f"load average {os.getloadavg()[0]:.2f} after the subsurf runs")
    if args.no_peers:
        print(TARGETS)
        return 0

    print("\nMCML (per core; CPU time of the MCML process; events/s = photons/s x subsurf's events per photon)")
    mcml = os.environ.get("MCML_BIN")
    if not mcml or not os.access(mcml, os.X_OK):
        print(f"  MCML unavailable: set MCML_BIN to an MCML 1.2.x executable (MCML_BIN={mcml!r})")
    else:
        print(
            f"{'case':<24} {'photons':>9} {'CPU s':>7} {'photons/s':>10} {'events/s':>10} {'Rd':>8} "
            f"{'x totals':>8} {'x mcml':>7} {'x noerr':>7}"
        )
        for key in keys:
            name, stack = CASES[key]
            n, cpu, rd = run_mcml(mcml, stack, args.seconds)
            ph = n / cpu
            ev = ph * ours[(key, "totals", 1)]["ev_per_ph"]

            def ratio(t, key=key, ph=ph):
                return ours[(key, t, 1)]["ph_cpu"] / ph

            print(
                f"{name:<24} {n:>9} {cpu:>7.2f} {ph:>10.3e} {ev:>10.3e} {rd:>8.5f} "
                f"{ratio('totals'):>8.2f} {ratio('mcml'):>7.2f} {ratio('mcml-noerr'):>7.2f}"
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
                return ours[(key, t, cores)]["ph"] / ph

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
