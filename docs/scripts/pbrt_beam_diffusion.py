"""Reference values of photon beam diffusion as pbrt-v4 computes them.

A double-precision numpy transcription of pbrt-v4's ``BeamDiffusionMS`` and ``BeamDiffusionSS``
(src/pbrt/bssrdf.cpp; PBR 3rd ed. §15.5): each integral over the depth t of the refracted beam is
estimated with ``n`` depths at the midpoints of the exponential CDF, t_i = −ln(1 − (i + ½)/n)/σ.
pbrt uses n = 100; ``--check`` also prints the n = 10⁵ values to show the 100-point rule's own
quadrature error. The printed tuples are the expected numbers of
``crates/subsurf-core/src/bssrdf/contract_tests.rs`` (PBRT_BEAM_DIFFUSION).

Usage: python docs/scripts/pbrt_beam_diffusion.py [--check]
"""

from __future__ import annotations

import sys

import numpy as np


def fresnel_moments(eta):
    """pbrt's FresnelMoment1/2 for eta >= 1 (d'Eon's fits)."""
    e = eta
    c1 = -4.61686 + 11.1136 * e - 10.4646 * e**2 + 5.11455 * e**3 - 1.27198 * e**4 + 0.12746 * e**5
    r = 1 / e
    c2 = (
        -547.033
        + 45.3087 * r**3
        - 218.725 * r**2
        + 458.843 * r
        + 404.557 * e
        - 189.519 * e**2
        + 54.9327 * e**3
        - 9.00603 * e**4
        + 0.63942 * e**5
    )
    return c1, c2


def fr_dielectric(cos_i, eta):
    """pbrt-v4 FrDielectric (unpolarised); negative cos flips to the inside."""
    cos_i = np.clip(cos_i, -1, 1)
    inside = cos_i < 0
    eta = np.where(inside, 1 / eta, eta)
    cos_i = np.abs(cos_i)
    sin2_t = (1 - cos_i**2) / eta**2
    cos_t = np.sqrt(np.maximum(0, 1 - sin2_t))
    rpar = (eta * cos_i - cos_t) / (eta * cos_i + cos_t)
    rper = (cos_i - eta * cos_t) / (cos_i + eta * cos_t)
    return np.where(sin2_t >= 1, 1.0, 0.5 * (rpar**2 + rper**2))


def hg_pbrt(cos_theta, g):
    """pbrt-v4 HenyeyGreenstein (its cosine is between two directions pointing away)."""
    denom = 1 + g * g + 2 * g * cos_theta
    return (1 - g * g) / (4 * np.pi * denom * np.sqrt(denom))


def beam_ms(sigma_s, sigma_a, g, eta, r, n=100):
    sps = sigma_s * (1 - g)
    spt = sigma_a + sps
    rhop = sps / spt
    dg = (2 * sigma_a + sps) / (3 * spt * spt)
    s_tr = np.sqrt(sigma_a / dg)
    c1, c2 = fresnel_moments(eta)
    ze = -2 * dg * (1 + 3 * c2) / (1 - 2 * c1)
    c_phi, c_e = 0.25 * (1 - 2 * c1), 0.5 * (1 - 3 * c2)
    i = np.arange(n)
    zr = -np.log(1 - (i + 0.5) / n) / spt
    zv = -zr + 2 * ze
    dr, dv = np.sqrt(r * r + zr * zr), np.sqrt(r * r + zv * zv)
    phi = (np.exp(-s_tr * dr) / dr - np.exp(-s_tr * dv) / dv) / (4 * np.pi * dg)
    edn = (zr * (1 + s_tr * dr) * np.exp(-s_tr * dr) / dr**3 - zv * (1 + s_tr * dv) * np.exp(-s_tr * dv) / dv**3) / (
        4 * np.pi
    )
    e = phi * c_phi + edn * c_e
    kappa = 1 - np.exp(-2 * spt * (dr + zr))
    return float(np.sum(kappa * rhop * rhop * e) / n)


def beam_ss(sigma_s, sigma_a, g, eta, r, n=100):
    st = sigma_a + sigma_s
    rho = sigma_s / st
    t_crit = r * np.sqrt(max(eta * eta - 1, 0))
    i = np.arange(n)
    ti = t_crit - np.log(1 - (i + 0.5) / n) / st
    d = np.sqrt(r * r + ti * ti)
    cos_o = ti / d
    f = rho * np.exp(-st * (d + t_crit)) / d**2 * hg_pbrt(cos_o, g) * (1 - fr_dielectric(-cos_o, eta)) * np.abs(cos_o)
    return float(np.sum(f) / n)


POINTS = [
    (0.5, 0.0, 1.0, 0.5),
    (0.8, 0.0, 1.33, 1.0),
    (0.95, 0.5, 1.33, 0.3),
    (0.99, 0.0, 1.5, 2.0),
    (0.99, 0.9, 1.33, 5.0),
    (0.9, 0.5, 1.5, 0.1),
]


def main(argv):
    check = "--check" in argv
    for rho, g, eta, r in POINTS:
        ms, ss = beam_ms(rho, 1 - rho, g, eta, r), beam_ss(rho, 1 - rho, g, eta, r)
        print(f"    ({rho}, {g}, {eta}, {r}, {ms:.6e}, {ss:.6e}),")
        if check:
            ms5, ss5 = beam_ms(rho, 1 - rho, g, eta, r, 100000), beam_ss(rho, 1 - rho, g, eta, r, 100000)
            print(f"    # n=1e5: {ms5:.6e} ({ms / ms5 - 1:+.2e}), {ss5:.6e} ({ss / ss5 - 1:+.2e})")


if __name__ == "__main__":
    main(sys.argv[1:])
