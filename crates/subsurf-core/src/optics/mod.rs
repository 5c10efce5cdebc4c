//! Optics primitives: Fresnel equations, Snell's law, phase functions and sampling.
//!
//! Free functions named by their symbols (pbrt-v4 style); every sampling routine sits beside
//! its pdf, and its tests check statistics (normalisation, mean cosine, χ²).

pub mod fresnel;
pub mod phase;

pub use fresnel::{
    cos_transmitted, fr_dielectric, fr_dielectric_cos_t, fr_dielectric_sp, fresnel_reflectance,
    fresnel_transmittance, reflect, refract, Polarization,
};
pub use phase::{hg_phase, sample_hg, spin, HgLobe, Phase, MAX_LOBES};
