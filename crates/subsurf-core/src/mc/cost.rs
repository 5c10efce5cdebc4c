//! The up-front cost of a run: an estimate of the scattering events per photon history, so that
//! a stack whose histories would be endless (or practically so) is refused with an explanation
//! instead of running for hours with nothing to show.
//!
//! For a layer with albedo a = σs/σt, mean cosine g and optical thickness τ = σt d:
//! - *absorption bound*: with implicit capture the weight after k interactions is aᵏ; Russian
//!   roulette starts below [`ROULETTE_THRESHOLD`] and a survivor (probability 1/m) needs another
//!   ln m/(−ln a) interactions, so a history that never leaves lasts on average
//!   K_abs = (ln(1/threshold) + ln m/(m − 1))/(−ln a) ≈ 9.5 σt/σa interactions (∞ for σa = 0);
//! - *escape bound* of a finite layer: a diffusing photon leaves a slab of transport optical
//!   thickness τ' = (σa + σs(1 − g)) d after ~τ'² transport steps of 1/(1 − a g)
//!   interactions each: K_geom = τ + τ'²/(1 − a g);
//! - a semi-infinite layer: a random walk in a half-space returns to its boundary with
//!   probability 1 but after an infinite mean time; absorption truncates it at K_abs
//!   interactions, and the chance of not having returned after n steps decays as n^(−1/2)
//!   (Sparre Andersen), so K_semi = 1 + 2√(K_abs/(1 − a g)).
//!
//! The estimate is Σ over layers of min(K_abs, K_geom) (finite) or min(K_abs, K_semi)
//! (semi-infinite): the order of magnitude, not a prediction (e.g. 1.9·10³ for σa = 0.001,
//! σs = 100 mm⁻¹, g = 0, n = 1.4 in air, semi-infinite, where 5.1·10³ are measured: internal
//! reflection at the surface lengthens the walk). A semi-infinite scattering layer with
//! σa = 0 is refused outright (its histories have no finite mean length; it reflects all light
//! that is not specularly reflected, R_d = 1 − R_sp), and so is any stack whose estimate exceeds
//! [`MAX_EVENTS_PER_PHOTON`].

use super::config::{ROULETTE_M, ROULETTE_THRESHOLD};
use crate::error::{fmt_value, Error, Result};
use crate::medium::{Layer, Stack};

/// Largest estimated number of scattering events per photon a run accepts (≈ 30 s of one core
/// per photon at 3·10⁷ events/s).
pub const MAX_EVENTS_PER_PHOTON: f64 = 1e9;

/// Estimated interactions of a history confined to `l` (`semi_infinite`: no lower face).
fn layer_events(l: &Layer, semi_infinite: bool) -> f64 {
    let st = l.sigma_t();
    if st == 0.0 {
        return 0.0;
    }
    let a = l.mus / st;
    let minus_ln_a = -(-l.mua / st).ln_1p();
    let per_history = (1.0 / ROULETTE_THRESHOLD).ln() + ROULETTE_M.ln() / (ROULETTE_M - 1.0);
    let k_abs = (per_history / minus_ln_a).max(1.0); // ∞ for σa = 0
    let persistence = 1.0 - a * l.g(); // > 0 since |g| < 1
    let k_escape = if semi_infinite {
        1.0 + 2.0 * (k_abs / persistence).sqrt()
    } else {
        let tau = st * l.thickness;
        let tau_tr = (l.mua + l.mus * (1.0 - l.g())) * l.thickness;
        tau + tau_tr * tau_tr / persistence
    };
    k_abs.min(k_escape)
}

/// The estimated scattering events per photon of `stack` (see the module docs); `∞` when a
/// semi-infinite layer scatters without absorbing.
pub fn expected_events(stack: &Stack) -> f64 {
    let last = stack.layers.len().saturating_sub(1);
    stack.layers.iter().enumerate().map(|(i, l)| layer_events(l, i == last && l.thickness.is_infinite())).sum()
}

/// Refuse a stack whose photon histories would be endless or longer than
/// [`MAX_EVENTS_PER_PHOTON`] (naming the layer and what to change); returns the estimate.
pub fn check(stack: &Stack) -> Result<f64> {
    let last = stack.layers.len().saturating_sub(1);
    if let Some(l) = stack.layers.get(last) {
        if l.thickness.is_infinite() && l.mua == 0.0 && l.mus > 0.0 {
            return Err(Error::param(
                format!("layers[{last}].mua"),
                0.0,
                "> 0 in a semi-infinite scattering layer: without absorption its photon histories have no finite \
                 mean length (such a medium reflects all light that enters it: diffuse reflectance = 1 - specular \
                 reflectance); give mua > 0 (a weakly absorbing medium is fine) or a finite thickness",
            ));
        }
    }
    let e = expected_events(stack);
    if !(e <= MAX_EVENTS_PER_PHOTON) {
        let (worst, l) = stack
            .layers
            .iter()
            .enumerate()
            .max_by(|a, b| {
                layer_events(a.1, a.0 == last && a.1.thickness.is_infinite())
                    .total_cmp(&layer_events(b.1, b.0 == last && b.1.thickness.is_infinite()))
            })
            .expect("a stack has layers");
        return Err(Error::Invalid(format!(
            "layers[{worst}]: each photon history would take about {e:.1e} scattering events (more than \
             {MAX_EVENTS_PER_PHOTON:.0e}): mua = {}, mus = {}, thickness = {} mm absorb too little for so many \
             mean free paths; give it more absorption or make it thinner",
            fmt_value(l.mua),
            fmt_value(l.mus),
            fmt_value(l.thickness),
        )));
    }
    Ok(e)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stack(l: Layer) -> Stack {
        Stack::new(vec![l], 1.0, 1.0).unwrap()
    }

    #[test]
    fn estimates_and_refusals() {
        let heavy = stack(Layer::new(1.4, 0.001, 100.0, 0.0, f64::INFINITY).unwrap());
        let e = check(&heavy).unwrap();
        assert!((1e3..3e3).contains(&e), "{e}");
        let glass = stack(Layer::new(1.5, 0.0, 0.0, 0.0, 1.0).unwrap());
        assert_eq!(check(&glass).unwrap(), 0.0);
        let e = check(&stack(Layer::new(1.0, 1.0, 9.0, 0.75, 0.2).unwrap())).unwrap();
        assert!(e > 1.0 && e < 10.0, "{e}");
        // non-absorbing semi-infinite: refused, naming the field
        let white = stack(Layer::new(1.4, 0.0, 10.0, 0.9, f64::INFINITY).unwrap());
        let msg = check(&white).unwrap_err().to_string();
        assert!(msg.starts_with("layers[0].mua = 0.0 is out of range") && msg.contains("1 - specular"), "{msg}");
        // a thick non-absorbing slab is fine up to ~1e9 events, then refused
        assert!(check(&stack(Layer::new(1.0, 0.0, 100.0, 0.0, 10.0).unwrap())).is_ok());
        let msg = check(&stack(Layer::new(1.0, 0.0, 1e4, 0.0, 100.0).unwrap())).unwrap_err().to_string();
        assert!(
            msg.starts_with("layers[0]: each photon history would take about 1.0e12 scattering events (more than 1e9)"),
            "{msg}"
        );
        // barely absorbing semi-infinite: refused; weakly absorbing: fine
        assert!(check(&stack(Layer::new(1.0, 1e-300, 1.0, 0.0, f64::INFINITY).unwrap())).is_err());
        assert!(check(&stack(Layer::new(1.0, 1e-8, 1.0, 0.9, f64::INFINITY).unwrap())).is_ok());
    }
}
