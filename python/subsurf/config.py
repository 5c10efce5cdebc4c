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
    "load_config",
    "parse_config",
    "TOP_KEYS",
    "LAYER_KEYS",
    "SOURCE_KEYS",
    "TALLY_KEYS",
]

TOP_KEYS = ("description", "photons", "seed", "threads", "n_above", "n_below", "layers", "source", "tallies", "output")
LAYER_KEYS = ("name", "n", "mua", "mus", "g", "thickness", "phase")
SOURCE_KEYS = ("type", "theta_deg", "phi_deg")
#: Fields of ``subsurf.Tallies`` (docs/architecture.md) and their kinds.
TALLY_KEYS = {
    "nr": "count",
    "dr": "length",
    "nz": "count",
    "dz": "length",
    "na": "count",
    "nt": "count",
    "dt": "length",
    "brdf": "brdf",
    "max_order": "count",
    "spatial": "bool",
    "angular": "bool",
}


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
        if kind == "count":  # ranges: subsurf.Tallies (the core) checks them, errors mapped below
            out[k] = _int(ctx, key, v)
        elif kind == "length":
            out[k] = _number(ctx, key, v)
        elif kind == "bool":
            if not isinstance(v, bool):
                raise ctx.error(key, f"expected true or false, got {v!r}")
            out[k] = v
        elif kind == "brdf":
            if v is False:
                out[k] = None
                continue
            if not (isinstance(v, list) and len(v) == 2):
                raise ctx.error(key, f"expected [n_cos_theta, n_phi] (two integers) or false, got {v!r}")
            out[k] = (_int(ctx, key, v[0]), _int(ctx, key, v[1]))
    try:
        return out, Tallies(**out)
    except _core.ParameterError as e:
        raise _param_message(ctx, "tallies", e) from None


def parse_config(text: str, path: str = "<string>") -> RunConfig:
    """Parse the TOML text of a configuration; ``path`` is used in error messages."""
    ctx = _Ctx(path, text)
    try:
        data = tomllib.loads(text)
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
    _check_keys(ctx, "", data, TOP_KEYS)
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
        path=path,
        data={"source": src_spec, "tallies": tally_spec},
    )


def load_config(path: str | os.PathLike) -> RunConfig:
    """Read and check a TOML configuration file."""
    path = os.fspath(path)
    try:
        with open(path, "rb") as f:
            raw = f.read()
    except FileNotFoundError:
        raise ConfigError(f"{path}: no such file") from None
    except OSError as e:
        raise ConfigError(f"{path}: cannot read ({e.strerror})") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as e:
        raise ConfigError(f"{path}: not UTF-8 text (byte {e.start})") from None
    return parse_config(text, path)
