"""Run configurations in TOML: :func:`load_config`, :func:`parse_config`.

A configuration file describes one Monte Carlo run (units mm, mm⁻¹, ps, degrees for angles)::

    photons = 100000
    seed = 1
    threads = 2              # optional; default: all cores
    n_above = 1.0
    n_below = 1.0

    [[layers]]               # from the top down
    n = 1.4
    mua = 0.1                # mm⁻¹
    mus = 10.0               # mm⁻¹
    g = 0.9
    thickness = 1.0          # mm, or "inf" for a semi-infinite last layer

    [source]
    type = "pencil"          # or "diffuse"
    theta_deg = 0.0          # pencil beam only
    phi_deg = 0.0

    [tallies]                # the fields of subsurf.Tallies
    nr = 100
    dr = 0.01
    brdf = [8, 16]

Errors (malformed TOML, unknown keys, wrong types, values out of range) raise
:class:`ConfigError` (a :class:`subsurf.ParameterError`) with one line naming the file, the key
(and its line where it can be found) and the problem.
"""

from __future__ import annotations

import dataclasses
import math
import os
import re
import sys
from typing import Any

from . import _core
from .mc import DiffuseIllumination, PencilBeam
from .medium import Layer, Stack
from .tallies import Tallies

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - exercised on 3.9/3.10 only
    import tomli as tomllib

__all__ = [
    "ConfigError",
    "RunConfig",
    "SweepConfig",
    "load_config",
    "load_sweep",
    "parse_config",
    "parse_sweep",
    "TOP_KEYS",
    "LAYER_KEYS",
    "SOURCE_KEYS",
    "TALLY_KEYS",
]

TOP_KEYS = ("description", "photons", "seed", "threads", "n_above", "n_below", "layers", "source", "tallies", "output")
LAYER_KEYS = ("name", "n", "mua", "mus", "g", "thickness", "phase")
SOURCE_KEYS = ("type", "theta_deg", "phi_deg")
#: Fields of ``subsurf.Tallies`` and their kinds ("count", "length", "pair", "order", "bool"): the
#: core's list (``TallyConfig::fields``), so that ``[tallies]`` takes every field.
TALLY_KEYS = {name: kind for name, kind, _ in _core.MC_TALLY_FIELDS}


class ConfigError(_core.ParameterError):
    """A configuration problem; the message is one line: ``FILE[:LINE]: KEY: problem``."""


@dataclasses.dataclass
class RunConfig:
    """A parsed configuration: what :func:`subsurf.simulate` needs, plus where it came from."""

    stack: Stack
    source: Any
    tallies: Any
    photons: int = 100_000
    seed: int = 0
    threads: int | None = None
    output: str | None = None
    description: str = ""
    path: str = "<string>"
    data: dict = dataclasses.field(default_factory=dict)

    def simulate_kwargs(self) -> dict:
        """Keyword arguments for :func:`subsurf.simulate` (besides the stack)."""
        return dict(
            photons=self.photons, seed=self.seed, threads=self.threads, source=self.source, tallies=self.tallies
        )


class _Ctx:
    """Builds error messages that name the file, the line of a key and the key path."""

    def __init__(self, path: str, text: str):
        self.path, self.text = path, text
        self.lines = text.splitlines()

    def line_of(self, key: str) -> int | None:
        """Best-effort line number of a dotted key path such as ``layers[1].g`` or ``tallies.nr``."""
        m = re.fullmatch(r"(\w+)(?:\[(\d+)\])?(?:\.(\w+))?(?:\[\d+\])?", key)
        if not m:
            return None
        table, index, field = m.group(1), m.group(2), m.group(3)
        header_re = re.compile(r"^\s*\[\[?\s*([\w.]+)\s*\]\]?")
        key_re = lambda k: re.compile(rf"^\s*{re.escape(k)}\s*=")  # noqa: E731
        current, count, header_line = None, {}, None
        for i, line in enumerate(self.lines, 1):
            h = header_re.match(line)
            if h:
                current = h.group(1)
                count[current] = count.get(current, -1) + 1
                if current == table and (index is None or count[current] == int(index)):
                    if field is None:
                        return i
                    header_line = i  # a key missing from its table: point at the table
                continue
            if field is None and current is None and key_re(table).match(line):
                return i
            if field is not None and current == table and key_re(field).match(line):
                if index is None or count.get(table) == int(index):
                    return i
        return header_line

    def error(self, key: str | None, problem: str) -> ConfigError:
        where = self.path
        if key:
            line = self.line_of(key)
            if line is not None:
                where += f":{line}"
            return ConfigError(f"{where}: {key}: {problem}")
        return ConfigError(f"{where}: {problem}")


def _number(ctx: _Ctx, key: str, v, allow_inf: bool = False) -> float:
    if isinstance(v, str) and allow_inf and v.strip().lower() in ("inf", "infinity"):
        return math.inf
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        extra = ' or "inf"' if allow_inf else ""
        raise ctx.error(key, f"expected a number{extra}, got {v!r}")
    return float(v)


def _int(ctx: _Ctx, key: str, v, lo: int | None = None, hi: int | None = None) -> int:
    """An integer, within [lo, hi] where they are given (the engine's limits are the core's)."""
    if isinstance(v, float) and v.is_integer():
        v = int(v)
    if isinstance(v, bool) or not isinstance(v, int):
        raise ctx.error(key, f"expected an integer, got {v!r}")
    if (lo is not None and v < lo) or (hi is not None and v > hi):
        rng = f">= {lo}" if hi is None else f"in [{lo}, {hi}]"
        raise ctx.error(key, f"{v} is out of range: must be an integer {rng}")
    return v


def _check_keys(ctx: _Ctx, where: str, table: dict, allowed) -> None:
    for k in table:
        if k not in allowed:
            key = f"{where}.{k}" if where else k
            raise ctx.error(key, f"unknown key (allowed: {', '.join(allowed)})")


def _param_message(ctx: _Ctx, prefix: str, e: Exception) -> ConfigError:
    """Map a ParameterError ("field = v is out of range: …") onto the config key path."""
    msg = str(e)
    m = re.match(r"([\w.\[\]]+) = ", msg)
    if m:
        field = m.group(1)
        own = field.startswith(("layers", "n_above", "n_below")) or (prefix and field.startswith(prefix + "."))
        key = field if own or not prefix else f"{prefix}.{field}"
        return ctx.error(key, msg.split(" = ", 1)[1])
    if prefix and msg.startswith(prefix + ": "):
        msg = msg[len(prefix) + 2 :]
    return ctx.error(prefix or None, msg)


def _layers(ctx: _Ctx, data: dict) -> list[Layer]:
    raw = data.get("layers")
    if raw is None:
        raise ctx.error("layers", "missing: give at least one [[layers]] table (n, mua, mus, g, thickness)")
    if not isinstance(raw, list) or not raw or not all(isinstance(x, dict) for x in raw):
        raise ctx.error("layers", "expected one or more [[layers]] tables")
    layers = []
    for i, t in enumerate(raw):
        p = f"layers[{i}]"
        _check_keys(ctx, p, t, LAYER_KEYS)
        for k in ("n", "mua", "mus"):
            if k not in t:
                raise ctx.error(f"{p}.{k}", "missing (each layer needs n, mua, mus; g and thickness are optional)")
        vals = {k: _number(ctx, f"{p}.{k}", t[k]) for k in ("n", "mua", "mus", "g") if k in t}
        vals["thickness"] = _number(ctx, f"{p}.thickness", t.get("thickness", "inf"), allow_inf=True)
        phase = None
        if "phase" in t:
            ph = t["phase"]
            if not isinstance(ph, list) or not all(isinstance(x, list) and len(x) == 2 for x in ph) or not ph:
                raise ctx.error(f"{p}.phase", "expected a list of [weight, g] pairs")
            phase = [(_number(ctx, f"{p}.phase", w), _number(ctx, f"{p}.phase", g)) for w, g in ph]
        try:
            layers.append(Layer(phase=phase, **vals))
        except _core.ParameterError as e:
            raise _param_message(ctx, p, e) from None
    return layers


def _source(ctx: _Ctx, data: dict):
    t = data.get("source", {})
    if not isinstance(t, dict):
        raise ctx.error("source", "expected a [source] table")
    _check_keys(ctx, "source", t, SOURCE_KEYS)
    kind = t.get("type", "pencil")
    if kind not in ("pencil", "diffuse"):
        raise ctx.error("source.type", f'{kind!r} is not a source type: use "pencil" or "diffuse"')
    theta = _number(ctx, "source.theta_deg", t.get("theta_deg", 0.0))
    phi = _number(ctx, "source.phi_deg", t.get("phi_deg", 0.0))
    if kind == "diffuse":
        for k in ("theta_deg", "phi_deg"):
            if k in t:
                raise ctx.error(
                    f"source.{k}", "only a pencil beam has a direction (diffuse light comes from all directions)"
                )
    spec = {"type": kind} if kind == "diffuse" else {"type": kind, "theta_deg": theta, "phi_deg": phi}
    try:
        return spec, _make_source(spec)
    except _core.ParameterError as e:  # the core's range, stated in radians
        key, value = ("source.phi_deg", phi) if str(e).startswith("source.phi") else ("source.theta_deg", theta)
        raise ctx.error(key, f"{value:g} is out of range (in radians: {e})") from None


def _make_source(spec: dict):
    """The engine's source object for a source spec."""
    if spec["type"] == "diffuse":
        return DiffuseIllumination()
    return PencilBeam(theta=math.radians(spec["theta_deg"]), phi=math.radians(spec["phi_deg"]))


def _tallies(ctx: _Ctx, data: dict):
    t = data.get("tallies", {})
    if not isinstance(t, dict):
        raise ctx.error("tallies", "expected a [tallies] table")
    _check_keys(ctx, "tallies", t, tuple(TALLY_KEYS))
    out: dict[str, Any] = {}
    for k, v in t.items():
        kind, key = TALLY_KEYS[k], f"tallies.{k}"
        if kind in ("count", "order"):  # ranges: subsurf.Tallies (the core) checks them, errors mapped below
            out[k] = _int(ctx, key, v)
        elif kind == "length":
            out[k] = _number(ctx, key, v)
        elif kind == "bool":
            if not isinstance(v, bool):
                raise ctx.error(key, f"expected true or false, got {v!r}")
            out[k] = v
        elif kind == "pair":
            if v is False:
                out[k] = None
                continue
            if not (isinstance(v, list) and len(v) == 2):
                raise ctx.error(key, f"expected [n_cos_theta, n_phi] (two integers) or false, got {v!r}")
            out[k] = (_int(ctx, key, v[0]), _int(ctx, key, v[1]))
        else:  # a kind the core added: this table must learn to read it
            raise ctx.error(key, f"fields of kind {kind!r} cannot be given in a configuration file yet")
    try:
        return out, Tallies(**out)
    except _core.ParameterError as e:
        raise _param_message(ctx, "tallies", e) from None


def _toml(text: str, path: str) -> tuple[_Ctx, dict]:
    ctx = _Ctx(path, text)
    try:
        return ctx, tomllib.loads(text)
    except RecursionError:
        raise ConfigError(f"{path}: invalid TOML: arrays or tables nested too deeply") from None
    except tomllib.TOMLDecodeError as e:
        msg = str(e)
        m = re.search(r"\(at line (\d+), column (\d+)\)", msg)
        if m:
            return_msg = msg[: m.start()].strip()
            raise ConfigError(f"{path}:{m.group(1)}: invalid TOML: {return_msg} (column {m.group(2)})") from None
        if "end of document" in msg:
            raise ConfigError(f"{path}:{max(len(ctx.lines), 1)}: invalid TOML: {msg}") from None
        raise ConfigError(f"{path}: invalid TOML: {msg}") from None


def parse_config(text: str, path: str = "<string>") -> RunConfig:
    """Parse the TOML text of a configuration; ``path`` is used in error messages."""
    return _from_data(*_toml(text, path))


def _from_data(ctx: _Ctx, data: dict, top_keys=TOP_KEYS) -> RunConfig:
    """A checked :class:`RunConfig` from parsed TOML data."""
    _check_keys(ctx, "", data, top_keys)
    photons = _int(ctx, "photons", data.get("photons", 100_000))
    seed = _int(ctx, "seed", data.get("seed", 0))
    threads = _int(ctx, "threads", data["threads"]) if "threads" in data else None
    try:
        _core.mc_validate_run(photons, seed, threads)
    except _core.ParameterError as e:
        raise _param_message(ctx, "", e) from None
    n_above = _number(ctx, "n_above", data.get("n_above", 1.0))
    n_below = _number(ctx, "n_below", data.get("n_below", 1.0))
    layers = _layers(ctx, data)
    try:
        stack = Stack(layers, n_above=n_above, n_below=n_below)
    except _core.ParameterError as e:
        raise _param_message(ctx, "", e) from None
    src_spec, source = _source(ctx, data)
    tally_spec, tallies = _tallies(ctx, data)
    output = data.get("output")
    if output is not None and not isinstance(output, str):
        raise ctx.error("output", f"expected a file name, got {output!r}")
    desc = data.get("description", "")
    if not isinstance(desc, str):
        raise ctx.error("description", f"expected a string, got {desc!r}")
    return RunConfig(
        stack=stack,
        source=source,
        tallies=tallies,
        photons=photons,
        seed=seed,
        threads=threads,
        output=output,
        description=desc,
        path=ctx.path,
        data={"source": src_spec, "tallies": tally_spec},
    )


# ---- sweeps -----------------------------------------------------------------------------------

SWEEP_KEYS = ("name", "values", "units", "set")
#: Keys of a configuration an axis of a sweep may set (tallies stay fixed: every point has the same grids).
SWEEPABLE = re.compile(
    r"(photons|seed|n_above|n_below|layers\[(\d+)\]\.(n|mua|mus|g|thickness)|source\.(theta_deg|phi_deg))"
)


@dataclasses.dataclass
class SweepConfig:
    """A sweep file: a run configuration (the keys of :func:`parse_config`) plus ``[[sweep]]``
    tables, one per grid axis, the first outermost::

        [[sweep]]
        name = "g"                  # the coordinate's name
        values = [0.0, 0.5, 0.9]    # its values (numbers)
        set = "layers[0].g"         # the key it sets (default: the name)

        [[sweep]]                   # several keys varying together along one axis
        name = "wavelength"
        units = "nm"
        values = [450, 550, 650]
        [sweep.set]
        "layers[0].mua" = [0.30, 0.10, 0.05]
        "layers[0].mus" = [12.0, 10.0, 8.0]

    Keys an axis may set: photons, seed, n_above, n_below, ``layers[i].{n, mua, mus, g,
    thickness}`` and ``source.{theta_deg, phi_deg}``. Every point uses the file's seed unless an
    axis sets ``seed`` (common random numbers: neighbouring points differ by much less noise than
    their standard errors). An instance is a picklable sweep point for :func:`subsurf.sweep`:
    ``config(**coords)`` runs that point's simulation.
    """

    base: dict
    axes: list
    path: str = "<string>"
    output: str | None = None
    description: str = ""
    threads: int | None = None

    def grid(self) -> dict:
        return {a["name"]: list(a["values"]) for a in self.axes}

    def units(self) -> dict:
        return {a["name"]: a["units"] for a in self.axes}

    def data_at(self, **coords) -> dict:
        """The configuration data of the point with these coordinates."""
        import copy

        data = copy.deepcopy(self.base)
        for a in self.axes:
            i = a["values"].index(coords[a["name"]])
            for key, vals in a["set"].items():
                m = SWEEPABLE.fullmatch(key)
                if m.group(2) is not None:
                    data["layers"][int(m.group(2))][m.group(3)] = vals[i]
                elif m.group(4) is not None:
                    data.setdefault("source", {})[m.group(4)] = vals[i]
                else:
                    data[key] = vals[i]
        return data

    def run_config(self, **coords) -> RunConfig:
        """The checked run configuration of one point."""
        text = f"sweep point ({', '.join(f'{k} = {v!r}' for k, v in coords.items())})"
        try:
            return _from_data(_Ctx(self.path, ""), self.data_at(**coords))
        except ConfigError as e:
            msg = str(e)
            if msg.startswith(self.path + ": "):
                msg = msg[len(self.path) + 2 :]
            raise ConfigError(f"{self.path}: {text}: {msg}") from None

    def fingerprint(self) -> dict:
        base = {k: v for k, v in self.base.items() if k not in ("threads", "output", "description")}
        return {"kind": "subsurf.simulate", "base": base, "axes": self.axes}

    def __call__(self, **coords):
        """Simulate one point: its totals and histograms (:func:`subsurf.sweeps.result_data`)."""
        from .cluster import task_threads
        from .mc import simulate
        from .sweeps import result_data

        rc = self.run_config(**coords)
        threads = task_threads(self.threads if self.threads is not None else rc.threads)
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # an interrupted point is redone, not kept
            res = simulate(rc.stack, **{**rc.simulate_kwargs(), "threads": threads})
        if res.partial:
            raise KeyboardInterrupt(f"{self.path}: interrupted during a sweep point")
        return result_data(res)


def _sweep_axes(ctx: _Ctx, raw) -> list:
    if not isinstance(raw, list) or not raw or not all(isinstance(t, dict) for t in raw):
        raise ctx.error("sweep", "expected one or more [[sweep]] tables (name, values, set)")
    axes, names, keys = [], set(), set()
    for i, t in enumerate(raw):
        p = f"sweep[{i}]"
        _check_keys(ctx, p, t, SWEEP_KEYS)
        name = t.get("name")
        if not isinstance(name, str) or not name.isidentifier() or name in names:
            raise ctx.error(f"{p}.name", f"expected a new axis name (letters, digits, _), got {name!r}")
        names.add(name)
        values = t.get("values")
        if not isinstance(values, list) or not values:
            raise ctx.error(f"{p}.values", f"expected a non-empty list of numbers, got {values!r}")
        for v in values:
            _number(ctx, f"{p}.values", v)
        if len(set(values)) != len(values):
            raise ctx.error(f"{p}.values", "values repeat")
        units = t.get("units", "")
        if not isinstance(units, str):
            raise ctx.error(f"{p}.units", f"expected a string, got {units!r}")
        st = t.get("set", name)
        sets = {st: values} if isinstance(st, str) else st
        if not isinstance(sets, dict) or not sets:
            raise ctx.error(f"{p}.set", 'expected a key ("layers[0].g") or a table of keys and value lists')
        for key, vals in sets.items():
            if not SWEEPABLE.fullmatch(key):
                raise ctx.error(
                    f"{p}.set",
                    f"{key!r} cannot be swept (photons, seed, n_above, n_below, layers[i].n/mua/mus/g/thickness, "
                    "source.theta_deg/phi_deg)",
                )
            if key in keys:
                raise ctx.error(f"{p}.set", f"{key!r} is already set by another axis")
            keys.add(key)
            if not isinstance(vals, list) or len(vals) != len(values):
                raise ctx.error(f"{p}.set", f"{key!r}: expected a list of {len(values)} values (one per axis value)")
        axes.append({"name": name, "values": values, "units": units, "set": sets})
    return axes


def parse_sweep(text: str, path: str = "<string>") -> SweepConfig:
    """Parse the TOML text of a sweep (see :class:`SweepConfig`); every point is checked."""
    import itertools

    ctx, data = _toml(text, path)
    axes = _sweep_axes(ctx, data.get("sweep"))
    base = {k: v for k, v in data.items() if k != "sweep"}
    first = _from_data(ctx, base)  # the base configuration, with the file's line numbers in errors
    for i, a in enumerate(axes):
        for key in a["set"]:
            m = SWEEPABLE.fullmatch(key)
            if m.group(2) is not None and int(m.group(2)) >= len(first.stack.layers):
                raise ctx.error(f"sweep[{i}].set", f"{key!r}: there are {len(first.stack.layers)} layers")
    cfg = SweepConfig(base, axes, path, first.output, first.description)
    for combo in itertools.product(*(a["values"] for a in axes)):
        cfg.run_config(**dict(zip((a["name"] for a in axes), combo)))
    return cfg


def _read(path: str | os.PathLike) -> tuple[str, str]:
    path = os.fspath(path)
    try:
        with open(path, "rb") as f:
            raw = f.read()
    except FileNotFoundError:
        raise ConfigError(f"{path}: no such file") from None
    except OSError as e:
        raise ConfigError(f"{path}: cannot read ({e.strerror})") from None
    try:
        return raw.decode("utf-8"), path
    except UnicodeDecodeError as e:
        raise ConfigError(f"{path}: not UTF-8 text (byte {e.start})") from None


def load_config(path: str | os.PathLike) -> RunConfig:
    """Read and check a TOML configuration file."""
    return parse_config(*_read(path))


def load_sweep(path: str | os.PathLike) -> SweepConfig:
    """Read and check a sweep file (a configuration with ``[[sweep]]`` axes; see
    :class:`SweepConfig`): every point of the grid is checked up front."""
    return parse_sweep(*_read(path))
