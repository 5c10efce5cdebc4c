//! Mixtures of scattering and absorbing components (seed eq. 1.5; Hanrahan & Krueger 1993 §4):
//! σa = Σ f_l σa,l and σs p = Σ f_l σs,l p_l, so the mixture's phase function is the
//! scattering-weighted mixture of the components' HG lobes.

use super::Layer;
use crate::error::{check_coefficient, check_g, Error, Result};
use crate::optics::Phase;

/// One component of a mixture: its volume fraction and the coefficients of the pure component.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Component {
    /// Volume fraction in [0, 1].
    pub fraction: f64,
    /// Absorption coefficient of the pure component, mm⁻¹.
    pub mua: f64,
    /// Scattering coefficient of the pure component, mm⁻¹.
    pub mus: f64,
    /// Mean cosine of the component's HG phase function.
    pub g: f64,
}

/// Build a layer of index `n` and thickness `thickness` from components by volume fraction.
/// Fractions must lie in [0, 1] and sum to at most 1 (the rest is a clear, non-interacting
/// base). The phase function is the mixture of the components' lobes weighted by f_l σs,l.
pub fn mix(n: f64, thickness: f64, components: &[Component]) -> Result<Layer> {
    if components.is_empty() {
        return Err(Error::Invalid("components: give at least one component".into()));
    }
    let mut total_f = 0.0;
    let (mut mua, mut mus) = (0.0, 0.0);
    let mut lobes = Vec::with_capacity(components.len());
    for (i, c) in components.iter().enumerate() {
        if !(c.fraction.is_finite() && (0.0..=1.0).contains(&c.fraction)) {
            return Err(Error::param(format!("components[{i}].fraction"), c.fraction, "a number in [0, 1]"));
        }
        check_coefficient(&format!("components[{i}].mua"), c.mua)?;
        check_coefficient(&format!("components[{i}].mus"), c.mus)?;
        check_g(&format!("components[{i}].g"), c.g)?;
        total_f += c.fraction;
        mua += c.fraction * c.mua;
        mus += c.fraction * c.mus;
        lobes.push((c.fraction * c.mus, c.g));
    }
    if total_f > 1.0 + 1e-9 {
        return Err(Error::param("sum of components' fractions", total_f, "at most 1"));
    }
    // Merge lobes with equal g so that more components than MAX_LOBES can share few lobes.
    let mut merged: Vec<(f64, f64)> = Vec::new();
    for (w, g) in lobes {
        if w == 0.0 {
            continue;
        }
        match merged.iter_mut().find(|(_, mg)| *mg == g) {
            Some(m) => m.0 += w,
            None => merged.push((w, g)),
        }
    }
    let phase = if merged.is_empty() { Phase::isotropic() } else { Phase::mixture(&merged)? };
    Layer::with_phase(n, mua, mus, phase, thickness)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mix_weights_by_scattering() {
        let l = mix(
            1.4,
            1.0,
            &[
                Component { fraction: 0.25, mua: 2.0, mus: 40.0, g: 0.9 },
                Component { fraction: 0.5, mua: 0.2, mus: 20.0, g: 0.0 },
            ],
        )
        .unwrap();
        assert!((l.mua - 0.6).abs() < 1e-12);
        assert!((l.mus - 20.0).abs() < 1e-12);
        // weights 10/20 and 10/20 → g = 0.45
        assert!((l.g() - 0.45).abs() < 1e-12);
        let ct = 0.3;
        let expect = 0.5 * crate::optics::hg_phase(ct, 0.9) + 0.5 * crate::optics::hg_phase(ct, 0.0);
        assert!((l.phase.eval(ct) - expect).abs() < 1e-14);
    }

    #[test]
    fn mix_rejects_bad_fractions() {
        let c = Component { fraction: 0.7, mua: 0.0, mus: 1.0, g: 0.0 };
        assert!(mix(1.0, 1.0, &[c, c]).unwrap_err().to_string().contains("fractions"));
        let bad = Component { fraction: -0.1, ..c };
        assert!(mix(1.0, 1.0, &[bad]).unwrap_err().to_string().starts_with("components[0].fraction"));
        assert!(mix(1.0, 1.0, &[]).is_err());
    }
}
