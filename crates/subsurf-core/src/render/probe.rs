//! `probe`: the entry point x_i is importance-sampled from the profile with probe rays, as in
//! pbrt-v4 (`TabulatedBSSRDF::Sample`/`PDF`, §11.4 of Pharr, Jakob & Humphreys 2023 / pbrt-v3
//! §15.4.1; King, Kulla, Conty & Fajardo 2013, "BSSRDF importance sampling").
//!
//! At x_o: pick a projection axis (the normal with probability ½, each tangent with ¼) and a
//! channel c (uniform over channels with a non-zero profile); sample a radius r ~ pdf_c and an
//! angle φ in the plane perpendicular to the axis; cast the probe segment through that point
//! along the axis, clipped to the sphere of radius R (the largest channel's
//! `radius_for_fraction(0.9999)`) about x_o, and take one of its hits with the same object
//! uniformly. The density of the chosen point per unit area is the multiple-importance
//! (one-sample, balance heuristic) combination over the three axes and the channels:
//!
//! p(x_i) = Σ_axes Σ_c P(axis) P(c) · R_d,c(r_axis)/total_c · |n_i · axis| / N_axis,
//!
//! with r_axis the distance of x_i from x_o projected on the axis' plane (R_d/total is the
//! planar density of `sample_r` with a uniform angle) and N_axis the number of hits on the
//! probe segment *of that axis* through x_i. pbrt-v4 divides every axis by the chosen axis'
//! count, which is biased where the counts differ (curved objects smaller than R); here the
//! two other axes' segments are cast too, so the estimator is unbiased (up to the 10⁻⁴ of
//! each profile beyond R). The estimate of the translucent
//! radiance is F_t(η, ω_o) R_d(‖x_o − x_i‖) E_t(x_i) / (π c(η) p(x_i)) per channel, E_t from
//! one shadow-ray sample of each light and one cosine-weighted gathering ray (environment, light
//! reflected by other surfaces, translucent surfaces by this method at depth + 1;
//! [`super::irradiance`]). For `adaptive` under lights, R_d is weighted by the entry point's
//! azimuthal factor ([`crate::bssrdf::harmonic`], amplitudes at x_i's probed curvature), and
//! on the near class by 1 + D·ω_o,t, the exit direction's coupling to x_i's lights
//! ([`crate::bssrdf::coupling`]), plus the pair's exit flow B(r) t̂·ω_o,t without the harmonic
//! ([`crate::bssrdf::flow`]).

use super::accel::Hit;
use super::adaptive::entry_amplitudes;
use super::hierarchical::{area_tree, HierarchicalParams};
use super::irradiance::{irradiance_and_harmonic, transmitted_irradiance, Entry};
use super::math::{add, dot, length, madd, max3, mul, scale, sub, Frame, Rgb, V3};
use super::scene::Scene;
use super::shade::{ft, single_scattering, tint, Translucency};
use super::texture::shading_medium;
use super::tree::Tree;
use crate::bssrdf::harmonic::{factors, Lobe};
use crate::rng::PhotonRng;
use std::f64::consts::PI;
use std::sync::OnceLock;

/// Fraction of each profile's energy inside the probe sphere (pbrt-v4 uses 0.999 likewise).
pub const R_MAX_FRACTION: f64 = 0.9999;

/// The probe method (per object: the probe radius of each channel).
pub struct Probe {
    r_max: Vec<Rgb>,
    /// Per object, built when first needed: the hierarchical method's samples with E_t = 1
    /// (`adaptive` at a tube's saddle normalises its kernel by its integral over them).
    areas: Vec<OnceLock<Option<Tree>>>,
}

impl Probe {
    pub fn new(scene: &Scene) -> Probe {
        let r_max = (0..scene.objects.len())
            .map(|oi| match scene.material(oi).translucent() {
                // (The largest over every texel material of a textured one.)
                Some(m) => match m.texture.as_ref().and_then(|t| t.radius_range(R_MAX_FRACTION)) {
                    Some((_, hi)) => hi,
                    None => std::array::from_fn(|k| {
                        let p = &m.profiles()[k];
                        if p.total() > 0.0 {
                            p.radius_for_fraction(R_MAX_FRACTION)
                        } else {
                            0.0
                        }
                    }),
                },
                None => [0.0; 3],
            })
            .collect();
        Probe { r_max, areas: (0..scene.objects.len()).map(|_| OnceLock::new()).collect() }
    }

    /// All hits with `object` on the segment from `a` along unit `d` of length `len`.
    fn probe_hits(scene: &Scene, object: usize, a: V3, d: V3, len: f64) -> Vec<Hit> {
        let mut hits = vec![];
        let (mut o, mut skip, mut travelled) = (a, u32::MAX, 0.0);
        while let Some(h) = scene.accel.intersect(o, d, len - travelled, skip) {
            travelled += h.t;
            if h.object == object {
                hits.push(h);
            }
            o = h.p;
            skip = h.tri;
            if hits.len() > 64 {
                break;
            }
        }
        hits
    }
}

impl Translucency for Probe {
    fn radiance(&self, scene: &Scene, hit: &Hit, wo: V3, depth: u32, rng: &mut PhotonRng) -> Rgb {
        // A textured material's profiles are its texel's at the shading point x_o.
        let Some(m) = shading_medium(scene, hit) else { return [0.0; 3] };
        let (u_axis, u_ch, u_r, u_phi, u_pick) =
            (rng.uniform(), rng.uniform(), rng.uniform(), rng.uniform(), rng.uniform());
        let s1 = if m.single_scattering { single_scattering(scene, m, hit, wo, depth, rng, self) } else { [0.0; 3] };
        let r_max = self.r_max[hit.object];
        let chans: Vec<usize> = (0..3).filter(|&k| r_max[k] > 0.0 && m.profiles()[k].total() > 0.0).collect();
        if chans.is_empty() {
            return s1;
        }
        let f = Frame::new(hit.n);
        let axes = [(f.t, f.b, f.n), (f.b, f.n, f.t), (f.n, f.t, f.b)];
        let probs = [0.5, 0.25, 0.25];
        let ai = if u_axis < probs[0] {
            0
        } else if u_axis < probs[0] + probs[1] {
            1
        } else {
            2
        };
        let c = chans[((u_ch * chans.len() as f64) as usize).min(chans.len() - 1)];
        let r = m.profiles()[c].sample_r(u_r);
        if !(r < max3(r_max)) {
            return s1;
        }
        let big_r = max3(r_max);
        let (a1, a2, ax) = axes[ai];
        let phi = 2.0 * PI * u_phi;
        let base = madd(madd(hit.p, a1, r * phi.cos()), a2, r * phi.sin());
        let segment = |p: V3, axis: V3| -> Vec<Hit> {
            // The line through p along axis, clipped to the sphere of radius R about x_o.
            let q = sub(p, hit.p);
            let along = dot(q, axis);
            let rp2 = dot(q, q) - along * along;
            if rp2 >= big_r * big_r {
                return vec![];
            }
            let half = (big_r * big_r - rp2).sqrt();
            Probe::probe_hits(scene, hit.object, madd(p, axis, -along - half), axis, 2.0 * half)
        };
        let hits = segment(base, ax);
        if hits.is_empty() {
            return s1;
        }
        let hi = hits[((u_pick * hits.len() as f64) as usize).min(hits.len() - 1)];
        // MIS density of the chosen point over axes and channels.
        let dx = sub(hi.p, hit.p);
        let mut pdf = 0.0;
        for (j, &(_, _, axj)) in axes.iter().enumerate() {
            let along = dot(dx, axj);
            let rp = (dot(dx, dx) - along * along).max(0.0).sqrt();
            let count = if j == ai { hits.len() } else { segment(hi.p, axj).len().max(1) };
            for &k in &chans {
                if rp < big_r {
                    let prof = &m.profiles()[k];
                    pdf += probs[j] / chans.len() as f64 * prof.rd(rp) / prof.total() * dot(hi.n, axj).abs()
                        / count as f64;
                }
            }
        }
        if !(pdf > 0.0) {
            return s1;
        }
        let dist = length(dx);
        let mu_o = dot(wo, hit.n);
        let (rd, e) = match &m.adaptive {
            Some(t) => {
                let kernel = super::adaptive::Kernel::at(scene, t, hit);
                let (c, rd) = kernel.value_class(hi.p);
                let tree = || self.areas[hit.object].get_or_init(|| area_tree(scene, hit.object)).as_ref();
                let rd = match kernel.target.and_then(|_| tree()) {
                    Some(tree) => mul(rd, kernel.normalisation(tree, HierarchicalParams::default().epsilon)),
                    None => rd,
                };
                // the exit term's angular shape on the near class (`bssrdf::exit`); across a part, none
                let rd = if c == 0 { mul(rd, t.exit_factors(mu_o)) } else { rd };
                // the exit flow from x_i (`bssrdf::flow`): B(r) t̂·ω_o,t on the pair without the harmonic
                let ot = sub(wo, scale(hit.n, mu_o));
                let flow: Rgb = if c == 0 && t.has_flow() {
                    let d = sub(hit.p, hi.p);
                    let tt = sub(d, scale(hit.n, dot(d, hit.n)));
                    let (tl, ln_r) = (length(tt), dist.ln());
                    if tl > 0.0 {
                        let u = dot(tt, ot) / tl;
                        std::array::from_fn(|k| rd[k] * t.flow(k.min(t.channels() - 1)).at_ln(ln_r) * u)
                    } else {
                        [0.0; 3]
                    }
                } else {
                    [0.0; 3]
                };
                let amps = if scene.lights.is_empty() { None } else { entry_amplitudes(scene, t, &hi) };
                let coupled = !scene.lights.is_empty() && t.has_coupling();
                if amps.is_some() || coupled {
                    let (e, hm, d) =
                        irradiance_and_harmonic(scene, &hi, Entry::of(m), 1, 1, depth, rng, self, amps.as_ref());
                    let rd = mul(rd, factors(&hm[c].map(Lobe::new), hi.n, sub(hit.p, hi.p)));
                    // the near class' exit coupling to the light's direction (`bssrdf::coupling`)
                    let rd = if c == 0 { std::array::from_fn(|k| rd[k] * (1.0 + dot(d[k], ot))) } else { rd };
                    (add(rd, flow), e)
                } else {
                    (add(rd, flow), transmitted_irradiance(scene, &hi, Entry::of(m), 1, 1, depth, rng, self))
                }
            }
            None => {
                let rd: Rgb = std::array::from_fn(|k| m.profiles()[k].rd(dist));
                (rd, transmitted_irradiance(scene, &hi, Entry::of(m), 1, 1, depth, rng, self))
            }
        };
        let w = ft(m.eta, mu_o) / (PI * m.c_norm * pdf);
        add(scale(mul(mul(rd, e), tint(scene, hit)), w), s1)
    }
    fn adds_unscattered(&self) -> bool {
        true
    }
}
