"""
Absorption with depth in three-layer skin
=========================================

A(z), the power absorbed per unit depth, in a three-layer model of skin at about 630 nm
(epidermis, dermis, subcutis; the stack of ``examples/skin_three_layer.toml``) under a normally
incident pencil beam, with the Monte Carlo standard errors as a band. The strongly absorbing
0.1 mm epidermis takes a large share near the surface; below it A(z) falls off with the dermis'
effective attenuation. :func:`subsurf.plot.absorption_depth` draws the layer boundaries.
"""

import matplotlib.pyplot as plt
import subsurf
from subsurf import plot

stack = subsurf.Stack(
    [
        subsurf.Layer(1.4, 0.97, 25.3, 0.9, 0.1),  # epidermis: n, μa, μs (mm⁻¹), g, thickness (mm)
        subsurf.Layer(1.4, 0.049, 25.3, 0.9, 1.5),  # dermis
        subsurf.Layer(1.4, 0.011, 12.0, 0.9),  # subcutis, semi-infinite
    ]
)
res = subsurf.simulate(stack, photons=5_000, seed=2001, tallies=subsurf.Tallies(nr=40, dr=0.1, nz=80, dz=0.04))
print(res.summary() if hasattr(res, "summary") else res)
print("absorbed per layer:", res.absorbed_per_layer)

fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(9.6, 4.0), layout="constrained")
plot.absorption_depth(res, ax=ax1)
ax1.set_title("A(z)", fontsize=10)
plot.reflectance_profile(res, ax=ax2, models=())
ax2.set_title("R(r)", fontsize=10)
plt.show()
