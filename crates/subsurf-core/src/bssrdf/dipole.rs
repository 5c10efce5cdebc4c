//! The classical dipole of Jensen, Marschner, Levoy & Hanrahan, "A Practical Model for Subsurface
//! Light Transport", SIGGRAPH 2001, §2.4 (eqs. 4–5 of the paper's diffusion term; Farrell,
//! Patterson & Wilson 1992), as a [`RadialProfile`](super::RadialProfile). The formulas live in
//! [`crate::diffusion::dipole`]; this file only gives them the profile interface.

use super::{ClosedForm, Medium, Tabulated};
use crate::diffusion::Dipole;
use crate::error::Result;

impl ClosedForm for Dipole {
    fn rd(&self, r: f64) -> f64 {
        Dipole::rd(self, r)
    }
    fn scale(&self) -> f64 {
        self.z_r
    }
}

/// The dipole profile of a semi-infinite medium (σs' = σs(1 − g); η ∈ [1, 2.5]).
pub fn profile(m: &Medium) -> Result<Tabulated<Dipole>> {
    Ok(Tabulated::new(Dipole::new(m.sigma_a, m.sigma_s_prime(), m.eta)?))
}
