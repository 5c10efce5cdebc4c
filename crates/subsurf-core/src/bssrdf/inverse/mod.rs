//! Inverse problems: a material from its appearance ([`appearance`]) and optical properties
//! fitted to measurements with their covariance ([`fit`], on [`lm`]).

pub mod appearance;
pub mod fit;
pub mod lm;

pub use appearance::{material_from_reflectance, Conventions, MeanFreePath, Power};
pub use fit::{fit_profile, fit_slab_totals, SlabTable};
pub use lm::{levenberg_marquardt, Fit};

#[cfg(test)]
mod tests;
