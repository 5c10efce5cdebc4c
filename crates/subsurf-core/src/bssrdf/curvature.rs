//! The curvature part of the `adaptive` model: per channel, the escape of uniform diffuse light
//! from spheres, infinite cylinders and spherical cavities of radius ρ (exact transport,
//! [`crate::bssrdf::curved`]) relative to the flat half-space (the engine itself), turned into
//! scales of the renderer's kernel so that it integrates, over a sphere (cavity) of radius ρ, to
//! the exact escape, distributed over the sphere as the exact one is.
//!
//! - [`curvature_nodes`]: ρ_j = ℓ·2^j (ℓ the largest 1/σt' of the stack), j = −1, 0, …, up to
//!   the first node ≥ max(8ℓ, 8L) (L the deepest layer's diffusion length), at most 2⁸ℓ.
//! - [`build_curvature`]: the engine's flat diffuse reflectance R_flat under
//!   [`Source::Diffuse`] (seed + 64c + [`SEED_FLAT`], the table's photons), the flat pencil
//!   runs of the oblique-incidence gain ([`super::oblique`], seed offsets
//!   [`super::oblique::SEED_OBLIQUE`] + i, 4 × the table's photons), and the sphere, cylinder and
//!   cavity escapes P(ρ_j) (seed offsets [`SEED_SPHERE`] + j, [`SEED_CYLINDER`] + j and
//!   [`SEED_CAVITY`] + j), with [`curved_photons`] each: a quarter of the table's photons,
//!   at most [`MAX_CURVED_PHOTONS`], as an escape fraction near 1 varies little from photon to
//!   photon (0.1–0.3 % standard error at 2 500 photons, below the flat run's), and the sphere's
//!   pencil runs of the azimuthal harmonic ([`super::harmonic`], seed offsets
//!   [`super::harmonic::SEED_HARMONIC`] + i, as many photons). The sphere's and
//!   the cylinder's escapes are also tallied by where they leave: per chord bin of the entry's
//!   half ([`NEAR_BINS`] bins, of equal area on the sphere, [`bin_edges`]) and the far half.
//! - [`Scales`]: C = P/R_flat is the curvature's own effect (the same illumination on both sides
//!   of the ratio); the kernel's units are R_∞ (the semi-infinite total per entering power) per
//!   R_flat. On a sphere of radius ρ the kernel of `render::adaptive` (thickness d = 2ρ) puts
//!   entry points of the near hemisphere (depth ≤ ρ) in R(chord; 2ρ) — on a sphere the area within
//!   chord c is exactly πc², so a bin's share is the profile's CDF difference — and those of the
//!   far hemisphere in T(ρ sin θ; 2ρ) (integrated by the midpoint rule in θ). The near scale of
//!   bin b is (escape in bin b)·R_∞/R_flat over the kernel's mass in bin b, the far scale the same
//!   for the far hemisphere (where the kernel's far mass is under [`FAR_MIN`] of the whole, the
//!   far escape is spread over the near bins instead). So the thickness part (R and T of the slab
//!   2ρ) is *inside* what is scaled, not added to a correction: a sphere's light is counted once.
//!   A cavity's kernel (entry points all above the tangent plane, thickness ∞) gathers R_∞·F_∞(2ρ)
//!   (F the CDF): its one scale is C_cav/F_∞(2ρ).
//!
//! - The cylinder's scales alike, from the kernel's integral over an infinite cylinder of radius ρ
//!   ([`cylinder_gather`]: the entry's half per chord bin, the far half by lateral offset, with
//!   the exact area of the cylinder within a chord / an offset, [`cylinder_near_area`],
//!   [`cylinder_far_area`]) and its escapes tallied alike. A point of principal curvatures
//!   κ₁ ≥ κ₂ takes a mixture of the sphere's and the cylinder's scales of radius 1/κ₁
//!   ([`Scales::at_principal`]).
//!
//! Scales are interpolated linearly in ln ρ between nodes, held below the first node, and go to 1
//! beyond the last node ρ_n as 1 + (s_n − 1)·ρ_n/ρ (the curvature effect is first order in 1/ρ).
//! Under uniform light on a sphere the kernel's integral is then the traced escape up to the
//! tables' noise (the rendered exitance also carries the renderer's flat-surface exit term, off
//! on optically small spheres: `docs/render.md`); under a directional light the shape within
//! each bin and across the far side is the slab's.

use super::adaptive::{thickness_nodes, transport_length, AdaptiveSettings, Mix};
use super::curved::{escape, Curved, Escape, NEAR_BINS};
use super::RadialProfile;
use crate::error::{Error, Result};
use crate::mc::tally::totals::{Total, Totals};
use crate::mc::{run, RunConfig, Source};
use crate::medium::Stack;
use std::f64::consts::PI;
use std::sync::atomic::{AtomicBool, AtomicU64};

/// First curvature node, in ℓ (ρ₀ = ℓ/2).
pub const FIRST_RHO_LOG2: i32 = -1;
/// Largest curvature node, in ℓ (2⁸).
pub const LAST_RHO_LOG2: i32 = 8;
/// Seed offsets within a channel's stride (the thickness nodes use 0 … 16).
pub const SEED_SPHERE: u64 = 20;
/// See [`SEED_SPHERE`].
pub const SEED_CAVITY: u64 = 40;
/// See [`SEED_SPHERE`].
pub const SEED_CYLINDER: u64 = 50;
/// See [`SEED_SPHERE`].
pub const SEED_FLAT: u64 = 60;
/// Below this fraction of the kernel's sphere integral on the far side, the far side is not
/// scaled on its own (see [`Scales::new`]).
pub const FAR_MIN: f64 = 0.02;
/// Midpoints of the far-hemisphere quadrature.
const FAR_STEPS: usize = 2048;

/// Most photons of one sphere or cavity run: the escapes' standard errors there (≈ 0.15 % of the
/// total, ≈ 1 % per chord bin) are an order below the model's remaining error, and the curved
/// Monte Carlo is scalar code (a table of 10⁵ photons per node would otherwise spend most of
/// its time here).
pub const MAX_CURVED_PHOTONS: u64 = 5_000;

/// Photons of each sphere and cavity run for `photons` per table node: a quarter, at least 2,
/// at most [`MAX_CURVED_PHOTONS`].
pub fn curved_photons(photons: u64) -> u64 {
    (photons / 4).clamp(2, MAX_CURVED_PHOTONS)
}

/// Relative standard error to which the sphere's and the cylinder's escapes are traced (at most
/// [`MAX_PRECISE_PHOTONS`] photons): under uniform light a convex object's rendered escape *is*
/// the table's, so its noise is the model's error there (at 2 500 photons, 10 000 per node: the
/// two-layer skin's green and blue 2.5–3.8 %, ketchup's up to 19 %, marble 0.7–0.8 %).
pub const CURVED_REL_ERR: f64 = 0.005;
/// Most photons of one sphere or cylinder run traced on to [`CURVED_REL_ERR`]: the two-layer
/// skin's green reaches it there from 2 500 (0.28 CPU s a run); the darkest channels (ketchup's
/// green and blue) stop short of it, at 1.5–3.5 %.
pub const MAX_PRECISE_PHOTONS: u64 = 80_000;

/// Photons of a sphere or cylinder run after one of `n` photons with relative standard error
/// `rel`: `n` doubled until the expected error (∝ 1/√n) is at most [`CURVED_REL_ERR`], at most
/// `cap` (`n` itself where `rel` is not finite, nothing escaped, or `n` ≥ `cap`). The builder
/// repeats it on each run's own error, with `cap` = [`MAX_PRECISE_PHOTONS`].
pub fn extended_photons(n: u64, rel: f64, cap: u64) -> u64 {
    let mut m = n;
    while rel.is_finite() && m < cap && rel * (n as f64 / m as f64).sqrt() > CURVED_REL_ERR {
        m = m.saturating_mul(2).min(cap);
    }
    m
}

/// One channel's curved-transport data.
#[derive(Clone, Debug, PartialEq)]
pub struct CurvatureData {
    /// Radii ρ_j, mm.
    pub rho: Vec<f64>,
    /// Escape from the sphere of radius ρ_j.
    pub sphere: Vec<Escape>,
    /// Escape from the cavity of radius ρ_j.
    pub cavity: Vec<Escape>,
    /// Escape from the infinite cylinder of radius ρ_j.
    pub cylinder: Vec<Escape>,
    /// The engine's flat half-space diffuse reflectance under diffuse light.
    pub flat: Escape,
    /// The engine's flat half-space diffuse reflectance (per unit incident power) under pencil
    /// beams at [`super::oblique::OBLIQUE_THETA_DEG`] (the oblique-incidence gain).
    pub oblique: Vec<Escape>,
    /// The first azimuthal harmonic ⟨cos φ⟩ of the sphere's escapes under pencil beams, per
    /// radius ρ_j, per angle of [`super::oblique::OBLIQUE_THETA_DEG`]: (entry's half, far half)
    /// ([`super::harmonic`]).
    pub harmonic: Vec<Vec<[f64; 2]>>,
    /// The engine's exit-angle histogram of the flat half-space under diffuse light ([`super::exit`]).
    pub exit: super::exit::ExitBins,
    /// The engine's flat half-space under pencil beams at [`super::oblique::OBLIQUE_THETA_DEG`]
    /// (the oblique runs themselves): exit weight and its cos Δφ moment per exit-cosine bin
    /// ([`super::coupling`]).
    pub coupling: Vec<super::exit::ExitBins>,
    /// The engine's flat half-space under diffuse light: exit weight and its cos Δφ moment about
    /// the direction from the entry point, per distance bin and exit-cosine bin ([`super::flow`]).
    pub flow: super::exit::ExitBins,
}

/// The curvature nodes (mm) of a stack (see the module docs).
pub fn curvature_nodes(stack: &Stack) -> Result<Vec<f64>> {
    thickness_nodes(stack)?; // the same checks
    let ell = transport_length(stack);
    let deep = stack.layers.last().expect("a stack has a layer");
    let l_diff = if deep.mua > 0.0 { 1.0 / (3.0 * deep.mua * deep.sigma_t_prime()).sqrt() } else { f64::INFINITY };
    let goal = (8.0 * ell).max(8.0 * l_diff);
    let mut out = vec![];
    for j in FIRST_RHO_LOG2..=LAST_RHO_LOG2 {
        out.push(ell * 2f64.powi(j));
        if ell * 2f64.powi(j) >= goal {
            break;
        }
    }
    Ok(out)
}

/// The engine's flat diffuse reflectance of `stack` under [`Source::Diffuse`].
pub fn flat_escape(
    stack: &Stack,
    photons: u64,
    seed: u64,
    threads: Option<usize>,
    cancel: &AtomicBool,
    progress: &AtomicU64,
) -> Result<Option<Escape>> {
    let cfg = RunConfig { photons, seed, threads, source: Source::Diffuse, isa: None };
    let out = run(stack, &cfg, || Totals::new(stack.layers.len()), cancel, progress)?;
    if out.cancelled {
        return Ok(None);
    }
    let (mean, stderr) = out.tally.get(Total::Diffuse);
    Ok(Some(Escape { mean, stderr, near: mean, near_stderr: stderr, bins: vec![], shift: 0.0, harmonic: vec![] }))
}

/// Trace channel `channel`'s curvature data (see the module docs); `None` when cancelled.
pub fn build_curvature(
    stack: &Stack,
    channel: usize,
    s: &AdaptiveSettings,
    cancel: &AtomicBool,
    progress: &AtomicU64,
) -> Result<Option<CurvatureData>> {
    let base = s.seed.wrapping_add(super::adaptive::SEED_STRIDE * channel as u64);
    let Some(flat) = flat_escape(stack, s.photons, base + SEED_FLAT, s.threads, cancel, progress)? else {
        return Ok(None);
    };
    let Some((oblique, coupling)) = super::oblique::build_oblique(stack, channel, s, cancel, progress)? else {
        return Ok(None);
    };
    let rho = curvature_nodes(stack)?;
    let (mut sphere, mut cavity, mut cylinder) = (vec![], vec![], vec![]);
    for (j, &r) in rho.iter().enumerate() {
        let j = j as u64;
        let one =
            |kind, off| escape(stack, kind, r, curved_photons(s.photons), base + off + j, s.threads, cancel, progress);
        // the sphere's and the cylinder's escapes are the convex scales themselves: traced on
        // to [`CURVED_REL_ERR`] (the same photons' streams, so the pilot is their first part)
        let precise = |kind, off| -> Result<Option<Escape>> {
            let mut n = curved_photons(s.photons);
            let Some(mut e) = one(kind, off)? else { return Ok(None) };
            loop {
                let next = extended_photons(n, e.stderr / e.mean, MAX_PRECISE_PHOTONS);
                if next == n {
                    return Ok(Some(e));
                }
                n = next;
                let local = AtomicU64::new(0);
                let Some(more) = escape(stack, kind, r, n, base + off + j, s.threads, cancel, &local)? else {
                    return Ok(None);
                };
                e = more;
            }
        };
        let (Some(a), Some(b), Some(c)) = (
            precise(Curved::Sphere, SEED_SPHERE)?,
            one(Curved::Cavity, SEED_CAVITY)?,
            precise(Curved::Cylinder, SEED_CYLINDER)?,
        ) else {
            return Ok(None);
        };
        sphere.push(a);
        cavity.push(b);
        cylinder.push(c);
    }
    let Some(harmonic) = super::harmonic::build_harmonic(stack, channel, &rho, s, cancel, progress)? else {
        return Ok(None);
    };
    let Some(exit) = super::exit::build_exit(stack, channel, s, cancel, progress)? else {
        return Ok(None);
    };
    let Some(flow) = super::flow::build_flow(stack, channel, s, cancel, progress)? else {
        return Ok(None);
    };
    Ok(Some(CurvatureData { rho, sphere, cavity, cylinder, flat, oblique, harmonic, exit, coupling, flow }))
}

/// Photons a channel's curvature data traces (with its oblique runs).
pub fn curvature_photons(stack: &Stack, photons: u64) -> u64 {
    let n_rho = curvature_nodes(stack).map_or(0, |v| v.len());
    let oblique = super::oblique::OBLIQUE_PHOTONS * super::oblique::OBLIQUE_THETA_DEG.len() as u64;
    let flat = photons.saturating_mul(1 + oblique);
    let harmonic = super::harmonic::harmonic_photons(n_rho, photons)
        .saturating_add(super::exit::exit_photons(photons))
        .saturating_add(super::flow::flow_photons(photons));
    flat.saturating_add(curved_photons(photons).saturating_mul(3 * n_rho as u64)).saturating_add(harmonic)
}

/// Edges (mm) of the near-side chord bins of a sphere of radius `rho` ([`NEAR_BINS`]; the last
/// open to ∞).
pub fn bin_edges(rho: f64) -> [f64; NEAR_BINS + 1] {
    std::array::from_fn(|b| match b {
        0 => 0.0,
        NEAR_BINS => f64::INFINITY,
        _ => rho * (2.0 * b as f64 / NEAR_BINS as f64).sqrt(),
    })
}

/// The kernel's integral over the sphere of radius `rho` (see the module docs): R, T the slab
/// profiles at d = 2ρ (per unit entering power); the near side per chord bin (the bins of
/// [`bin_edges`], the last one closed at the equator ρ√2), and the far side.
pub fn sphere_gather(r: &Mix, t: &Mix, rho: f64) -> ([f64; NEAR_BINS], f64) {
    let mut e = bin_edges(rho);
    e[NEAR_BINS] = rho * std::f64::consts::SQRT_2;
    let near = std::array::from_fn(|b| r.total() * (r.cdf(e[b + 1]) - r.cdf(e[b])));
    let h = 0.5 * PI / FAR_STEPS as f64;
    let far: f64 = if t.total() > 0.0 {
        (0..FAR_STEPS)
            .map(|i| {
                let th = 0.5 * PI + (i as f64 + 0.5) * h;
                t.rd(rho * th.sin()) * 2.0 * PI * rho * rho * th.sin() * h
            })
            .sum()
    } else {
        0.0
    };
    (near, far)
}

/// ∫₀^b √(c² − a² sin²θ)₊ dθ, by the midpoint rule on a smooth integrand: in θ when c ≥ a sin b
/// (the root never vanishes), else in ψ with sin θ = (c/a) sin ψ.
fn arc_integral(c: f64, a: f64, b: f64) -> f64 {
    const N: usize = 96;
    if c >= a * b.sin() {
        let h = b / N as f64;
        let f = |i: usize| (c * c - (a * ((i as f64 + 0.5) * h).sin()).powi(2)).max(0.0).sqrt();
        (0..N).map(f).sum::<f64>() * h
    } else {
        let (k, h) = (c / a, 0.5 * PI / N as f64);
        let f = |i: usize| {
            let p = (i as f64 + 0.5) * h;
            p.cos().powi(2) / (1.0 - (k * p.sin()).powi(2)).max(1e-300).sqrt()
        };
        (0..N).map(f).sum::<f64>() * h * c * c / a
    }
}

/// Area (mm²) of the entry's half of an infinite cylinder of radius `rho` within chord `c` of
/// the entry point: chord² = 4ρ² sin²(φ/2) + z², |φ| ≤ π/2 (πc² for c ≪ ρ).
pub fn cylinder_near_area(c: f64, rho: f64) -> f64 {
    8.0 * rho * arc_integral(c, 2.0 * rho, 0.25 * PI)
}

/// Area (mm²) of the far half of an infinite cylinder of radius `rho` within lateral offset `u`
/// of the entry's normal line: u² = ρ² sin²φ + z², |φ − π| ≤ π/2.
pub fn cylinder_far_area(u: f64, rho: f64) -> f64 {
    4.0 * rho * arc_integral(u, rho, 0.5 * PI)
}

/// ∫ p(x) dA(x) over x in the consecutive points `xs` (the last may be ∞): per step the CDF's
/// mass times the area's density relative to the plane, ΔA/(πΔx²) (the tail beyond the last
/// finite point takes the last step's density).
fn gather_area(p: &dyn RadialProfile, xs: &[f64], area: &dyn Fn(f64) -> f64) -> f64 {
    let mut g_last = 1.0;
    let mut sum = 0.0;
    for w in xs.windows(2) {
        let (a, b) = (w[0], w[1]);
        if b.is_finite() {
            g_last = (area(b) - area(a)) / (PI * (b * b - a * a));
        }
        sum += (cdf_at(p, b) - cdf_at(p, a)).max(0.0) * g_last;
    }
    sum * p.total()
}

/// Points from `lo` to `hi` (finite): `n` steps uniform in x².
fn steps_sq(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    (0..=n).map(|i| (lo * lo + (hi * hi - lo * lo) * i as f64 / n as f64).sqrt()).collect()
}

/// Points from `lo` (> 0) geometrically (2^⅛) over 16 octaves, then ∞.
fn steps_to_inf(lo: f64) -> Vec<f64> {
    (0..=128).map(|i| lo * 2f64.powf(i as f64 / 8.0)).chain([f64::INFINITY]).collect()
}

/// The kernel's integral over an infinite cylinder of radius `rho` (R, T the slab profiles at
/// d = 2ρ, the cylinder's diameter, which the thickness probe measures): the entry's half
/// (depth ≤ ρ) per chord bin of [`bin_edges`] (the last open), and the far half by the lateral
/// offset r⊥ (as `render::adaptive` classes them).
pub fn cylinder_gather(r: &dyn RadialProfile, t: &dyn RadialProfile, rho: f64) -> ([f64; NEAR_BINS], f64) {
    let e = bin_edges(rho);
    let near_area = |c: f64| cylinder_near_area(c, rho);
    let near = std::array::from_fn(|b| {
        let xs = if b + 1 < NEAR_BINS { steps_sq(e[b], e[b + 1], 16) } else { steps_to_inf(e[b]) };
        if r.total() > 0.0 {
            gather_area(r, &xs, &near_area)
        } else {
            0.0
        }
    });
    let far = if t.total() > 0.0 {
        let mut xs = steps_sq(0.0, rho, 64);
        xs.extend(steps_to_inf(rho).into_iter().skip(1));
        gather_area(t, &xs, &|u| cylinder_far_area(u, rho))
    } else {
        0.0
    };
    (near, far)
}

/// The cylinder's area densities relative to the plane for radius 1 on coarser steps than
/// [`cylinder_gather`]'s (4 per chord bin, then 2^⅛ over 3 octaves and 2^½ up to 16; the far
/// half 32 steps to the radius, then the same): (end, density, chord bin) of consecutive steps
/// from 0, in units of the radius, entry half and far half. The area within a chord (an offset)
/// scales as ρ², so these hold for every radius.
type UnitSteps = (Vec<(f64, f64, usize)>, Vec<(f64, f64, usize)>);

fn unit_steps() -> &'static UnitSteps {
    static STEPS: std::sync::OnceLock<UnitSteps> = std::sync::OnceLock::new();
    STEPS.get_or_init(|| {
        // 2^⅛ over the first three octaves (the area's density changes fast past the radius),
        // then 2^½ up to 16 octaves, then ∞
        let tail = |lo: f64| {
            let fine = (0..24).map(move |i| lo * 2f64.powf(i as f64 / 8.0));
            fine.chain((6..=32).map(move |i| lo * 2f64.powf(i as f64 / 2.0))).chain([f64::INFINITY])
        };
        let e = bin_edges(1.0);
        let mut near = vec![(0.0, 0)];
        for b in 0..NEAR_BINS - 1 {
            near.extend(steps_sq(e[b], e[b + 1], 4).into_iter().skip(1).map(|x| (x, b)));
        }
        near.extend(tail(e[NEAR_BINS - 1]).skip(1).map(|x| (x, NEAR_BINS - 1)));
        let mut far: Vec<(f64, usize)> = steps_sq(0.0, 1.0, 32).into_iter().map(|x| (x, 0)).collect();
        far.extend(tail(1.0).skip(1).map(|x| (x, 0)));
        let densities = |xs: &[(f64, usize)], area: &dyn Fn(f64) -> f64| {
            let mut g = 1.0;
            let mut out = vec![];
            for w in xs.windows(2) {
                let (a, b) = (w[0].0, w[1].0);
                if b.is_finite() {
                    g = (area(b) - area(a)) / (PI * (b * b - a * a));
                }
                out.push((b, g, w[1].1));
            }
            out
        };
        (densities(&near, &|c| cylinder_near_area(c, 1.0)), densities(&far, &|u| cylinder_far_area(u, 1.0)))
    })
}

/// Σ over `steps` (radius `rho`) of the CDF's step × the area's density × `scale` of the step's
/// chord bin, times `total` (the CDF evaluated once per point; 0 at 0, 1 at ∞).
fn mass_on(steps: &[(f64, f64, usize)], rho: f64, total: f64, cdf: impl Fn(f64) -> f64, scale: &[f64]) -> f64 {
    if !(total > 0.0) {
        return 0.0;
    }
    let (mut prev, mut sum) = (0.0, 0.0);
    for &(b, g, bin) in steps {
        let f = if b.is_finite() { cdf(rho * b) } else { 1.0 };
        sum += (f - prev).max(0.0) * g * scale[bin];
        prev = f;
    }
    sum * total
}

/// The kernel's whole integral over an infinite cylinder of radius `rho` (R on the entry's half
/// by chord, T on the far half by lateral offset, as [`cylinder_gather`] sums them), on coarser
/// steps (≈ 160 CDF evaluations; the escape at every node of a table to 0.2 %: a kernel per
/// shading point, `render::adaptive`).
pub fn cylinder_mass(r: &dyn RadialProfile, t: &dyn RadialProfile, rho: f64) -> f64 {
    let (near, far) = unit_steps();
    let one = [1.0; NEAR_BINS];
    mass_on(near, rho, r.total(), |x| r.cdf(x), &one) + mass_on(far, rho, t.total(), |x| t.cdf(x), &one)
}

/// Per-bin near scales and the far scale that make a kernel whose integral is `(k_near, k_far)`
/// give the escape `esc` (`unit`: escape per incident power → the kernel's units).
fn convex_scales(esc: &Escape, (k_near, k_far): ([f64; NEAR_BINS], f64), unit: f64) -> ([f64; NEAR_BINS], f64) {
    let k_tot: f64 = k_near.iter().sum::<f64>() + k_far;
    let (far, spill) = if k_far > FAR_MIN * k_tot {
        ((esc.mean - esc.near) * unit / k_far, 1.0)
    } else {
        // no transmission to speak of: the far side's escape goes to the near side
        let near = esc.near * unit;
        (1.0, if near > 0.0 { (esc.mean * unit - k_far) / near } else { 1.0 })
    };
    let near = std::array::from_fn(|b| if k_near[b] > 0.0 { esc.bins[b] * unit * spill / k_near[b] } else { 1.0 });
    (near, far)
}

/// One channel's scales at its nodes (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct Scales {
    /// ln ρ_j.
    ln_rho: Vec<f64>,
    /// Convex (sphere) scales of the near side (R), per chord bin.
    pub convex: Vec<[f64; NEAR_BINS]>,
    /// Convex scales of the far side (T).
    pub convex_far: Vec<f64>,
    /// Cylinder scales of the near side, per chord bin.
    pub cylinder: Vec<[f64; NEAR_BINS]>,
    /// Cylinder scales of the far side.
    pub cylinder_far: Vec<f64>,
    /// Concave (cavity) scales.
    pub concave: Vec<f64>,
}

/// The scales at one shading point: the near side's per chord bin of a sphere of radius `rho`
/// (mm), and the far side's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LocalScale {
    /// Radius of the bins (1/|H|; ∞ when flat).
    pub rho: f64,
    /// Near side, per bin.
    pub near: [f64; NEAR_BINS],
    /// Far side.
    pub far: f64,
}

impl LocalScale {
    /// No correction.
    pub const ONE: LocalScale = LocalScale { rho: f64::INFINITY, near: [1.0; NEAR_BINS], far: 1.0 };
}

/// The kernel's integrals over a sphere and over a cylinder of radius ρ.
pub struct Gathers<'a> {
    /// [`sphere_gather`] at ρ.
    pub sphere: &'a dyn Fn(f64) -> ([f64; NEAR_BINS], f64),
    /// [`cylinder_gather`] at ρ.
    pub cylinder: &'a dyn Fn(f64) -> ([f64; NEAR_BINS], f64),
}

impl Scales {
    /// The scales of `data`: `gather` the kernel's integrals over a sphere and a cylinder of
    /// radius ρ, `semi` the semi-infinite reflection profile (per unit entering power), `flat`
    /// the model's own flat diffuse reflectance per unit incident power (`semi`'s total through
    /// the renderer's oblique gain, [`super::oblique::Gain::diffuse_weight`]), so that under
    /// uniform light the rendered sphere's escape is the traced one whatever the noise of the
    /// gain's runs (and the engine's flat run, `data.flat`, an independent estimate of the same
    /// quantity, adds none).
    pub fn new(data: &CurvatureData, gather: Gathers<'_>, semi: &dyn RadialProfile, flat: f64) -> Result<Scales> {
        let n = data.rho.len();
        if n == 0 || data.sphere.len() != n || data.cavity.len() != n || data.cylinder.len() != n {
            return Err(Error::Invalid("adaptive table: curvature data of unequal lengths".into()));
        }
        if data.sphere.iter().chain(&data.cylinder).any(|e| e.bins.len() != NEAR_BINS) {
            return Err(Error::Invalid(format!(
                "adaptive table: the sphere and cylinder escapes need {NEAR_BINS} chord bins"
            )));
        }
        if !(flat > 0.0) {
            return Err(Error::param("curvature.flat", flat, "a flat diffuse reflectance > 0"));
        }
        let unit = semi.total() / flat; // escape per incident → the kernel's units
        let (mut convex, mut convex_far, mut concave) = (vec![], vec![], vec![]);
        let (mut cylinder, mut cylinder_far) = (vec![], vec![]);
        for j in 0..n {
            let rho = data.rho[j];
            let (near, far) = convex_scales(&data.sphere[j], (gather.sphere)(rho), unit);
            convex.push(near);
            convex_far.push(far);
            let (near, far) = convex_scales(&data.cylinder[j], (gather.cylinder)(rho), unit);
            cylinder.push(near);
            cylinder_far.push(far);
            let f = semi.cdf(2.0 * rho);
            concave.push(if f > 0.0 { data.cavity[j].mean / flat / f } else { 1.0 });
        }
        let ln_rho = data.rho.iter().map(|r| r.ln()).collect();
        Ok(Scales { ln_rho, convex, convex_far, cylinder, cylinder_far, concave })
    }

    /// The scales at mean curvature `h` (mm⁻¹; > 0 convex, < 0 concave, 0 flat: none), ρ = 1/|h|,
    /// as on a sphere (cavity): [`Scales::at_principal`] with κ₁ = κ₂ = h.
    pub fn at(&self, h: f64) -> LocalScale {
        self.at_principal(h, h)
    }

    /// The scales at principal curvatures `k1`, `k2` (mm⁻¹, either order). Mean curvature
    /// H = (κ₁ + κ₂)/2 ≤ 0: the cavity of radius 1/|H| (1 when flat). H > 0: with κ₁ ≥ κ₂ the
    /// bins of radius ρ = 1/κ₁ and the mixture of the sphere's and the cylinder's scales of
    /// radius ρ with weight w = (max(κ₂, 0)/κ₁)² on the sphere (1 a sphere, 0 a tube or a
    /// saddle's convex direction). The square, not the ratio itself, was measured: a marble torus
    /// (tube 2.5 mm, κ₂/κ₁ = 0.26 on its outer side) in uniform light is +4.5, +2.5, +0.9 % off
    /// the random walk with the ratio, +2.9, +1.2, −0.2 % with its square, +2.5, +1.0, −0.4 % as
    /// a pure cylinder (`docs/render.md`).
    pub fn at_principal(&self, k1: f64, k2: f64) -> LocalScale {
        let (k1, k2) = if k1 >= k2 { (k1, k2) } else { (k2, k1) };
        let h = 0.5 * (k1 + k2);
        if h == 0.0 || !h.is_finite() {
            return LocalScale::ONE;
        }
        if h < 0.0 {
            let rho = 1.0 / h.abs();
            let s = self.interp(|j| self.concave[j], rho);
            return LocalScale { rho, near: [s; NEAR_BINS], far: s };
        }
        let rho = 1.0 / k1;
        let w = (k2.max(0.0) / k1).min(1.0).powi(2);
        let mix = |a: f64, b: f64| w * a + (1.0 - w) * b;
        let near = std::array::from_fn(|b| {
            mix(self.interp(|j| self.convex[j][b], rho), self.interp(|j| self.cylinder[j][b], rho))
        });
        let far = mix(self.interp(|j| self.convex_far[j], rho), self.interp(|j| self.cylinder_far[j], rho));
        LocalScale { rho, near, far }
    }

    /// Node values `s(j)` at radius `rho`: linear in ln ρ, held below the first node, → 1 as
    /// ρ_n/ρ beyond the last.
    fn interp(&self, s: impl Fn(usize) -> f64, rho: f64) -> f64 {
        let x = rho.ln();
        let n = self.ln_rho.len();
        if x <= self.ln_rho[0] {
            return s(0);
        }
        if x >= self.ln_rho[n - 1] {
            return 1.0 + (s(n - 1) - 1.0) * (self.ln_rho[n - 1] - x).exp();
        }
        let i = self.ln_rho.partition_point(|&v| v <= x) - 1;
        let t = (x - self.ln_rho[i]) / (self.ln_rho[i + 1] - self.ln_rho[i]);
        (1.0 - t) * s(i) + t * s(i + 1)
    }
}

/// The CDF of `p` at `r`, 1 at r = ∞ (the bins' open end; flat points have every edge there).
fn cdf_at(p: &dyn RadialProfile, r: f64) -> f64 {
    if r.is_finite() {
        p.cdf(r)
    } else {
        1.0
    }
}

/// A near-side profile scaled per chord bin: s_b·R(r) for r in bin b of [`bin_edges`] (the
/// kernel of `render::adaptive` at a curved point).
#[derive(Clone)]
pub struct Binned {
    base: Mix,
    edges: [f64; NEAR_BINS + 1],
    /// s_b · (mass of the base in bin b), and the cumulative sums.
    mass: [f64; NEAR_BINS],
    cum: [f64; NEAR_BINS + 1],
    s: [f64; NEAR_BINS],
}

impl Binned {
    /// `base` scaled by `sc` (its bins and near-side scales).
    pub fn new(base: Mix, sc: &LocalScale) -> Binned {
        let edges = bin_edges(sc.rho);
        let t = base.total();
        let f: [f64; NEAR_BINS + 1] = std::array::from_fn(|b| cdf_at(&base, edges[b]));
        let mass: [f64; NEAR_BINS] = std::array::from_fn(|b| sc.near[b] * t * (f[b + 1] - f[b]).max(0.0));
        let mut cum = [0.0; NEAR_BINS + 1];
        for b in 0..NEAR_BINS {
            cum[b + 1] = cum[b] + mass[b];
        }
        Binned { base, edges, mass, cum, s: sc.near }
    }
    /// The chord bin of radius `r` (mm).
    #[inline(always)]
    pub fn bin(&self, r: f64) -> usize {
        self.edges[1..NEAR_BINS].partition_point(|&e| e <= r)
    }
    /// Whether `other` has the same bins (then [`Binned::bin`] of one serves both).
    pub fn same_bins(&self, other: &Binned) -> bool {
        self.edges == other.edges
    }
    /// [`RadialProfile::rd_ln`] without the trait objects ([`Mix::value_ln`]): the adaptive
    /// kernel's tree walk.
    #[inline(always)]
    pub fn value_ln(&self, r: f64, ln_r: f64) -> f64 {
        self.value_ln_in(self.bin(r), r, ln_r)
    }
    /// [`Binned::value_ln`] given `r`'s bin `b` ([`Binned::bin`]).
    #[inline(always)]
    pub fn value_ln_in(&self, b: usize, r: f64, ln_r: f64) -> f64 {
        self.s[b] * self.base.value_ln(r, ln_r)
    }
    /// [`cylinder_mass`] of this near side and the far side `t` on the cylinder of its bins'
    /// radius `rho` (the base's CDF per point, scaled per bin: half the work).
    pub fn cylinder_mass(&self, t: &dyn RadialProfile, rho: f64) -> f64 {
        debug_assert!(self.edges[1] == bin_edges(rho)[1]);
        let (near, far) = unit_steps();
        let one = [1.0; NEAR_BINS];
        mass_on(near, rho, self.base.total(), |x| self.base.cdf(x), &self.s)
            + mass_on(far, rho, t.total(), |x| t.cdf(x), &one)
    }
}

impl RadialProfile for Binned {
    fn rd(&self, r: f64) -> f64 {
        self.s[self.bin(r)] * self.base.rd(r)
    }
    fn rd_ln(&self, r: f64, ln_r: f64) -> f64 {
        self.value_ln(r, ln_r)
    }
    fn reach(&self) -> f64 {
        self.base.reach()
    }
    fn total(&self) -> f64 {
        self.cum[NEAR_BINS]
    }
    fn cdf(&self, r: f64) -> f64 {
        if !(self.total() > 0.0) {
            return 0.0;
        }
        let b = self.bin(r);
        let part = self.s[b] * self.base.total() * (cdf_at(&self.base, r) - cdf_at(&self.base, self.edges[b])).max(0.0);
        ((self.cum[b] + part) / self.total()).min(1.0)
    }
    fn sample_r(&self, u: f64) -> f64 {
        let x = u * self.total();
        let b = self.cum[1..].partition_point(|&c| c < x).min(NEAR_BINS - 1);
        let frac = if self.mass[b] > 0.0 { ((x - self.cum[b]) / self.mass[b]).clamp(0.0, 1.0) } else { 0.0 };
        let (lo, hi) = (cdf_at(&self.base, self.edges[b]), cdf_at(&self.base, self.edges[b + 1]));
        self.base.sample_r(lo + frac * (hi - lo))
    }
}
