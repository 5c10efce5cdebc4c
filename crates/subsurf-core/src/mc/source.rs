//! Light sources: a collimated pencil beam at any incidence and diffuse (Lambertian)
//! illumination, both arriving from above (z < 0) at the origin.
//!
//! Launch as in MCML (Wang, Jacques & Zheng 1995, §3.2 and eq. 3.1): the specular part
//! R_sp = R_F(θi; n_above → n_top) (unpolarised Fresnel, Born & Wolf eq. 1.5.21) is scored
//! deterministically as specular reflectance, and the packet enters with weight 1 − R_sp along
//! the Snell-refracted direction. (MCML's special treatment of a clear top layer — multiple
//! specular bounces folded into R_sp — is not used: a clear layer is traced like any other.)

use crate::error::{Error, Result};
use crate::optics::fr_dielectric_cos_t;
use crate::rng::PhotonRng;

/// Largest polar angle of a pencil beam, rad: π/2 − 10⁻⁶. Closer to grazing, a fraction
/// below ~10⁻⁵ of the light enters and, refracted to within 10⁻⁶ rad of the critical angle, meets
/// ~10⁵ or more interfaces before it leaves a thin layer again: a run would crawl for a result
/// that is the specular reflection to 5 digits.
pub const MAX_PENCIL_THETA: f64 = std::f64::consts::FRAC_PI_2 - 1e-6;

/// A light source above the stack.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Source {
    /// A collimated pencil beam hitting the origin, arriving at polar angle `theta` (radians
    /// from the inward normal, 0 ≤ θ ≤ [`MAX_PENCIL_THETA`]) and azimuth `phi` (radians); its propagation
    /// direction in the ambient medium is (sin θ cos φ, sin θ sin φ, cos θ).
    Pencil { theta: f64, phi: f64 },
    /// Diffuse (Lambertian, cosine-weighted) illumination from the upper hemisphere, hitting
    /// the origin. Directions are drawn by Malley's method: a uniform point (x, y) of the unit
    /// disc (by rejection from the square, two uniforms per try, in stream order x then y)
    /// gives the direction (x, y, √(1 − x² − y²)), whose pdf is cos θ / π (Pharr, Jakob &
    /// Humphreys, *PBR* 4th ed., §A.5.3).
    Diffuse,
}

impl Default for Source {
    fn default() -> Self {
        Source::Pencil { theta: 0.0, phi: 0.0 }
    }
}

impl Source {
    /// Check the parameters.
    pub fn validate(&self) -> Result<()> {
        if let Source::Pencil { theta, phi } = *self {
            if !(0.0..=MAX_PENCIL_THETA).contains(&theta) {
                return Err(Error::param(
                    "source.theta",
                    theta,
                    "a number in [0, pi/2 - 1e-6] (radians; closer to grazing almost no light enters)",
                ));
            }
            if !phi.is_finite() {
                return Err(Error::param("source.phi", phi, "a finite number (radians)"));
            }
        }
        Ok(())
    }
}

/// A source prepared for a given top interface (n_above → n_top).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Launcher {
    source: Source,
    n_above: f64,
    n_top: f64,
    /// Pencil beam: direction inside and specular reflectance (deterministic, computed once).
    pencil_dir: [f64; 3],
    pencil_rsp: f64,
}

impl Launcher {
    pub(crate) fn new(source: Source, n_above: f64, n_top: f64) -> Self {
        let (mut pencil_dir, mut pencil_rsp) = ([0.0, 0.0, 1.0], 0.0);
        if let Source::Pencil { theta, phi } = source {
            let d = [theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos()];
            let (dir, rsp) = refract_in(d, n_above, n_top);
            pencil_dir = dir;
            pencil_rsp = rsp;
        }
        Launcher { source, n_above, n_top, pencil_dir, pencil_rsp }
    }

    /// The pencil beam's direction inside the top layer and its specular reflectance (the
    /// same at every launch, drawing nothing); `None` for a diffuse source.
    pub(crate) fn pencil(&self) -> Option<([f64; 3], f64)> {
        matches!(self.source, Source::Pencil { .. }).then_some((self.pencil_dir, self.pencil_rsp))
    }

    /// Direction inside the top layer and the specular reflectance of one launch.
    #[inline]
    pub(crate) fn launch(&self, rng: &mut PhotonRng) -> ([f64; 3], f64) {
        match self.source {
            Source::Pencil { .. } => (self.pencil_dir, self.pencil_rsp),
            Source::Diffuse => {
                let (x, y) = rng.disc_point();
                let z = (1.0 - x * x - y * y).sqrt();
                refract_in([x, y, z], self.n_above, self.n_top)
            }
        }
    }
}

/// Refract an incoming unit direction `d` (d[2] > 0) from `n_above` into `n_top`; returns the
/// inside direction and the Fresnel reflectance (Snell: tangential part scaled by η = n₁/n₂).
#[inline]
fn refract_in(d: [f64; 3], n_above: f64, n_top: f64) -> ([f64; 3], f64) {
    let (r, cos_t) = fr_dielectric_cos_t(d[2], n_above, n_top);
    let eta = n_above / n_top;
    ([d[0] * eta, d[1] * eta, cos_t], r)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pencil_refracts_by_snell() {
        let th = 0.6f64;
        let l = Launcher::new(Source::Pencil { theta: th, phi: 0.3 }, 1.0, 1.4);
        let mut rng = PhotonRng::new(0, 0);
        let (d, rsp) = l.launch(&mut rng);
        let sin_t = (d[0] * d[0] + d[1] * d[1]).sqrt();
        assert!((1.4 * sin_t - th.sin()).abs() < 1e-14);
        assert!(((d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) - 1.0).abs() < 1e-14);
        assert!((d[1] / d[0] - 0.3f64.tan()).abs() < 1e-12);
        assert!((rsp - crate::optics::fr_dielectric(th.cos(), 1.0, 1.4)).abs() < 1e-15);
        assert!(Source::Pencil { theta: 1.6, phi: 0.0 }.validate().is_err());
        assert!(Source::Pencil { theta: MAX_PENCIL_THETA, phi: 0.0 }.validate().is_ok());
        assert!(Source::Pencil { theta: (89.9999999f64).to_radians(), phi: 0.0 }.validate().is_err());
        assert!(Source::Pencil { theta: -0.1, phi: 0.0 }.validate().is_err());
    }

    /// Lambertian launch: E[cos θ] = 2/3 and E[cos² θ] = 1/2 for the pdf cos θ / π (checked
    /// with n_above = n_top so the direction is not refracted), within 5σ.
    #[test]
    fn diffuse_is_cosine_weighted() {
        let l = Launcher::new(Source::Diffuse, 1.0, 1.0);
        let n = 200_000;
        let (mut s, mut s2) = (0.0, 0.0);
        for p in 0..n {
            let mut rng = PhotonRng::new(1, p);
            let (d, r) = l.launch(&mut rng);
            assert_eq!(r, 0.0);
            s += d[2];
            s2 += d[2] * d[2];
        }
        let nf = n as f64;
        let sd = (0.5f64 - 4.0 / 9.0).sqrt() / nf.sqrt();
        assert!((s / nf - 2.0 / 3.0).abs() < 5.0 * sd, "{}", s / nf);
        assert!((s2 / nf - 0.5).abs() < 5.0 * (1.0f64 / 3.0 - 0.25).sqrt() / nf.sqrt());
    }
}
