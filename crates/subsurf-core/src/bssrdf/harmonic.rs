//! The azimuthal part of the `adaptive` model: where, around its entry point, a collimated beam's
//! light leaves. The kernel of `render::adaptive` is radially symmetric about the entry point,
//! which is right under diffuse light; a collimated beam entering obliquely carries its light
//! *forward*, along the tangent t̂ of its refracted direction, before it leaves (ketchup red on a
//! 10 mm sphere: 1.7, 2.6, 3.1 mm at θi = 30, 50, 65°; `docs/render.md`, "A sun on a sphere").
//! On a sphere under a sun these offsets all point away from the sub-solar point, where a
//! symmetric kernel piles the light (+38 % ketchup red there).
//!
//! Per channel, curvature node ρ_j (the sphere of [`super::curvature`]) and polar angle θi of
//! [`OBLIQUE_THETA_DEG`], the table keeps the first azimuthal harmonic a = ⟨cos φ⟩ of the
//! escaped weight about the entry's normal (φ from t̂), for the entry's half of the sphere (the
//! kernel's near class) and for the far half (its far class): the curved transport's pencil launch
//! ([`escape_from`], [`Source::Pencil`], the tally [`Escape::harmonic`]) with
//! [`curved_photons`] photons, seed + 64c + [`SEED_HARMONIC`] + i for angle i — the same stream
//! for every ρ_j (common random numbers: the amplitudes are smooth in ρ, and the 64-wide
//! stride of a channel has only the offsets 34–39 and 61–63 free).
//!
//! The renderer weights each pair (entry point x_i, exit point x_o) of the kernel by the
//! wrapped-Cauchy factor f(φ) = (1 − a²)/(1 + a² − 2a cos φ), φ the angle between t̂ and the
//! tangential direction from x_i to x_o: f has mean 1 over φ, so every total (and a flat surface
//! under uniform light) is unchanged, and ⟨cos φ⟩ under it is a, the tallied harmonic. Between
//! nodes a is linear in μ = cos θi (0 at normal incidence, where there is no forward direction;
//! held below cos 80°) and in ln ρ (held beyond the end nodes; flat and concave points take the
//! largest sphere's).

use super::adaptive::{AdaptiveSettings, SEED_STRIDE};
use super::curvature::curved_photons;
use super::curved::{escape_from, Curved, Escape, NEAR_BINS};
use super::oblique::OBLIQUE_THETA_DEG;
use crate::error::{Error, Result};
use crate::mc::Source;
use crate::medium::Stack;
use std::sync::atomic::{AtomicBool, AtomicU64};

/// Seed offset of the first angle's pencil runs within a channel's stride (34 … 37).
pub const SEED_HARMONIC: u64 = 34;

/// Largest |a| used (the factor's peak (1 + a)/(1 − a) stays ≤ 39).
pub const MAX_AMPLITUDE: f64 = 0.95;

/// (near, far) ⟨cos φ⟩ of one pencil run: the entry's half and the far half.
pub fn amplitudes(e: &Escape) -> [f64; 2] {
    if e.harmonic.len() != NEAR_BINS + 1 {
        return [0.0; 2];
    }
    let near_h: f64 = e.harmonic[..NEAR_BINS].iter().sum();
    let far_w = e.mean - e.near;
    let ratio = |h: f64, w: f64| if w > 1e-12 * e.mean.max(1e-300) && w > 0.0 { h / w } else { 0.0 };
    [ratio(near_h, e.near), ratio(e.harmonic[NEAR_BINS], far_w)]
}

/// Trace channel `channel`'s amplitudes at the curvature nodes `rho` (mm): per node, per angle
/// of [`OBLIQUE_THETA_DEG`], (near, far); `None` when cancelled.
pub fn build_harmonic(
    stack: &Stack,
    channel: usize,
    rho: &[f64],
    s: &AdaptiveSettings,
    cancel: &AtomicBool,
    progress: &AtomicU64,
) -> Result<Option<Vec<Vec<[f64; 2]>>>> {
    let base = s.seed.wrapping_add(SEED_STRIDE * channel as u64 + SEED_HARMONIC);
    let photons = curved_photons(s.photons);
    let mut out = vec![];
    for &r in rho {
        let mut row = vec![];
        for (i, deg) in OBLIQUE_THETA_DEG.iter().enumerate() {
            let source = Source::Pencil { theta: deg.to_radians(), phi: 0.0 };
            let seed = base + i as u64;
            let Some(e) = escape_from(stack, Curved::Sphere, r, source, photons, seed, s.threads, cancel, progress)?
            else {
                return Ok(None);
            };
            row.push(amplitudes(&e));
        }
        out.push(row);
    }
    Ok(Some(out))
}

/// Photons a channel's amplitudes trace at `n_rho` curvature nodes.
pub fn harmonic_photons(n_rho: usize, photons: u64) -> u64 {
    curved_photons(photons).saturating_mul((n_rho * OBLIQUE_THETA_DEG.len()) as u64)
}

/// One channel's amplitudes at its nodes (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct Harmonic {
    ln_rho: Vec<f64>,
    /// Per curvature node, per angle, (near, far).
    a: Vec<Vec<[f64; 2]>>,
}

/// The amplitudes at one point's curvature, per angle node: [`Harmonic::at_rho`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AtRho {
    a: [[f64; 2]; OBLIQUE_THETA_DEG.len()],
}

impl AtRho {
    /// No harmonic at any angle.
    pub const ZERO: AtRho = AtRho { a: [[0.0; 2]; OBLIQUE_THETA_DEG.len()] };

    /// (near, far) a at μ = cos θi ∈ [0, 1]: linear in μ between the nodes, 0 at μ = 1, held
    /// below the last node.
    pub fn at(&self, mu: f64) -> [f64; 2] {
        let n = OBLIQUE_THETA_DEG.len();
        let node_mu = |i: usize| if i == 0 { 1.0 } else { OBLIQUE_THETA_DEG[i - 1].to_radians().cos() };
        let val = |i: usize| if i == 0 { [0.0; 2] } else { self.a[i - 1] };
        if mu >= 1.0 {
            return [0.0; 2];
        }
        if mu <= node_mu(n) {
            return val(n);
        }
        let i = (1..=n).find(|&i| node_mu(i) <= mu).unwrap_or(n); // node_mu(i-1) > mu ≥ node_mu(i)
        let t = (node_mu(i - 1) - mu) / (node_mu(i - 1) - node_mu(i));
        let (a, b) = (val(i - 1), val(i));
        [(1.0 - t) * a[0] + t * b[0], (1.0 - t) * a[1] + t * b[1]]
    }

    /// Whether every amplitude is 0 (the factor is 1 everywhere).
    pub fn is_zero(&self) -> bool {
        self.a.iter().all(|x| x[0] == 0.0 && x[1] == 0.0)
    }
}

impl Harmonic {
    /// The amplitudes `a` (per curvature node `rho`, per angle, (near, far)).
    pub fn new(rho: &[f64], a: &[Vec<[f64; 2]>]) -> Result<Harmonic> {
        if rho.is_empty() || a.len() != rho.len() || a.iter().any(|r| r.len() != OBLIQUE_THETA_DEG.len()) {
            return Err(Error::Invalid(format!(
                "adaptive table: the harmonic needs {} angles at each of the {} curvature nodes",
                OBLIQUE_THETA_DEG.len(),
                rho.len()
            )));
        }
        if a.iter().flatten().flatten().any(|x| !x.is_finite() || x.abs() > 1.0) {
            return Err(Error::Invalid("adaptive table: a harmonic amplitude outside [-1, 1]".into()));
        }
        Ok(Harmonic { ln_rho: rho.iter().map(|r| r.ln()).collect(), a: a.to_vec() })
    }

    /// The amplitudes on a sphere of radius `rho` (mm; ∞ for flat): linear in ln ρ, held beyond
    /// the end nodes, each clamped to ±[`MAX_AMPLITUDE`].
    pub fn at_rho(&self, rho: f64) -> AtRho {
        let n = self.ln_rho.len();
        let x = rho.ln();
        let (i, t) = if !(x > self.ln_rho[0]) {
            (0, 0.0)
        } else if x >= self.ln_rho[n - 1] {
            (n - 1, 0.0)
        } else {
            let i = self.ln_rho.partition_point(|&v| v <= x) - 1;
            (i, (x - self.ln_rho[i]) / (self.ln_rho[i + 1] - self.ln_rho[i]))
        };
        let j = (i + 1).min(n - 1);
        let a = std::array::from_fn(|k| {
            std::array::from_fn(|c| {
                let v = (1.0 - t) * self.a[i][k][c] + t * self.a[j][k][c];
                v.clamp(-MAX_AMPLITUDE, MAX_AMPLITUDE)
            })
        });
        AtRho { a }
    }

    /// The amplitudes at principal curvatures `k1`, `k2` (mm⁻¹, either order): the sphere of
    /// radius 1/κ₁ (κ₁ ≥ κ₂, as the curvature scales' bins) where the mean curvature is > 0,
    /// else the largest sphere's.
    pub fn at_principal(&self, k1: f64, k2: f64) -> AtRho {
        let k = k1.max(k2);
        if 0.5 * (k1 + k2) > 0.0 && k.is_finite() {
            self.at_rho(1.0 / k)
        } else {
            self.at_rho(f64::INFINITY)
        }
    }
}

/// A harmonic vector m in the form the pair factors use: its unit direction and its length a
/// (at most [`MAX_AMPLITUDE`]; 0: no harmonic).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Lobe {
    /// Unit forward direction (0 when a = 0).
    pub u: [f64; 3],
    /// Amplitude a = ⟨cos φ⟩.
    pub a: f64,
}

impl Lobe {
    /// The lobe of harmonic vector `m`.
    pub fn new(m: [f64; 3]) -> Lobe {
        let len = (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt();
        if !(len > 1e-12) {
            return Lobe::default();
        }
        Lobe { u: [m[0] / len, m[1] / len, m[2] / len], a: len.min(MAX_AMPLITUDE) }
    }
    /// The harmonic vector a·u.
    pub fn vector(&self) -> [f64; 3] {
        [self.a * self.u[0], self.a * self.u[1], self.a * self.u[2]]
    }
}

/// The wrapped-Cauchy factor (1 − a²)/(1 + a² − 2a cos φ) of a pair (see the module docs): `m`
/// the entry point's harmonic vector (a = |m|, its direction the forward tangent), `n` its
/// normal (any length), `v` the vector from the entry point to the exit point; 1 when there is no
/// harmonic or no tangential direction.
pub fn factor(m: [f64; 3], n: [f64; 3], v: [f64; 3]) -> f64 {
    let nl = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    let n = if nl > 0.0 { [n[0] / nl, n[1] / nl, n[2] / nl] } else { [0.0; 3] };
    factors(&[Lobe::new(m); 3], n, v)[0]
}

/// [`factor`] for three lobes (one per channel) and the same pair; `n` the entry point's unit
/// normal (or 0).
#[inline]
pub fn factors(l: &[Lobe; 3], n: [f64; 3], v: [f64; 3]) -> [f64; 3] {
    if l[0].a == 0.0 && l[1].a == 0.0 && l[2].a == 0.0 {
        return [1.0; 3];
    }
    let dot = |p: [f64; 3], q: [f64; 3]| p[0] * q[0] + p[1] * q[1] + p[2] * q[2];
    let vn = dot(v, n);
    let t2 = dot(v, v) - vn * vn; // |v's tangential part|²
    if t2 <= 1e-24 {
        return [1.0; 3];
    }
    let inv_t = 1.0 / t2.sqrt();
    std::array::from_fn(|c| {
        let a = l[c].a;
        if a == 0.0 {
            return 1.0;
        }
        let cos_phi = ((dot(l[c].u, v) - vn * dot(l[c].u, n)) * inv_t).clamp(-1.0, 1.0);
        (1.0 - a * a) / (1.0 + a * a - 2.0 * a * cos_phi)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// The factor's mean over φ is 1 and its ⟨cos φ⟩ is a (midpoint rule, 4096 steps), for
    /// either sign of a, and it ignores the normal component of v.
    #[test]
    fn the_factor_keeps_the_total_and_has_the_harmonic() {
        for a in [-0.7, 0.0, 0.3, 0.9] {
            let n = 4096;
            let (mut m0, mut m1) = (0.0, 0.0);
            for i in 0..n {
                let phi = 2.0 * PI * (i as f64 + 0.5) / n as f64;
                let f = factor([a, 0.0, 0.0], [0.0, 0.0, 2.0], [phi.cos(), phi.sin(), 5.0]);
                m0 += f / n as f64;
                m1 += f * phi.cos() / n as f64;
            }
            assert!((m0 - 1.0).abs() < 1e-9, "a = {a}: mean {m0}");
            assert!((m1 - a).abs() < 1e-9, "a = {a}: <cos> {m1}");
        }
        assert_eq!(factor([0.5, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 3.0]), 1.0);
        // straight behind
    }

    /// 0 at normal incidence, the node values at the nodes, linear between, held below 80°;
    /// interpolated in ln ρ and held beyond the nodes.
    #[test]
    fn amplitudes_interpolate() {
        let rho = [1.0, 4.0];
        let row = |s: f64| (1..=4).map(|i| [s * i as f64 * 0.1, -s * 0.01 * i as f64]).collect::<Vec<_>>();
        let h = Harmonic::new(&rho, &[row(1.0), row(2.0)]).unwrap();
        let at = h.at_rho(2.0); // halfway in ln ρ
        assert_eq!(at.at(1.0), [0.0, 0.0]);
        let m50 = 50f64.to_radians().cos();
        assert!((at.at(m50)[0] - 1.5 * 0.2).abs() < 1e-12 && (at.at(m50)[1] + 1.5 * 0.02).abs() < 1e-12);
        assert!((at.at(0.0)[0] - 0.6).abs() < 1e-12 && at.at(0.0) == at.at(0.1));
        let m30 = 30f64.to_radians().cos();
        assert!((at.at(0.5 * (1.0 + m30))[0] - 0.075).abs() < 1e-12);
        assert_eq!(h.at_rho(0.1), h.at_rho(1.0));
        assert_eq!(h.at_rho(f64::INFINITY), h.at_rho(4.0));
        assert_eq!(h.at_principal(-0.2, -0.3), h.at_rho(4.0)); // concave: the largest sphere's
        assert_eq!(h.at_principal(0.5, 0.0), h.at_rho(2.0));
        assert!(Harmonic::new(&rho, &[row(1.0)]).is_err());
        assert!(Harmonic::new(&rho, &[row(1.0), row(20.0)]).is_err()); // |a| > 1
    }
}
