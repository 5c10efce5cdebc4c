//! One homogeneous layer of a turbid medium.

use crate::error::{check_coefficient, check_index, Error, Result};
use crate::optics::Phase;

/// A homogeneous slab: refractive index `n`, absorption `mua` and scattering `mus`
/// coefficients (mm⁻¹), a phase function and a thickness (mm; `f64::INFINITY` for a
/// semi-infinite last layer).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Layer {
    /// Refractive index (≥ 1).
    pub n: f64,
    /// Absorption coefficient σa, mm⁻¹.
    pub mua: f64,
    /// Scattering coefficient σs, mm⁻¹.
    pub mus: f64,
    /// Phase function (HG or a mixture of HG lobes).
    pub phase: Phase,
    /// Thickness d, mm (> 0, may be infinite).
    pub thickness: f64,
}

impl Layer {
    /// A layer with a Henyey–Greenstein phase function of mean cosine `g`.
    pub fn new(n: f64, mua: f64, mus: f64, g: f64, thickness: f64) -> Result<Self> {
        let phase = Phase::hg(g)?;
        Self::with_phase(n, mua, mus, phase, thickness)
    }

    /// A layer with any phase function.
    pub fn with_phase(n: f64, mua: f64, mus: f64, phase: Phase, thickness: f64) -> Result<Self> {
        let layer = Layer { n, mua, mus, phase, thickness };
        layer.validate("")?;
        Ok(layer)
    }

    /// Validate every field; `prefix` (e.g. `"layers[1]."`) is put before the field names.
    pub fn validate(&self, prefix: &str) -> Result<()> {
        check_index(&format!("{prefix}n"), self.n)?;
        check_coefficient(&format!("{prefix}mua"), self.mua)?;
        check_coefficient(&format!("{prefix}mus"), self.mus)?;
        if !self.sigma_t().is_finite() {
            return Err(Error::param(
                format!("{prefix}mua + {prefix}mus"),
                self.sigma_t(),
                "finite (the extinction coefficient sigma_t = mua + mus overflows)",
            ));
        }
        for (i, l) in self.phase.lobes().iter().enumerate() {
            let field = if self.phase.lobes().len() == 1 {
                format!("{prefix}g")
            } else {
                format!("{prefix}phase.lobes[{i}].g")
            };
            crate::error::check_g(&field, l.g)?;
        }
        if self.thickness.is_nan() || self.thickness <= 0.0 {
            return Err(Error::param(format!("{prefix}thickness"), self.thickness, "a number > 0 (mm) or infinity"));
        }
        Ok(())
    }

    /// Mean cosine of the phase function.
    pub fn g(&self) -> f64 {
        self.phase.g()
    }
    /// Extinction coefficient σt = σa + σs, mm⁻¹.
    pub fn sigma_t(&self) -> f64 {
        self.mua + self.mus
    }
    /// Single-scattering albedo σs/σt (0 for a non-interacting layer).
    pub fn albedo(&self) -> f64 {
        let t = self.sigma_t();
        if t > 0.0 {
            self.mus / t
        } else {
            0.0
        }
    }
    /// Reduced scattering coefficient σs' = σs (1 − g), mm⁻¹.
    pub fn mus_prime(&self) -> f64 {
        self.mus * (1.0 - self.g())
    }
    /// Reduced extinction σt' = σa + σs', mm⁻¹.
    pub fn sigma_t_prime(&self) -> f64 {
        self.mua + self.mus_prime()
    }
    /// Transport mean free path 1/σt', mm (infinite for a non-interacting layer).
    pub fn transport_mfp(&self) -> f64 {
        1.0 / self.sigma_t_prime()
    }
    /// Optical thickness τ = σt d (infinite for a semi-infinite layer unless σt = 0, then 0).
    pub fn optical_thickness(&self) -> f64 {
        let t = self.sigma_t();
        if t == 0.0 {
            0.0
        } else {
            t * self.thickness
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn derived_quantities() {
        let l = Layer::new(1.4, 0.1, 10.0, 0.9, 2.0).unwrap();
        assert!((l.sigma_t() - 10.1).abs() < 1e-12);
        assert!((l.albedo() - 10.0 / 10.1).abs() < 1e-12);
        assert!((l.mus_prime() - 1.0).abs() < 1e-12);
        assert!((l.transport_mfp() - 1.0 / 1.1).abs() < 1e-12);
        assert!((l.optical_thickness() - 20.2).abs() < 1e-12);
        let glass = Layer::new(1.5, 0.0, 0.0, 0.0, 1.0).unwrap();
        assert_eq!(glass.albedo(), 0.0);
        assert_eq!(glass.optical_thickness(), 0.0);
    }

    #[test]
    fn validation_names_fields() {
        let e = Layer::new(1.4, -1.0, 1.0, 0.0, 1.0).unwrap_err().to_string();
        assert!(e.starts_with("mua = -1"), "{e}");
        assert!(Layer::new(0.9, 0.0, 1.0, 0.0, 1.0).is_err());
        assert!(Layer::new(1.0, 0.0, f64::NAN, 0.0, 1.0).is_err());
        assert!(Layer::new(1.0, 0.0, 1.0, -1.0, 1.0).is_err());
        assert!(Layer::new(1.0, 0.0, 1.0, 0.0, 0.0).is_err());
        assert!(Layer::new(1.0, 0.0, 1.0, 0.0, f64::NAN).is_err());
        assert!(Layer::new(1.0, 0.0, 1.0, 0.0, f64::INFINITY).is_ok());
        // subnormal coefficients and an overflowing sigma_t are refused
        assert!(Layer::new(1.0, 0.0, 1e-320, 0.0, 1.0).unwrap_err().to_string().starts_with("mus = 1e-320"));
        assert!(Layer::new(1.0, 1e-310, 1e-310, 0.0, 1.0).unwrap_err().to_string().starts_with("mua = 1e-310"));
        let e = Layer::new(1.4, 1e308, 1e308, 0.0, 1.0).unwrap_err().to_string();
        assert!(e.starts_with("mua + mus = inf"), "{e}");
    }
}
