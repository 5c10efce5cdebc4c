"""``subsurf demo``: a three-layer skin at ~630 nm, and the dipole against Monte Carlo for its dermis.

Optical properties (mm⁻¹, mm) at λ = 630 nm, from S. L. Jacques, "Skin optics", Oregon Medical
Laser Center News, Jan. 1998 (omlc.org/news/jan98/skinoptics.html), whose formulas give:

* baseline (bloodless, melanin-free) skin absorption 0.244 + 85.3·exp(−(λ − 154)/66.2) cm⁻¹
  = 0.308 cm⁻¹;
* melanosome absorption 6.6·10¹¹·λ⁻³·³³ cm⁻¹ = 315 cm⁻¹; a light-skinned epidermis with a
  melanosome volume fraction of 3 % absorbs 0.03·315 + 0.97·0.308 ≈ 9.7 cm⁻¹ = 0.97 mm⁻¹;
* dermal reduced scattering 2·10⁵·λ⁻¹·⁵ + 2·10¹²·λ⁻⁴ cm⁻¹ = 25.3 cm⁻¹ = 2.53 mm⁻¹ (used for
  epidermis and dermis), with g = 0.9 (σs = 25.3 mm⁻¹);
* dermal absorption with 2 % blood at 75 % saturation: whole blood (150 g/L haemoglobin,
  molar extinction at 630 nm 610 (HbO₂) and 5149 (Hb) cm⁻¹/M, S. Prahl's compilation) absorbs
  ≈ 9.4 cm⁻¹, so 0.02·9.4 + 0.98·0.308 ≈ 0.49 cm⁻¹ = 0.049 mm⁻¹.

Subcutaneous fat: σa = 0.011 mm⁻¹, σs′ = 1.2 mm⁻¹ (g = 0.9), representative of the in-vitro
adipose-tissue values near 630 nm reviewed by Lister, Wright & Chappell, J. Biomed. Opt. 17,
090901 (2012), where published values spread by a factor of ~2. Refractive index 1.4 for all three
layers (Lister et al. 2012 §4), epidermis 0.1 mm and dermis 1.5 mm thick, fat semi-infinite, air above.

These are representative values for a demonstration, not a patient model.
"""

from __future__ import annotations

import math
import os
import time

#: (name, n, σa mm⁻¹, σs mm⁻¹, g, thickness mm) — see the module docstring for sources.
SKIN_630NM = (
    ("epidermis", 1.4, 0.97, 25.3, 0.9, 0.1),
    ("dermis", 1.4, 0.049, 25.3, 0.9, 1.5),
    ("subcutis", 1.4, 0.011, 12.0, 0.9, math.inf),
)

DEFAULT_PHOTONS = 150_000  # ~1300 scattering events per photon: 20-40 s for both runs on 2 cores
QUICK_PHOTONS = 2_000  # `subsurf demo --quick`: every output, in seconds


def skin_stack():
    """The demo's three-layer skin as a :class:`subsurf.Stack` (in air)."""
    from .medium import Layer, Stack

    return Stack([Layer(n, mua, mus, g, d) for _, n, mua, mus, g, d in SKIN_630NM], n_above=1.0, n_below=1.0)


def dermis_stack():
    """A semi-infinite slab of the demo's dermis, for the comparison with diffusion theory."""
    from .medium import Layer, Stack

    _, n, mua, mus, g, _ = SKIN_630NM[1]
    return Stack([Layer(n, mua, mus, g)], n_above=1.0, n_below=1.0)


def run(
    out_dir: str = "out",
    photons: int | None = None,
    threads: int | None = None,
    quiet: bool = False,
    quick: bool = False,
) -> int:
    """Simulate the skin and the dermis, write ``out_dir/demo.h5``, ``demo_dermis.h5`` and
    ``demo.png``, then render the materials scene (:mod:`subsurf.render.demo`: ``render.png``, and
    ``render.exr`` when the ``openexr`` package is there — checked first, with one line if not).

    ``quick``: a smoke run in seconds (few photons, a tiny image) that still writes every output.
    ``out_dir`` is created if needed; the demo's own files in it are replaced. Returns the exit
    status: 0, or 130 when Ctrl-C cut a run short (what was traced is written, marked partial).
    """
    from matplotlib.figure import Figure

    from . import diffusion, plot, runner
    from .render import demo as render_demo
    from .tallies import Tallies

    photons = int(photons or (QUICK_PHOTONS if quick else DEFAULT_PHOTONS))
    if os.path.exists(out_dir) and not os.path.isdir(out_dir):
        raise runner.UserError(f"--out-dir {out_dir}: is a file, not a directory")
    os.makedirs(out_dir, exist_ok=True)
    exr = render_demo.check_exr()
    tallies = Tallies(nr=100, dr=0.05, nz=100, dz=0.04, na=15)
    t0 = time.monotonic()
    results, written = {}, []
    for key, stack, label, name in (
        ("skin", skin_stack(), "three-layer skin", "demo.h5"),
        ("dermis", dermis_stack(), "semi-infinite dermis", "demo_dermis.h5"),
    ):
        res = runner.simulate(stack, label, quiet, photons=photons, seed=2001, threads=threads, tallies=tallies)
        if not quiet:
            print(f"{label} at 630 nm:")
            print(res.summary())
            print()
        path, held = runner.save_result(res, os.path.join(out_dir, name), force=True)
        written.append(path)
        if res.partial or held:
            print(f"wrote {path} (partial: interrupted)")
            return runner.EXIT_INTERRUPTED
        results[key] = res
    skin, dermis = results["skin"], results["dermis"]

    fig = Figure(figsize=(16, 4.8), layout="constrained")
    ax = plot.reflectance_profile(skin, fig.add_subplot(1, 3, 1), models=())
    ax.set_title("three-layer skin: R(r)", fontsize=10)
    ax = plot.absorption_depth(skin, fig.add_subplot(1, 3, 2))
    ax.set_title("three-layer skin: absorption vs depth", fontsize=10)
    _, n, mua, mus, g, _ = SKIN_630NM[1]
    optics = (mua, mus * (1 - g), n)
    ax = plot.reflectance_profile(dermis, fig.add_subplot(1, 3, 3), optics=optics)
    ax.set_title("semi-infinite dermis: Monte Carlo vs diffusion", fontsize=10)
    fig.suptitle(
        f"subsurf demo: skin at 630 nm, {photons:,} photons per run "
        f"(R_d = {skin.diffuse_reflectance:.4f} ± {skin.diffuse_reflectance_stderr:.1g})",
        fontsize=11,
    )
    png = plot.save_figure(fig, os.path.join(out_dir, "demo.png"))
    dipole = float(diffusion.total_diffuse_reflectance(optics[1] / (optics[0] + optics[1]), optics[2]))
    print(
        f"dermis total diffuse reflectance: Monte Carlo {dermis.diffuse_reflectance:.4f} ± "
        f"{dermis.diffuse_reflectance_stderr:.1g}, dipole {dipole:.4f}"
    )
    print(f"wrote {written[0]}, {written[1]} and {png} ({time.monotonic() - t0:.1f} s)")
    img = render_demo.run(out_dir, threads=threads, quiet=quiet, quick=quick, exr=exr)
    return runner.EXIT_INTERRUPTED if img.partial or img.spp == 0 else 0
