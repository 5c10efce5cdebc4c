//! Hemispherical integrals of the first-order BRDF/BTDF: the single-scattering reflectance
//! ρ₁(wi) = ∫ f_r(wi, wo) cos θo dωo and transmittance τ₁(wi) = ∫ f_t(wi, wo) |cos θo| dωo
//! (directional-hemispherical, dimensionless), by product quadrature.
//!
//! With s = sin θo, cos θo dωo = s ds dφ. Each layer's term vanishes beyond the exit cut-off
//! s_c (total internal reflection at the lowest-index medium on the way out), and behaves like
//! √(s_c − s) there (the refracted cosine); the substitution s = s_c (1 − u²) makes it smooth
//! in u, so Gauss–Legendre in u ∈ [0, 1] converges fast. The integrand depends on φ only
//! through cos(φo − φi) and is periodic, so the midpoint rule on [0, π] (doubled) is spectrally
//! accurate. Gauss–Legendre nodes: Newton iteration on P_n (Numerical Recipes §4.6, `gauleg`).

use super::stack::{check_direction, exit_sine_limit, terms};
use crate::error::{Error, Result};
use crate::medium::Stack;
use std::f64::consts::PI;

/// Gauss–Legendre nodes and weights on [0, 1] (n ≥ 1): [`crate::stats::gauss_legendre`] mapped
/// from [−1, 1].
pub fn gauss_legendre_01(n: usize) -> (Vec<f64>, Vec<f64>) {
    let (x, w) = crate::stats::gauss_legendre(n);
    (x.iter().map(|xi| 0.5 * (1.0 + xi)).collect(), w.iter().map(|wi| 0.5 * wi).collect())
}

/// A quadrature node count `n_theta` or `n_phi` given as any integer: in [4, 4096].
pub fn nodes(field: &str, n: i128) -> Result<usize> {
    if (4..=4096).contains(&n) {
        Ok(n as usize)
    } else {
        Err(Error::param_int(field, n, "an integer in [4, 4096]"))
    }
}

fn check_nodes(field: &str, n: usize) -> Result<()> {
    nodes(field, n as i128).map(|_| ())
}

fn hemispherical(stack: &Stack, wi: [f64; 3], reflection: bool, n_theta: usize, n_phi: usize) -> Result<f64> {
    let wi = check_direction("wi", wi, true)?;
    check_nodes("n_theta", n_theta)?;
    check_nodes("n_phi", n_phi)?;
    let (u, wu) = gauss_legendre_01(n_theta);
    let phi_i = wi[1].atan2(wi[0]);
    let dphi = PI / n_phi as f64;
    let zsign = if reflection { 1.0 } else { -1.0 };
    let mut total = 0.0;
    for j in 0..stack.layers.len() {
        let sc = exit_sine_limit(stack, j, reflection);
        let mut acc = 0.0;
        for (&uk, &wk) in u.iter().zip(&wu) {
            let s = sc * (1.0 - uk * uk);
            let c = ((1.0 - s) * (1.0 + s)).max(0.0).sqrt();
            if c == 0.0 {
                continue;
            }
            let jac = s * 2.0 * sc * uk; // s ds = s · 2 s_c u du
            let mut ring = 0.0;
            for l in 0..n_phi {
                let phi = phi_i + (l as f64 + 0.5) * dphi;
                let wo = [s * phi.cos(), s * phi.sin(), zsign * c];
                ring += terms(stack, wi, wo, reflection)[j];
            }
            acc += wk * jac * ring * 2.0 * dphi;
        }
        total += acc;
    }
    Ok(total)
}

/// Single-scattering (first-order) directional-hemispherical reflectance
/// ρ₁(wi) = ∫_{H+} f_r(wi, wo) cos θo dωo (dimensionless), by `n_theta` × `n_phi` product
/// quadrature (see module docs). `wi` unit with z > 0. The Monte Carlo counterpart is the total
/// of the order-1, no-interface-reflection paths (`rd_single_direct`).
pub fn single_scattering_reflectance(stack: &Stack, wi: [f64; 3], n_theta: usize, n_phi: usize) -> Result<f64> {
    hemispherical(stack, wi, true, n_theta, n_phi)
}

/// Single-scattering (first-order) directional-hemispherical transmittance
/// τ₁(wi) = ∫_{H−} f_t(wi, wo) |cos θo| dωo (dimensionless); zero for a semi-infinite stack.
pub fn single_scattering_transmittance(stack: &Stack, wi: [f64; 3], n_theta: usize, n_phi: usize) -> Result<f64> {
    if stack.is_semi_infinite() {
        check_direction("wi", wi, true)?;
        return Ok(0.0);
    }
    hemispherical(stack, wi, false, n_theta, n_phi)
}
