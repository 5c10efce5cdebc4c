"""Efficiency of random_walk on the benchmark scenes (benches/render_compare.py), 64×64, 1 thread.

For each scene: K independent renders at N spp (seeds 1000+i); per-pixel variance of an N-spp
image from the K renders (unbiased, ddof=1), averaged over the object pixels and channels (= the
expected RMSE^2 of one render of an unbiased method); CPU seconds per render (1 thread);
efficiency = 1 / (var * s). Also the object mean +- sigma (bias check between versions).
Usage: python docs/scripts/walk_efficiency.py LABEL [K] [scene ...]; writes (or updates)
walk_efficiency_LABEL.json in the working directory (docs/render.md, "Random walk speed").
"""

import json
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "benches"))
import render_compare as rc  # noqa: E402
import subsurf.render as R  # noqa: E402

N = {"marble-env": 32, "marble-rect": 8, "skin-env": 128, "skin-rect": 64, "ear-env": 128, "ear-rect": 32}


def main(argv):
    label = argv[0]
    K = int(argv[1]) if len(argv) > 1 else 6
    cases = argv[2:] or list(N)
    out = {}
    for case in cases:
        obj, light = case.split("-")
        sc = rc.scene(obj, light, 64)
        mask = rc.object_mask(sc)
        imgs, cpu = [], []
        for i in range(K):
            c0 = time.process_time()
            img = R.render(sc, "random_walk", spp=N[case], seed=1000 + i, threads=1, pass_spp=N[case])
            cpu.append(time.process_time() - c0)
            imgs.append(np.asarray(img.array, float))
        a = np.stack([im[mask] for im in imgs])
        var = float(a.var(axis=0, ddof=1).mean())
        mean, sig = rc.mean_and_sigma(imgs, mask)
        s = float(np.mean(cpu))
        out[case] = dict(
            spp=N[case],
            var=var,
            cpu=s,
            eff=1.0 / (var * s),
            mean=mean.tolist(),
            sigma=sig.tolist(),
            load=os.getloadavg()[0],
        )
        print(
            f"{label} {case}: N={N[case]} var={var:.4e} cpu={s:.3f}s eff={1 / (var * s):.4e} "
            f"mean={np.round(mean, 4)} ±{np.round(sig, 4)} load={os.getloadavg()[0]:.1f}",
            flush=True,
        )
    path = f"walk_efficiency_{label}.json"
    old = json.load(open(path)) if os.path.exists(path) else {}
    old.update(out)
    json.dump(old, open(path, "w"), indent=1)


if __name__ == "__main__":
    main(sys.argv[1:])
