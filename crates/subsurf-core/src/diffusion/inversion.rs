//! Inversions: the reduced albedo α' from a total diffuse reflectance, and optical properties
//! (σa, σs') from a diffuse colour and a mean free path per channel.
//!
//! Jensen et al. (2001, §3) find α' from a measured total R_d by inverting the closed form;
//! Jensen & Buhler, "A Rapid Hierarchical Rendering Technique for Translucent Materials"
//! (SIGGRAPH 2002, §4) turn this into an artist's parameterisation (diffuse reflectance and
//! a mean free path); pbrt-v3's `SubsurfaceFromDiffuse` does the same with the transport mean
//! free path. Both definitions of the mean free path are offered, see [`MeanFreePath`].

use super::{check_eta, Model};
use crate::error::{Error, Result};

/// Invert the model's closed-form total diffuse reflectance R_d(α', η) for α' ∈ [0, 1].
/// R_d is strictly increasing in α' with R_d(0) = 0 and R_d(1) = 1 for both models, so every
/// rd ∈ [0, 1] has exactly one α'; found by bisection until the bracket is below 1e-15
/// (then |α' − α'_true| ≤ 1e-15 up to the rounding of R_d itself).
pub fn alpha_prime_from_rd(rd: f64, eta: f64, model: Model) -> Result<f64> {
    alpha_prime_of("rd", rd, eta, model)
}

/// [`alpha_prime_from_rd`] with the reflectance argument called `field` in errors.
fn alpha_prime_of(field: &str, rd: f64, eta: f64, model: Model) -> Result<f64> {
    if !(rd.is_finite() && (0.0..=1.0).contains(&rd)) {
        return Err(Error::param(
            field,
            rd,
            "a finite number in [0, 1] (the total diffuse reflectance a semi-infinite medium can reach)",
        ));
    }
    check_eta(eta)?;
    if rd == 0.0 {
        return Ok(0.0);
    }
    if rd == 1.0 {
        return Ok(1.0);
    }
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi || hi - lo < 1e-15 {
            break;
        }
        if model.total_rd(mid, eta)? < rd {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Ok(0.5 * (lo + hi))
}

/// Which length the user's "mean free path" ℓ is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MeanFreePath {
    /// Transport mean free path ℓ = 1/σt' = 1/(σa + σs') (pbrt-v3 `SubsurfaceFromDiffuse`).
    Transport,
    /// Diffuse mean free path ℓ_d = 1/σtr (Jensen & Buhler 2002, §4), with σtr the model's
    /// effective transport coefficient: √(3(1−α'))·σt' (dipole) or
    /// √(3(1−α')/(2−α'))·σt' (better dipole).
    Diffuse,
}

impl MeanFreePath {
    /// `"transport"` or `"diffuse"`.
    pub fn from_name(name: &str) -> Result<MeanFreePath> {
        match name {
            "transport" => Ok(MeanFreePath::Transport),
            "diffuse" => Ok(MeanFreePath::Diffuse),
            other => Err(Error::Invalid(format!(
                "mfp_kind = {other:?} is not a mean free path kind: must be one of [\"transport\", \"diffuse\"]"
            ))),
        }
    }
}

/// Optical properties (σa, σs') in mm⁻¹ whose total diffuse reflectance (of `model`, at η) is
/// `rd` (errors name it `diffuse_color`, as the Python API does) and whose mean free path of the
/// given kind is `mfp` (mm):
/// α' = alpha_prime_from_rd(rd, η); σt' = 1/ℓ (transport) or σtr/(ℓ_d σtr/σt') (diffuse);
/// σs' = α' σt'; σa = σt' − σs' = (1 − α') σt'.
/// For the diffuse kind, rd = 1 (α' = 1, σtr = 0) has no finite σt' and is refused.
pub fn properties_from_color(rd: f64, mfp: f64, eta: f64, model: Model, kind: MeanFreePath) -> Result<(f64, f64)> {
    if !(mfp.is_finite() && mfp > 0.0) {
        return Err(Error::param("mean_free_path", mfp, "a finite number > 0 (mm)"));
    }
    let ap = alpha_prime_of("diffuse_color", rd, eta, model)?;
    let st = match kind {
        MeanFreePath::Transport => 1.0 / mfp,
        MeanFreePath::Diffuse => {
            let k = match model {
                Model::Dipole => (3.0 * (1.0 - ap)).sqrt(),
                Model::BetterDipole => (3.0 * (1.0 - ap) / (2.0 - ap)).sqrt(),
            };
            if k <= 0.0 {
                return Err(Error::param(
                    "diffuse_color",
                    rd,
                    "< 1 when mean_free_path is a diffuse mean free path 1/sigma_tr (rd = 1 means no absorption)",
                ));
            }
            1.0 / (mfp * k)
        }
    };
    Ok(((1.0 - ap) * st, ap * st))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips() {
        for model in [Model::Dipole, Model::BetterDipole] {
            for &eta in &[1.0, 1.3, 1.5, 2.5] {
                for i in 0..=50 {
                    let ap = i as f64 / 50.0;
                    let rd = model.total_rd(ap, eta).unwrap();
                    let back = alpha_prime_from_rd(rd, eta, model).unwrap();
                    assert!((back - ap).abs() < 1e-12, "{model:?} {eta} {ap}: {back}");
                }
            }
        }
        assert!(alpha_prime_from_rd(1.5, 1.3, Model::Dipole).is_err());
        assert!(alpha_prime_from_rd(f64::NAN, 1.3, Model::Dipole).is_err());
    }

    #[test]
    fn color_round_trip() {
        for model in [Model::Dipole, Model::BetterDipole] {
            for kind in [MeanFreePath::Transport, MeanFreePath::Diffuse] {
                let (sa, ssp) = properties_from_color(0.6, 2.0, 1.3, model, kind).unwrap();
                let st = sa + ssp;
                let rd = model.total_rd(ssp / st, 1.3).unwrap();
                assert!((rd - 0.6).abs() < 1e-12);
                let l = match (kind, model) {
                    (MeanFreePath::Transport, _) => 1.0 / st,
                    (MeanFreePath::Diffuse, Model::Dipole) => 1.0 / (3.0 * sa * st).sqrt(),
                    (MeanFreePath::Diffuse, Model::BetterDipole) => {
                        1.0 / (sa * 3.0 * st * st / (2.0 * sa + ssp)).sqrt()
                    }
                };
                assert!((l - 2.0).abs() < 1e-12, "{model:?} {kind:?} {l}");
            }
        }
        assert!(properties_from_color(1.0, 2.0, 1.3, Model::Dipole, MeanFreePath::Diffuse).is_err());
        assert!(properties_from_color(0.5, 0.0, 1.3, Model::Dipole, MeanFreePath::Transport).is_err());
    }
}
