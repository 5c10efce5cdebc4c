//! The better dipole of E. d'Eon, "A Better Dipole", Weta Digital technical report (2012),
//! eqs. for R(r) = C_φ φ(r) + C_E E(r) with Grosjean's diffusion coefficient, as a
//! [`RadialProfile`](super::RadialProfile). The formulas live in [`crate::diffusion::better_dipole`].

use super::{ClosedForm, Medium, Tabulated};
use crate::diffusion::BetterDipole;
use crate::error::Result;

impl ClosedForm for BetterDipole {
    fn rd(&self, r: f64) -> f64 {
        BetterDipole::rd(self, r)
    }
    fn scale(&self) -> f64 {
        self.z_r
    }
}

/// The better-dipole profile of a semi-infinite medium (σs' = σs(1 − g); η ∈ [1, 2.5]).
pub fn profile(m: &Medium) -> Result<Tabulated<BetterDipole>> {
    Ok(Tabulated::new(BetterDipole::new(m.sigma_a, m.sigma_s_prime(), m.eta)?))
}
