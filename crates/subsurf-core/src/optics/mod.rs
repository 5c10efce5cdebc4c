//! Optics primitives: Fresnel equations, Snell's law, phase functions and sampling.
//!
//! Free functions named by their symbols (pbrt-v4 style); every sampling routine sits beside
//! its pdf, and its tests check statistics (normalisation, mean cosine, χ²). [`checked`] holds
//! the validated entry points for untrusted input.

pub mod checked;
pub mod diffuse;
pub mod fresnel;
pub mod phase;
pub mod sampling;

pub use diffuse::{
    diffuse_fresnel_reflectance, diffuse_fresnel_reflectance_fit, fresnel_moment, fresnel_moment1, fresnel_moment2,
};
pub use fresnel::{
    cos_transmitted, fr_dielectric, fr_dielectric_cos_t, fr_dielectric_sp, fresnel_reflectance, fresnel_transmittance,
    reflect, refract, Polarization,
};
pub use phase::{
    hg_phase, isotropic_phase, sample_hg, sample_isotropic, spin, HgLobe, Phase, G_ISOTROPIC, MAX_LOBES, SPIN_POLE_COS,
};
pub use sampling::{
    beer_lambert, cosine_hemisphere_pdf, free_path_pdf, invert_cosine_hemisphere, sample_cosine_hemisphere,
    sample_free_path, sample_uniform_sphere, uniform_sphere_pdf,
};
