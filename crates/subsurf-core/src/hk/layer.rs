//! Single scattering inside one homogeneous layer, in terms of the directions *inside* it.
//!
//! Hanrahan & Krueger, "Reflection from layered surfaces due to subsurface scattering",
//! SIGGRAPH 1993, §4 ("first-order approximation"): a collimated beam refracted into a slab of
//! optical thickness τ = σt d travels at cosine μi (w.r.t. the normal), scatters once at depth z
//! with probability σs dz/μi into p(cos θ) dω, and leaves along a path of cosine μo. Integrating
//! over depth (H&K eqs. 21 and 23 for reflection and transmission; the seed's eqs. 1.24–1.25 in
//! their corrected form) gives, per unit incident flux crossing the layer's top per unit area,
//! the radiance leaving the layer (inside it) as
//!
//! * reflection (leaving through the top):
//!   L/E = α p(cos θ) · (1 − e^{−τ(1/μi + 1/μo)}) / (μi + μo),
//! * transmission (leaving through the bottom):
//!   L/E = α p(cos θ) · (e^{−τ/μi} − e^{−τ/μo}) / (μi μo (1/μo − 1/μi)),
//!
//! with α = σs/σt. The depth integrals are [`reflection_depth_factor`] and
//! [`transmission_depth_factor`]. Interfaces (Fresnel and the η² radiance factor) are applied by
//! the stack ([`super::stack`]).

use crate::medium::Layer;

/// (1 − e^{−x})/x for x ≥ 0, accurate for small x (→ 1 as x → 0) and for x = ∞ (→ 0).
#[inline]
pub fn one_minus_exp_over_x(x: f64) -> f64 {
    if x == 0.0 {
        1.0
    } else if x.is_infinite() {
        0.0
    } else {
        -(-x).exp_m1() / x
    }
}

/// Depth integral for single-scattered *reflection* (H&K 1993 eq. 21):
/// (1/(μi μo)) ∫₀^τ e^{−t(1/μi + 1/μo)} dt = (1 − e^{−τ(1/μi + 1/μo)}) / (μi + μo).
///
/// `tau` = σt d (dimensionless, may be ∞ for a semi-infinite layer), `mu_i`, `mu_o` the
/// cosines (> 0) of the refracted incident and exit paths inside the layer. Unit: 1.
/// Thin layer: ≈ τ/(μi μo); semi-infinite: 1/(μi + μo).
#[inline]
pub fn reflection_depth_factor(tau: f64, mu_i: f64, mu_o: f64) -> f64 {
    if tau.is_infinite() {
        return 1.0 / (mu_i + mu_o);
    }
    // x = τ (μi + μo)/(μi μo); (1 − e^{−x})/(μi + μo) = τ/(μi μo) · (1 − e^{−x})/x.
    let x = tau * (1.0 / mu_i + 1.0 / mu_o);
    tau / (mu_i * mu_o) * one_minus_exp_over_x(x)
}

/// Depth integral for single-scattered *transmission* (H&K 1993 eq. 23):
/// (1/(μi μo)) ∫₀^τ e^{−t/μi} e^{−(τ − t)/μo} dt = (e^{−τ/μi} − e^{−τ/μo}) / (μi μo (1/μo − 1/μi)).
///
/// Evaluated stably as e^{−τ·min(a, b)} · τ/(μi μo) · (1 − e^{−x})/x with a = 1/μi, b = 1/μo,
/// x = τ|a − b|, which is symmetric in (μi, μo) and has the equal-cosine limit τ e^{−τ/μ}/μ².
/// Zero for a semi-infinite layer. Unit: 1.
#[inline]
pub fn transmission_depth_factor(tau: f64, mu_i: f64, mu_o: f64) -> f64 {
    if tau.is_infinite() || tau == 0.0 {
        return 0.0;
    }
    let (a, b) = (1.0 / mu_i, 1.0 / mu_o);
    let (lo, hi) = if a < b { (a, b) } else { (b, a) };
    (-tau * lo).exp() * tau / (mu_i * mu_o) * one_minus_exp_over_x(tau * (hi - lo))
}

/// Cosine of the angle between two unit vectors, clamped to [−1, 1].
#[inline]
pub fn cos_between(a: [f64; 3], b: [f64; 3]) -> f64 {
    (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]).clamp(-1.0, 1.0)
}

/// Single-scattered reflection of one layer in its own medium (no interfaces): the radiance
/// leaving through the top per unit incident flux through the top, α p(d_in·d_out) ×
/// [`reflection_depth_factor`]. `d_in` is the propagation direction of the incident light inside
/// the layer (pointing down, z < 0, pbrt frame with normal +z), `d_out` that of the scattered
/// light (pointing up, z > 0); both unit vectors. Unit: sr⁻¹. H&K 1993 eq. 21 without T12 T21.
#[inline]
pub fn layer_reflection(layer: &Layer, d_in: [f64; 3], d_out: [f64; 3]) -> f64 {
    if layer.mus == 0.0 {
        return 0.0;
    }
    let p = layer.phase.eval(cos_between(d_in, d_out));
    layer.albedo() * p * reflection_depth_factor(layer.optical_thickness(), d_in[2].abs(), d_out[2].abs())
}

/// Single-scattered transmission of one layer in its own medium: the radiance leaving through
/// the bottom per unit incident flux through the top, α p(d_in·d_out) ×
/// [`transmission_depth_factor`]. Both directions point down (z < 0). Unit: sr⁻¹.
/// H&K 1993 eq. 23 without the interface transmittances.
#[inline]
pub fn layer_transmission(layer: &Layer, d_in: [f64; 3], d_out: [f64; 3]) -> f64 {
    if layer.mus == 0.0 {
        return 0.0;
    }
    let p = layer.phase.eval(cos_between(d_in, d_out));
    layer.albedo() * p * transmission_depth_factor(layer.optical_thickness(), d_in[2].abs(), d_out[2].abs())
}

/// Unscattered (order-0) attenuation of a path crossing the whole layer at cosine `mu`:
/// e^{−τ/μ} (Beer–Lambert; zero for a semi-infinite layer unless it does not interact).
#[inline]
pub fn layer_attenuation(layer: &Layer, mu: f64) -> f64 {
    let tau = layer.optical_thickness();
    if tau == 0.0 {
        1.0
    } else {
        (-tau / mu).exp()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Direct numerical depth integration (composite Simpson) of the defining integrals.
    fn simpson(f: impl Fn(f64) -> f64, a: f64, b: f64, n: usize) -> f64 {
        let h = (b - a) / n as f64;
        let mut s = f(a) + f(b);
        for k in 1..n {
            s += f(a + k as f64 * h) * if k % 2 == 1 { 4.0 } else { 2.0 };
        }
        s * h / 3.0
    }

    #[test]
    fn depth_factors_match_direct_integration() {
        for &(tau, mi, mo) in &[(0.3, 0.9, 0.4), (2.0, 0.2, 0.7), (1.0, 0.5, 0.5), (5.0, 1.0, 0.999_999)] {
            let r = simpson(|t| (-t / mi - t / mo).exp(), 0.0, tau, 2000) / (mi * mo);
            assert!((reflection_depth_factor(tau, mi, mo) - r).abs() < 1e-10 * r, "{tau} {mi} {mo}");
            let t = simpson(|t| (-t / mi - (tau - t) / mo).exp(), 0.0, tau, 2000) / (mi * mo);
            assert!((transmission_depth_factor(tau, mi, mo) - t).abs() < 1e-10 * t, "{tau} {mi} {mo}");
        }
    }

    #[test]
    fn equal_cosine_limit_is_continuous() {
        let (tau, mu) = (1.7f64, 0.6f64);
        let exact = tau * (-tau / mu).exp() / (mu * mu);
        assert!((transmission_depth_factor(tau, mu, mu) - exact).abs() < 1e-15 * exact);
        // near-equal cosines: the naive formula is still accurate to ~1e-9 at eps = 1e-6, and the
        // stable one must agree with it there and with the limit at eps = 1e-14.
        let naive = |mi: f64, mo: f64| ((-tau / mi).exp() - (-tau / mo).exp()) / (mi * mo * (1.0 / mo - 1.0 / mi));
        let v = transmission_depth_factor(tau, mu, mu + 1e-6);
        assert!((v - naive(mu, mu + 1e-6)).abs() < 1e-8 * exact);
        assert!((transmission_depth_factor(tau, mu, mu + 1e-14) - exact).abs() < 1e-12 * exact);
        // symmetric
        assert_eq!(transmission_depth_factor(tau, 0.3, 0.8), transmission_depth_factor(tau, 0.8, 0.3));
    }

    #[test]
    fn limits() {
        // semi-infinite and thin
        assert_eq!(reflection_depth_factor(f64::INFINITY, 0.3, 0.5), 1.0 / 0.8);
        assert_eq!(transmission_depth_factor(f64::INFINITY, 0.3, 0.5), 0.0);
        let tau = 1e-9;
        assert!((reflection_depth_factor(tau, 0.3, 0.5) / (tau / 0.15) - 1.0).abs() < 1e-8);
        assert!((transmission_depth_factor(tau, 0.3, 0.5) / (tau / 0.15) - 1.0).abs() < 1e-8);
        assert!((reflection_depth_factor(200.0, 0.3, 0.5) - 1.0 / 0.8).abs() < 1e-15);
    }
}
