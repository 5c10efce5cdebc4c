//! The classical dipole of Jensen, Marschner, Levoy & Hanrahan, "A Practical Model for
//! Subsurface Light Transport", SIGGRAPH 2001 (§2.4, the diffusion term), which is the
//! steady-state diffuse reflectance of Farrell, Patterson & Wilson, Med. Phys. 19(4), 1992.
//!
//! The incident beam is replaced by an isotropic point source of strength α' at depth
//! z_r = 1/σt' and a negative image source at height z_v above the surface, chosen so that the
//! fluence vanishes on the extrapolated boundary z = −2AD (Jensen's boundary condition with
//! the diffuse Fresnel reflectance F_dr). The radiant exitance is the flux −D ∂φ/∂z at z = 0.

use super::{check_alpha_prime, check_eta, check_properties, check_r};
use crate::error::Result;
use std::f64::consts::PI;

/// Diffuse Fresnel reflectance F_dr(η) by the rational fit Jensen et al. (2001) quote
/// (Egan & Hilgeman 1979, via Groenhuis et al. 1983):
/// F_dr = −1.440/η² + 0.710/η + 0.668 + 0.0636 η, with η = n_medium/n_outside.
/// It approximates the hemispherical (cosine-weighted) reflectance of the boundary seen from
/// inside the medium, 2∫₀¹ F_r(η, μ) μ dμ. Note F_dr(1) = 0.0016, not 0.
#[inline]
pub fn fdr(eta: f64) -> f64 {
    -1.440 / (eta * eta) + 0.710 / eta + 0.668 + 0.0636 * eta
}

/// Jensen's boundary coefficient A = (1 + F_dr)/(1 − F_dr) (A(1) = 1.0032 with the fit).
#[inline]
pub fn a_coefficient(eta: f64) -> f64 {
    let f = fdr(eta);
    (1.0 + f) / (1.0 - f)
}

/// The dipole for one set of optical properties (Jensen et al. 2001, §2.4).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dipole {
    /// Reduced albedo α' = σs'/σt'.
    pub alpha_prime: f64,
    /// Effective transport coefficient σtr = √(3 σa σt'), mm⁻¹.
    pub sigma_tr: f64,
    /// Diffusion coefficient D = 1/(3σt'), mm.
    pub d: f64,
    /// Boundary coefficient A(η).
    pub a: f64,
    /// Depth of the real source z_r = 1/σt', mm.
    pub z_r: f64,
    /// Height of the virtual source z_v = z_r + 4AD, mm.
    pub z_v: f64,
}

impl Dipole {
    /// Build and validate: σa, σs' ≥ 0 (mm⁻¹) with σa + σs' > 0, η ∈ [1, 2.5].
    pub fn new(sigma_a: f64, sigma_s_prime: f64, eta: f64) -> Result<Dipole> {
        let st = check_properties(sigma_a, sigma_s_prime, eta)?;
        let d = 1.0 / (3.0 * st);
        let a = a_coefficient(eta);
        let z_r = 1.0 / st;
        Ok(Dipole {
            alpha_prime: sigma_s_prime / st,
            sigma_tr: (3.0 * sigma_a * st).sqrt(),
            d,
            a,
            z_r,
            z_v: z_r + 4.0 * a * d,
        })
    }

    /// Diffuse reflectance profile R_d(r), mm⁻², r ≥ 0 in mm (not validated here):
    /// R_d = α'/(4π) [z_r (σtr d_r + 1) e^{−σtr d_r}/d_r³ + z_v (σtr d_v + 1) e^{−σtr d_v}/d_v³],
    /// d_r = √(r² + z_r²), d_v = √(r² + z_v²).
    #[inline]
    pub fn rd(&self, r: f64) -> f64 {
        let r2 = r * r;
        let dr = (r2 + self.z_r * self.z_r).sqrt();
        let dv = (r2 + self.z_v * self.z_v).sqrt();
        let s = self.sigma_tr;
        self.alpha_prime / (4.0 * PI) * (flux_term(self.z_r, dr, s) + flux_term(self.z_v, dv, s))
    }
}

/// The normal flux of a point source at signed depth `z` (mm) seen at distance `d` (mm):
/// z (σtr d + 1) e^{−σtr d} / d³ = −∂/∂z (e^{−σtr d}/d) (Farrell et al. 1992); the dipole is the
/// sum of two of these, the multipole (Donner & Jensen 2005) of many.
#[inline]
pub fn flux_term(z: f64, d: f64, sigma_tr: f64) -> f64 {
    z * (sigma_tr * d + 1.0) * (-sigma_tr * d).exp() / (d * d * d)
}

/// R_d(r) of the Jensen dipole in mm⁻² (r in mm, σa and σs' in mm⁻¹), validated.
pub fn dipole_rd(r: f64, sigma_a: f64, sigma_s_prime: f64, eta: f64) -> Result<f64> {
    check_r(r)?;
    Ok(Dipole::new(sigma_a, sigma_s_prime, eta)?.rd(r))
}

/// Total diffuse reflectance of the dipole, ∫₀^∞ R_d(r) 2πr dr in closed form
/// (Jensen et al. 2001, §3, the relation used to find α' from a measured R_d):
/// R_d = (α'/2) (1 + e^{−(4/3) A √(3(1−α'))}) e^{−√(3(1−α'))}.
pub fn dipole_total_rd(alpha_prime: f64, eta: f64) -> Result<f64> {
    check_alpha_prime(alpha_prime)?;
    check_eta(eta)?;
    let s = (3.0 * (1.0 - alpha_prime)).sqrt();
    let a = a_coefficient(eta);
    Ok(0.5 * alpha_prime * (1.0 + (-(4.0 / 3.0) * a * s).exp()) * (-s).exp())
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// ∫₀^∞ f(r) 2πr dr by composite Gauss–Legendre on log-spaced panels (independent of the
    /// closed form). Panels from 1e-9 to 1e4 transport lengths.
    pub(crate) fn radial_integral(f: impl Fn(f64) -> f64, scale: f64) -> f64 {
        // 10-point Gauss–Legendre nodes/weights on [-1, 1].
        const X: [f64; 5] =
            [0.1488743389816312, 0.4333953941292472, 0.6794095682990244, 0.8650633666889845, 0.9739065285171717];
        const W: [f64; 5] =
            [0.2955242247147529, 0.2692667193099963, 0.2190863625159820, 0.1494513491505806, 0.0666713443086881];
        let mut edges = vec![0.0];
        let n = 400;
        let (lo, hi) = ((1e-9f64).ln(), (1e4f64).ln());
        for i in 0..=n {
            edges.push(scale * (lo + (hi - lo) * i as f64 / n as f64).exp());
        }
        let mut sum = 0.0;
        for w in edges.windows(2) {
            let (a, b) = (w[0], w[1]);
            let (c, h) = (0.5 * (a + b), 0.5 * (b - a));
            for k in 0..5 {
                for s in [-1.0, 1.0] {
                    let r = c + s * h * X[k];
                    sum += W[k] * h * f(r) * 2.0 * PI * r;
                }
            }
        }
        sum
    }

    #[test]
    fn integral_matches_closed_form() {
        for &(sa, ssp) in &[(0.01, 1.0), (0.1, 1.0), (0.5, 0.5), (0.0032, 2.29), (1.45, 0.03)] {
            for &eta in &[1.0, 1.3, 1.5, 2.0] {
                let d = Dipole::new(sa, ssp, eta).unwrap();
                let num = radial_integral(|r| d.rd(r), 1.0 / (sa + ssp));
                let exact = dipole_total_rd(d.alpha_prime, eta).unwrap();
                assert!(((num - exact) / exact).abs() < 1e-9, "{sa} {ssp} {eta}: {num} vs {exact}");
            }
        }
    }

    #[test]
    fn constants_and_limits() {
        // F_dr fit at η = 1 is 0.0016 (not 0), so A(1) = 1.0016/0.9984.
        assert!((fdr(1.0) - 0.0016).abs() < 1e-14);
        assert!((a_coefficient(1.0) - 1.0016 / 0.9984).abs() < 1e-14);
        let d = Dipole::new(0.1, 0.9, 1.3).unwrap();
        assert!((d.d - 1.0 / 3.0).abs() < 1e-15 && (d.z_r - 1.0).abs() < 1e-15);
        assert!((d.sigma_tr - (0.3f64).sqrt()).abs() < 1e-15);
        assert!((d.z_v - (1.0 + 4.0 * a_coefficient(1.3) / 3.0)).abs() < 1e-15);
        assert_eq!(dipole_rd(0.5, 1.0, 0.0, 1.3).unwrap(), 0.0);
        assert_eq!(dipole_total_rd(0.0, 1.3).unwrap(), 0.0);
        assert!((dipole_total_rd(1.0, 1.3).unwrap() - 1.0).abs() < 1e-15);
        assert!(dipole_rd(-1.0, 0.1, 1.0, 1.3).is_err());
        assert!(dipole_rd(1.0, -0.1, 1.0, 1.3).is_err());
        assert!(dipole_rd(1.0, 0.1, f64::NAN, 1.3).is_err());
        assert!(dipole_rd(1.0, 0.0, 0.0, 1.3).is_err());
        assert!(dipole_rd(1.0, 0.1, 1.0, 0.9).is_err());
        assert!(dipole_total_rd(1.1, 1.3).is_err());
    }
}
