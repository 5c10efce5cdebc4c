//! Lights: point, directional, spherical and rectangular area lights; the constant
//! environment is a field of the scene. Each sampler sits beside what it returns.
//!
//! Units: power Φ in W, intensity W sr⁻¹, irradiance W mm⁻², radiance W mm⁻² sr⁻¹ (any
//! consistent unit of power works: images are linear in it). Area lights emit diffusely:
//! L = Φ/(π A) from the front of a rectangle and outwards from a sphere (A = 4πr²).

use super::math::{cross, dot, length, madd, normalize, scale, sub, unit, Frame, Rgb, V3};
use crate::error::{Error, Result};
use std::f64::consts::PI;

/// A light source.
#[derive(Clone, Debug)]
pub enum Light {
    /// Isotropic point light of intensity I = Φ/(4π) per channel.
    Point { position: V3, intensity: Rgb },
    /// Distant light: collimated irradiance `irradiance` (on a surface facing it) arriving
    /// from the unit direction `to_light`.
    Directional { to_light: V3, irradiance: Rgb },
    /// Sphere of radius `radius` emitting radiance `radiance` outwards.
    Sphere { center: V3, radius: f64, radiance: Rgb },
    /// Rectangle centre ± `u` ± `v` (half-edge vectors) emitting along n = u × v / |u × v|.
    Rect { center: V3, u: V3, v: V3, n: V3, radiance: Rgb },
}

crate::named_enum! {
    /// The types of [`Light`], as scenes name them (`type = "point"`).
    pub enum LightKind ("a light type") {
        /// [`Light::point`].
        Point = "point",
        /// [`Light::directional`].
        Directional = "directional",
        /// [`Light::sphere`].
        Sphere = "sphere",
        /// [`Light::rect`].
        Rect = "rect",
    }
}

impl LightKind {
    /// The parameters a scene gives for this type, in the constructor's order.
    pub fn params(self) -> &'static [&'static str] {
        match self {
            LightKind::Point => &["position", "power"],
            LightKind::Directional => &["direction", "irradiance"],
            LightKind::Sphere => &["position", "radius", "power"],
            LightKind::Rect => &["position", "u", "v", "power"],
        }
    }
}

/// A light sample seen from a point: the unit direction to the light, the distance to it
/// (∞ for a directional light) and the irradiance it delivers on a surface normal to `wi`
/// divided by the sampling pdf (W mm⁻²): multiply by cos θ for a tilted surface.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    pub wi: V3,
    pub dist: f64,
    pub value: Rgb,
}

/// Largest light power (W), irradiance (W mm⁻²) or environment radiance per channel: radiance
/// sums over paths and samples stay finite (images are linear in it; rescale the units).
pub const MAX_POWER: f64 = 1e100;

/// Check a power-like RGB value: each channel in [0, [`MAX_POWER`]].
pub fn check_power(field: &str, p: Rgb) -> Result<()> {
    for (k, &x) in p.iter().enumerate() {
        if !(x.is_finite() && (0.0..=MAX_POWER).contains(&x)) {
            return Err(Error::param(format!("{field}[{k}]"), x, "a number in [0, 1e100]"));
        }
    }
    Ok(())
}

impl Light {
    /// A point light of total power `power` (W per channel). `field` names it in errors.
    pub fn point(field: &str, position: V3, power: Rgb) -> Result<Light> {
        check_power(&format!("{field}.power"), power)?;
        Ok(Light::Point { position, intensity: scale(power, 1.0 / (4.0 * PI)) })
    }

    /// A directional light from `to_light` delivering `irradiance` (W mm⁻²) on a normal surface.
    pub fn directional(field: &str, to_light: V3, irradiance: Rgb) -> Result<Light> {
        check_power(&format!("{field}.irradiance"), irradiance)?;
        let Some(to_light) = unit(to_light) else {
            return Err(Error::Invalid(format!("{field}.direction: must be a finite non-zero vector")));
        };
        Ok(Light::Directional { to_light, irradiance })
    }

    /// A spherical area light of total power `power`.
    pub fn sphere(field: &str, center: V3, radius: f64, power: Rgb) -> Result<Light> {
        check_power(&format!("{field}.power"), power)?;
        if !(radius > 0.0 && radius.is_finite()) {
            return Err(Error::param(format!("{field}.radius"), radius, "a finite number > 0 (mm)"));
        }
        let area = 4.0 * PI * radius * radius;
        Ok(Light::Sphere { center, radius, radiance: scale(power, 1.0 / (PI * area)) })
    }

    /// A one-sided rectangular area light (centre ± u ± v) of total power `power`.
    pub fn rect(field: &str, center: V3, u: V3, v: V3, power: Rgb) -> Result<Light> {
        check_power(&format!("{field}.power"), power)?;
        let c = cross(u, v);
        let area = 4.0 * length(c);
        if !(area > 0.0 && area.is_finite()) {
            return Err(Error::Invalid(format!("{field}: the rectangle has zero area (u and v must span a plane)")));
        }
        Ok(Light::Rect { center, u, v, n: normalize(c), radiance: scale(power, 1.0 / (PI * area)) })
    }

    /// The light's type.
    pub fn kind(&self) -> LightKind {
        match self {
            Light::Point { .. } => LightKind::Point,
            Light::Directional { .. } => LightKind::Directional,
            Light::Sphere { .. } => LightKind::Sphere,
            Light::Rect { .. } => LightKind::Rect,
        }
    }

    /// Sample the light from point `p` with uniforms (u1, u2); `None` when nothing reaches `p`.
    pub fn sample(&self, p: V3, u1: f64, u2: f64) -> Option<LightSample> {
        match *self {
            Light::Point { position, intensity } => {
                let d = sub(position, p);
                let r2 = dot(d, d);
                (r2 > 0.0).then(|| LightSample {
                    wi: scale(d, 1.0 / r2.sqrt()),
                    dist: r2.sqrt(),
                    value: scale(intensity, 1.0 / r2),
                })
            }
            Light::Directional { to_light, irradiance } => {
                Some(LightSample { wi: to_light, dist: f64::INFINITY, value: irradiance })
            }
            Light::Sphere { center, radius, radiance } => {
                // Uniform direction in the cone subtended by the sphere (pbrt-v4 §6.2.4):
                // pdf = 1/(2π(1 − cos θmax)), value = L / pdf.
                let dc = sub(center, p);
                let d2 = dot(dc, dc);
                if d2 <= radius * radius {
                    return None;
                }
                let cos_max = (1.0 - radius * radius / d2).max(0.0).sqrt();
                let cos_t = 1.0 - u1 * (1.0 - cos_max);
                let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
                let phi = 2.0 * PI * u2;
                let f = Frame::new(scale(dc, 1.0 / d2.sqrt()));
                let wi = f.to_world([sin_t * phi.cos(), sin_t * phi.sin(), cos_t]);
                let dist = sphere_hit(p, wi, center, radius).unwrap_or(d2.sqrt() - radius);
                Some(LightSample { wi, dist, value: scale(radiance, 2.0 * PI * (1.0 - cos_max)) })
            }
            Light::Rect { center, u, v, n, radiance } => {
                let q = madd(madd(center, u, 2.0 * u1 - 1.0), v, 2.0 * u2 - 1.0);
                let d = sub(q, p);
                let r2 = dot(d, d);
                let r = r2.sqrt();
                let wi = scale(d, 1.0 / r);
                let cos_l = -dot(wi, n);
                if cos_l <= 0.0 || r2 == 0.0 {
                    return None;
                }
                let area = 4.0 * length(cross(u, v));
                Some(LightSample { wi, dist: r, value: scale(radiance, cos_l * area / r2) })
            }
        }
    }

    /// A point on an area light's surface, uniform by area: (point, emitting unit normal there,
    /// radiance, area pdf in mm⁻²); `None` for point and directional lights.
    pub fn sample_point(&self, u1: f64, u2: f64) -> Option<(V3, V3, Rgb, f64)> {
        match *self {
            Light::Rect { center, u, v, n, radiance } => {
                let y = madd(madd(center, u, 2.0 * u1 - 1.0), v, 2.0 * u2 - 1.0);
                Some((y, n, radiance, 1.0 / (4.0 * length(cross(u, v)))))
            }
            Light::Sphere { center, radius, radiance } => {
                let dir = crate::optics::sample_uniform_sphere(u1, u2);
                Some((madd(center, dir, radius), dir, radiance, 1.0 / (4.0 * PI * radius * radius)))
            }
            Light::Point { .. } | Light::Directional { .. } => None,
        }
    }

    /// The area pdf (mm⁻²) of [`Self::sample_point`] and the emitting unit normal at the point
    /// `y` of the light's surface; `None` for point and directional lights.
    pub fn point_pdf(&self, y: V3) -> Option<(f64, V3)> {
        match *self {
            Light::Rect { u, v, n, .. } => Some((1.0 / (4.0 * length(cross(u, v))), n)),
            Light::Sphere { center, radius, .. } => {
                Some((1.0 / (4.0 * PI * radius * radius), scale(sub(y, center), 1.0 / radius)))
            }
            Light::Point { .. } | Light::Directional { .. } => None,
        }
    }

    /// Where a ray (o, unit d) meets the light's emitting surface before `tmax`: the distance
    /// and the radiance seen; `None` for point and directional lights (zero measure).
    pub fn hit(&self, o: V3, d: V3, tmax: f64) -> Option<(f64, Rgb)> {
        match *self {
            Light::Sphere { center, radius, radiance } => {
                sphere_hit(o, d, center, radius).filter(|&t| t < tmax).map(|t| (t, radiance))
            }
            Light::Rect { center, u, v, n, radiance } => {
                let dn = dot(d, n);
                if dn >= 0.0 {
                    return None;
                }
                let t = dot(sub(center, o), n) / dn;
                if !(t > 0.0 && t < tmax) {
                    return None;
                }
                let q = sub(madd(o, d, t), center);
                let (a, b) = (dot(q, u) / dot(u, u), dot(q, v) / dot(v, v));
                (a.abs() <= 1.0 && b.abs() <= 1.0).then_some((t, radiance))
            }
            Light::Point { .. } | Light::Directional { .. } => None,
        }
    }
}

/// Nearest positive intersection of the ray (o, unit d) with a sphere seen from outside.
fn sphere_hit(o: V3, d: V3, c: V3, r: f64) -> Option<f64> {
    let oc = sub(o, c);
    let b = dot(oc, d);
    let cc = dot(oc, oc) - r * r;
    let disc = b * b - cc;
    if disc < 0.0 {
        return None;
    }
    let s = disc.sqrt();
    let t0 = -b - s;
    let t1 = -b + s;
    if t0 > 0.0 {
        Some(t0)
    } else if t1 > 0.0 && cc > 0.0 {
        Some(t1)
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Irradiance at a point facing each area light, by sampling vs by quadrature of the
    /// closed forms: sphere, E = π L (r/d)² on the axis; rectangle, E by a 400² midpoint rule.
    #[test]
    fn area_light_samples_integrate_to_the_irradiance() {
        let mut rng = crate::rng::PhotonRng::new(3, 0);
        let s = Light::sphere("l", [0.0, 0.0, 5.0], 1.0, [1.0; 3]).unwrap();
        let Light::Sphere { radiance, .. } = s else { unreachable!() };
        let exact = PI * radiance[0] / 25.0;
        let n = 200_000;
        let est: f64 = (0..n)
            .map(|_| {
                let ls = s.sample([0.0; 3], rng.uniform(), rng.uniform()).unwrap();
                ls.value[0] * ls.wi[2]
            })
            .sum::<f64>()
            / n as f64;
        assert!((est / exact - 1.0).abs() < 5e-3, "{est} vs {exact}");
        let r = Light::rect("l", [0.3, 0.0, 2.0], [0.5, 0.0, 0.0], [0.0, -1.0, 0.0], [1.0; 3]).unwrap();
        let Light::Rect { radiance, .. } = r else { unreachable!() };
        let m = 400;
        let mut quad = 0.0;
        for i in 0..m {
            for j in 0..m {
                let q = [
                    0.3 + (-1.0 + (2.0 * i as f64 + 1.0) / m as f64) * 0.5,
                    (-1.0 + (2.0 * j as f64 + 1.0) / m as f64),
                    2.0,
                ];
                let d2 = dot(q, q);
                let c = q[2] / d2.sqrt();
                quad += radiance[0] * c * c / d2 * 2.0 / (m * m) as f64;
            }
        }
        let est: f64 = (0..n)
            .map(|_| r.sample([0.0; 3], rng.uniform(), rng.uniform()).map_or(0.0, |ls| ls.value[0] * ls.wi[2]))
            .sum::<f64>()
            / n as f64;
        assert!((est / quad - 1.0).abs() < 5e-3, "{est} vs {quad}");
        assert!(r.hit([0.3, 0.0, 0.0], [0.0, 0.0, 1.0], 10.0).is_some());
        assert!(Light::point("lights[0]", [0.0; 3], [1.0, -1.0, 1.0])
            .unwrap_err()
            .to_string()
            .contains("lights[0].power[1]"));
    }
}
