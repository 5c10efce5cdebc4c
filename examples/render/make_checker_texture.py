"""Write the colour map and the mesh of ``textured_cube.toml``: ``checker.png``, an 8 × 8
checkerboard of two skin-like reflectances (sRGB-encoded, as image files are), and
``uv_cube.obj``, a unit cube whose every face carries the whole map (texture coordinates per
face corner; trimesh splits the vertices at the seams, subsurf merges them again). Run from this
folder: ``python make_checker_texture.py``."""

import numpy as np
from PIL import Image


def srgb(x):
    x = np.asarray(x, dtype=np.float64)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / 2.4) - 0.055)


light, dark = [0.63, 0.44, 0.34], [0.25, 0.12, 0.08]  # linear reflectance per RGB channel
i, j = np.indices((8, 8))
img = np.where(((i + j) % 2 == 0)[..., None], srgb(light), srgb(dark))
Image.fromarray(np.round(img * 255).astype(np.uint8)).save("checker.png")

corners = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)]
faces = [(1, 4, 3, 2), (5, 6, 7, 8), (1, 2, 6, 5), (2, 3, 7, 6), (3, 4, 8, 7), (4, 1, 5, 8)]  # outward
lines = [f"v {x} {y} {z}" for x, y, z in corners] + ["vt 0 0", "vt 1 0", "vt 1 1", "vt 0 1"]
for a, b, c, d in faces:
    lines += [f"f {a}/1 {b}/2 {c}/3", f"f {a}/1 {c}/3 {d}/4"]
with open("uv_cube.obj", "w") as f:
    f.write("\n".join(lines) + "\n")
