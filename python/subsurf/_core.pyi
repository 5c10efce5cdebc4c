"""Type stubs of the extension module ``subsurf._core`` (one section per binding module)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

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
def diffusion_sd(model_name: str, xi: _F, wi: _F, xo: _F, wo: _F, sigma_a: _F, sigma_s_prime: _F, eta: _F) -> _F: ...
def diffusion_brdf(model_name: str, wi: _F, wo: _F, sigma_a: _F, sigma_s_prime: _F, eta: _F) -> _F: ...
def diffusion_ft(eta: _F, cos_theta: _F) -> _F: ...
def diffusion_check_properties(sigma_a: _F, sigma_s_prime: _F, eta: _F) -> None: ...

# --- mc (crates/subsurf-py/src/mc.rs) ---
# Layers as (n, mua, mus, lobes [(weight, g)], thickness); source as ("pencil", theta, phi) or
# ("diffuse", 0, 0); tallies as subsurf.Tallies.to_dict() with brdf a tuple or None.
# A state dict (flat, see subsurf.state.TallyState): {"scheme": str, "start": int, "end": int,
# "events": int, "fingerprint": int, "names": list[str], "lengths": list[int],
# "extremes": list[bool], "s1": uint64 array (4 limbs per bin), "s2": uint64 array (5 per bin),
# "min": float64 array, "max": float64 array}.
_Layers = list[tuple[float, float, float, list[tuple[float, float]], float]]
_Source = tuple[str, float, float]

MC_CHUNK_PHOTONS: int
MC_MAX_THREADS: int
MC_MAX_BINS: int
MC_MAX_ORDER: int
MC_MAX_PENCIL_THETA: float
MC_MAX_EVENTS_PER_PHOTON: float
MC_STATE_SCHEME: str
#: The fields of subsurf.Tallies (core TallyConfig::fields): (name, kind, default); kinds "count",
#: "length", "pair", "order", "bool".
MC_TALLY_FIELDS: list[tuple[str, str, Any]]

def mc_isa() -> str:
    """Instruction set of the Monte Carlo lane kernel for the next run: avx512, avx2, sse, neon or scalar (the
    best this machine has, or the one the environment variable SUBSURF_ISA forces; ValueError when it names an
    unknown one or one this CPU cannot run)."""

def mc_isas() -> list[str]:
    """Every instruction set this machine can run the Monte Carlo lane kernel on, best first."""

def mc_validate_source(kind: str, theta: float, phi: float) -> None: ...
def mc_validate_run(photons: int, seed: int, threads: int | None = None) -> None: ...
def mc_validate_tallies(tallies: dict) -> None: ...
def mc_expected_events(layers: _Layers, n_above: float, n_below: float) -> float:
    """Estimated scattering events per photon; raises ParameterError for endless histories."""

def mc_run(
    layers: _Layers,
    n_above: float,
    n_below: float,
    photons: int,
    seed: int,
    threads: int | None,
    source: _Source,
    progress: object | None = None,
    tallies: dict | None = None,
    state: dict | None = None,
    start: int | None = None,
) -> dict:
    """Trace photons [start (or state["end"]), photons): {"state": state dict,
    "interrupted": bool, "elapsed_s": float}."""

def mc_check_state(
    layers: _Layers,
    n_above: float,
    n_below: float,
    seed: int,
    source: _Source,
    state: dict,
    tallies: dict | None = None,
) -> None:
    """Raise ParameterError unless ``state`` belongs to the run described (same stack, source,
    seed and tallies); traces and finishes nothing."""

def mc_finish(
    layers: _Layers,
    n_above: float,
    n_below: float,
    seed: int,
    source: _Source,
    state: dict,
    tallies: dict | None = None,
) -> dict:
    """Totals (+ "_stderr"; specular_reflectance, diffuse_reflectance, transmittance,
    unscattered_transmittance, absorbed, roulette), absorbed_per_layer (+ stderr), photons,
    events, and "histograms": a list of dicts (name, values, stderr, measures: flat float64
    arrays in C order / per axis; shape, edges, axes, edge_units, overflow, units, description)."""

def mc_merge_states(states: list[dict]) -> dict:
    """States of consecutive photon ranges, in range order, appended exactly into one."""

def mc_axis_measures(kind: str, edges: _F) -> _F:
    """Exact bin measures of an axis kind ("r", "z", "t", "theta", "theta_projected",
    "cos_theta", "phi", "order", "order_one")."""

# --- medium (crates/subsurf-py/src/medium.rs) ---
def validate_layer(
    n: float, mua: float, mus: float, lobes: list[tuple[float, float]], thickness: float, prefix: str = ""
) -> None: ...
def validate_stack(layers: _Layers, n_above: float, n_below: float) -> None: ...
def layer_properties(layer: tuple[float, float, float, list[tuple[float, float]], float]) -> dict[str, float]:
    """g, sigma_t, albedo, mus_prime, sigma_t_prime, transport_mfp, optical_thickness."""

def stack_boundaries(layers: _Layers, n_above: float, n_below: float) -> list[float]: ...
def mix_components(
    n: float, thickness: float, components: list[tuple[float, float, float, float]]
) -> tuple[float, float, float, list[tuple[float, float]], float]: ...

# --- optics (crates/subsurf-py/src/optics.rs): 1-D contiguous float64 arrays in and out -----
F64 = _F

def fresnel_v(cos_theta_i: F64, eta_i: F64, eta_t: F64, polarization: str, transmit: bool) -> F64: ...
def refract_v(d: F64, normal: F64, eta_i: F64, eta_t: F64) -> F64: ...
def reflect_v(d: F64, normal: F64) -> F64: ...
def diffuse_fresnel_reflectance_v(eta: F64, internal: bool) -> F64: ...
def diffuse_fresnel_reflectance_fit_v(eta: F64) -> F64: ...
def fresnel_moment_v(eta: F64, i: int) -> F64: ...
def hg_phase_v(cos_theta: F64, g: F64) -> F64: ...
def sample_hg_v(u: F64, g: F64) -> F64: ...
def isotropic_phase_v(cos_theta: F64) -> F64: ...
def mixture_phase_v(cos_theta: F64, lobes: Sequence[tuple[float, float]]) -> F64: ...
def sample_mixture_v(u: F64, lobes: Sequence[tuple[float, float]]) -> F64: ...
def beer_lambert_v(mu_t: F64, distance: F64) -> F64: ...
def sample_free_path_v(u: F64, sigma_t: F64) -> F64: ...
def free_path_pdf_v(s: F64, sigma_t: F64) -> F64: ...
def sample_cosine_hemisphere_v(u1: F64, u2: F64) -> F64: ...
def cosine_hemisphere_pdf_v(cos_theta: F64) -> F64: ...
def chi2_sf(statistic: float, dof: float) -> float: ...
def gamma_q(a: float, x: float) -> float: ...
def sidak_alpha(significance: float, tests: int) -> float: ...
def chi2_pooled(observed: F64, expected: F64, min_expected: float) -> tuple[float, int, float, int]: ...
def chi2_test_grid(
    samples: Sequence[F64],
    edges: Sequence[F64],
    names: Sequence[str],
    pdf: Callable[..., F64],
    min_expected: float,
    quad_points: int,
    max_subdivisions: int,
) -> tuple[float, int, float, int, int, float, float]:
    """(statistic, dof, p_value, pooled_cells, outside, pdf_integral, quadrature_error) of the χ² test
    on a grid of 1 or 2 axes; ``pdf(*coordinates)`` returns a flat float64 array."""

def graded_cos_edges(n_end: int, n_mid: int, min_gap: float) -> F64: ...

# (layers [(n, mua, mus, lobes [(weight, g)], thickness)], n_above, n_below)
_StackTuple = tuple[list[tuple[float, float, float, list[tuple[float, float]], float]], float, float]

# --- hk (Hanrahan–Krueger first order); directions are flat float64 arrays of 3N; `shape` is
# the numpy shape of the N directions (errors name elements by their index in it) ---
def hk_brdf(stack: _StackTuple, wi: _F, wo: _F, shape: Sequence[int] = ()) -> _F: ...
def hk_btdf(stack: _StackTuple, wi: _F, wo: _F, shape: Sequence[int] = ()) -> _F: ...
def hk_layer_terms(stack: _StackTuple, wi: _F, wo: _F, transmission: bool = False, shape: Sequence[int] = ()) -> _F: ...
def hk_unscattered(stack: _StackTuple, wi: _F, shape: Sequence[int] = ()) -> tuple[_F, _F]: ...
def hk_albedo(
    stack: _StackTuple, wi: _F, n_theta: int, n_phi: int, transmission: bool = False, shape: Sequence[int] = ()
) -> _F: ...

# --- bssrdf (crates/subsurf-py/src/bssrdf.rs); python/subsurf/bssrdf.py wraps these -------------
class Profile:
    """Queries are checked (core ``bssrdf::Query``): radii r in [0, inf] (mm), fractions u, q in
    [0, 1); anything else (nan, negative, u >= 1) raises ParameterError naming the argument."""

    model: str
    def rd(self, r: _F) -> _F: ...
    def pdf(self, r: _F) -> _F: ...
    def cdf(self, r: _F) -> _F: ...
    def sample_r(self, u: _F) -> _F: ...
    def radius_for_fraction(self, q: _F) -> _F: ...
    def total(self) -> float: ...
    def has_single(self) -> bool: ...
    def single_total(self) -> float: ...
    def single_rd(self, r: _F) -> _F:
        """ParameterError for a model without a separate single-scattering part."""
    def mc_data(self) -> dict | None:
        """edges, weight, stderr, single, single_stderr (arrays), total, total_stderr, photons,
        tail_start, tail_sigma"""

class ProfileTable:
    @staticmethod
    def assemble(settings: dict, points: list[dict]) -> ProfileTable: ...
    def rho_eff(self, albedo: _F) -> _F: ...
    def albedo_for(self, rho: _F) -> _F: ...
    def profile(self, sigma_a: float, sigma_s: float) -> Profile: ...
    def node_totals(self) -> list[float]: ...
    def points(self) -> list[dict]: ...

class AdaptiveTable:
    """The adaptive model's finite-slab R(r; d) and T(r; d) tables, one per channel."""
    @staticmethod
    def build(
        stacks_in: list[_StackTuple],
        photons: int,
        seed: int,
        threads: int | None = None,
        max_rel_err: float = 0.2,
        progress: Callable[[int, int], object] | None = None,
    ) -> AdaptiveTable: ...
    @staticmethod
    def assemble(
        stacks_in: list[_StackTuple],
        nodes: list[list[dict]],
        curvature: list[dict],
        photons: int,
        seed: int,
        max_rel_err: float,
    ) -> AdaptiveTable: ...
    def nodes(self) -> list[list[dict]]:
        """Per channel: {d, top, bottom} (top/bottom: the radial data dicts of Profile.mc_data)."""
    def curvature(self) -> list[dict]:
        """Per channel: {rho, sphere, sphere_stderr, sphere_near, sphere_near_stderr, sphere_bins,
        the same for cylinder (cylinder_bins) and cavity (no bins), flat, flat_stderr, oblique_theta,
        oblique, oblique_stderr, scale_convex, scale_convex_far, scale_cylinder, scale_cylinder_far,
        scale_concave}."""
    def curvature_scale(self, channel: int, h: float) -> tuple[list[float], float]: ...
    def oblique_gain(self, channel: int, mu: float) -> float: ...
    def exit_factor(self, channel: int, mu: float) -> float: ...
    def totals(self, channel: int, d: float) -> tuple[float, float]: ...
    def profile(self, channel: int, d: float, which: str) -> Profile: ...

def bssrdf_adaptive_nodes(stack: _StackTuple) -> list[float]: ...
def bssrdf_adaptive_curvature_nodes(stack: _StackTuple) -> list[float]: ...
def bssrdf_curved_escape(
    stack: _StackTuple, kind: str, rho: float, photons: int, seed: int, threads: int | None = None
) -> tuple[float, float]: ...
def bssrdf_curved_escape_parts(
    stack: _StackTuple,
    kind: str,
    rho: float,
    photons: int,
    seed: int,
    theta_deg: float | None = None,
    threads: int | None = None,
) -> tuple[float, float, float, float, list[float], float, list[float]]: ...
def bssrdf_sun_exitance(
    stack: _StackTuple, rho: float, bins: int, photons: int, seed: int, threads: int | None = None
) -> list[float]: ...

class SlabTable:
    @staticmethod
    def from_totals(
        g: float,
        n: float,
        n_above: float,
        n_below: float,
        albedos: list[float],
        taus: list[float],
        totals: list[tuple[float, float, float, float]],
    ) -> SlabTable:
        """totals: (rd, rd_stderr, tt, tt_stderr) per (albedo, tau), row-major"""

    def totals(self, albedo: float, tau: float) -> tuple[float, float]: ...

def bssrdf_models() -> list[str]: ...

#: The profile models (core bssrdf::Model), in order.
BSSRDF_MODELS: list[str]
#: The Monte Carlo profile's defaults (core McSettings::default()): photons, seed, per_decade,
#: max_rel_err, r_min, r_max.
BSSRDF_MC_DEFAULTS: dict[str, Any]

def bssrdf_medium_profile(model_name: str, sigma_a: float, sigma_s: float, g: float, eta: float) -> Profile: ...
def bssrdf_stack_profile(
    model_name: str,
    stack_tuple: _StackTuple,
    photons: int,
    seed: int,
    threads: int | None,
    per_decade: int,
    max_rel_err: float,
    r_min: float | None = None,
    r_max: float | None = None,
    progress: Callable[[int, int], object] | None = None,
) -> Profile:
    """Monte Carlo: interruptible (KeyboardInterrupt)"""

def bssrdf_normalized_diffusion(albedo: float, mfp: float, variant: str) -> Profile: ...
def bssrdf_check_medium(sigma_a: float, sigma_s: float, g: float, eta: float) -> None:
    """ParameterError naming the field unless (σa, σs, g, η) is a medium the profile models take."""

def bssrdf_chandrasekhar_reflectance(a: float) -> float: ...
def bssrdf_table_defaults(g: float, eta: float, n_albedos: int) -> dict: ...
def bssrdf_table_point(settings: dict, index: int, progress: Callable[[int, int], object] | None = None) -> dict:
    """interruptible (KeyboardInterrupt)"""

def bssrdf_slab_point(
    g: float,
    n: float,
    n_above: float,
    n_below: float,
    a: float,
    tau: float,
    photons: int,
    seed: int,
    threads: int | None = None,
    progress: Callable[[int, int], object] | None = None,
) -> tuple[float, float, float, float]:
    """(rd, rd_stderr, tt, tt_stderr); interruptible (KeyboardInterrupt)"""

BSSRDF_POWERS: list[str]
BSSRDF_MFP_KINDS: list[str]

def bssrdf_material_from_reflectance(
    reflectance: list[float],
    mfp: list[float],
    eta: float,
    g: float,
    model_name: str,
    power: str,
    mfp_kind: str,
    table: ProfileTable | None = None,
) -> list[tuple[float, float, float, float]]:
    """(n, mua, mus, g) per channel"""

def bssrdf_fit_profile(
    model_name: str,
    r: list[float],
    rd: list[float],
    sigma: list[float],
    g: float,
    eta: float,
    initial: tuple[float, float],
    table: ProfileTable | None = None,
) -> dict:
    """params, cov (row-major), stderr, chi2, dof, iterations"""

def bssrdf_fit_profile_layer(
    stack_tuple: _StackTuple,
    layer: int,
    r: list[float],
    rd: list[float],
    sigma: list[float],
    initial: tuple[float, float],
) -> dict: ...
def bssrdf_fit_slab_totals(
    rd: float,
    tt: float,
    sigma: tuple[float, float],
    thickness: float,
    g: float,
    n: float,
    n_above: float,
    n_below: float,
    model_name: str,
    initial: tuple[float, float],
    table: SlabTable | None = None,
) -> dict: ...

# --- render (crates/subsurf-py/src/render.rs); scene dicts come from subsurf.render.Scene._to_core
# (a translucent material's optional "grid": {sigma_a, sigma_s: float64 (nx, ny, nz, 3), lo, hi,
# to_object: 3 rows of (A | b)} and "texture": {sigma_a, sigma_s, reflectance: float64 (height,
# width, 3) per texel, rows from the top; reflectance per incident power or None}; a mesh's
# optional "uv": float64 (n_triangles, 3, 2))

#: The render methods (core render::Method), in order.
RENDER_METHODS: list[str]
#: Light types → their parameters in the constructor's order (core render::LightKind).
RENDER_LIGHTS: dict[str, list[str]]
#: The hierarchical method's settings and defaults (core HierarchicalParams).
RENDER_HIERARCHICAL_DEFAULTS: dict[str, Any]

def render_check_settings(spp: int, seed: int) -> tuple[int, int]:
    """(spp, seed) validated: spp in [1, 2^32 - 1], seed in [0, 2^64)."""

class RenderJob:
    """A scene prepared for one method; render_pass adds samples (GIL released)."""

    def __init__(
        self,
        scene: dict,
        method: str,
        seed: int,
        threads: int | None = None,
        hierarchical: dict[str, Any] | None = None,
        progress: Callable[[str, int, int], object] | None = None,
    ) -> None:
        """Prepare the scene with the GIL released; Ctrl-C raises KeyboardInterrupt. progress(stage,
        done, total): stage "profiles" (monte_carlo photons; none for random_walk) or "irradiance"."""
    @property
    def warnings(self) -> list[str]:
        """Warnings about the scene (lights that cannot light anything), one line each."""
    def render_pass(self, n: int) -> int:
        """Render n more samples per pixel; returns the total so far."""
    def image(self) -> np.ndarray:
        """Mean radiance, shape (height, width, 3)."""
    @property
    def spp(self) -> int: ...
    @property
    def dropped(self) -> int: ...

def render_shape(
    kind: str,
    a: Sequence[float],
    b: Sequence[float] | None = None,
    c: float = 0.0,
    d: float = 0.0,
    level: int | None = None,
    nu: int = 64,
    nv: int = 32,
) -> tuple[np.ndarray, np.ndarray]:
    """(positions (N, 3), triangles (M, 3)) of a built-in shape."""

def render_mesh_info(mesh: dict) -> tuple[bool, int, float, float]:
    """(closed, open_edges, area, volume) of a validated mesh."""

def render_walk_simulate(
    scene: dict,
    source: tuple[str, Sequence[float], Sequence[float]],
    photons: int,
    seed: int,
    channel: int | None = None,
    voxels: tuple[Sequence[float], Sequence[float], Sequence[int]] | None = None,
    threads: int | None = None,
) -> dict: ...
def render_bvh_benchmark(scene: dict, n: int) -> tuple[float, float]:
    """(incoherent, camera) closest-hit rays/s on one thread."""
