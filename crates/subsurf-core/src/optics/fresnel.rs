//! Fresnel equations for smooth dielectric interfaces and Snell's law.
//!
//! Light travels from a medium of index `eta_i` into one of index `eta_t`; `cos_i` is the
//! cosine of the angle of incidence (its sign is ignored). Reflectances are power (intensity)
//! ratios, so T = 1 − R for each polarisation. Past the critical angle R = 1 (total internal
//! reflection). References: Born & Wolf, *Principles of Optics*, §1.5.2 (eqs. 21a–21b);
//! pbrt-v4 `FrDielectric`.

/// Polarisation state of the incident light.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Polarization {
    /// Natural (unpolarised) light: the mean of s and p.
    Unpolarized,
    /// Electric field perpendicular to the plane of incidence (TE).
    S,
    /// Electric field parallel to the plane of incidence (TM).
    P,
}

/// cos θt by Snell's law, n_i sin θi = n_t sin θt; `None` past the critical angle.
#[inline]
pub fn cos_transmitted(cos_i: f64, eta_i: f64, eta_t: f64) -> Option<f64> {
    let cos_i = cos_i.abs().min(1.0);
    let eta = eta_i / eta_t;
    let sin2_i = (1.0 - cos_i * cos_i).max(0.0);
    // at normal incidence no index ratio, however extreme, bends the ray (η² may overflow)
    let sin2_t = if sin2_i == 0.0 { 0.0 } else { eta * eta * sin2_i };
    if sin2_t >= 1.0 {
        None
    } else {
        Some((1.0 - sin2_t).sqrt())
    }
}

/// Reflectances (R_s, R_p) for the two linear polarisations (Born & Wolf eqs. 1.5.21).
#[inline]
pub fn fr_dielectric_sp(cos_i: f64, eta_i: f64, eta_t: f64) -> (f64, f64) {
    let ci = cos_i.abs().min(1.0);
    match cos_transmitted(ci, eta_i, eta_t) {
        None => (1.0, 1.0),
        Some(ct) => {
            let rs = (eta_i * ci - eta_t * ct) / (eta_i * ci + eta_t * ct);
            let rp = (eta_t * ci - eta_i * ct) / (eta_t * ci + eta_i * ct);
            (rs * rs, rp * rp)
        }
    }
}

/// Unpolarised Fresnel reflectance R = (R_s + R_p)/2.
#[inline]
pub fn fr_dielectric(cos_i: f64, eta_i: f64, eta_t: f64) -> f64 {
    let (rs, rp) = fr_dielectric_sp(cos_i, eta_i, eta_t);
    0.5 * (rs + rp)
}

/// Unpolarised reflectance and the transmitted cosine in one call (the Monte Carlo kernel's
/// boundary test; MCML's `RFresnel`). Past the critical angle returns (1, 0).
#[inline]
pub fn fr_dielectric_cos_t(cos_i: f64, eta_i: f64, eta_t: f64) -> (f64, f64) {
    let ci = cos_i.abs().min(1.0);
    if eta_i == eta_t {
        return (0.0, ci);
    }
    match cos_transmitted(ci, eta_i, eta_t) {
        None => (1.0, 0.0),
        Some(ct) => {
            let rs = (eta_i * ci - eta_t * ct) / (eta_i * ci + eta_t * ct);
            let rp = (eta_t * ci - eta_i * ct) / (eta_t * ci + eta_i * ct);
            (0.5 * (rs * rs + rp * rp), ct)
        }
    }
}

/// Fresnel reflectance for a given polarisation.
#[inline]
pub fn fresnel_reflectance(cos_i: f64, eta_i: f64, eta_t: f64, pol: Polarization) -> f64 {
    let (rs, rp) = fr_dielectric_sp(cos_i, eta_i, eta_t);
    match pol {
        Polarization::Unpolarized => 0.5 * (rs + rp),
        Polarization::S => rs,
        Polarization::P => rp,
    }
}

/// Fresnel (power) transmittance T = 1 − R for a given polarisation.
#[inline]
pub fn fresnel_transmittance(cos_i: f64, eta_i: f64, eta_t: f64, pol: Polarization) -> f64 {
    1.0 - fresnel_reflectance(cos_i, eta_i, eta_t, pol)
}

/// Refract the propagation direction `d` (unit, travelling towards the surface) through a
/// surface with unit normal `normal` (either orientation), from index `eta_i` into `eta_t`.
/// Returns the transmitted unit propagation direction, or `None` on total internal reflection.
/// Vector form of Snell's law: t = η d + (η cos θi − cos θt) n, with n facing the incident side.
#[inline]
pub fn refract(d: [f64; 3], normal: [f64; 3], eta_i: f64, eta_t: f64) -> Option<[f64; 3]> {
    let mut n = normal;
    let mut cos_i = -(d[0] * n[0] + d[1] * n[1] + d[2] * n[2]);
    if cos_i < 0.0 {
        n = [-n[0], -n[1], -n[2]];
        cos_i = -cos_i;
    }
    let eta = eta_i / eta_t;
    let cos_t = cos_transmitted(cos_i, eta_i, eta_t)?;
    let k = eta * cos_i - cos_t;
    Some([eta * d[0] + k * n[0], eta * d[1] + k * n[1], eta * d[2] + k * n[2]])
}

/// Mirror reflection of the propagation direction `d` about a surface with unit normal `normal`.
#[inline]
pub fn reflect(d: [f64; 3], normal: [f64; 3]) -> [f64; 3] {
    let dn = d[0] * normal[0] + d[1] * normal[1] + d[2] * normal[2];
    [d[0] - 2.0 * dn * normal[0], d[1] - 2.0 * dn * normal[1], d[2] - 2.0 * dn * normal[2]]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_incidence_closed_form() {
        for (n1, n2) in [(1.0, 1.5), (1.5, 1.0), (1.33, 1.4)] {
            let r = ((n1 - n2) / (n1 + n2)) * ((n1 - n2) / (n1 + n2));
            assert!((fr_dielectric(1.0, n1, n2) - r).abs() < 1e-15);
            assert!((fr_dielectric_cos_t(1.0, n1, n2).0 - r).abs() < 1e-15);
        }
    }

    #[test]
    fn brewster_and_tir() {
        let (n1, n2) = (1.0f64, 1.5f64);
        let theta_b = (n2 / n1).atan();
        assert!(fresnel_reflectance(theta_b.cos(), n1, n2, Polarization::P) < 1e-28);
        let theta_c = (1.0f64 / 1.5).asin();
        assert_eq!(fr_dielectric((theta_c + 1e-6).cos(), 1.5, 1.0), 1.0);
        assert!(fr_dielectric((theta_c - 1e-3).cos(), 1.5, 1.0) < 1.0);
        assert_eq!(fr_dielectric_cos_t(0.1, 1.5, 1.0), (1.0, 0.0));
    }

    #[test]
    fn refract_obeys_snell() {
        let th = 0.7f64;
        let d = [th.sin(), 0.0, -th.cos()];
        let t = refract(d, [0.0, 0.0, 1.0], 1.0, 1.4).unwrap();
        let sin_t = (t[0] * t[0] + t[1] * t[1]).sqrt();
        assert!((1.4 * sin_t - th.sin()).abs() < 1e-14);
        assert!(t[2] < 0.0 && ((t[0] * t[0] + t[1] * t[1] + t[2] * t[2]) - 1.0).abs() < 1e-14);
        assert!(refract([0.9, 0.0, -(1.0f64 - 0.81).sqrt()], [0.0, 0.0, 1.0], 1.5, 1.0).is_none());
    }
}
