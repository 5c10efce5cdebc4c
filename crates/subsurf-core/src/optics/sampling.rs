//! Sampling routines beside their pdfs: cosine-weighted hemisphere, uniform sphere,
//! Beer–Lambert attenuation and exponential free paths.
//!
//! Directions are unit vectors in a local frame with the normal along +z; pdfs are with respect
//! to solid angle (sr⁻¹) or length (mm⁻¹). `u`, `u1`, `u2` are uniform numbers in [0, 1).
//! References: pbrt-v4 §A.5 (Pharr, Jakob & Humphreys 2023) for the warps; MCML (Wang, Jacques
//! & Zheng 1995, eq. 3.19) for the step size.

use std::f64::consts::PI;

/// Cosine-weighted direction on the upper hemisphere (z ≥ 0) by Malley's method: a uniform
/// point on the unit disk (polar map r = √u1, φ = 2π u2) lifted to the hemisphere,
/// z = √(1 − r²). pdf = cos θ / π ([`cosine_hemisphere_pdf`]).
#[inline]
pub fn sample_cosine_hemisphere(u1: f64, u2: f64) -> [f64; 3] {
    let r = u1.max(0.0).sqrt();
    let phi = 2.0 * PI * u2;
    [r * phi.cos(), r * phi.sin(), (1.0 - u1).max(0.0).sqrt()]
}

/// pdf of [`sample_cosine_hemisphere`] in sr⁻¹: max(cos θ, 0)/π.
#[inline]
pub fn cosine_hemisphere_pdf(cos_theta: f64) -> f64 {
    cos_theta.max(0.0) / PI
}

/// Inverse of [`sample_cosine_hemisphere`]: the (u1, u2) that map to the unit vector `w`
/// (z ≥ 0): u1 = sin²θ = x² + y², u2 = φ/(2π) ∈ [0, 1).
#[inline]
pub fn invert_cosine_hemisphere(w: [f64; 3]) -> [f64; 2] {
    let u1 = (w[0] * w[0] + w[1] * w[1]).min(1.0);
    let mut phi = w[1].atan2(w[0]);
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    [u1, (phi / (2.0 * PI)).min(1.0 - f64::EPSILON / 2.0)]
}

/// Uniform direction on the unit sphere (Archimedes: z = 1 − 2 u1 is uniform), pdf 1/(4π).
#[inline]
pub fn sample_uniform_sphere(u1: f64, u2: f64) -> [f64; 3] {
    let z = 1.0 - 2.0 * u1;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u2;
    [r * phi.cos(), r * phi.sin(), z]
}

/// pdf of [`sample_uniform_sphere`]: 1/(4π) sr⁻¹.
#[inline]
pub fn uniform_sphere_pdf() -> f64 {
    1.0 / (4.0 * PI)
}

/// Beer–Lambert transmittance exp(−μt d) over a distance `distance` (mm) with attenuation
/// coefficient `mu_t` (mm⁻¹). Returns 0 for an infinite optical depth, 1 for zero.
#[inline]
pub fn beer_lambert(mu_t: f64, distance: f64) -> f64 {
    if mu_t == 0.0 || distance == 0.0 {
        1.0
    } else {
        (-mu_t * distance).exp()
    }
}

/// Sample a free path s (mm) from the exponential density σt e^(−σt s) by inversion,
/// s = −ln(1 − u)/σt (MCML eq. 3.19 with 1 − u in place of u so that u = 0 gives s = 0).
/// `sigma_t` > 0 (mm⁻¹); u → 1 gives large finite paths, u = 1 gives +∞.
#[inline]
pub fn sample_free_path(u: f64, sigma_t: f64) -> f64 {
    -(-u).ln_1p() / sigma_t
}

/// pdf of [`sample_free_path`] in mm⁻¹: σt e^(−σt s) for s ≥ 0, else 0.
#[inline]
pub fn free_path_pdf(s: f64, sigma_t: f64) -> f64 {
    if s < 0.0 {
        0.0
    } else {
        sigma_t * beer_lambert(sigma_t, s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stats::{chi2_test_cos_phi, sidak_alpha, uniform_edges, SplitMix64};

    fn to_cos_phi(w: [f64; 3]) -> (f64, f64) {
        let mut phi = w[1].atan2(w[0]);
        if phi < 0.0 {
            phi += 2.0 * PI;
        }
        (w[2], phi)
    }

    /// Power: a relative deviation ±δ of the cell probabilities over cells holding a fraction f
    /// of the probability adds λ = N Σ(δp)²/p ≈ N f δ² to X²; at α_i = 5·10⁻³ (2 tests) on ≈ 320
    /// cells the test fails with probability 0.9 once λ ≳ 110 (non-central χ²), so with
    /// N = 2·10⁵ δ ≈ 2.3 % over the whole pdf, or ≈ 7 % over a tenth of it, fails.
    #[test]
    fn cosine_hemisphere_chi2_and_inverse() {
        let mut rng = SplitMix64::new(0x5eed_0001);
        let n = 200_000;
        let mut samples = Vec::with_capacity(n);
        for _ in 0..n {
            let (u1, u2) = (rng.next_f64(), rng.next_f64());
            let w = sample_cosine_hemisphere(u1, u2);
            assert!(((w[0] * w[0] + w[1] * w[1] + w[2] * w[2]) - 1.0).abs() < 1e-12 && w[2] >= 0.0);
            let [v1, v2] = invert_cosine_hemisphere(w);
            assert!((v1 - u1).abs() < 1e-12 && ((v2 - u2).abs() < 1e-12 || (v2 - u2).abs() > 1.0 - 1e-12));
            samples.push(to_cos_phi(w));
        }
        let pdf = |c: f64, _p: f64| cosine_hemisphere_pdf(c);
        let r =
            chi2_test_cos_phi(&samples, &pdf, &uniform_edges(0.0, 1.0, 20), &uniform_edges(0.0, 2.0 * PI, 16)).unwrap();
        println!("cosine hemisphere χ²: {r:?}");
        assert!(r.p_value > sidak_alpha(0.01, 2).unwrap());
        // Uniform sphere with the same kit.
        let samples: Vec<_> =
            (0..n).map(|_| to_cos_phi(sample_uniform_sphere(rng.next_f64(), rng.next_f64()))).collect();
        let pdf = |_c: f64, _p: f64| uniform_sphere_pdf();
        let r = chi2_test_cos_phi(&samples, &pdf, &uniform_edges(-1.0, 1.0, 20), &uniform_edges(0.0, 2.0 * PI, 16))
            .unwrap();
        println!("uniform sphere χ²: {r:?}");
        assert!(r.p_value > sidak_alpha(0.01, 2).unwrap());
    }

    #[test]
    fn cosine_pdf_rejects_uniform_hemisphere_samples() {
        // The kit must be able to fail: uniform-hemisphere samples against the cosine pdf.
        // Power: λ = N Σ(δp)²/p ≈ 7·10⁴ over the 20 cos θ rows at N = 5·10⁴, against X² ≈ 320
        // for p = 10⁻¹² on ≈ 160 cells.
        let mut rng = SplitMix64::new(7);
        let samples: Vec<_> = (0..50_000)
            .map(|_| {
                let w = sample_uniform_sphere(rng.next_f64(), rng.next_f64());
                to_cos_phi([w[0], w[1], w[2].abs()])
            })
            .collect();
        let pdf = |c: f64, _p: f64| cosine_hemisphere_pdf(c);
        let r =
            chi2_test_cos_phi(&samples, &pdf, &uniform_edges(0.0, 1.0, 20), &uniform_edges(0.0, 2.0 * PI, 8)).unwrap();
        assert!(r.p_value < 1e-12, "{r:?}");
    }

    #[test]
    fn free_path_mean_and_distribution() {
        // Mean of an exponential is 1/σt, variance 1/σt²; 4σ tolerance on the sample mean.
        let sigma_t = 2.5;
        let n = 400_000;
        let mut rng = SplitMix64::new(11);
        let mut sum = 0.0;
        let mut below = 0usize;
        let s_half = std::f64::consts::LN_2 / sigma_t; // median
        for _ in 0..n {
            let s = sample_free_path(rng.next_f64(), sigma_t);
            assert!(s >= 0.0 && s.is_finite());
            sum += s;
            below += (s < s_half) as usize;
        }
        let mean = sum / n as f64;
        let se = (1.0 / sigma_t) / (n as f64).sqrt();
        assert!((mean - 1.0 / sigma_t).abs() < 4.0 * se, "mean {mean}");
        let frac = below as f64 / n as f64;
        assert!((frac - 0.5).abs() < 4.0 * (0.25 / n as f64).sqrt());
        assert_eq!(sample_free_path(0.0, sigma_t), 0.0);
        // pdf integrates to 1 and equals −d/ds of the transmittance.
        let integral = crate::stats::integrate_adaptive(&mut |s| free_path_pdf(s, sigma_t), 0.0, 40.0, 1e-12);
        assert!((integral - 1.0).abs() < 1e-10);
        let (s, h) = (0.3, 1e-5);
        let deriv = (beer_lambert(sigma_t, s - h) - beer_lambert(sigma_t, s + h)) / (2.0 * h);
        assert!((deriv - free_path_pdf(s, sigma_t)).abs() < 1e-8);
        assert_eq!(beer_lambert(0.0, f64::INFINITY), 1.0);
        assert_eq!(beer_lambert(1.0, f64::INFINITY), 0.0);
        assert!((beer_lambert(0.5, 2.0) - (-1.0f64).exp()).abs() < 1e-16);
    }
}
