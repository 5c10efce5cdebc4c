"""The README's Python example: a semi-infinite medium, Monte Carlo R(r) against the dipole."""

import os

import subsurf
from subsurf import diffusion, plot

photons = int(os.environ.get("SUBSURF_EXAMPLE_PHOTONS", 200_000))
stack = subsurf.Stack([subsurf.Layer(n=1.3, mua=0.01, mus=2.0, g=0.0)])  # mm^-1, semi-infinite
res = subsurf.simulate(stack, photons=photons, seed=1, tallies=subsurf.Tallies(nr=50, dr=0.2))
print(f"R_d = {res.diffuse_reflectance:.4f} ± {res.diffuse_reflectance_stderr:.4f}")
r = res.rd_r.centers()
print("dipole at r = 1 mm:", diffusion.dipole_rd(1.0, 0.01, 2.0, 1.3), " MC:", res.rd_r.values[r.searchsorted(1.0)])
subsurf.save(res, os.path.join(os.environ.get("SUBSURF_EXAMPLE_OUT", "."), "quickstart.h5"))
plot.save_figure(plot.figure(res), os.path.join(os.environ.get("SUBSURF_EXAMPLE_OUT", "."), "quickstart.png"))
