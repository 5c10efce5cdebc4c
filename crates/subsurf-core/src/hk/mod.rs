//! Hanrahan–Krueger (1993) first-order (single-scattering) BRDF/BTDF of layered media.
