//! Henyey–Greenstein phase function, mixtures of HG lobes, and the direction update.
//!
//! Convention: `cos_theta` is the cosine between the propagation direction before and after
//! scattering, so g > 0 is forward scattering. Phase functions are normalised over the sphere,
//! ∫ p dω = 1 (units sr⁻¹).
//!
//! References: Henyey & Greenstein, ApJ 93 (1941) 70; sampling formula as in Prahl et al.
//! (1989) / MCML (Wang, Jacques & Zheng 1995, eq. 3.28); direction update MCML eq. 3.30.

use crate::error::{check_g, Error, Result};
use std::f64::consts::PI;

/// Below this |g| the HG sampler switches to the isotropic formula (the general one loses
/// precision as g → 0; the two agree to O(g)).
const G_ISOTROPIC: f64 = 1e-6;

/// Henyey–Greenstein phase function p(cos θ; g) in sr⁻¹.
#[inline]
pub fn hg_phase(cos_theta: f64, g: f64) -> f64 {
    let denom = 1.0 + g * g - 2.0 * g * cos_theta;
    (1.0 - g * g) / (4.0 * PI * denom * denom.sqrt())
}

/// Sample cos θ from HG by inverting its CDF; `u` uniform in [0, 1). Monotonic increasing in
/// `u` (u = 0 → cos θ = −1, u → 1 → cos θ = 1) for every g, including the isotropic branch.
/// Exact for every |g| < 1 (isotropic limit for |g| < 1e-6), result clamped to [-1, 1].
#[inline]
pub fn sample_hg(u: f64, g: f64) -> f64 {
    if g.abs() < G_ISOTROPIC {
        return 2.0 * u - 1.0;
    }
    let s = (1.0 - g) * (1.0 + g) / (1.0 - g + 2.0 * g * u);
    ((1.0 + g * g - s * s) / (2.0 * g)).clamp(-1.0, 1.0)
}

/// Turn the unit direction `d` by polar angle θ (given as cos θ) and azimuth φ
/// (given as cos φ, sin φ). MCML's "Spin" (Wang et al. 1995, eq. 3.30), with the
/// special case of a direction along ±z. Returns a unit vector.
#[inline]
pub fn spin(d: [f64; 3], cos_theta: f64, cos_phi: f64, sin_phi: f64) -> [f64; 3] {
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    let [ux, uy, uz] = d;
    if uz.abs() > 1.0 - 1e-12 {
        [sin_theta * cos_phi, sin_theta * sin_phi, cos_theta * uz.signum()]
    } else {
        let temp = (1.0 - uz * uz).sqrt();
        let a = sin_theta / temp;
        [
            a * (ux * uz * cos_phi - uy * sin_phi) + ux * cos_theta,
            a * (uy * uz * cos_phi + ux * sin_phi) + uy * cos_theta,
            -sin_theta * cos_phi * temp + uz * cos_theta,
        ]
    }
}

/// The most lobes a phase-function mixture may have.
pub const MAX_LOBES: usize = 4;

/// One Henyey–Greenstein lobe of a mixture: its weight and mean cosine.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HgLobe {
    /// Weight of the lobe; the weights of a [`Phase`] sum to 1.
    pub weight: f64,
    /// Mean cosine of the lobe, |g| < 1.
    pub g: f64,
}

/// A phase function: a convex mixture of up to [`MAX_LOBES`] HG lobes (seed eq. 1.5:
/// σs p = Σ_l w_l σs,l p(g_l)). A plain HG phase function is a mixture of one lobe.
/// Plain data (`Copy`), so the Monte Carlo kernel can hold it per layer without indirection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Phase {
    lobes: [HgLobe; MAX_LOBES],
    count: usize,
}

impl Phase {
    /// A single HG lobe with mean cosine `g` (validated: |g| < 1).
    pub fn hg(g: f64) -> Result<Self> {
        check_g("g", g)?;
        let mut lobes = [HgLobe { weight: 0.0, g: 0.0 }; MAX_LOBES];
        lobes[0] = HgLobe { weight: 1.0, g };
        Ok(Phase { lobes, count: 1 })
    }

    /// The isotropic phase function 1/(4π).
    pub fn isotropic() -> Self {
        Phase::hg(0.0).expect("g = 0 is valid")
    }

    /// A mixture from (weight, g) pairs. Weights must be finite and ≥ 0 with a positive sum
    /// (they are normalised); each |g| < 1; at most [`MAX_LOBES`] lobes.
    pub fn mixture(lobes: &[(f64, f64)]) -> Result<Self> {
        if lobes.is_empty() {
            return Err(Error::Invalid("phase mixture: needs at least one lobe".into()));
        }
        if lobes.len() > MAX_LOBES {
            return Err(Error::Invalid(format!(
                "phase mixture: {} lobes given, at most {MAX_LOBES} are supported",
                lobes.len()
            )));
        }
        let mut total = 0.0;
        for (i, &(w, g)) in lobes.iter().enumerate() {
            crate::error::check_nonneg(&format!("lobes[{i}].weight"), w)?;
            check_g(&format!("lobes[{i}].g"), g)?;
            total += w;
        }
        if !(total > 0.0) {
            return Err(Error::param("sum of lobe weights", total, "a number > 0"));
        }
        let mut out = [HgLobe { weight: 0.0, g: 0.0 }; MAX_LOBES];
        for (o, &(w, g)) in out.iter_mut().zip(lobes) {
            *o = HgLobe { weight: w / total, g };
        }
        Ok(Phase { lobes: out, count: lobes.len() })
    }

    /// The lobes (normalised weights).
    pub fn lobes(&self) -> &[HgLobe] {
        &self.lobes[..self.count]
    }

    /// Mean cosine of the mixture, Σ w_l g_l.
    pub fn g(&self) -> f64 {
        self.lobes().iter().map(|l| l.weight * l.g).sum()
    }

    /// Evaluate p(cos θ) in sr⁻¹.
    #[inline]
    pub fn eval(&self, cos_theta: f64) -> f64 {
        self.lobes().iter().map(|l| l.weight * hg_phase(cos_theta, l.g)).sum()
    }

    /// The pdf of [`Phase::sample`] with respect to solid angle: equal to [`Phase::eval`].
    #[inline]
    pub fn pdf(&self, cos_theta: f64) -> f64 {
        self.eval(cos_theta)
    }

    /// Sample cos θ with one uniform `u` in [0, 1): the lobe is chosen by `u` and `u` is then
    /// rescaled within the chosen lobe's interval, so one number suffices.
    #[inline]
    pub fn sample(&self, u: f64) -> f64 {
        if self.count == 1 {
            return sample_hg(u, self.lobes[0].g);
        }
        let mut lo = 0.0;
        for (i, l) in self.lobes().iter().enumerate() {
            let hi = lo + l.weight;
            if u < hi || i + 1 == self.count {
                let v = if l.weight > 0.0 { ((u - lo) / l.weight).clamp(0.0, 1.0 - f64::EPSILON) } else { 0.5 };
                return sample_hg(v, l.g);
            }
            lo = hi;
        }
        unreachable!("loop returns on its last lobe")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sample_hg_endpoints() {
        for g in [-0.9, -0.3, 0.0, 0.5, 0.9, 0.99, 0.999_999] {
            assert!((sample_hg(0.0, g) + 1.0).abs() < 1e-9, "g={g}");
            assert!((sample_hg(1.0 - 1e-16, g) - 1.0).abs() < 1e-6, "g={g}");
        }
    }

    #[test]
    fn spin_keeps_unit_length_and_angle() {
        let d = [0.3, -0.4, (1.0f64 - 0.25).sqrt()];
        let (ct, phi) = (0.37, 1.1f64);
        let e = spin(d, ct, phi.cos(), phi.sin());
        let norm = (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt();
        assert!((norm - 1.0).abs() < 1e-12);
        let dot = d[0] * e[0] + d[1] * e[1] + d[2] * e[2];
        assert!((dot - ct).abs() < 1e-12);
    }
}
