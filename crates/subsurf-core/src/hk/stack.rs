//! First-order (single-scattering) BRDF and BTDF of a layered stack, and its unscattered
//! (order-0) transmittance (Hanrahan & Krueger 1993, §4, eqs. 21–23, and their layered
//! generalisation: "the reflection from each layer, attenuated by the layers above it").
//!
//! Frame (pbrt): surface normal +z; `wi`, `wo` are unit vectors pointing *away* from the
//! surface; the stack lies below z = 0, the ambient medium of index `n_above` above it. For the
//! BRDF both directions have z > 0; for the BTDF `wo` has z < 0 and lies in the medium of index
//! `n_below`.
//!
//! Media are numbered m = 0 (above), 1…L (the layers), L+1 (below); interface k separates
//! medium k and k+1. All interfaces are parallel, so a path keeps its Snell invariant, the
//! horizontal vector k = n (wx, wy): inside medium m the propagation direction is
//! (k/n_m, ±μ_m) with μ_m = √(1 − |k|²/n_m²); |k| ≥ n_m is total internal reflection (the
//! path, hence its first-order contribution, is zero).
//!
//! Single scattering in layer j (medium m = j+1), derivation (H&K §4 with radiance bookkeeping):
//! the incident irradiance E (outside) reaches the layer's top as a flux E·Π T_k·Π e^{−τ_k/μ_k}
//! (interface transmittances T = 1 − R_Fresnel and attenuation of the layers above); inside,
//! [`super::layer::layer_reflection`] gives the radiance leaving the layer per unit of that flux;
//! on the way out the radiance is multiplied by the transmittances and attenuations again and
//! by (n_out/n_m)² (radiance/n² is invariant across a smooth interface: the solid-angle
//! compression n_a² cos θa dωa = n_b² cos θb dωb). Hence, with f expressed per *outside*
//! solid angle,
//!
//!   f_r = Σ_j (n_0/n_m)² T_in T_out A_in A_out α_m p_m(cos θ) (1 − e^{−τ_m(1/μi + 1/μo)})/(μi + μo),
//!   f_t = Σ_j (n_{L+1}/n_m)² T_in T_out A_in A_out α_m p_m(cos θ) (e^{−τ_m/μi} − e^{−τ_m/μo})/(μi μo (1/μo − 1/μi)),
//!
//! where θ is the angle between the refracted incident and exit propagation directions in the
//! layer. This f_r is reciprocal, and ∫ f_r cos θo dωo equals the power-counting integral over
//! the inside hemisphere T_in ∫ p T_out α μo/(μi + μo) dω' (checked in tests); f_t obeys the
//! generalised reciprocity f_t(wi → wo)/n_o² = f_t(wo → wi)/n_i². Restatements of H&K eq. 21
//! without the (n_0/n_m)² factor (e.g. the seed's eq. 1.25, which also has cos θi cos θr where
//! cos θi + cos θr belongs, and outside instead of refracted cosines) overestimate the reflected
//! flux by (n_m/n_0)² for n_m ≠ n_0.
//! No interface reflections are included (paths reflected at an interface are of higher order
//! in the Monte Carlo sense; they are the MC tallies' `*_order[1] − *_single_direct`).

use super::layer::{layer_attenuation, layer_reflection, layer_transmission};
use crate::error::{Error, Result};
use crate::medium::Stack;

/// Largest allowed deviation of |w| from 1.
pub const UNIT_TOLERANCE: f64 = 1e-6;

/// Validate a direction: finite, unit within [`UNIT_TOLERANCE`], and `z > 0` (`upper`) or
/// `z < 0` (lower hemisphere). Returns it normalised. `field` names it in the error.
pub fn check_direction(field: &str, w: [f64; 3], upper: bool) -> Result<[f64; 3]> {
    let norm = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
    if !(norm.is_finite() && (norm - 1.0).abs() <= UNIT_TOLERANCE) {
        return Err(Error::param(format!("|{field}|"), norm, "1 within 1e-6 (a unit vector)"));
    }
    let z = w[2] / norm;
    if upper && !(z > 0.0) {
        return Err(Error::param(
            format!("{field}.z"),
            w[2],
            "> 0 (above the surface, pointing away from it; normal +z)",
        ));
    }
    if !upper && !(z < 0.0) {
        return Err(Error::param(
            format!("{field}.z"),
            w[2],
            "< 0 (below the stack, pointing away from it; normal +z)",
        ));
    }
    Ok([w[0] / norm, w[1] / norm, z])
}

/// Refractive indices of the media 0…L+1 (above, layers, below).
fn media(stack: &Stack) -> Vec<f64> {
    let mut n = Vec::with_capacity(stack.layers.len() + 2);
    n.push(stack.n_above);
    n.extend(stack.layers.iter().map(|l| l.n));
    n.push(stack.n_below);
    n
}

/// Cosine of a path with Snell invariant |k|² = `k2` in a medium of index `n`; `None` on TIR.
#[inline]
fn cos_in(k2: f64, n: f64) -> Option<f64> {
    let s2 = k2 / (n * n);
    if s2 >= 1.0 {
        None
    } else {
        Some((1.0 - s2).sqrt())
    }
}

/// Interface transmittance 1 − R (unpolarised Fresnel, Born & Wolf eqs. 1.5.21), from the
/// cosines on both sides (`mu_a` in `n_a`, `mu_b` in `n_b`, related by Snell). Symmetric in
/// (a ↔ b) to the last bit, so the BRDF is exactly reciprocal; equals
/// `1 − fr_dielectric(mu_a, n_a, n_b)` (tested).
#[inline]
fn t12(mu_a: f64, mu_b: f64, n_a: f64, n_b: f64) -> f64 {
    if n_a == n_b {
        return 1.0;
    }
    let rs = (n_a * mu_a - n_b * mu_b) / (n_a * mu_a + n_b * mu_b);
    let rp = (n_b * mu_a - n_a * mu_b) / (n_b * mu_a + n_a * mu_b);
    1.0 - 0.5 * (rs * rs + rp * rp)
}

/// Cosines of a path with invariant `k2` in every medium 0…L+1 (`None` where it cannot exist).
fn cosines(n: &[f64], k2: f64) -> Vec<Option<f64>> {
    n.iter().map(|&nm| cos_in(k2, nm)).collect()
}

/// Through-factors of a path entering from medium 0 and going down: `down[m]` (m = 1…L+1) is
/// the product of interface transmittances 0…m−1 and attenuations of the layers 1…m−1, i.e.
/// the fraction of flux reaching the top of medium m unscattered (0 on TIR).
fn through_from_top(stack: &Stack, n: &[f64], mu: &[Option<f64>]) -> Vec<f64> {
    let lm = n.len() - 1;
    let mut out = vec![0.0; lm + 1];
    let mut acc = 1.0;
    out[0] = 1.0;
    for m in 1..=lm {
        let (Some(mu_prev), Some(mu_m)) = (mu[m - 1], mu[m]) else {
            break;
        };
        if m >= 2 {
            acc *= layer_attenuation(&stack.layers[m - 2], mu_prev);
        }
        acc *= t12(mu_prev, mu_m, n[m - 1], n[m]);
        out[m] = acc;
    }
    out
}

/// Through-factors of a path leaving through the bottom: `up[m]` (m = 0…L) is the fraction of
/// flux that, starting at the bottom of medium m going down, crosses interfaces m…L and the
/// layers m+1…L unscattered and reaches medium L+1 (0 on TIR).
fn through_to_bottom(stack: &Stack, n: &[f64], mu: &[Option<f64>]) -> Vec<f64> {
    let lm = n.len() - 1;
    let mut out = vec![0.0; lm + 1];
    out[lm] = 1.0;
    let mut acc = 1.0;
    for m in (0..lm).rev() {
        let (Some(mu_m), Some(mu_next)) = (mu[m], mu[m + 1]) else {
            break;
        };
        if m < lm - 1 {
            acc *= layer_attenuation(&stack.layers[m], mu_next);
        }
        acc *= t12(mu_m, mu_next, n[m], n[m + 1]);
        out[m] = acc;
    }
    out
}

/// Contribution of each layer to the first-order BRDF (sr⁻¹), for validated `wi`, `wo`.
fn brdf_terms(stack: &Stack, wi: [f64; 3], wo: [f64; 3]) -> Vec<f64> {
    let n = media(stack);
    let n0 = n[0];
    let ki = [-n0 * wi[0], -n0 * wi[1]]; // incident propagation direction is −wi
    let ko = [n0 * wo[0], n0 * wo[1]];
    let mu_i = cosines(&n, ki[0] * ki[0] + ki[1] * ki[1]);
    let mu_o = cosines(&n, ko[0] * ko[0] + ko[1] * ko[1]);
    let (down_i, down_o) = (through_from_top(stack, &n, &mu_i), through_from_top(stack, &n, &mu_o));
    let mut terms = vec![0.0; stack.layers.len()];
    for (j, layer) in stack.layers.iter().enumerate() {
        let m = j + 1;
        let w = down_i[m] * down_o[m];
        if w == 0.0 || layer.mus == 0.0 {
            continue;
        }
        let (Some(ci), Some(co)) = (mu_i[m], mu_o[m]) else {
            continue;
        };
        let nm = n[m];
        let d_in = [ki[0] / nm, ki[1] / nm, -ci];
        let d_out = [ko[0] / nm, ko[1] / nm, co];
        let eta2 = (n0 / nm) * (n0 / nm);
        terms[j] = w * eta2 * layer_reflection(layer, d_in, d_out);
    }
    terms
}

/// Contribution of each layer to the first-order BTDF (sr⁻¹), for validated `wi` (z > 0) and
/// `wo` (z < 0).
fn btdf_terms(stack: &Stack, wi: [f64; 3], wo: [f64; 3]) -> Vec<f64> {
    let mut terms = vec![0.0; stack.layers.len()];
    if stack.is_semi_infinite() {
        return terms;
    }
    let n = media(stack);
    let (n0, nb) = (n[0], n[n.len() - 1]);
    let ki = [-n0 * wi[0], -n0 * wi[1]];
    let ko = [nb * wo[0], nb * wo[1]]; // exit propagation direction is wo (downwards)
    let mu_i = cosines(&n, ki[0] * ki[0] + ki[1] * ki[1]);
    let mu_o = cosines(&n, ko[0] * ko[0] + ko[1] * ko[1]);
    let down_i = through_from_top(stack, &n, &mu_i);
    let up_o = through_to_bottom(stack, &n, &mu_o);
    for (j, layer) in stack.layers.iter().enumerate() {
        let m = j + 1;
        let w = down_i[m] * up_o[m];
        if w == 0.0 || layer.mus == 0.0 {
            continue;
        }
        let (Some(ci), Some(co)) = (mu_i[m], mu_o[m]) else {
            continue;
        };
        let nm = n[m];
        let d_in = [ki[0] / nm, ki[1] / nm, -ci];
        let d_out = [ko[0] / nm, ko[1] / nm, -co];
        let eta2 = (nb / nm) * (nb / nm);
        terms[j] = w * eta2 * layer_transmission(layer, d_in, d_out);
    }
    terms
}

/// First-order (single-scattering) BRDF of the stack, sr⁻¹, per outside solid angle:
/// f_r(wi, wo) = dL_o/(L_i cos θi dωi). `wi`, `wo` unit vectors with z > 0 (pbrt frame).
/// See the module documentation for the formula and its sources.
pub fn single_scattering_brdf(stack: &Stack, wi: [f64; 3], wo: [f64; 3]) -> Result<f64> {
    let wi = check_direction("wi", wi, true)?;
    let wo = check_direction("wo", wo, true)?;
    Ok(brdf_terms(stack, wi, wo).iter().sum())
}

/// Per-layer contributions to [`single_scattering_brdf`] (sr⁻¹; they sum to it).
pub fn single_scattering_brdf_layers(stack: &Stack, wi: [f64; 3], wo: [f64; 3]) -> Result<Vec<f64>> {
    let wi = check_direction("wi", wi, true)?;
    let wo = check_direction("wo", wo, true)?;
    Ok(brdf_terms(stack, wi, wo))
}

/// First-order (single-scattering) BTDF of the stack, sr⁻¹, per solid angle in the medium
/// below: f_t(wi, wo) = dL_o/(L_i cos θi dωi). `wi` has z > 0, `wo` z < 0 (pbrt frame).
/// Zero for a semi-infinite stack.
pub fn single_scattering_btdf(stack: &Stack, wi: [f64; 3], wo: [f64; 3]) -> Result<f64> {
    let wi = check_direction("wi", wi, true)?;
    let wo = check_direction("wo", wo, false)?;
    Ok(btdf_terms(stack, wi, wo).iter().sum())
}

/// Per-layer contributions to [`single_scattering_btdf`] (sr⁻¹; they sum to it).
pub fn single_scattering_btdf_layers(stack: &Stack, wi: [f64; 3], wo: [f64; 3]) -> Result<Vec<f64>> {
    let wi = check_direction("wi", wi, true)?;
    let wo = check_direction("wo", wo, false)?;
    Ok(btdf_terms(stack, wi, wo))
}

/// Unscattered (order-0) directional transmittance of the stack for light arriving from
/// direction `wi` (z > 0): Π_k T_k · Π_layers e^{−τ/μ} (H&K 1993 §4; Beer–Lambert along the
/// refracted path, Fresnel transmittance at every interface, no interface reflections), and the
/// exit direction below the stack (Snell: k = −n_0 (wi_x, wi_y), z < 0). Zero (and exit
/// direction `None`) on total internal reflection or for a semi-infinite stack. Unit: 1.
pub fn unscattered_transmittance(stack: &Stack, wi: [f64; 3]) -> Result<(f64, Option<[f64; 3]>)> {
    let wi = check_direction("wi", wi, true)?;
    if stack.is_semi_infinite() {
        return Ok((0.0, None));
    }
    let n = media(stack);
    let (n0, nb) = (n[0], n[n.len() - 1]);
    let ki = [-n0 * wi[0], -n0 * wi[1]];
    let mu = cosines(&n, ki[0] * ki[0] + ki[1] * ki[1]);
    let down = through_from_top(stack, &n, &mu);
    let t = down[n.len() - 1];
    match mu[n.len() - 1] {
        Some(mb) if t > 0.0 => Ok((t, Some([ki[0] / nb, ki[1] / nb, -mb]))),
        _ => Ok((0.0, None)),
    }
}

/// Largest sine of the exit angle (in the exit medium of index `n_exit`) for which a path from
/// layer j can leave: min(1, min over the traversed layers' indices / n_exit). Used by the
/// hemispherical integrals to put the TIR cut-off at an end of the integration range.
pub(crate) fn exit_sine_limit(stack: &Stack, j: usize, reflection: bool) -> f64 {
    let (n_exit, range) = if reflection { (stack.n_above, 0..j + 1) } else { (stack.n_below, j..stack.layers.len()) };
    let nmin = stack.layers[range].iter().map(|l| l.n).fold(f64::INFINITY, f64::min);
    (nmin / n_exit).min(1.0)
}

/// Per-layer first-order BRDF or BTDF for already validated directions (for quadrature).
pub(crate) fn terms(stack: &Stack, wi: [f64; 3], wo: [f64; 3], reflection: bool) -> Vec<f64> {
    if reflection {
        brdf_terms(stack, wi, wo)
    } else {
        btdf_terms(stack, wi, wo)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optics::{cos_transmitted, fr_dielectric};

    #[test]
    fn interface_transmittance_matches_fresnel() {
        for &(na, nb) in &[(1.0, 1.5), (1.5, 1.0), (1.33, 1.4)] {
            for k in 0..50 {
                let ca = 0.02 + 0.98 * k as f64 / 49.0;
                if let Some(cb) = cos_transmitted(ca, na, nb) {
                    let t = t12(ca, cb, na, nb);
                    assert!((t - (1.0 - fr_dielectric(ca, na, nb))).abs() < 1e-14);
                    assert_eq!(t, t12(cb, ca, nb, na));
                }
            }
        }
    }
}
