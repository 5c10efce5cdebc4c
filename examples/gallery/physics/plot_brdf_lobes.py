"""
BRDF lobes of a thin slab, by scattering order
==============================================

The BRDF of a thin forward-scattering slab (0.5 mm, σs = 2 mm⁻¹, g = 0.6, n = 1.5) lit at 45°,
tallied by the Monte Carlo engine on equal-solid-angle bins (:class:`subsurf.Tallies` ``brdf``),
shown in the plane of incidence and over the whole hemisphere. The single-scattering part with no
interface reflection (``brdf_single_direct``) is compared with Hanrahan and Krueger's first-order
BRDF (:func:`subsurf.hk.single_scattering_brdf`, H&K 1993 eq. 21), which it estimates exactly.
"""

import math

import matplotlib.pyplot as plt
import numpy as np
import subsurf
from subsurf import hk, plot

stack = subsurf.Stack([subsurf.Layer(1.5, 0.05, 2.0, 0.6, 0.5)])
theta_i = math.radians(45)
res = subsurf.simulate(
    stack,
    photons=200_000,
    seed=3,
    source=subsurf.PencilBeam(theta_i),
    tallies=subsurf.Tallies(brdf=(8, 12), max_order=4, spatial=False),
)

fig = plt.figure(figsize=(11, 4.4), layout="constrained")
ax1 = fig.add_subplot(1, 2, 1)
plot.in_plane(res, ax=ax1)
ax1.set_title("all orders, plane of incidence", fontsize=10)
ax2 = fig.add_subplot(1, 2, 2, projection="polar")
plot.hemisphere_map(res, ax=ax2, fig=fig)
ax2.set_xlabel("")

# Order 1 without interface reflections against Hanrahan–Krueger. The tally is a cosine-weighted
# average over each (cos θ, φ) bin, so the model is averaged the same way (Gauss–Legendre in each bin).
# Frames: the engine's z points into the slab; the model's wi points towards the light.
h = res.histograms["brdf_single_direct"]
mu_e, phi_e = (np.asarray(e, float) for e in h.edges[1:3])
wi = np.array([-math.sin(theta_i), 0.0, math.cos(theta_i)])
x, w = np.polynomial.legendre.leggauss(6)
x, w = 0.5 * (x + 1), 0.5 * w


def bin_average(j):
    """The model's cosine-weighted average over every μ bin of φ bin j."""
    out = []
    for m0, m1 in zip(mu_e[:-1], mu_e[1:]):
        mu, ph = np.meshgrid(m0 + (m1 - m0) * x, phi_e[j] + (phi_e[j + 1] - phi_e[j]) * x, indexing="ij")
        s = np.sqrt(1 - mu**2)
        f = hk.single_scattering_brdf(stack, wi, np.stack([s * np.cos(ph), s * np.sin(ph), mu], -1))
        out.append(np.sum(f * mu * np.outer(w, w)) / np.sum(mu * np.outer(w, w)))
    return np.array(out)


phi_c = 0.5 * (phi_e[1:] + phi_e[:-1])
theta_c = np.degrees(np.arccos(0.5 * (mu_e[1:] + mu_e[:-1])))
fig2, ax = plt.subplots(figsize=(6.4, 4.0), layout="constrained")
for target, sign, c in ((0.0, 1, "C0"), (math.pi, -1, "C3")):
    j = int(np.argmin(np.abs(np.angle(np.exp(1j * (phi_c - target))))))
    label = f"bin φ = {math.degrees(phi_c[j]):.0f}°"
    ax.errorbar(sign * theta_c, h.values[0, :, j], yerr=h.stderr[0, :, j], fmt="o", ms=3, color=c, label=f"MC, {label}")
    ax.plot(sign * theta_c, bin_average(j), "-", color=c, lw=1, label=f"Hanrahan–Krueger, {label}")
ax.set(xlabel="exit polar angle θ (deg), signed by side", ylabel="order-1 BRDF (sr⁻¹)", xlim=(-90, 90))
ax.set_title("single scattering, no interface reflection", fontsize=10)
ax.legend(fontsize=8)
ax.grid(True, alpha=0.25)
plt.show()
