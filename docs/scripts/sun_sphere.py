"""A sphere under a sun: where the ``adaptive`` model puts the light, against an exact reference
(docs/render.md, "A sun on a sphere: where the directional error sits").

The reference is ``_core.bssrdf_sun_exitance`` (the curved Monte Carlo on an analytic sphere: the
exitance per unit sun irradiance by equal-area bins of cos α, α from the sub-solar point). The
model's exitance is read from its ``hierarchical`` image by dividing each pixel by its
deterministic exit term F_t(μ_o) s(μ_o)/(π c) (s the exit term's shape) and binned the same way
(pixels with μ_o > 0.2; a sun from the camera shows the lit bins, from behind the dark ones).
Then, per incidence angle, the sphere's own tallies under a pencil launch
(``_core.bssrdf_curved_escape_parts``): total and near-half escape per entering power against the
diffuse run's, the forward exit offset and the exits' first azimuthal harmonic ⟨cos φ⟩ per chord
bin and for the far half.

Usage: python docs/scripts/sun_sphere.py [--cases ketchup:1,marble:0.25] [--size 48] [--spp 4]
"""

from __future__ import annotations

import argparse

import numpy as np
import subsurf._core as C
import subsurf.render as R
from subsurf.adaptive_table import _stacks

RADIUS, DIST, FOV, BINS = 10.0, 60.0, 24.0, 10


def material(name, scale, model):
    if name == "skin_layered":  # the validation matrix's two-layer skin (adaptive_validation.py)
        import adaptive_validation

        return adaptive_validation.skin_layered(scale, model, 10000)
    m = R.Translucent.library(name, model=model, mc_photons=10000, mc_seed=3)
    m.sigma_a, m.sigma_s = [scale * x for x in m.sigma_a], [scale * x for x in m.sigma_s]
    return m


def fresnel(mu, n):
    mu = np.clip(mu, 1e-9, 1.0)
    st = np.sqrt(1 - mu * mu) / n
    ct = np.sqrt(np.maximum(0.0, 1 - st * st))
    return 0.5 * (((mu - n * ct) / (mu + n * ct)) ** 2 + ((n * mu - ct) / (n * mu + ct)) ** 2)


def camera_frame():
    cam = np.array([0.0, -DIST, 0.15 * DIST])
    fw = -cam / np.linalg.norm(cam)
    right = np.cross(fw, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    return cam, fw, right, np.cross(right, fw)


def model_exitance(m, angle, size, spp):
    """The model's exitance by cos α bins (NaN where fewer than 8 pixels), sun at `angle` degrees
    from the camera."""
    cam, fw, right, up = camera_frame()
    a = np.radians(angle)
    to_sun = -fw * np.cos(a) + right * np.sin(a)
    scene = R.Scene(
        [R.Object.sphere(m, radius=RADIUS, subdivisions=5)],
        [R.DirectionalLight(tuple(to_sun), 1.0)],
        (0, 0, 0),
        R.Camera(tuple(cam), fov=FOV, width=size, height=size),
    )
    img = R.render(scene, "hierarchical", spp=spp, seed=2).array
    tab = m.adaptive_table()
    mus = (np.arange(100000) + 0.5) / 100000
    c = 1 - np.mean(2 * mus * fresnel(mus, m.eta))
    t = np.tan(np.radians(FOV) / 2)
    sums, count = np.zeros((BINS, 3)), np.zeros(BINS)
    for i in range(size):
        for j in range(size):
            d = fw + (2 * (j + 0.5) / size - 1) * t * right + (1 - 2 * (i + 0.5) / size) * t * up
            d /= np.linalg.norm(d)
            b = np.dot(cam, d)
            disc = b * b - (np.dot(cam, cam) - RADIUS**2)
            if disc < 0:
                continue
            n = (cam + (-b - np.sqrt(disc)) * d) / RADIUS
            mu_o = np.dot(n, -d)
            if mu_o < 0.2:
                continue
            k = min(int((np.dot(n, to_sun) + 1) / 2 * BINS), BINS - 1)
            shape = np.array([tab.exit_factor(ch, mu_o) for ch in range(3)])  # the exit term's shape
            sums[k] += img[i, j] * np.pi * c / ((1 - fresnel(mu_o, m.eta)) * shape)
            count[k] += 1
    return np.where(count[:, None] >= 8, sums / np.maximum(count, 1)[:, None], np.nan)


def pct(x):
    return " ".join("  -  " if np.isnan(v) else f"{100 * v:+.0f}".replace("-", "−") for v in x)


def sun_map(name, scale, size, spp):
    m = material(name, scale, "adaptive")
    m.adaptive_table()
    lit, dark = model_exitance(m, 0.0, size, spp), model_exitance(m, 180.0, size, spp)
    got = np.where(np.isnan(lit), dark, lit)
    print(f"\n{name} x{scale}, sphere r = {RADIUS} mm: cos α bins from −1 (anti-solar) to 1 (sub-solar)")
    for ch, stack in enumerate(m.channel_stacks()):
        exact = np.array(C.bssrdf_sun_exitance(_stacks([stack])[0], RADIUS, BINS, 200000, 11))
        print(f"  channel {ch}: exact " + " ".join(f"{x:.4f}" for x in exact))
        rel = np.where(exact > 1e-3 * exact.max(), got[:, ch] / np.maximum(exact, 1e-300) - 1, np.nan)
        print(f"  channel {ch}: adaptive / exact − 1 (%) {pct(rel)}")


def pencil_table(name, scale, photons=40000):
    m = material(name, scale, "monte_carlo")
    mus = (np.arange(20000) + 0.5) / 20000
    entering_diffuse = np.mean(2 * mus * (1 - fresnel(mus, m.eta)))
    for ch, stack in enumerate(m.channel_stacks()):
        st = _stacks([stack])[0]
        d = C.bssrdf_curved_escape_parts(st, "sphere", RADIUS, photons, 11)
        print(f"\n{name} x{scale} channel {ch}, sphere r = {RADIUS} mm (diffuse: near/total {d[2] / d[0]:.3f})")
        for th in (0, 30, 50, 65, 80):
            out = C.bssrdf_curved_escape_parts(st, "sphere", RADIUS, photons, 11, theta_deg=th)
            mean, near, bins, shift, harm = out[0], out[2], out[4], out[5], out[6]
            e = 1 - fresnel(np.cos(np.radians(th)), m.eta)
            rel = (mean / e) / (d[0] / entering_diffuse)
            cos_phi = [h / b if b > 0 else 0.0 for h, b in zip(harm[:-1], bins)]
            far = harm[-1] / (mean - near) if mean - near > 1e-12 else 0.0
            print(
                f"  θi {th:2d}°: total per entering / diffuse {rel:.3f}, near/total {near / mean:.3f}, "
                f"forward offset {shift:.2f} mm; <cos φ> per chord bin "
                + " ".join(f"{x:+.2f}" for x in cos_phi)
                + f", far half {far:+.2f}"
            )


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument(
        "--cases", default="ketchup:1,marble:0.25", help="material:scale, comma-separated (or skin_layered:1)"
    )
    ap.add_argument("--size", type=int, default=48)
    ap.add_argument("--spp", type=int, default=4)
    a = ap.parse_args(argv)
    for case in a.cases.split(","):
        name, scale = case.split(":")
        sun_map(name, float(scale), a.size, a.spp)
        pencil_table(name, float(scale))
    return 0


if __name__ == "__main__":
    main()
