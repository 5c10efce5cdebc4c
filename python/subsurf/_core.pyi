"""Type stubs of the extension module ``subsurf._core`` (sections by core module)."""
from __future__ import annotations

import numpy as np
import numpy.typing as npt

_F = npt.NDArray[np.float64]

class ParameterError(ValueError): ...

__version__: str

# ---- diffusion ------------------------------------------------------------------------------
# Flat float64 arrays of equal length in, flat arrays out (python/subsurf/diffusion.py
# broadcasts); model names "dipole" | "better_dipole"; mfp kinds "transport" | "diffuse".
def diffusion_fdr(eta: _F) -> _F: ...
def diffusion_a(model_name: str, eta: _F) -> _F: ...
def diffusion_fresnel_moments(eta: _F) -> tuple[_F, _F]: ...
def diffusion_params(model_name: str, sigma_a: _F, sigma_s_prime: _F, eta: _F) -> list[_F]:
    """[alpha_prime, D, sigma_tr, A, z_r, z_v]"""
def diffusion_rd(model_name: str, r: _F, sigma_a: _F, sigma_s_prime: _F, eta: _F) -> _F: ...
def diffusion_total_rd(model_name: str, alpha_prime: _F, eta: _F) -> _F: ...
def diffusion_alpha_prime_from_rd(model_name: str, rd: _F, eta: _F) -> _F: ...
def diffusion_properties_from_color(model_name: str, mfp_kind: str, rd: _F, mfp: _F, eta: _F) -> tuple[_F, _F]: ...
def diffusion_sd(model_name: str, xi: _F, wi: _F, xo: _F, wo: _F, sigma_a: _F, sigma_s_prime: _F, eta: _F) -> _F: ...
def diffusion_brdf(model_name: str, wi: _F, wo: _F, sigma_a: _F, sigma_s_prime: _F, eta: _F) -> _F: ...
def diffusion_ft(eta: _F, cos_theta: _F) -> _F: ...
def diffusion_check_properties(sigma_a: _F, sigma_s_prime: _F, eta: _F) -> None: ...

# --- mc ---
def mc_validate_source(kind: str, theta: float, phi: float) -> None: ...
def mc_simulate(
    layers: list[tuple[float, float, float, list[tuple[float, float]], float]],
    n_above: float,
    n_below: float,
    photons: int,
    seed: int,
    threads: int | None,
    source: tuple[str, float, float],
    progress: object | None = None,
    tallies: dict | None = None,
) -> dict:
    """Totals, and under "histograms" a list of dicts (name, values, stderr: flat float64 arrays
    in C order; shape, edges, axes, edge_units, units, description) when ``tallies`` (a
    ``subsurf.Tallies.to_dict()``) is given."""
