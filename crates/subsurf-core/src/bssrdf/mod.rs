//! Radial BSSRDF profiles R_d(r): the diffuse reflectance per unit area (mm⁻²) at distance r
//! (mm) from a normally incident pencil beam of unit power, for one colour channel.
//!
//! Every model (dipole, better dipole, multipole, photon beam diffusion, normalized diffusion,
//! Monte Carlo) implements [`RadialProfile`]; renderers and fits use profiles only through it.

/// A radial diffuse-reflectance profile and the sampling routines a renderer needs.
///
/// Contract (tested for every model):
/// - [`rd`](Self::rd) ≥ 0, finite for r > 0;
/// - [`total`](Self::total) = ∫₀^∞ R_d(r) 2πr dr (the total diffuse reflectance, in [0, 1]);
/// - [`pdf`](Self::pdf) = 2πr R_d(r) / total, which integrates to 1 over r ∈ [0, ∞);
/// - [`cdf`](Self::cdf) is its integral from 0, and [`sample_r`](Self::sample_r) its inverse:
///   `cdf(sample_r(u)) = u` for u ∈ [0, 1);
/// - a profile with `total() == 0` has `pdf ≡ 0` and is never sampled.
pub trait RadialProfile: Send + Sync {
    /// R_d(r), mm⁻², at radius `r` ≥ 0 (mm).
    fn rd(&self, r: f64) -> f64;
    /// ∫₀^∞ R_d(r) 2πr dr, dimensionless.
    fn total(&self) -> f64;
    /// Fraction of [`total`](Self::total) inside radius `r` (mm).
    fn cdf(&self, r: f64) -> f64;
    /// The radius r (mm) with `cdf(r) = u`, u ∈ [0, 1): the inverse-CDF sampler of [`pdf`](Self::pdf).
    fn sample_r(&self, u: f64) -> f64;
    /// 2πr R_d(r) / total, mm⁻¹: the density of [`sample_r`](Self::sample_r).
    fn pdf(&self, r: f64) -> f64 {
        let t = self.total();
        if t > 0.0 {
            2.0 * std::f64::consts::PI * r * self.rd(r) / t
        } else {
            0.0
        }
    }
    /// The radius (mm) holding a fraction `q` ∈ [0, 1) of the energy (renderers bound their
    /// searches with it, e.g. q = 0.999).
    fn radius_for_fraction(&self, q: f64) -> f64 {
        self.sample_r(q)
    }
}
