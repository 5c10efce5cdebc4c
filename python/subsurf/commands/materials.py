"""``subsurf materials``: the Jensen et al. (2001) material library."""

from __future__ import annotations


def add_parser(sub) -> None:
    p = sub.add_parser("materials", help="list the material library")
    p.set_defaults(func=run)


def run(a) -> int:
    import numpy as np

    from .. import materials

    print(f"{'name':<12} {'sigma_s_prime R G B (mm^-1)':>30}   {'sigma_a R G B (mm^-1)':>30}   {'eta':>5}")
    for n in materials.names():
        m = materials.get(n)
        sp = " ".join(f"{x:9.4g}" for x in np.atleast_1d(m.sigma_s_prime))
        sa = " ".join(f"{x:9.4g}" for x in np.atleast_1d(m.sigma_a))
        print(f"{n:<12} {sp:>30}   {sa:>30}   {m.eta:>5.3g}")
    print("(Jensen, Marschner, Levoy & Hanrahan, SIGGRAPH 2001, Fig. 5)")
    return 0
