//! The reduced albedo α' from a total diffuse reflectance: Jensen et al. (2001, §3) find α' from
//! a measured total R_d by inverting the closed form. The colour → material inversion built on
//! it (with its choices of power and mean free path) is
//! [`crate::bssrdf::inverse::material_from_reflectance`].

use super::{check_eta, Model};
use crate::error::{Error, Result};

/// Invert the model's closed-form total diffuse reflectance R_d(α', η) for α' ∈ [0, 1].
/// R_d is strictly increasing in α' with R_d(0) = 0 and R_d(1) = 1 for both models, so every
/// rd ∈ [0, 1] has exactly one α'; found by bisection until the bracket is below 1e-15
/// (then |α' − α'_true| ≤ 1e-15 up to the rounding of R_d itself).
pub fn alpha_prime_from_rd(rd: f64, eta: f64, model: Model) -> Result<f64> {
    alpha_prime_of("rd", rd, eta, model)
}

/// [`alpha_prime_from_rd`] with the reflectance argument called `field` in errors.
fn alpha_prime_of(field: &str, rd: f64, eta: f64, model: Model) -> Result<f64> {
    if !(rd.is_finite() && (0.0..=1.0).contains(&rd)) {
        return Err(Error::param(
            field,
            rd,
            "a finite number in [0, 1] (the total diffuse reflectance a semi-infinite medium can reach)",
        ));
    }
    check_eta(eta)?;
    if rd == 0.0 {
        return Ok(0.0);
    }
    if rd == 1.0 {
        return Ok(1.0);
    }
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi || hi - lo < 1e-15 {
            break;
        }
        if model.total_rd(mid, eta)? < rd {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Ok(0.5 * (lo + hi))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips() {
        for model in [Model::Dipole, Model::BetterDipole] {
            for &eta in &[1.0, 1.3, 1.5, 2.5] {
                for i in 0..=50 {
                    let ap = i as f64 / 50.0;
                    let rd = model.total_rd(ap, eta).unwrap();
                    let back = alpha_prime_from_rd(rd, eta, model).unwrap();
                    assert!((back - ap).abs() < 1e-12, "{model:?} {eta} {ap}: {back}");
                }
            }
        }
        assert!(alpha_prime_from_rd(1.5, 1.3, Model::Dipole).is_err());
        assert!(alpha_prime_from_rd(f64::NAN, 1.3, Model::Dipole).is_err());
    }
}
