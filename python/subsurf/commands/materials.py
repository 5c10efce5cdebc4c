"""``subsurf materials``: the Jensen et al. (2001) material library."""

from __future__ import annotations

from . import Command


def add_arguments(p) -> None:
    pass


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


COMMAND = Command("materials", "list the material library", add_arguments, run)
