"""Write the voxel grid of ``veined_cube.toml``: a 12³ medium of marble (Jensen et al. 2001,
σa, σs' per RGB channel) crossed by dark, more absorbing veins, as ``veined_sigma_a.npy``
(shape (12, 12, 12, 3), mm⁻¹) and ``veined_sigma_s.npy`` (shape (12, 12, 12): the same in
every channel). Run from this folder: ``python make_veined_grid.py``."""

import numpy as np

n = 12
x, y, z = np.meshgrid(*(np.linspace(-1.0, 1.0, n),) * 3, indexing="ij")
vein = np.abs(np.sin(5.0 * (x + 0.5 * y + 0.3 * np.sin(3.0 * z)))) < 0.35
marble_a = np.array([0.0021, 0.0041, 0.0071])
vein_a = np.array([1.5, 1.8, 1.2])
sigma_a = np.where(vein[..., None], vein_a, marble_a).astype(np.float32)
sigma_s = np.where(vein, 1.2, 2.6).astype(np.float32)
np.save("veined_sigma_a.npy", sigma_a)
np.save("veined_sigma_s.npy", sigma_s)
print(f"veins: {vein.mean():.0%} of the voxels")
