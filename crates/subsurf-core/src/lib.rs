//! subsurf-core: light transport in layered turbid media.
//!
//! Pure Rust, no Python. Units: lengths in mm, coefficients in mm⁻¹, angles in radians,
//! directions are unit vectors with the surface normal along +z (pbrt's convention for
//! BSDF arguments; inside the Monte Carlo engine +z points *into* the stack, as in MCML).
//!
//! Modules:
//! - [`optics`]: Fresnel, Snell, phase functions and their sampling routines.
//! - [`medium`]: layers, stacks, validation and mixtures.
//! - [`rng`]: the counter-based random number generator (reproducible for any thread count).
//! - [`mc`]: the Monte Carlo photon-packet engine and its tallies.
//! - [`hk`]: Hanrahan–Krueger first-order (single-scattering) BRDF/BTDF.
//! - [`bssrdf`]: radial BSSRDF profiles behind one trait, [`bssrdf::RadialProfile`].
//! - [`diffusion`]: the Jensen et al. dipole and d'Eon's better dipole.
//! - [`render`]: images of translucent meshes (hierarchical, probe and random-walk methods).
//! - [`stats`]: χ² goodness-of-fit kit and quadrature for testing samplers.

pub mod bssrdf;
pub mod diffusion;
pub mod error;
pub mod hk;
pub mod mc;
pub mod medium;
pub mod names;
pub mod optics;
pub mod render;
pub mod rng;
pub mod sobol;
mod sobol_table;
pub mod stats;

pub use error::{Error, Result};
