//! Optics primitives: Fresnel equations, Snell's law, phase functions and sampling.
//!
//! Free functions named by their symbols (pbrt-v4 style); every sampling routine sits beside
//! its pdf, and its tests check statistics (normalisation, mean cosine, χ²).

pub mod phase;

pub use phase::{hg_phase, sample_hg, spin, HgLobe, Phase, MAX_LOBES};
