//! Hanrahan–Krueger (1993) first-order (single-scattering) BRDF/BTDF of layered media.
//!
//! Reference: P. Hanrahan and W. Krueger, "Reflection from layered surfaces due to subsurface
//! scattering", SIGGRAPH 1993, §4 (eqs. 21–23). Modules:
//! - [`layer`]: the depth integrals and one layer's single scattering in its own medium;
//! - [`stack`]: the BRDF/BTDF of a stack (Fresnel, attenuation by the layers above/below,
//!   η² radiance factors) and its unscattered transmittance;
//! - [`albedo`]: hemispherical integrals (first-order reflectance and transmittance).

pub mod albedo;
pub mod layer;
pub mod stack;

pub use albedo::{gauss_legendre_01, single_scattering_reflectance, single_scattering_transmittance};
pub use layer::{
    layer_attenuation, layer_reflection, layer_transmission, reflection_depth_factor, transmission_depth_factor,
};
pub use stack::{
    check_direction, single_scattering_brdf, single_scattering_brdf_layers, single_scattering_btdf,
    single_scattering_btdf_layers, unscattered_transmittance, UNIT_TOLERANCE,
};

#[cfg(test)]
mod tests {
    use super::*;
    use crate::medium::{Layer, Stack};
    use crate::optics::fr_dielectric;
    use std::f64::consts::PI;

    fn dir(theta: f64, phi: f64, up: bool) -> [f64; 3] {
        let z = if up { theta.cos() } else { -theta.cos() };
        [theta.sin() * phi.cos(), theta.sin() * phi.sin(), z]
    }

    fn one(n: f64, mua: f64, mus: f64, g: f64, d: f64, n_above: f64, n_below: f64) -> Stack {
        Stack::new(vec![Layer::new(n, mua, mus, g, d).unwrap()], n_above, n_below).unwrap()
    }

    #[test]
    fn gauss_legendre_integrates_polynomials() {
        let (x, w) = gauss_legendre_01(8);
        for p in 0..16 {
            let s: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(p)).sum();
            assert!((s - 1.0 / (p as f64 + 1.0)).abs() < 1e-14, "p={p}");
        }
    }

    /// Semi-infinite, index-matched, isotropic, normal incidence:
    /// ρ₁ = (α/4π) 2π ∫₀¹ μ/(1 + μ) dμ = (α/2)(1 − ln 2).
    #[test]
    fn index_matched_semi_infinite_albedo_closed_form() {
        let s = one(1.0, 0.001, 0.999, 0.0, f64::INFINITY, 1.0, 1.0);
        let rho = single_scattering_reflectance(&s, [0.0, 0.0, 1.0], 64, 16).unwrap();
        let exact = 0.999 / 2.0 * (1.0 - 2f64.ln());
        assert!((rho - exact).abs() < 1e-12, "{rho} vs {exact}");
    }

    /// Power counting inside the layer (independent of the η² factor and the outside Jacobian):
    /// ρ₁ = T_in ∫_{inside H+} α p T_out μo'/(μi' + μo') dω'.
    #[test]
    fn mismatched_albedo_equals_inside_power_count() {
        let (n0, n1, g, alb) = (1.0, 1.45, 0.4, 0.9);
        let s = one(n1, 1.0 - alb, alb, g, f64::INFINITY, n0, 1.0);
        let th = 0.6f64;
        let wi = dir(th, 0.3, true);
        let rho = single_scattering_reflectance(&s, wi, 96, 96).unwrap();
        // inside integral: μ' ∈ (0, 1] (all directions with μ' > μ_c escape), φ' midpoint.
        let mi = crate::optics::cos_transmitted(th.cos(), n0, n1).unwrap();
        let t_in = 1.0 - fr_dielectric(th.cos(), n0, n1);
        let si = (1.0 - mi * mi).sqrt();
        let (x, w) = gauss_legendre_01(400);
        let mc = (1.0 - (n0 / n1) * (n0 / n1)).sqrt(); // critical cosine inside
        let phase = crate::optics::Phase::hg(g).unwrap();
        let nphi = 200;
        let mut acc = 0.0;
        for (&xk, &wk) in x.iter().zip(&w) {
            let mo = mc + (1.0 - mc) * xk;
            let so = (1.0 - mo * mo).sqrt();
            let t_out = 1.0 - fr_dielectric(mo, n1, n0);
            for l in 0..nphi {
                let dphi = (l as f64 + 0.5) * 2.0 * PI / nphi as f64;
                let cos = -si * so * dphi.cos() - mi * mo; // d_in=(si,0,-mi), d_out=(-so cos, .., mo)
                acc += wk * (1.0 - mc) * (2.0 * PI / nphi as f64) * alb * phase.eval(cos) * t_out * mo / (mi + mo);
            }
        }
        let power = t_in * acc;
        assert!((rho - power).abs() < 2e-6 * power, "{rho} vs {power}");
    }

    #[test]
    fn reciprocity_single_layer_and_stack() {
        let stacks = [
            one(1.0, 0.1, 3.0, 0.7, 0.4, 1.0, 1.0),
            one(1.4, 0.1, 3.0, 0.7, 0.4, 1.0, 1.2),
            Stack::new(
                vec![
                    Layer::new(1.3, 0.2, 5.0, 0.5, 0.2).unwrap(),
                    Layer::new(1.6, 0.05, 2.0, -0.3, 0.3).unwrap(),
                    Layer::new(1.1, 0.01, 8.0, 0.9, f64::INFINITY).unwrap(),
                ],
                1.2,
                1.0,
            )
            .unwrap(),
        ];
        let mut rng = crate::stats::SplitMix64::new(12345);
        let mut rnd = || rng.next_f64();
        for s in &stacks {
            for _ in 0..200 {
                let a = dir((rnd() * 0.999).acos(), 2.0 * PI * rnd(), true);
                let b = dir((rnd() * 0.999).acos(), 2.0 * PI * rnd(), true);
                let f1 = single_scattering_brdf(s, a, b).unwrap();
                let f2 = single_scattering_brdf(s, b, a).unwrap();
                assert!((f1 - f2).abs() <= 1e-12 * f1.abs().max(1e-300), "{f1} {f2}");
                // generalised reciprocity of the BTDF: f(a→c)/n_below² = f(−c→−a)/n_above²
                let c = dir((rnd() * 0.999).acos(), 2.0 * PI * rnd(), false);
                if !s.is_semi_infinite() {
                    let ft = single_scattering_btdf(s, a, c).unwrap();
                    let flipped = Stack::new(s.layers.iter().rev().cloned().collect(), s.n_below, s.n_above).unwrap();
                    let (cr, ar) = ([c[0], c[1], -c[2]], [a[0], a[1], -a[2]]);
                    let fr = single_scattering_btdf(&flipped, cr, ar).unwrap();
                    let (na2, nb2) = (s.n_above * s.n_above, s.n_below * s.n_below);
                    assert!((ft / nb2 - fr / na2).abs() <= 1e-12 * (ft / nb2).max(1e-300), "{ft} {fr}");
                }
            }
        }
    }

    #[test]
    fn two_identical_layers_equal_one_thick_layer() {
        for (n, n0, nb) in [(1.0, 1.0, 1.0), (1.4, 1.0, 1.5)] {
            let l = |d| Layer::new(n, 0.3, 4.0, 0.6, d).unwrap();
            let single = Stack::new(vec![l(0.5)], n0, nb).unwrap();
            let double = Stack::new(vec![l(0.2), l(0.3)], n0, nb).unwrap();
            for (ti, to, dp) in [(0.1, 0.5, 0.0), (0.7, 0.2, 2.0), (1.2, 1.0, 3.1)] {
                let (wi, wo) = (dir(ti, 0.0, true), dir(to, dp, true));
                let a = single_scattering_brdf(&single, wi, wo).unwrap();
                let b = single_scattering_brdf(&double, wi, wo).unwrap();
                assert!((a - b).abs() < 1e-13 * a, "{a} {b}");
                let wt = dir(to, dp, false);
                let a = single_scattering_btdf(&single, wi, wt).unwrap();
                let b = single_scattering_btdf(&double, wi, wt).unwrap();
                assert!((a - b).abs() < 1e-13 * a, "{a} {b}");
                let a = unscattered_transmittance(&single, wi).unwrap().0;
                let b = unscattered_transmittance(&double, wi).unwrap().0;
                assert!((a - b).abs() < 1e-14, "{a} {b}");
            }
        }
    }

    #[test]
    fn thick_layer_tends_to_semi_infinite_and_no_scattering_gives_zero() {
        let thick = one(1.3, 0.5, 5.0, 0.2, 20.0, 1.0, 1.0);
        let semi = one(1.3, 0.5, 5.0, 0.2, f64::INFINITY, 1.0, 1.0);
        let (wi, wo) = (dir(0.4, 0.0, true), dir(0.9, 1.0, true));
        let a = single_scattering_brdf(&thick, wi, wo).unwrap();
        let b = single_scattering_brdf(&semi, wi, wo).unwrap();
        assert!((a - b).abs() < 1e-14 * b);
        assert_eq!(single_scattering_btdf(&semi, wi, dir(0.3, 0.0, false)).unwrap(), 0.0);
        let clear = one(1.3, 0.5, 0.0, 0.2, 1.0, 1.0, 1.0);
        assert_eq!(single_scattering_brdf(&clear, wi, wo).unwrap(), 0.0);
        assert_eq!(single_scattering_btdf(&clear, wi, dir(0.3, 0.0, false)).unwrap(), 0.0);
    }

    #[test]
    fn unscattered_transmittance_closed_form_and_tir() {
        let s = one(1.5, 0.2, 1.0, 0.0, 0.7, 1.0, 1.33);
        let th = 0.5f64;
        let (t, dir_out) = unscattered_transmittance(&s, dir(th, 0.0, true)).unwrap();
        let mu1 = crate::optics::cos_transmitted(th.cos(), 1.0, 1.5).unwrap();
        let expect = (1.0 - fr_dielectric(th.cos(), 1.0, 1.5))
            * (1.0 - fr_dielectric(mu1, 1.5, 1.33))
            * (-1.2 * 0.7 / mu1).exp();
        assert!((t - expect).abs() < 1e-15);
        let d = dir_out.unwrap();
        assert!((1.33 * (d[0] * d[0] + d[1] * d[1]).sqrt() - th.sin()).abs() < 1e-14 && d[0] < 0.0 && d[2] < 0.0);
        // glass above a lower-index layer: TIR past the critical angle
        let s = one(1.0, 0.0, 1.0, 0.0, 1.0, 1.5, 1.5);
        let th_c = (1.0f64 / 1.5).asin();
        assert_eq!(unscattered_transmittance(&s, dir(th_c + 0.01, 0.0, true)).unwrap().0, 0.0);
        assert!(unscattered_transmittance(&s, dir(th_c - 0.01, 0.0, true)).unwrap().0 > 0.0);
        assert_eq!(single_scattering_brdf(&s, dir(th_c + 0.01, 0.0, true), dir(0.1, 0.0, true)).unwrap(), 0.0);
    }

    #[test]
    fn energy_bound() {
        for (n, g, d) in [(1.0, 0.0, 0.3), (1.5, 0.8, 1.0), (1.33, -0.5, 0.05)] {
            let s = one(n, 0.0, 3.0, g, d, 1.0, 1.0);
            for th in [0.0, 0.6, 1.3] {
                let wi = dir(th, 0.0, true);
                let r = single_scattering_reflectance(&s, wi, 64, 64).unwrap();
                let t = single_scattering_transmittance(&s, wi, 64, 64).unwrap();
                let t0 = unscattered_transmittance(&s, wi).unwrap().0;
                assert!(r > 0.0 && t > 0.0 && r + t + t0 <= 1.0, "{r} {t} {t0}");
            }
        }
    }

    #[test]
    fn directions_are_validated() {
        let s = one(1.3, 0.1, 1.0, 0.0, 1.0, 1.0, 1.0);
        let e = single_scattering_brdf(&s, [0.0, 0.0, 1.1], [0.0, 0.0, 1.0]).unwrap_err().to_string();
        assert!(e.starts_with("|wi| = 1.1"), "{e}");
        let e = single_scattering_brdf(&s, [0.0, 0.0, 1.0], [0.0, 0.0, -1.0]).unwrap_err().to_string();
        assert!(e.starts_with("wo.z = -1"), "{e}");
        let e = single_scattering_btdf(&s, [0.0, 0.0, 1.0], [0.0, 0.0, 1.0]).unwrap_err().to_string();
        assert!(e.starts_with("wo.z = 1"), "{e}");
        assert!(single_scattering_brdf(&s, [f64::NAN, 0.0, 1.0], [0.0, 0.0, 1.0]).is_err());
        assert!(single_scattering_reflectance(&s, [0.0, 0.0, 1.0], 2, 8).is_err());
    }
}
