"""
Reflectance profiles: diffusion models against Monte Carlo
==========================================================

The radial diffuse reflectance R_d(r) of a semi-infinite medium under a normally incident pencil
beam, from the Monte Carlo engine (:meth:`subsurf.bssrdf.Profile.from_monte_carlo`, with its
standard errors) and from three closed-form models of :mod:`subsurf.bssrdf`: the classical dipole
(Jensen et al. 2001), d'Eon's better dipole (2012) and photon beam diffusion (Habel et al. 2013).
The medium has albedo 0.95 and isotropic scattering; r is in transport mean free paths. The
diffusion models miss the light that leaves near the beam after a few events (r < 1 mfp).
"""

import matplotlib.pyplot as plt
import numpy as np
import subsurf
from subsurf import bssrdf

mua, mus, n = 0.05, 0.95, 1.3  # mm⁻¹: σt = 1 mm⁻¹, so r is in mean free paths
stack = subsurf.Stack([subsurf.Layer(n, mua, mus, g=0.0)])
mc = bssrdf.Profile.from_monte_carlo(stack, photons=20_000, seed=1)
data = mc.mc_data()
# bins [0, r_min), then a log grid, then one overflow bin past the last edge (left out here)
edges, weight, stderr = (np.asarray(data[k], float) for k in ("edges", "weight", "stderr"))
weight, stderr = weight[:-1], stderr[:-1]
area = np.pi * (edges[1:] ** 2 - edges[:-1] ** 2)
r_mid = np.sqrt(edges[1:] * np.maximum(edges[:-1], 1e-12))
ok = (weight > 0) & (edges[:-1] >= 0.01)

r = np.geomspace(0.01, 20, 200)
fig, ax = plt.subplots(figsize=(6.4, 4.4), layout="constrained")
ax.errorbar(r_mid[ok], (weight / area)[ok], yerr=(stderr / area)[ok], fmt="o", ms=3, color="k", label="Monte Carlo ±1σ")
for model in ("dipole", "better_dipole", "photon_beam_diffusion"):
    p = bssrdf.Profile.from_model(model, mua, mus, g=0.0, eta=n)
    ax.plot(r, p.rd(r), label=f"{model} (total {p.total():.3f})")
ax.set(xscale="log", yscale="log", xlabel="radius r (mm = mean free paths)", ylabel="R_d(r) (mm⁻²)")
ax.set_title(f"albedo 0.95, η = {n}: Monte Carlo total {mc.total():.3f}", fontsize=10)
ax.set(xlim=(0.01, 30), ylim=(1e-6, None))
ax.legend(fontsize=8)
ax.grid(True, which="both", alpha=0.25)
plt.show()
