"""``subsurf fit MEASUREMENTS.csv --kind profile|slab``: optical properties from measurements.

- ``--kind profile``: a CSV with columns ``r`` (mm), ``rd`` (mm⁻²) and ``sigma`` (its standard
  deviation) → (σa, σs') of a semi-infinite medium with ``--model`` (``monte_carlo`` needs
  ``--table TABLE.h5``, a :class:`subsurf.bssrdf.ProfileTable` of the same g and eta);
- ``--kind slab``: a CSV with columns ``rd``, ``tt``, ``sigma_rd``, ``sigma_tt`` (one sample per
  row) and ``--thickness`` → (μa, μs') per row with ``--model multipole`` (diffusion).

Prints each parameter with its standard uncertainty (from the covariance) and χ²/dof."""

from __future__ import annotations

import csv

import numpy as np


def add_parser(sub):
    p = sub.add_parser("fit", help="fit optical properties to measurements in a CSV file")
    p.add_argument("csv", metavar="MEASUREMENTS.csv")
    p.add_argument("--kind", choices=("profile", "slab"), default="profile")
    p.add_argument("--model", default=None, help="profile model (default dipole) or multipole for slabs")
    p.add_argument("--g", type=float, default=0.0)
    p.add_argument("--eta", type=float, default=1.4, help="relative index of the medium (profile fits)")
    p.add_argument("--n", type=float, default=1.4, help="slab index (slab fits)")
    p.add_argument("--thickness", type=float, help="slab thickness, mm (slab fits)")
    p.add_argument("--table", metavar="TABLE.h5", help="ProfileTable for --model monte_carlo")
    p.add_argument("--initial", type=float, nargs=2, default=(0.05, 1.0), metavar=("MUA", "MUS_PRIME"))
    p.set_defaults(func=run)


def _read(path, cols):
    """The columns ``cols`` of a CSV file as float arrays (a UTF-8 byte-order mark is ignored)."""
    from . import CommandError as UserError

    try:
        with open(path, newline="", encoding="utf-8-sig") as f:
            rows = list(csv.DictReader(f))
    except FileNotFoundError:
        raise UserError(f"{path}: no such file") from None
    except (OSError, UnicodeDecodeError, csv.Error) as e:
        raise UserError(f"{path}: not a readable CSV file ({e})") from None
    if not rows:
        raise UserError(f"{path}: no data rows")
    header = [str(c).strip() for c in rows[0] if c is not None]
    missing = [c for c in cols if c not in header]
    if missing:
        raise UserError(f"{path}: missing column(s) {', '.join(missing)} (need {', '.join(cols)}; found {header})")
    out = {c: np.empty(len(rows)) for c in cols}
    for i, row in enumerate(rows):
        row = {str(k).strip(): v for k, v in row.items() if k is not None}
        for c in cols:
            try:
                out[c][i] = float(row[c])
            except (TypeError, ValueError):
                what = "is missing (a short row)" if row[c] is None else f"= {row[c]!r} is not a number"
                raise UserError(f"{path}: data row {i + 1}: {c} {what}") from None
    return out


def _show(fit):
    for name, (v, s) in fit.as_dict().items():
        print(f"  {name:<14} = {v:.6g} ± {s:.2g} mm^-1")
    print(f"  chi2/dof = {fit.chi2:.3g}/{fit.dof}")


def run(a) -> int:
    from .. import bssrdf
    from . import CommandError as UserError

    if a.kind == "profile":
        d = _read(a.csv, ("r", "rd", "sigma"))
        model = a.model or "dipole"
        table = bssrdf.ProfileTable.load(a.table) if a.table else None
        fit = bssrdf.fit_profile(
            d["r"], d["rd"], d["sigma"], model=model, g=a.g, eta=a.eta, initial=a.initial, table=table
        )
        print(f"{a.csv}: {len(d['r'])} points, model {model}, g = {a.g:g}, eta = {a.eta:g}")
        _show(fit)
        return 0
    if a.thickness is None:
        raise UserError("--kind slab needs --thickness (mm)")
    d = _read(a.csv, ("rd", "tt", "sigma_rd", "sigma_tt"))
    model = a.model or "multipole"
    for i in range(len(d["rd"])):
        fit = bssrdf.fit_slab_totals(
            d["rd"][i],
            d["tt"][i],
            (d["sigma_rd"][i], d["sigma_tt"][i]),
            a.thickness,
            g=a.g,
            n=a.n,
            model=model,
            initial=a.initial,
        )
        print(f"row {i + 1}: Rd = {d['rd'][i]:.5g}, Tt = {d['tt'][i]:.5g} (model {model}, d = {a.thickness:g} mm)")
        _show(fit)
    return 0
