"""A drop-in for MCML users: read MCML's ``.mci`` input, write MCML's ``.mco`` output.

MCML (Wang, Jacques & Zheng, Comput. Methods Programs Biomed. 47, 131–146, 1995; version 1.2.2)
reads an input file (units cm and cm⁻¹) holding one or more runs and writes one ASCII output file
per run. :func:`read_mci` parses the input exactly as MCML's ``mcmlio.c`` does (``#`` starts a
comment, blank lines are skipped; the first data line is the file version, then the number of runs,
and per run: output file name and format, photons, ``dz dr``, ``nz nr na``, number of layers, n of the
medium above, one ``n mua mus g d`` line per layer, n of the medium below). :func:`write_mco`
writes the sections of MCML's ``WriteResult`` in its order, layouts and C number formats (InParm, RAT,
A_l, A_z, Rd_r, Rd_a, Tt_r, Tt_a, A_rz, Rd_ra, Tt_ra), in cm units, so existing MCML
post-processing scripts keep working. :func:`read_mco` parses such a file back.

Unit conversions (subsurf works in mm): lengths ×0.1 (mm → cm), μ ×10 (mm⁻¹ → cm⁻¹),
A(z) mm⁻¹ → cm⁻¹ ×10, R(r) mm⁻² → cm⁻² ×100, A(r, z) mm⁻³ → cm⁻³ ×1000, per-sr quantities unchanged.
MCML divides the angular tallies by approximate bin measures (ScaleRdTt in mcmlio.c: solid angle
2π sin(α)Δα with α at the bin centre, and 4π² Δr² (i + ½) sin(2α) sin(Δα/2) for R(r, α)); subsurf's
histograms use exact bin measures (R(θ): ring solid angle 2π(cos θ₀ − cos θ₁); R(r, θ): annulus area
× projected solid angle π(sin²θ₁ − sin²θ₀)), which each histogram carries (``Histogram.measures``,
from the core), so the raw bin weights are recovered with ``Histogram.bin_measure()`` and divided by
MCML's measures, which reproduces MCML's numbers bin for bin. Like MCML, subsurf's
last r and z bins collect everything beyond the grid.
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Sequence
from typing import Callable

import numpy as np

from . import _core, atomic

__all__ = [
    "McmlInputError",
    "McmlRun",
    "read_mci",
    "parse_mci",
    "run_to_stack",
    "run_to_tallies",
    "write_mco",
    "format_mco",
    "read_mco",
    "mcml_arrays",
    "run_mci",
    "plan_runs",
    "write_run",
]

MM_PER_CM = 10.0


class McmlInputError(_core.ParameterError):
    """A malformed ``.mci`` file; the message names the file, the line and the problem."""


@dataclasses.dataclass
class McmlRun:
    """One run of an MCML input file, in MCML's units (cm, cm⁻¹)."""

    out_fname: str
    out_format: str  # "A" (or "B": MCML writes the same ASCII, version tag "B1")
    photons: int
    dz: float
    dr: float
    nz: int
    nr: int
    na: int
    n_above: float
    layers: list  # [(n, mua, mus, g, d)], cm and cm⁻¹
    n_below: float
    line: int = 0  # line of the output file name in the .mci

    @property
    def da(self) -> float:
        """Angular bin width, rad (MCML: 0.5π/na)."""
        return 0.5 * math.pi / self.na


def _data_lines(text: str):
    """(line number, fields) of MCML data lines: text before '#' that is not blank."""
    for i, line in enumerate(text.splitlines(), 1):
        body = line.split("#", 1)[0].strip()
        if body:
            yield i, body.split()


def parse_mci(text: str, path: str = "<string>") -> list[McmlRun]:
    """Parse the text of an MCML input file into its runs (see the module docstring)."""
    lines = list(_data_lines(text))
    pos = 0

    def fail(line, msg):
        where = f"{path}:{line}" if line else path
        return McmlInputError(f"{where}: {msg}")

    def take(what: str, count: int, conv: Sequence[Callable]):
        nonlocal pos
        if pos >= len(lines):
            raise fail(lines[-1][0] if lines else None, f"file ends early: expected {what}")
        ln, fields = lines[pos]
        pos += 1
        if len(fields) < count:
            raise fail(ln, f"expected {what}, got {' '.join(fields)!r}")
        out = []
        for f, c in zip(fields[:count], conv):
            try:
                out.append(c(f))
            except ValueError:
                raise fail(ln, f"expected {what}: {f!r} is not a{'n integer' if c is int else ' number'}") from None
        return ln, out

    def positive(ln, name, v):
        if not v > 0:
            raise fail(ln, f"{name} = {v:g} is out of range: must be > 0")
        return v

    take("the file version (e.g. 1.0)", 1, [str])
    ln, (nruns,) = take("the number of runs", 1, [int])
    positive(ln, "number of runs", nruns)
    runs = []
    names = set()
    for _ in range(nruns):
        ln0, (fname,) = take("an output file name and format (e.g. 'out.mco A')", 1, [str])
        fmt_fields = lines[pos - 1][1]
        fmt = fmt_fields[1].upper() if len(fmt_fields) > 1 else "A"
        fmt = "B" if fmt == "B" else "A"
        if fname in names:
            raise fail(ln0, f"output file name {fname} is used by two runs")
        names.add(fname)
        ln, (photons,) = take("the number of photons", 1, [int])
        positive(ln, "number of photons", photons)
        if photons >= 2**64:  # the engine counts photons in 64 bits
            raise fail(ln, f"number of photons = {photons} is out of range: must be < 2^64")
        ln, (dz, dr) = take("dz dr (cm)", 2, [float, float])
        positive(ln, "dz", dz)
        positive(ln, "dr", dr)
        ln, (nz, nr, na) = take("nz nr na (numbers of grid elements)", 3, [int, int, int])
        for name, v in (("nz", nz), ("nr", nr), ("na", na)):
            positive(ln, name, v)
        ln, (nl,) = take("the number of layers", 1, [int])
        positive(ln, "number of layers", nl)
        ln, (n_above,) = take("n of the medium above", 1, [float])
        if not n_above >= 1.0:
            raise fail(ln, f"n above = {n_above:g} is out of range: must be >= 1")
        layers = []
        for k in range(nl):
            ln, vals = take(f"layer {k + 1} of {nl}: n mua mus g d", 5, [float] * 5)
            n, mua, mus, g, d = vals
            for name, v, ok, allowed in (
                ("n", n, n >= 1.0, ">= 1"),
                ("mua", mua, mua >= 0, ">= 0 (1/cm)"),
                ("mus", mus, mus >= 0, ">= 0 (1/cm)"),
                ("g", g, -1 < g < 1, "in (-1, 1)"),
                ("d", d, 0 < d < math.inf, "> 0 (cm)"),
            ):
                if not ok:
                    raise fail(ln, f"layer {k + 1}: {name} = {v:g} is out of range: must be {allowed}")
            layers.append((n, mua, mus, g, d))
        ln, (n_below,) = take("n of the medium below", 1, [float])
        if not n_below >= 1.0:
            raise fail(ln, f"n below = {n_below:g} is out of range: must be >= 1")
        runs.append(McmlRun(fname, fmt, photons, dz, dr, nz, nr, na, n_above, layers, n_below, ln0))
    return runs


def read_mci(path: str | os.PathLike) -> list[McmlRun]:
    """Read every run of an MCML input file."""
    path = os.fspath(path)
    try:
        with open(path, encoding="utf-8", errors="replace") as f:
            text = f.read()
    except FileNotFoundError:
        raise McmlInputError(f"{path}: no such file") from None
    except OSError as e:
        raise McmlInputError(f"{path}: cannot read ({e.strerror})") from None
    return parse_mci(text, path)


def run_to_stack(run: McmlRun):
    """The :class:`subsurf.Stack` of a run, converted to mm and mm⁻¹."""
    from .medium import Layer, Stack

    layers = [Layer(n, mua / MM_PER_CM, mus / MM_PER_CM, g, d * MM_PER_CM) for n, mua, mus, g, d in run.layers]
    return Stack(layers, n_above=run.n_above, n_below=run.n_below)


def run_to_tallies(run: McmlRun):
    """The ``subsurf.Tallies`` of a run: MCML's grids in mm."""
    from .tallies import Tallies

    return Tallies(
        nr=run.nr, dr=run.dr * MM_PER_CM, nz=run.nz, dz=run.dz * MM_PER_CM, na=run.na, spatial=True, angular=True
    )


def mcml_arrays(run: McmlRun, result) -> dict:
    """MCML's output quantities (cm units, MCML's normalisation) from a subsurf result.

    Returns a dict with ``Rsp, Rd, A, Tt`` (floats), ``A_l`` (per layer), ``A_z`` [cm⁻¹],
    ``Rd_r, Tt_r`` [cm⁻²], ``Rd_a, Tt_a`` [sr⁻¹], ``A_rz`` [cm⁻³] (shape nr × nz),
    ``Rd_ra, Tt_ra`` [cm⁻² sr⁻¹] (shape nr × na).
    """
    nr, na, da = run.nr, run.na, run.da
    ir = np.arange(nr) + 0.5
    ia = (np.arange(na) + 0.5) * da
    out = {
        "Rsp": float(result.specular_reflectance),
        "Rd": float(result.diffuse_reflectance),
        # MCML's A is its absorption deposits (= Σ A_l = ∫A_z dz); subsurf's `absorbed` also
        # holds the zero-mean roulette term that makes its energy balance exact.
        "A": float(np.sum(result.absorbed_per_layer)),
        "Tt": float(result.transmittance),
        "A_l": np.asarray(result.absorbed_per_layer, dtype=float),
    }
    h = result.histograms
    # 1-D: subsurf divides by exact measures; MCML's radial area 2π(i+½)Δr² is exact too.
    out["A_z"] = np.asarray(h["a_z"].values, dtype=float) * MM_PER_CM  # mm⁻¹ → cm⁻¹
    out["A_rz"] = np.asarray(h["a_rz"].values, dtype=float) * MM_PER_CM**3  # mm⁻³ → cm⁻³
    for side in ("rd", "tt"):
        key = "Rd" if side == "rd" else "Tt"
        out[f"{key}_r"] = np.asarray(h[f"{side}_r"].values, dtype=float) * MM_PER_CM**2  # mm⁻² → cm⁻²
        ha = h[f"{side}_a"]
        raw_a = np.asarray(ha.values, dtype=float) * ha.bin_measure()  # bin weights (no unit)
        out[f"{key}_a"] = raw_a / (2.0 * math.pi * da * np.sin(ia))  # ScaleRdTt, Rd_a
        hra = h[f"{side}_ra"]
        raw_ra = np.asarray(hra.values, dtype=float) * hra.bin_measure()
        scale = 4.0 * math.pi**2 * run.dr  # cm²·sr
        scale = scale * math.sin(da / 2) * run.dr * ir[:, None] * np.sin(2.0 * ia)[None, :]
        out[f"{key}_ra"] = raw_ra / scale  # ScaleRdTt, Rd_ra
    return out


# --- writing ------------------------------------------------------------------------------------


def _c(fmt: str, x: float) -> str:
    """C printf formatting (Python's % operator follows C for these conversions)."""
    return fmt % x


def _grid(lines: list, arr: np.ndarray) -> None:
    """MCML's 2-D layout: '%12.4E ' per number, a newline after every 5th, then one newline."""
    flat = np.asarray(arr, dtype=float).ravel()
    buf = []
    for k, v in enumerate(flat):
        buf.append(_c("%12.4E ", v))
        if (k + 1) % 5 == 0:
            buf.append("\n")
    buf.append("\n")
    lines.append("".join(buf))


def format_mco(run: McmlRun, result, user_time_s: float | None = None) -> str:
    """The text MCML 1.2.2's ``WriteResult`` writes for ``run`` (see the module docstring)."""
    q = mcml_arrays(run, result)
    secs = float(result.elapsed_s if user_time_s is None else user_time_s)
    out = []
    out.append(f"{'B1' if run.out_format == 'B' else 'A1'} \t# Version number of the file format.\n\n")
    out.append(
        "####\n# Data categories include: \n# InParm, RAT, \n# A_l, A_z, Rd_r, Rd_a, Tt_r, Tt_a, \n"
        "# A_rz, Rd_ra, Tt_ra \n####\n\n"
    )
    out.append(
        "# "
        + ("User time: {:8.0f} sec = {:8.2f} hr.  {}\n".format(secs, secs / 3600.0, " Simulation time of this run."))
        + "\n"
    )
    out.append("InParm \t\t\t# Input parameters. cm is used.\n")
    out.append(f"{run.out_fname} \tA\t\t# output file name, ASCII.\n")
    out.append("%d \t\t\t# No. of photons\n" % run.photons)
    out.append(f"{run.dz:G}\t{run.dr:G}\t\t# dz, dr [cm]\n")
    out.append("%d\t%d\t%d\t# No. of dz, dr, da.\n\n" % (run.nz, run.nr, run.na))
    out.append("%d\t\t\t\t\t# Number of layers\n" % len(run.layers))
    out.append("#n\tmua\tmus\tg\td\t# One line for each layer\n")
    out.append(f"{run.n_above:G}\t\t\t\t\t# n for medium above\n")
    for i, (n, mua, mus, g, d) in enumerate(run.layers, 1):
        out.append("%G\t%G\t%G\t%G\t%G\t# layer %d\n" % (n, mua, mus, g, d, i))
    out.append(f"{run.n_below:G}\t\t\t\t\t# n for medium below\n\n")
    out.append("RAT #Reflectance, absorption, transmission. \n")
    out.append("{:<14.6G} \t#Specular reflectance [-]\n".format(q["Rsp"]))
    out.append("{:<14.6G} \t#Diffuse reflectance [-]\n".format(q["Rd"]))
    out.append("{:<14.6G} \t#Absorbed fraction [-]\n".format(q["A"]))
    out.append("{:<14.6G} \t#Transmittance [-]\n".format(q["Tt"]))
    out.append("\n")
    out.append("A_l #Absorption as a function of layer. [-]\n")
    out.append("".join(f"{v:12.4G}\n" for v in q["A_l"]) + "\n")
    out.append("A_z #A[0], [1],..A[nz-1]. [1/cm]\n")
    out.append("".join(f"{v:12.4E}\n" for v in q["A_z"]) + "\n")
    out.append("Rd_r #Rd[0], [1],..Rd[nr-1]. [1/cm2]\n")
    out.append("".join(f"{v:12.4E}\n" for v in q["Rd_r"]) + "\n")
    out.append("Rd_a #Rd[0], [1],..Rd[na-1]. [sr-1]\n")
    out.append("".join(f"{v:12.4E}\n" for v in q["Rd_a"]) + "\n")
    out.append("Tt_r #Tt[0], [1],..Tt[nr-1]. [1/cm2]\n")
    out.append("".join(f"{v:12.4E}\n" for v in q["Tt_r"]) + "\n")
    out.append("Tt_a #Tt[0], [1],..Tt[na-1]. [sr-1]\n")
    out.append("".join(f"{v:12.4E}\n" for v in q["Tt_a"]) + "\n")
    out.append(
        "# A[r][z]. [1/cm3]\n# A[0][0], [0][1],..[0][nz-1]\n# A[1][0], [1][1],..[1][nz-1]\n# ...\n"
        "# A[nr-1][0], [nr-1][1],..[nr-1][nz-1]\nA_rz\n"
    )
    _grid(out, q["A_rz"])
    for key in ("Rd", "Tt"):
        out.append(
            f"# {key}[r][angle]. [1/(cm2sr)].\n# {key}[0][0], [0][1],..[0][na-1]\n"
            f"# {key}[1][0], [1][1],..[1][na-1]\n# ...\n# {key}[nr-1][0], [nr-1][1],..[nr-1][na-1]\n"
            f"{key}_ra\n"
        )
        _grid(out, q[f"{key}_ra"])
    return "".join(out)


def write_mco(path: str | os.PathLike, run: McmlRun, result, force: bool = False, inputs=()) -> str:
    """Write a run's ``.mco`` atomically (:mod:`subsurf.atomic`); refuses to overwrite an existing
    file unless ``force``, to write over one of ``inputs``, and to write a result without photons."""
    path = os.fspath(path)
    if result.photons < 1:
        raise ValueError(f"{path}: no photons were traced (interrupted at once); nothing to write")
    return atomic.write_bytes(path, format_mco(run, result).encode(), force=force, inputs=inputs)


# --- reading .mco (for scripts and tests) -------------------------------------------------------

_SECTIONS_1D = ("A_l", "A_z", "Rd_r", "Rd_a", "Tt_r", "Tt_a")
_SECTIONS_2D = ("A_rz", "Rd_ra", "Tt_ra")


def read_mco(path: str | os.PathLike) -> dict:
    """Parse an MCML ``.mco`` file (ours or MCML's) into a dict of numbers and arrays (cm units).

    Keys: ``photons, dz, dr, nz, nr, na, layers, n_above, n_below, Rsp, Rd, A, Tt`` and the
    arrays ``A_l, A_z, Rd_r, Rd_a, Tt_r, Tt_a, A_rz (nr×nz), Rd_ra, Tt_ra (nr×na)``.
    """
    with open(os.fspath(path)) as f:
        lines = [ln.split("#", 1)[0].split() for ln in f.read().splitlines()]
    data = [l for l in lines if l]
    out: dict = {}
    i = 0
    while i < len(data):
        tag = data[i][0]
        if tag == "InParm":
            out["out_fname"] = data[i + 1][0]
            out["photons"] = int(data[i + 2][0])
            out["dz"], out["dr"] = float(data[i + 3][0]), float(data[i + 3][1])
            out["nz"], out["nr"], out["na"] = (int(x) for x in data[i + 4][:3])
            nl = int(data[i + 5][0])
            out["n_above"] = float(data[i + 6][0])
            out["layers"] = [tuple(float(x) for x in data[i + 7 + k][:5]) for k in range(nl)]
            out["n_below"] = float(data[i + 7 + nl][0])
            i += 8 + nl
        elif tag == "RAT":
            out["Rsp"], out["Rd"], out["A"], out["Tt"] = (float(data[i + k][0]) for k in range(1, 5))
            i += 5
        elif tag in _SECTIONS_1D + _SECTIONS_2D:
            i += 1
            vals = []
            while i < len(data) and data[i][0] not in _SECTIONS_1D + _SECTIONS_2D + ("RAT", "InParm"):
                vals.extend(float(x) for x in data[i])
                i += 1
            arr = np.array(vals)
            if tag == "A_rz":
                arr = arr.reshape(out["nr"], out["nz"])
            elif tag in ("Rd_ra", "Tt_ra"):
                arr = arr.reshape(out["nr"], out["na"])
            out[tag] = arr
        else:
            i += 1
    return out


# --- running ------------------------------------------------------------------------------------


def plan_runs(
    path: str | os.PathLike, force: bool = False, out_dir: str | None = None, photons: int | None = None
) -> list:
    """Every run of an ``.mci`` file, checked before any is simulated: ``[(run, stack, tallies, target)]``.

    Output names are taken relative to ``out_dir`` (default: the current directory, as MCML);
    ``photons`` overrides every run's photon count. An invalid layer or grid, two runs writing the
    same file (``same.mco`` and ``./same.mco``), an output that is the input file, a missing
    directory or (without ``force``) an existing output raise an error naming the run.
    """
    path = os.fspath(path)
    plan, seen = [], {}
    for i, run in enumerate(read_mci(path)):
        if photons is not None:
            run = dataclasses.replace(run, photons=int(photons))
        try:
            stack, tallies = run_to_stack(run), run_to_tallies(run)
        except _core.ParameterError as e:
            raise McmlInputError(f"{path}:{run.line}: run {i + 1}: {e}") from None
        target = os.path.join(out_dir, run.out_fname) if out_dir else run.out_fname
        real = os.path.realpath(target)
        if real in seen:
            raise McmlInputError(
                f"{path}:{run.line}: output file {run.out_fname} is the same file as run line "
                f"{seen[real].line}'s {seen[real].out_fname}"
            )
        seen[real] = run
        atomic.check_target(target, force=force, inputs=(path,))
        plan.append((run, stack, tallies, target))
    return plan


def run_mci(
    path: str | os.PathLike,
    force: bool = False,
    seed: int = 1,
    threads: int | None = None,
    progress_factory=None,
    out_dir: str | None = None,
    photons: int | None = None,
) -> list:
    """Simulate every run of an ``.mci`` file and write each ``.mco``; returns [(path, result)].

    Every run and output is checked first (:func:`plan_runs`), so a refusal costs nothing.
    ``photons`` overrides the photon counts of the file (for quick checks);
    ``progress_factory(i, run)`` may return a ``progress(done, total)`` callback. An interrupted
    run (Ctrl-C) is written with the photons traced so far and ends the loop; it never replaces an
    existing file (see :func:`subsurf.atomic.partial_path`).
    """
    from .mc import simulate

    done = []
    for i, (run, stack, tallies, target) in enumerate(plan_runs(path, force, out_dir, photons)):
        cb = progress_factory(i, run) if progress_factory else None
        result = simulate(stack, photons=run.photons, seed=seed + i, threads=threads, tallies=tallies, progress=cb)
        done.append((write_run(target, run, result, force=force, inputs=(path,)), result))
        if result.partial:
            break
    return done


def write_run(target: str, run: McmlRun, result, force: bool = False, inputs=()) -> str:
    """Write a run's result to ``target``; a partial result goes to :func:`subsurf.atomic.partial_path`
    and its ``.mco`` states the photons actually traced. Returns the path written."""
    if result.partial:
        run = dataclasses.replace(run, photons=int(result.photons))
        target = atomic.partial_path(target)
        force = False
    return write_mco(target, run, result, force=force, inputs=inputs)
