"""
One object, three rendering methods and an opaque surface
=========================================================

A marble sphere (Jensen et al. 2001) rendered by each method of :func:`subsurf.render.render`:
``hierarchical`` (Jensen & Buhler 2002, BSSRDF integrated over irradiance samples), ``probe``
(pbrt-v4's probe rays, unbiased for the profile) and ``random_walk`` (volumetric path tracing inside
the mesh with the engine's physics: no diffusion approximation, the reference). Beside them the same
sphere with an opaque Lambertian surface of the same total reflectance: the hard shadow line and the
missing glow where the light enters on the far side are what subsurface scattering removes.
"""

import matplotlib.pyplot as plt
import numpy as np
import subsurf.render as R
from subsurf import bssrdf, materials

marble = R.Translucent.library("marble", model="dipole")
m = materials.get("marble")
# the opaque twin reflects what the dipole says a flat marble surface reflects, per channel
albedo = [bssrdf.Profile.from_model("dipole", a, s, eta=m.eta).total() for a, s in zip(m.sigma_a, m.sigma_s_prime)]


def scene(material):
    return R.Scene(
        [
            R.Object.sphere(material, center=(0, 0, 8), radius=8, subdivisions=3),
            R.Object.plane(R.Lambertian(0.4), size=(200, 200)),
        ],
        [R.RectLight((-20, 30, 40), (6, 0, 0), (0, -4, 4), 2e4)],
        environment=(0.02, 0.025, 0.035),
        camera=R.Camera((0, -60, 22), look_at=(0, 0, 7), fov=24, width=100, height=92),
    )


panels = [
    ("hierarchical, 4 spp", R.render(scene(marble), "hierarchical", spp=4, seed=1)),
    ("probe, 32 spp", R.render(scene(marble), "probe", spp=32, seed=1)),
    ("random_walk, 32 spp", R.render(scene(marble), "random_walk", spp=32, seed=1)),
    ("opaque Lambertian, 4 spp", R.render(scene(R.Lambertian(albedo)), "hierarchical", spp=4, seed=1)),
]


def white_point(a):
    """tonemap's reference: the 99.5th percentile of the luminance."""
    return np.percentile(a @ [0.2126, 0.7152, 0.0722], 99.5)


ref = white_point(panels[2][1].array)  # one exposure for all four: the random walk's
fig, axes = plt.subplots(1, 4, figsize=(10, 2.8), layout="constrained")
for ax, (title, img) in zip(axes, panels):
    ax.imshow(R.tonemap(img.array, exposure=np.log2(white_point(img.array) / ref)))
    ax.set_title(f"{title}\n{img.elapsed_s:.1f} s", fontsize=8)
    ax.set_axis_off()
plt.show()
