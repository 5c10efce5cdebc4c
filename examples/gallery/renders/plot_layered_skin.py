"""
A layered material: skin with an epidermis
==========================================

Skin is layered: a thin, strongly absorbing epidermis over the scattering dermis. Here a 0.25 mm
pigmented epidermis (melanin absorbs blue most) lies over Jensen et al.'s ``skin1`` dermis. The Monte Carlo
profile (:meth:`subsurf.render.Translucent.from_stacks`, model ``monte_carlo``) is the engine's
R_d(r) of the two-layer stack, per RGB channel; beside it the dermis alone with the same profile
model. The epidermis darkens and reddens the light that comes back, most where it left the surface
near where it entered.
"""

import matplotlib.pyplot as plt
import numpy as np
import subsurf
import subsurf.render as R
from subsurf import materials

dermis = materials.get("skin1").to_layers()  # one semi-infinite layer per channel, n = η
g = 0.8
epidermis_mua = (0.6, 1.5, 3.0)  # mm⁻¹, R, G, B: a pigmented epidermis
stacks = [
    subsurf.Stack(
        [
            subsurf.Layer(d.n, mua, d.mus_prime / (1 - g), g, 0.25),
            subsurf.Layer(d.n, d.mua, d.mus_prime / (1 - g), g),
        ]
    )
    for d, mua in zip(dermis, epidermis_mua)
]
plain = [subsurf.Stack([s.layers[1]]) for s in stacks]


def scene(material):
    return R.Scene(
        [
            R.Object.sphere(material, center=(0, 0, 6), radius=6, subdivisions=3),
            R.Object.plane(R.Lambertian(0.4), size=(200, 200)),
        ],
        [R.RectLight((-25, -20, 40), (8, 0, 0), (0, -5, 5), 2e4)],
        environment=(0.03, 0.03, 0.035),
        camera=R.Camera((0, -45, 17), look_at=(0, 0, 5), fov=24, width=140, height=120),
    )


mc = dict(model="monte_carlo", mc_photons=10_000)
panels = [
    ("dermis alone", R.render(scene(R.Translucent.from_stacks(plain, **mc)), "hierarchical", spp=4, seed=1)),
    (
        "pigmented 0.25 mm epidermis over it",
        R.render(scene(R.Translucent.from_stacks(stacks, **mc)), "hierarchical", spp=4, seed=1),
    ),
]


def white_point(a):
    """tonemap's reference: the 99.5th percentile of the luminance."""
    return np.percentile(a @ [0.2126, 0.7152, 0.0722], 99.5)


ref = white_point(panels[0][1].array)  # the same exposure for both
fig, axes = plt.subplots(1, 2, figsize=(7, 3.2), layout="constrained")
for ax, (title, img) in zip(axes, panels):
    ax.imshow(R.tonemap(img.array, exposure=np.log2(white_point(img.array) / ref)))
    ax.set_title(f"{title}\nMonte Carlo profile, {img.elapsed_s:.1f} s", fontsize=8)
    ax.set_axis_off()
plt.show()
