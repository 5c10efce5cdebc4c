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
/// precision as g → 0; the two agree to O(g)). Every HG sampler (here and in the Monte Carlo
/// kernels) uses this threshold.
pub const G_ISOTROPIC: f64 = 1e-6;

/// When |u_z| of the direction to be turned exceeds this, [`spin`] uses the formula for a
/// direction along ±z (the general one divides by √(1 − u_z²)); every direction update (here and
/// in the Monte Carlo kernels) uses this threshold (MCML uses 1 − 10⁻¹²).
pub const SPIN_POLE_COS: f64 = 1.0 - 1e-12;

/// Henyey–Greenstein phase function p(cos θ; g) = (1 − g²) / (4π (1 + g² − 2g cos θ)^{3/2})
/// in sr⁻¹. The denominator is evaluated as (1 − |g|)² + 2|g|(1 ∓ cos θ), a sum of
/// non-negative terms, so the peak stays accurate (no cancellation) as |g| → 1.
#[inline]
pub fn hg_phase(cos_theta: f64, g: f64) -> f64 {
    let denom = if g >= 0.0 {
        (1.0 - g) * (1.0 - g) + 2.0 * g * (1.0 - cos_theta)
    } else {
        (1.0 + g) * (1.0 + g) - 2.0 * g * (1.0 + cos_theta)
    };
    (1.0 - g) * (1.0 + g) / (4.0 * PI * denom * denom.sqrt())
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

/// The isotropic phase function 1/(4π) sr⁻¹ (HG with g = 0).
#[inline]
pub fn isotropic_phase() -> f64 {
    1.0 / (4.0 * PI)
}

/// Sample cos θ from the isotropic phase function: uniform on [−1, 1], cos θ = 2u − 1
/// (Archimedes' hat-box theorem). pdf with respect to solid angle: [`isotropic_phase`].
#[inline]
pub fn sample_isotropic(u: f64) -> f64 {
    (2.0 * u - 1.0).clamp(-1.0, 1.0)
}

/// Turn the unit direction `d` by polar angle θ (given as cos θ) and azimuth φ
/// (given as cos φ, sin φ). MCML's "Spin" (Wang et al. 1995, eq. 3.30), with the
/// special case of a direction along ±z. Returns a unit vector.
#[inline]
pub fn spin(d: [f64; 3], cos_theta: f64, cos_phi: f64, sin_phi: f64) -> [f64; 3] {
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    let [ux, uy, uz] = d;
    if uz.abs() > SPIN_POLE_COS {
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

    /// Whether this is one lobe that [`sample_hg`] treats as isotropic (|g| < [`G_ISOTROPIC`]).
    #[inline]
    pub fn is_isotropic(&self) -> bool {
        self.count == 1 && self.lobes[0].g.abs() < G_ISOTROPIC
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

/// Statistical tests of the samplers: χ² on (cos θ, φ) about a fixed incoming direction (so the
/// direction update [`spin`] is tested too), normalisation and mean cosine by quadrature.
#[cfg(test)]
mod stat_tests {
    use super::*;
    use crate::stats::{
        chi2_test_cos_phi, graded_cos_edges, integrate_adaptive, sidak_alpha, uniform_edges, Chi2, SplitMix64,
    };

    /// Orthonormal basis (t1, t2) completing the unit vector n (Duff et al. 2017, JCGT 6(1)).
    fn frame(n: [f64; 3]) -> ([f64; 3], [f64; 3]) {
        let sign = 1.0f64.copysign(n[2]);
        let a = -1.0 / (sign + n[2]);
        let b = n[0] * n[1] * a;
        ([1.0 + sign * n[0] * n[0] * a, sign * b, -sign * n[0]], [b, sign + n[1] * n[1] * a, -n[1]])
    }

    fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
        a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
    }

    /// Scatter n photons from direction `d` with `sample_cos` and `spin`, measure (cos θ, φ)
    /// of the new direction in d's frame, and run the χ² test against `pdf`.
    fn chi2_of(d: [f64; 3], sample_cos: impl Fn(f64) -> f64, pdf: impl Fn(f64) -> f64, n: usize, seed: u64) -> Chi2 {
        let mut rng = SplitMix64::new(seed);
        let (t1, t2) = frame(d);
        let mut samples = Vec::with_capacity(n);
        for _ in 0..n {
            let ct = sample_cos(rng.next_f64());
            let phi = 2.0 * PI * rng.next_f64();
            let e = spin(d, ct, phi.cos(), phi.sin());
            let mut p = dot(e, t2).atan2(dot(e, t1));
            if p < 0.0 {
                p += 2.0 * PI;
            }
            samples.push((dot(e, d).clamp(-1.0, 1.0), p));
        }
        let edges = graded_cos_edges(12, 16, 1e-5).unwrap();
        chi2_test_cos_phi(&samples, &|c, _| pdf(c), &edges, &uniform_edges(0.0, 2.0 * PI, 8)).unwrap()
    }

    const GS: [f64; 6] = [-0.9, -0.3, 0.0, 0.5, 0.9, 0.99];
    /// One family of tests: 6 HG values + 1 mixture + 1 isotropic, at overall α = 0.01.
    const TESTS: usize = 8;

    /// Power (how the χ² statements here are derived): a relative deviation ±δ of the cell
    /// probabilities over cells holding a fraction f of the probability adds λ = N Σ(δp)²/p ≈
    /// N f δ² to X²; at α_i = 1.3·10⁻³ (α = 0.01 over 8 tests) on ≈ 320 cells (40 graded cos θ ×
    /// 8 φ) the test fails with probability 0.9 once λ ≳ 125 (non-central χ²). With N = 10⁶ per
    /// g that is δ ≈ 1.1 % spread over the whole pdf, or ≈ 3.5 % confined to a tenth of it.
    #[test]
    fn hg_sampling_chi2_slow() {
        let alpha = sidak_alpha(0.01, TESTS).unwrap();
        let s = 1.0 / 3.0f64.sqrt();
        let dirs = [[0.3, -0.5, (1.0f64 - 0.34).sqrt()], [0.0, 0.0, 1.0], [s, s, -s]];
        for (k, &g) in GS.iter().enumerate() {
            let phase = Phase::hg(g).unwrap();
            let r = chi2_of(dirs[k % 3], |u| phase.sample(u), |c| phase.pdf(c), 1_000_000, 100 + k as u64);
            println!("HG g = {g}: {r:?} (alpha_i = {alpha:.3e})");
            assert!(r.p_value > alpha, "g = {g}: {r:?}");
        }
    }

    /// Power (derived as for `hg_sampling_chi2_slow`: λ ≈ N f δ² ≳ 125 on ≈ 320 cells at
    /// α_i = 1.3·10⁻³): the mixture (N = 10⁶) fails for δ ≈ 1.1 % over the whole pdf or 3.5 % over
    /// a tenth of it; the isotropic case (N = 5·10⁵) for δ ≈ 1.6 % or 5.0 %.
    #[test]
    fn mixture_and_isotropic_chi2() {
        let alpha = sidak_alpha(0.01, TESTS).unwrap();
        let mix = Phase::mixture(&[(0.7, 0.8), (0.3, -0.4)]).unwrap();
        let r = chi2_of([0.6, 0.0, 0.8], |u| mix.sample(u), |c| mix.pdf(c), 1_000_000, 200);
        println!("mixture: {r:?}");
        assert!(r.p_value > alpha, "{r:?}");
        let r = chi2_of([0.0, 0.0, -1.0], sample_isotropic, |_| isotropic_phase(), 500_000, 201);
        println!("isotropic: {r:?}");
        assert!(r.p_value > alpha, "{r:?}");
    }

    #[test]
    fn chi2_rejects_wrong_sampler() {
        // Sampling with g = 0.5 but claiming g = 0.6 must fail decisively; so must a mixture
        // with swapped weights. Power: with N = 10⁵ the expected shift λ = N Σ(δp)²/p of the cell
        // probabilities is ≈ 6100 (g) and ≈ 3100 (weights 0.6/0.4 for 0.7/0.3) on ≈ 320 cells,
        // far past the X² ≈ 510 at which p = 10⁻¹⁰.
        let r = chi2_of([0.0, 0.0, 1.0], |u| sample_hg(u, 0.5), |c| hg_phase(c, 0.6), 100_000, 300);
        println!("wrong g: {r:?}");
        assert!(r.p_value < 1e-10, "{r:?}");
        let right = Phase::mixture(&[(0.7, 0.8), (0.3, -0.4)]).unwrap();
        let wrong = Phase::mixture(&[(0.6, 0.8), (0.4, -0.4)]).unwrap();
        let r = chi2_of([0.0, 0.0, 1.0], |u| wrong.sample(u), |c| right.pdf(c), 100_000, 301);
        assert!(r.p_value < 1e-10, "{r:?}");
    }

    #[test]
    fn normalisation_and_mean_cosine_by_quadrature() {
        for g in GS.iter().copied().chain([-0.99, 0.999]) {
            let norm = 2.0 * PI * integrate_adaptive(&mut |c| hg_phase(c, g), -1.0, 1.0, 1e-13);
            let mean = 2.0 * PI * integrate_adaptive(&mut |c| c * hg_phase(c, g), -1.0, 1.0, 1e-13);
            println!("g = {g}: ∫p dω − 1 = {:.2e}, <cos> − g = {:.2e}", norm - 1.0, mean - g);
            assert!((norm - 1.0).abs() < 1e-9, "g {g}: norm {norm}");
            assert!((mean - g).abs() < 1e-9, "g {g}: mean {mean}");
            // Closed forms at the poles: p(±1) = (1 − g²)/(4π (1 ∓ g)³).
            let p1 = (1.0 - g * g) / (4.0 * PI * (1.0 - g).powi(3));
            assert!((hg_phase(1.0, g) / p1 - 1.0).abs() < 1e-12);
        }
        let mix = Phase::mixture(&[(0.7, 0.8), (0.3, -0.4)]).unwrap();
        let norm = 2.0 * PI * integrate_adaptive(&mut |c| mix.eval(c), -1.0, 1.0, 1e-13);
        let mean = 2.0 * PI * integrate_adaptive(&mut |c| c * mix.eval(c), -1.0, 1.0, 1e-13);
        assert!((norm - 1.0).abs() < 1e-10 && (mean - mix.g()).abs() < 1e-10);
        assert!((mix.g() - (0.7 * 0.8 - 0.3 * 0.4)).abs() < 1e-15);
        assert!((4.0 * PI * isotropic_phase() - 1.0).abs() < 1e-15);
    }

    #[test]
    fn extreme_g_is_finite() {
        let mut rng = SplitMix64::new(5);
        for g in [-0.999_999_9, -0.99, -1e-7, 0.0, 1e-7, 0.99, 0.999_999_9] {
            for c in [-1.0, -0.5, 0.0, 0.5, 1.0] {
                let p = hg_phase(c, g);
                assert!(p.is_finite() && p > 0.0, "g {g} cos {c}: {p}");
            }
            for _ in 0..10_000 {
                let c = sample_hg(rng.next_f64(), g);
                assert!(c.is_finite() && (-1.0..=1.0).contains(&c), "g {g}: {c}");
            }
        }
        // Continuity across the isotropic switch at |g| = 1e-6: O(g) difference.
        for u in [0.1, 0.5, 0.9] {
            assert!((sample_hg(u, 1.01e-6) - sample_hg(u, 0.99e-6)).abs() < 1e-5);
        }
    }
}
