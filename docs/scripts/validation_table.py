#!/usr/bin/env python3
"""The README's validation table, recomputed: the Monte Carlo runs of the validation tests (same
media, photons and seeds as ``tests/test_mc_validation.py`` and ``tests/test_mc_tallies.py``)
against their exact references. Prints the table; ``--readme`` also replaces the table under
"## Validation" in README.md. The other rows (pass/fail checks with a band rather than a number)
are stated as their tests assert them.

Usage: python docs/scripts/validation_table.py [--readme] [--quick]
(``--quick``: 1/100 of the photons, to check the script runs; its numbers are not the README's.)
"""

from __future__ import annotations

import argparse
import math
import os
import re
import sys

import subsurf
from subsurf import Layer, Stack, Tallies, simulate

README = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))), "README.md")
HEADER = "| check | reference | result |\n|---|---|---|\n"
STATIC = (
    "| MC order-1 BRDF/BTDF vs Hanrahan–Krueger | the analytic model | every bin within a Šidák-corrected 10⁻³ band |\n"
    "| MC R(r) at albedo 0.01 | exact single-scattering R₁(r) | within 2 % + 4σ |\n"
    "| diffusion vs Monte Carlo | the MC engine | see `docs/diffusion_vs_mc.md` |\n"
)


def semi_infinite(n, albedo):
    return Stack([Layer(n, 1.0 - albedo, albedo, 0.0, math.inf)], 1.0, 1.0)


def sci(x):
    """One significant digit as the README writes it: 4·10⁻⁴."""
    m, e = f"{x:.0e}".split("e")
    sup = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")
    return f"{m}·10{str(int(e)).translate(sup)}"


def z(value, se, want):
    return f"{(value - want) / se:+.1f}σ".replace("-", "−")


def rows(scale=1.0):
    """The table's computed rows (markdown), photons × ``scale``."""
    n = lambda photons: max(100, int(photons * scale))  # noqa: E731
    out = []
    r = simulate(Stack([Layer(1.0, 1.0, 9.0, 0.75, 0.2)], 1.0, 1.0), photons=n(400_000), seed=1)
    rd, tt = r.diffuse_reflectance, r.transmittance
    out.append(
        "| van de Hulst slab (a/s = 0.9, g = 0.75, τ = 2) | Rd = 0.09739, Tt = 0.66096 | "
        f"{rd:.5f}, {tt:.5f} ({z(rd, r.diffuse_reflectance_stderr, 0.09739)}, "
        f"{z(tt, r.transmittance_stderr, 0.66096)}; σ ≈ {sci(r.diffuse_reflectance_stderr)}, {r.photons:,} photons) |"
    )
    r = simulate(Stack([Layer(1.5, 1.0, 9.0, 0.0, math.inf)], 1.0, 1.0), photons=n(200_000), seed=2)
    out.append(
        "| Giovanelli semi-infinite, n = 1.5 | Rsp + Rd = 0.2600 | "
        f"{r.specular_reflectance + r.diffuse_reflectance:.5f} ± {r.diffuse_reflectance_stderr:.5f} |"
    )
    zs, ses = [], []
    for albedo, rd, photons in [(0.8, 0.28525, 200_000), (0.9, 0.41495, 200_000), (0.99, 0.75272, 50_000)]:
        r = simulate(semi_infinite(1.0, albedo), photons=n(photons), seed=3)
        zs.append(abs(r.diffuse_reflectance - rd) / r.diffuse_reflectance_stderr)
        ses.append(r.diffuse_reflectance_stderr)
    out.append(
        "| exact semi-infinite, index-matched, isotropic | Rd = 0.28525, 0.41495, 0.75272 | "
        f"within {max(zs):.1f}σ (σ ≈ {sci(min(ses))}–{sci(max(ses))}) |"
    )
    a = 0.999
    r = simulate(
        semi_infinite(1.0, a), photons=n(200_000), seed=2, tallies=Tallies(spatial=False, angular=False, max_order=2)
    )
    out.append(
        f"| order-1 Rd, semi-infinite (albedo {a}) | (a/2)(1 − ln 2) = {a / 2 * (1 - math.log(2)):.5f} | "
        f"{r.rd_order.values[1]:.5f} ± {r.rd_order.stderr[1]:.5f} |"
    )
    return "\n".join(out) + "\n"


def write_readme(table, path=README):
    text = open(path, encoding="utf-8").read()
    new, count = re.subn(
        r"(## Validation[^\n]*\n\n)\| check \|.*?\n(?=\n)", lambda m: m.group(1) + table, text, count=1, flags=re.S
    )
    if count != 1:
        raise SystemExit(f"{path}: no '## Validation' table found")
    from subsurf.atomic import write_bytes

    write_bytes(path, new.encode("utf-8"), force=True)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--readme", action="store_true", help="replace the table in README.md")
    ap.add_argument("--quick", action="store_true", help="1/100 of the photons (a check that the script runs)")
    args = ap.parse_args(argv)
    table = HEADER + rows(0.01 if args.quick else 1.0) + STATIC
    print(f"subsurf {subsurf.__version__}\n\n{table}")
    if args.readme and not args.quick:
        write_readme(table)
        print(f"wrote {README}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
