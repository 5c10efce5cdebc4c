"""Two runs of one configuration with different seeds, merged into one result (tallies are additive)."""

import os

import subsurf
from subsurf.config import load_config

here = os.path.dirname(os.path.abspath(__file__))
out = os.environ.get("SUBSURF_EXAMPLE_OUT", ".")
photons = int(os.environ.get("SUBSURF_EXAMPLE_PHOTONS", 100_000))
cfg = load_config(os.path.join(here, "van_de_hulst_slab.toml"))
runs = [subsurf.simulate(cfg.stack, photons=photons, seed=s, source=cfg.source, tallies=cfg.tallies) for s in (1, 2)]
both = subsurf.merge(*runs)
for r in runs + [both]:
    print(f"{r.photons:>8} photons: R_d = {r.diffuse_reflectance:.5f} ± {r.diffuse_reflectance_stderr:.5f}")
subsurf.save(both, os.path.join(out, "merged.h5"))
