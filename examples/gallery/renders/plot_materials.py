"""
Translucent materials side by side
==================================

Five spheres (radius 6 mm) of measured and made-up materials, rendered with the hierarchical
BSSRDF integrator (Jensen & Buhler 2002) and the dipole profile: marble, skin, whole milk and
ketchup from Jensen et al. (2001) (:mod:`subsurf.materials`), and a jade green made from a surface
colour and a mean free path (:meth:`subsurf.render.Translucent.from_reflectance`). A small, bright area
light behind and above the row makes the light that travels through the material visible at the
silhouettes: the red channel, scattered and absorbed least in skin and ketchup, reaches furthest.
"""

import matplotlib.pyplot as plt
import subsurf.render as R

materials = [
    ("marble", R.Translucent.library("marble")),
    ("skin", R.Translucent.library("skin1")),
    ("whole milk", R.Translucent.library("wholemilk")),
    ("ketchup", R.Translucent.library("ketchup")),
    ("jade (from a colour)", R.Translucent.from_reflectance((0.35, 0.75, 0.45), mfp=(2.0, 4.0, 2.5))),
]
objects = [
    R.Object.sphere(m, center=(16 * (i - 2), 0, 6), radius=6, subdivisions=3) for i, (_, m) in enumerate(materials)
]
objects.append(R.Object.plane(R.Lambertian(0.4), size=(300, 300)))
scene = R.Scene(
    objects,
    [R.RectLight((0, 40, 40), (30, 0, 0), (0, -4, 4), 4e4), R.RectLight((-40, -40, 60), (8, 0, 0), (0, -6, 6), 8e3)],
    environment=(0.02, 0.025, 0.035),
    camera=R.Camera((0, -95, 30), look_at=(0, 0, 5), fov=24, width=400, height=150),
)
img = R.render(scene, "hierarchical", spp=4, seed=1)

fig, ax = plt.subplots(figsize=(8, 3.2), layout="constrained")
ax.imshow(R.tonemap(img.array))
for i, (name, _) in enumerate(materials):
    ax.text((i + 0.5) / len(materials), 0.04, name, transform=ax.transAxes, ha="center", color="w", fontsize=8)
ax.set_axis_off()
ax.set_title(f"hierarchical, dipole, {img.spp} spp, {img.elapsed_s:.1f} s", fontsize=9)
plt.show()
