//! Exact Monte Carlo transport in curved media with analytic geometry (no mesh): the fraction of
//! uniform diffuse light that leaves a homogeneous or layered **sphere** of radius ρ, the medium
//! around a **spherical cavity** of radius ρ (concave), or an infinite **cylinder** of radius ρ.
//! These are the references of the `adaptive` model's curvature correction
//! ([`crate::bssrdf::adaptive`]).
//!
//! Under uniform, isotropic radiance outside the medium (inside the cavity) every point of these
//! surfaces receives the same Lambertian irradiance, so by symmetry one entry point suffices: the
//! photon is launched at (ρ, 0, 0) with the engine's diffuse source (Malley's cosine-weighted
//! direction refracted by Fresnel–Snell, `mc::source`; weight 1 − R_sp(θ)) and traced until it
//! leaves through the outer surface anywhere. The result is the diffuse reflectance per unit
//! *incident* power (specular excluded), directly comparable with the engine's flat
//! [`crate::mc::tally::totals::Total::Diffuse`] under [`crate::mc::Source::Diffuse`].
//!
//! Physics and order of draws as the engine's kernel (`mc::kernel`, MCML, Wang, Jacques & Zheng
//! 1995 §3): free paths s = −ln ξ consumed across interfaces, all-or-none Fresnel at every
//! interface (the unpolarised [`fr_dielectric_cos_t`]; none at matched indices; total internal
//! reflection), implicit capture w ← w σs/σt, the layer's phase function ([`Phase::sample`]) with
//! the azimuth from a disc point, Russian roulette at [`ROULETTE_THRESHOLD`]·w₀ with survival
//! 1/[`ROULETTE_M`]; photon k uses `PhotonRng::new(seed, k)`. Interfaces are curved: reflection
//! and refraction about the local radial normal (projected on the xy-plane for the cylinder).
//!
//! Layers: the stack's layer i occupies depths [z_i, z_{i+1}) below the lit surface, i.e. radii
//! ρ − z (sphere, cylinder) or ρ + z (cavity); the deepest layer fills the rest (to the centre or
//! the axis, or to infinity around a cavity), whatever its own thickness. Photons are summed in
//! chunks of [`CHUNK`] in photon order, so the result is the same bits for any thread count.

use crate::error::{Error, Result};
use crate::mc::config::{ROULETTE_M, ROULETTE_THRESHOLD};
use crate::mc::source::Launcher;
use crate::mc::tally::totals::mean_stderr;
use crate::mc::Source;
use crate::medium::Stack;
use crate::optics::{fr_dielectric_cos_t, spin, Phase};
use crate::rng::PhotonRng;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

/// Photons per chunk (the unit of parallel work, of cancellation and of progress).
pub const CHUNK: u64 = 1024;

/// Interactions after which a history counts as trapped (its weight is lost, as the engine's
/// [`crate::mc::MAX_HITS_WITHOUT_INTERACTION`]): never reached by an allowed input.
const MAX_EVENTS: u64 = 100_000_000;

/// The curved geometries.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Curved {
    /// A sphere of radius ρ (convex; mean curvature 1/ρ).
    Sphere,
    /// A spherical cavity of radius ρ in an infinite medium (concave; mean curvature −1/ρ).
    Cavity,
    /// An infinite circular cylinder of radius ρ (convex; mean curvature 1/(2ρ)).
    Cylinder,
}

/// Bins of the escapes through the entry's half by chord: bin b holds chords c (mm, from the
/// entry point to the exit point) with c² / (2ρ²) in [b/N, (b+1)/N) (equal areas of a
/// hemisphere, whose area within chord c is πc²).
pub const NEAR_BINS: usize = 8;

/// The escape fraction of a run: mean and standard error over photons.
#[derive(Clone, Debug, PartialEq)]
pub struct Escape {
    /// Diffuse reflectance per unit incident power (all that leaves, specular excluded).
    pub mean: f64,
    /// Its standard error.
    pub stderr: f64,
    /// The part that leaves through the entry's half (x > 0: the hemisphere around the entry
    /// point of a sphere or cavity, the half of a cylinder), and its standard error.
    pub near: f64,
    /// See `near`.
    pub near_stderr: f64,
    /// `near` by chord bin ([`NEAR_BINS`]; they sum to `near` up to rounding).
    pub bins: Vec<f64>,
    /// The escaped weight's mean exit offset (mm) along the tangent y at the entry point (the
    /// plane of a [`Source::Pencil`] beam's refracted direction, which points to +y): how far a
    /// collimated beam's light moves forward before it leaves (0 by symmetry under diffuse light;
    /// 0 where not tallied).
    pub shift: f64,
    /// The first azimuthal harmonic of the escapes about the entry's normal: Σ w cos φ per
    /// photon, φ the exit point's azimuth from the tangent y, per chord bin of the near half
    /// ([`NEAR_BINS`]) and then the far half (its bins' share leaving forward minus backward;
    /// empty where not tallied).
    pub harmonic: Vec<f64>,
}

#[derive(Clone, Copy, Debug)]
struct Shell {
    /// Radius of the shell's face towards the lit surface (`r_top`) and away from it, mm.
    r_top: f64,
    r_bot: f64,
    n: f64,
    sigma_t: f64,
    keep: f64,
    phase: Phase,
}

struct Geometry {
    kind: Curved,
    shells: Vec<Shell>,
    n_above: f64,
    launcher: Launcher,
}

impl Geometry {
    fn new(stack: &Stack, kind: Curved, rho: f64, source: Source) -> Result<Geometry> {
        let b = stack.boundaries();
        let nl = stack.layers.len();
        let mut shells = vec![];
        for (i, l) in stack.layers.iter().enumerate() {
            let (z0, z1) = (b[i], if i + 1 == nl { f64::INFINITY } else { b[i + 1] });
            let (r_top, r_bot) = match kind {
                Curved::Cavity => (rho + z0, rho + z1),
                _ => (rho - z0, (rho - z1).max(0.0)),
            };
            if kind != Curved::Cavity && r_top <= 0.0 {
                break; // the layers below the centre are not part of the object
            }
            let st = l.sigma_t();
            if !(st > 0.0) {
                return Err(Error::Invalid(format!("curved transport: layer {i} does not interact (σt = 0)")));
            }
            shells.push(Shell { r_top, r_bot, n: l.n, sigma_t: st, keep: l.mus / st, phase: l.phase });
        }
        let deep = shells.last().expect("a stack has a layer");
        if kind == Curved::Cavity && !(deep.keep < 1.0) {
            return Err(Error::Invalid(
                "curved transport: a cavity needs an absorbing deepest layer (σa > 0), or light wanders off for ever"
                    .into(),
            ));
        }
        let launcher = Launcher::new(source, stack.n_above, stack.layers[0].n);
        Ok(Geometry { kind, shells, n_above: stack.n_above, launcher })
    }

    /// The radial unit vector at `p` (projected on the xy-plane for the cylinder) and |p⊥|.
    fn radial(&self, p: [f64; 3]) -> ([f64; 3], f64) {
        let z = if self.kind == Curved::Cylinder { 0.0 } else { p[2] };
        let r = (p[0] * p[0] + p[1] * p[1] + z * z).sqrt();
        ([p[0] / r, p[1] / r, z / r], r)
    }

    /// Distance along `u` from `p` to the sphere (cylinder) of radius `big` outwards and `small`
    /// inwards; returns (distance, whether the face hit is the outer one).
    fn to_face(&self, p: [f64; 3], u: [f64; 3], small: f64, big: f64) -> (f64, bool) {
        let cyl = self.kind == Curved::Cylinder;
        let a = if cyl { u[0] * u[0] + u[1] * u[1] } else { 1.0 };
        if a <= 0.0 {
            return (f64::INFINITY, true);
        }
        let bz = if cyl { 0.0 } else { p[2] * u[2] };
        let b = p[0] * u[0] + p[1] * u[1] + bz;
        let r2 = p[0] * p[0] + p[1] * p[1] + if cyl { 0.0 } else { p[2] * p[2] };
        if small > 0.0 && b < 0.0 {
            let disc = b * b - a * (r2 - small * small);
            if disc >= 0.0 {
                return ((-b - disc.sqrt()).max(0.0) / a, false);
            }
        }
        if big.is_finite() {
            let disc = (b * b - a * (r2 - big * big)).max(0.0);
            return ((-b + disc.sqrt()).max(0.0) / a, true);
        }
        (f64::INFINITY, true)
    }

    /// The chord bin of an exit point `p` in the entry's half (x > 0), else `None`.
    fn near_bin(&self, p: [f64; 3], rho: f64) -> Option<usize> {
        if !(p[0] > 0.0) {
            return None;
        }
        let c2 = (p[0] - rho).powi(2) + p[1] * p[1] + p[2] * p[2];
        Some(((c2 / (2.0 * rho * rho) * NEAR_BINS as f64) as usize).min(NEAR_BINS - 1))
    }

    /// One photon's escaped weight, exit point, launch direction in the engine's frame (z into
    /// the medium) and near chord bin, and its exit direction (outside).
    fn trace_path(&self, seed: u64, photon: u64) -> (f64, [f64; 3], [f64; 3], Option<usize>, [f64; 3]) {
        let mut rng = PhotonRng::new(seed, photon);
        let (d, rsp) = self.launcher.launch(&mut rng);
        let w0 = 1.0 - rsp;
        if !(w0 > 0.0) {
            return (0.0, [0.0; 3], d, None, [0.0; 3]);
        }
        let rho = self.shells[0].r_top;
        // engine frame (z into the medium) → the entry point (ρ, 0, 0), inward ∓x
        let inward = if self.kind == Curved::Cavity { 1.0 } else { -1.0 };
        let mut u = [inward * d[2], d[0], d[1]];
        let mut p = [rho, 0.0, 0.0];
        let (mut w, w_min) = (w0, ROULETTE_THRESHOLD * w0);
        let (mut k, mut s_left) = (0usize, 0.0f64);
        for _ in 0..MAX_EVENTS {
            let sh = &self.shells[k];
            let (small, big) = if self.kind == Curved::Cavity { (sh.r_top, sh.r_bot) } else { (sh.r_bot, sh.r_top) };
            if s_left <= 0.0 {
                s_left = -rng.uniform().ln();
            }
            let s = s_left / sh.sigma_t;
            let (t, outer) = self.to_face(p, u, small, big);
            if s >= t {
                s_left -= t * sh.sigma_t;
                let r_face = if outer { big } else { small };
                p = [p[0] + t * u[0], p[1] + t * u[1], p[2] + t * u[2]];
                let (nr, r) = self.radial(p);
                let f = r_face / r; // snap onto the face
                p = [p[0] * f, p[1] * f, if self.kind == Curved::Cylinder { p[2] } else { p[2] * f }];
                let up = outer != (self.kind == Curved::Cavity); // towards the lit surface
                let n_next = if up {
                    if k == 0 {
                        self.n_above
                    } else {
                        self.shells[k - 1].n
                    }
                } else {
                    self.shells[k + 1].n
                };
                match cross(&mut u, nr, sh.n, n_next, &mut rng) {
                    false => {}
                    true if up && k == 0 => return (w, p, d, self.near_bin(p, rho), u),
                    true => k = if up { k - 1 } else { k + 1 },
                }
                continue;
            }
            p = [p[0] + s * u[0], p[1] + s * u[1], p[2] + s * u[2]];
            s_left = 0.0;
            w *= sh.keep;
            let cos_t = sh.phase.sample(rng.uniform());
            let (x, y) = rng.disc_point();
            let r2 = x * x + y * y;
            u = spin(u, cos_t, (x * x - y * y) / r2, 2.0 * x * y / r2);
            if w < w_min {
                if rng.uniform() * ROULETTE_M <= 1.0 {
                    w *= ROULETTE_M;
                } else {
                    return (0.0, [0.0; 3], d, None, [0.0; 3]);
                }
            }
        }
        (0.0, [0.0; 3], d, None, [0.0; 3])
    }
}

/// All-or-none Fresnel at a curved interface of radial normal `nr` between indices `n1` (the
/// photon's side) and `n2`: reflect `u` about the face (false) or refract it through (true).
fn cross(u: &mut [f64; 3], nr: [f64; 3], n1: f64, n2: f64, rng: &mut PhotonRng) -> bool {
    let un = u[0] * nr[0] + u[1] * nr[1] + u[2] * nr[2];
    let cos_i = un.abs().min(1.0);
    let m = if un >= 0.0 { nr } else { [-nr[0], -nr[1], -nr[2]] }; // along the travel
    let (r, cos_t) = if n1 == n2 { (0.0, cos_i) } else { fr_dielectric_cos_t(cos_i, n1, n2) };
    if r >= 1.0 || (r > 0.0 && rng.uniform() <= r) {
        *u = [u[0] - 2.0 * un * nr[0], u[1] - 2.0 * un * nr[1], u[2] - 2.0 * un * nr[2]];
        return false;
    }
    let eta = n1 / n2;
    let k = cos_t - eta * cos_i;
    let v = [eta * u[0] + k * m[0], eta * u[1] + k * m[1], eta * u[2] + k * m[2]];
    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    *u = [v[0] / l, v[1] / l, v[2] / l];
    true
}

/// The escape fraction of uniform diffuse light from `kind` of radius `rho` (mm) made of `stack`
/// (see the module docs): `photons` photons of stream `seed`; `threads` workers (`None`: all
/// cores). `None` when `cancel` stopped it; `progress` counts photons.
#[allow(clippy::too_many_arguments)] // the engine's run inputs, spelled out
pub fn escape(
    stack: &Stack,
    kind: Curved,
    rho: f64,
    photons: u64,
    seed: u64,
    threads: Option<usize>,
    cancel: &AtomicBool,
    progress: &AtomicU64,
) -> Result<Option<Escape>> {
    let e = escape_from(stack, kind, rho, Source::Diffuse, photons, seed, threads, cancel, progress)?;
    // 0 by symmetry under diffuse light: the tables keep no noise of them
    Ok(e.map(|e| Escape { shift: 0.0, harmonic: vec![], ..e }))
}

/// [`escape`] with the engine's launch `source` at the entry point (ρ, 0, 0) instead of the
/// diffuse one: [`Source::Pencil`] `{ theta, phi: 0 }` is a collimated beam at polar angle θi to
/// the entry's normal (in the plane z = 0), the light a sphere receives from a sun at the points
/// θi away from the sub-solar point. The tallies are per unit incident power, as [`escape`]'s.
#[allow(clippy::too_many_arguments)] // the engine's run inputs, spelled out
pub fn escape_from(
    stack: &Stack,
    kind: Curved,
    rho: f64,
    source: Source,
    photons: u64,
    seed: u64,
    threads: Option<usize>,
    cancel: &AtomicBool,
    progress: &AtomicU64,
) -> Result<Option<Escape>> {
    if !(rho > 0.0 && rho.is_finite()) {
        return Err(Error::param("rho", rho, "a radius > 0 (mm)"));
    }
    if photons < 2 {
        return Err(Error::param("photons", photons as f64, "an integer >= 2"));
    }
    let g = Geometry::new(stack, kind, rho, source)?;
    let chunks = photons.div_ceil(CHUNK);
    const NS: usize = 6 + 2 * NEAR_BINS;
    let work = |c: u64| -> Option<[f64; NS]> {
        if cancel.load(Ordering::Relaxed) {
            return None;
        }
        let (lo, hi) = (c * CHUNK, ((c + 1) * CHUNK).min(photons));
        let mut s = [0.0; NS];
        for k in lo..hi {
            let (x, p, _, near, _) = g.trace_path(seed, k);
            s[0] += x;
            s[1] += x * x;
            s[4] += x * p[1];
            let rt = (p[1] * p[1] + p[2] * p[2]).sqrt();
            let cos_phi = if rt > 0.0 { p[1] / rt } else { 0.0 };
            if let Some(b) = near {
                s[2] += x;
                s[3] += x * x;
                s[5 + b] += x;
                s[5 + NEAR_BINS + b] += x * cos_phi;
            } else {
                s[5 + 2 * NEAR_BINS] += x * cos_phi;
            }
        }
        progress.fetch_add(hi - lo, Ordering::Relaxed);
        Some(s)
    };
    let parts: Vec<Option<[f64; NS]>> = map_chunks(threads, chunks, work)?;
    let mut s = [0.0; NS];
    for p in parts {
        let Some(a) = p else { return Ok(None) };
        (0..NS).for_each(|i| s[i] += a[i]);
    }
    let (mean, stderr) = mean_stderr(s[0], s[1], photons);
    let (near, near_stderr) = mean_stderr(s[2], s[3], photons);
    let bins = s[5..5 + NEAR_BINS].iter().map(|x| x / photons as f64).collect();
    let harmonic = s[5 + NEAR_BINS..].iter().map(|x| x / photons as f64).collect();
    let shift = if s[0] > 0.0 { s[4] / s[0] } else { 0.0 };
    Ok(Some(Escape { mean, stderr, near, near_stderr, bins, shift, harmonic }))
}

/// The exitance of a sphere of radius `rho` (mm) made of `stack` under a sun (collimated light
/// of unit irradiance), by the angle α between the exit point's normal and the direction to the
/// sun: `bins` equal-area bins of cos α from −1 (the anti-solar point) to 1 (the sub-solar
/// point), per unit irradiance (specular excluded). A sun lights the points of a sphere at every
/// θi with the weight cos θi sin θi, which is the diffuse launch's: so each photon of the
/// diffuse launch at (ρ, 0, 0) is a sun photon, the sun's direction is its launch direction
/// before refraction, and only the tally differs from [`escape`] (same photons, same seed).
#[allow(clippy::too_many_arguments)] // the engine's run inputs, spelled out
pub fn sun_exitance(
    stack: &Stack,
    rho: f64,
    bins: usize,
    photons: u64,
    seed: u64,
    threads: Option<usize>,
    cancel: &AtomicBool,
    progress: &AtomicU64,
) -> Result<Option<Vec<f64>>> {
    if !(rho > 0.0 && rho.is_finite()) || bins == 0 || photons < 2 {
        return Err(Error::Invalid("sun exitance: rho > 0 (mm), bins >= 1 and photons >= 2".into()));
    }
    let g = Geometry::new(stack, Curved::Sphere, rho, Source::Diffuse)?;
    let eta = stack.n_above / stack.layers[0].n;
    let work = |c: u64| -> Option<Vec<f64>> {
        if cancel.load(Ordering::Relaxed) {
            return None;
        }
        let (lo, hi) = (c * CHUNK, ((c + 1) * CHUNK).min(photons));
        let mut h = vec![0.0; bins];
        for k in lo..hi {
            let (w, p, d, _, _) = g.trace_path(seed, k);
            if w > 0.0 {
                // the sun's direction before refraction: tangential part d/η, towards the sun −(x, y, z)
                let (x, y) = (d[0] / eta, d[1] / eta);
                let z = (1.0 - x * x - y * y).max(0.0).sqrt();
                let to_sun = [z, -x, -y]; // engine (a, b, c) → world (−c, a, b), negated
                let cos_a = (p[0] * to_sun[0] + p[1] * to_sun[1] + p[2] * to_sun[2]) / rho;
                let j = (((cos_a + 1.0) * 0.5 * bins as f64) as usize).min(bins - 1);
                h[j] += w;
            }
        }
        progress.fetch_add(hi - lo, Ordering::Relaxed);
        Some(h)
    };
    let chunks = photons.div_ceil(CHUNK);
    let parts: Vec<Option<Vec<f64>>> = map_chunks(threads, chunks, work)?;
    let mut h = vec![0.0; bins];
    for p in parts {
        let Some(a) = p else { return Ok(None) };
        h.iter_mut().zip(a).for_each(|(x, y)| *x += y);
    }
    // power πρ²·E into 4πρ²/bins of area per bin
    Ok(Some(h.iter().map(|x| x / photons as f64 * 0.25 * bins as f64).collect()))
}

/// The radiance a sphere of radius `rho` (mm) made of `stack` sends back towards a sun of unit
/// irradiance (the retro-reflection a camera beside the light sees), exactly: the weight leaving
/// within `cone` rad of the sun's direction per unit solid angle (the intensity I; the image mean
/// of the sphere's disk seen from the sun is I/(πρ²)·πρ² = I per unit irradiance), with its
/// standard error; and what an exit radiance symmetric about each exit point's normal would
/// give from the same exits: Σ w·`pred`(μ) with μ = n·ω_sun (`pred`(μ) = the exit distribution's
/// intensity towards ω_sun per unit exiting power, e.g. F_t s μ/(π c)), 0 for μ ≤ 0. Per unit
/// incident power; the photons of [`sun_exitance`]'s launch (same seed, same photons).
pub fn sun_retro(
    stack: &Stack,
    rho: f64,
    cone: f64,
    photons: u64,
    seed: u64,
    pred: impl Fn(f64) -> f64,
) -> Result<(f64, f64, f64)> {
    sun_retro_pairs(stack, rho, cone, photons, seed, |mu, _| pred(mu))
}

/// [`sun_retro`] with an exit model that also sees each exit's pair: `pred`(μ, [`RetroPair`]) with c =
/// t̂·ω_sun,t (t̂ the unit tangential direction at the exit point from the entry point, ω_sun,t the
/// tangential part of the direction to the sun; 0 at the entry point) and r the chord (mm) from
/// the entry point (the exit flow of [`super::flow`]); c is NaN for the exits through the far half
/// (x ≤ 0: the model's far class, which has no flow); a > 0 when the refracted launch direction's
/// tangential part at the entry points towards the exit point ([`sphere_flow`]'s split); μ_i the
/// sun's cosine at the entry and s = ω_sun,t(x_i)·ω_sun,t(x_o) (the exit coupling's dot product);
/// w the exit's weight.
pub fn sun_retro_pairs(
    stack: &Stack,
    rho: f64,
    cone: f64,
    photons: u64,
    seed: u64,
    pred: impl Fn(f64, RetroPair) -> f64,
) -> Result<(f64, f64, f64)> {
    if !(rho > 0.0 && rho.is_finite() && cone > 0.0 && cone < 1.0) || photons < 2 {
        return Err(Error::Invalid("sun retro: rho > 0 (mm), cone in (0, 1) rad and photons >= 2".into()));
    }
    let g = Geometry::new(stack, Curved::Sphere, rho, Source::Diffuse)?;
    let eta = stack.n_above / stack.layers[0].n;
    let (mut hit, mut hit2, mut model) = (0.0, 0.0, 0.0);
    let dom = 2.0 * std::f64::consts::PI * (1.0 - cone.cos());
    for k in 0..photons {
        let (w, p, d, _, u) = g.trace_path(seed, k);
        if w > 0.0 {
            let (x, y) = (d[0] / eta, d[1] / eta);
            let z = (1.0 - x * x - y * y).max(0.0).sqrt();
            let to_sun = [z, -x, -y]; // as in `sun_exitance`
            let mu = (p[0] * to_sun[0] + p[1] * to_sun[1] + p[2] * to_sun[2]) / rho;
            if mu > 0.0 {
                let n = [p[0] / rho, p[1] / rho, p[2] / rho];
                let (c, r) = pair_flow(p, n, rho, to_sun);
                let along = d[0] * p[1] + d[1] * p[2];
                // the sun's tangential parts at the entry (normal +x) and at the exit
                let ti = [0.0, to_sun[1], to_sun[2]];
                let to = [to_sun[0] - mu * n[0], to_sun[1] - mu * n[1], to_sun[2] - mu * n[2]];
                let ss = ti[1] * to[1] + ti[2] * to[2];
                let c = if p[0] > 0.0 { c } else { f64::NAN };
                model += w * pred(mu, RetroPair { c, r, along, mu_i: to_sun[0], ss, w });
            }
            if u[0] * to_sun[0] + u[1] * to_sun[1] + u[2] * to_sun[2] > cone.cos() {
                hit += w / dom;
                hit2 += (w / dom).powi(2);
            }
        }
    }
    let (mean, stderr) = mean_stderr(hit, hit2, photons);
    Ok((mean, stderr, model / photons as f64))
}

/// The renderer's flow term ([`super::flow`]: B(r) t̂·ω_t on pairs weighted by the kernel *without*
/// the entry harmonic) towards a sun, for [`sun_retro`]'s sphere: Σ w `sym`(μ') B(r) c' over the
/// exits through the entry's half, with the sun's direction turned about the entry's normal by a
/// uniform random azimuth (stream (`seed` + 1, k)), so the exits' offsets from the entry carry no
/// harmonic about it while its polar angle (the entry's irradiance) is the photon's own; μ' and c'
/// are the turned sun's. Per unit incident power (add it to [`sun_retro`]'s model).
pub fn sun_retro_flow(
    stack: &Stack,
    rho: f64,
    photons: u64,
    seed: u64,
    sym: impl Fn(f64) -> f64,
    b: impl Fn(f64) -> f64,
) -> Result<f64> {
    let g = Geometry::new(stack, Curved::Sphere, rho, Source::Diffuse)?;
    let eta = stack.n_above / stack.layers[0].n;
    let mut model = 0.0;
    for k in 0..photons {
        let (w, p, d, _, _) = g.trace_path(seed, k);
        if !(w > 0.0 && p[0] > 0.0) {
            continue;
        }
        let (x, y) = (d[0] / eta, d[1] / eta);
        let z = (1.0 - x * x - y * y).max(0.0).sqrt();
        let phi = 2.0 * std::f64::consts::PI * PhotonRng::new(seed.wrapping_add(1), k).uniform();
        let (c, s) = (phi.cos(), phi.sin());
        let (x, y) = (c * x - s * y, s * x + c * y);
        let to_sun = [z, -x, -y];
        let n = [p[0] / rho, p[1] / rho, p[2] / rho];
        let mu = n[0] * to_sun[0] + n[1] * to_sun[1] + n[2] * to_sun[2];
        if mu > 0.0 {
            let (cf, r) = pair_flow(p, n, rho, to_sun);
            if r > 0.0 {
                model += w * sym(mu) * b(r) * cf;
            }
        }
    }
    Ok(model / photons as f64)
}

/// What [`sun_retro_pairs`]' model sees of one exit (see there).
#[derive(Clone, Copy, Debug)]
pub struct RetroPair {
    pub c: f64,
    pub r: f64,
    pub along: f64,
    pub mu_i: f64,
    pub ss: f64,
    /// The exit's weight (the model's term is multiplied by it).
    pub w: f64,
}

/// t̂·v_t and the chord r for an exit at `p` (normal `n`) of the sphere of radius `rho` entered at
/// (ρ, 0, 0): t̂ the unit tangential part of the chord p − (ρ, 0, 0) at p, v_t the tangential part of
/// `v` (0 and 0 at the entry point itself).
fn pair_flow(p: [f64; 3], n: [f64; 3], rho: f64, v: [f64; 3]) -> (f64, f64) {
    let d = [p[0] - rho, p[1], p[2]];
    let r = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    let dn = d[0] * n[0] + d[1] * n[1] + d[2] * n[2];
    let t = [d[0] - dn * n[0], d[1] - dn * n[1], d[2] - dn * n[2]];
    let tl = (t[0] * t[0] + t[1] * t[1] + t[2] * t[2]).sqrt();
    if !(tl > 0.0) {
        return (0.0, r);
    }
    let vn = v[0] * n[0] + v[1] * n[1] + v[2] * n[2];
    let c = ((v[0] - vn * n[0]) * t[0] + (v[1] - vn * n[1]) * t[1] + (v[2] - vn * n[2]) * t[2]) / tl;
    (c, r)
}

/// The exit flow's tally ([`super::flow::FlowTally`]'s layout: weight per (r bin, exit-cosine
/// bin), r the chord in the transport length `ell` (mm), then × cos Δφ about t̂) of the exits of a
/// sphere of radius `rho` under uniform diffuse light through the entry's half (the near class);
/// per incident photon, with standard errors. Single-threaded (a measurement, not a table run).
/// `launch` 0 counts every photon; +1 (−1) only those whose refracted launch direction's
/// tangential part at the entry points towards (away from) the exit point.
pub fn sphere_flow(
    stack: &Stack,
    rho: f64,
    ell: f64,
    photons: u64,
    seed: u64,
    launch: i32,
) -> Result<super::exit::ExitBins> {
    use super::coupling::COUPLING_BINS;
    use super::flow::{FLOW_BINS, FLOW_EDGES};
    if !(rho > 0.0 && rho.is_finite() && ell > 0.0) || photons < 2 {
        return Err(Error::Invalid("sphere flow: rho > 0, ell > 0 (mm) and photons >= 2".into()));
    }
    let g = Geometry::new(stack, Curved::Sphere, rho, Source::Diffuse)?;
    let n = FLOW_BINS * COUPLING_BINS;
    let (mut s1, mut s2) = (vec![0.0; 2 * n], vec![0.0; 2 * n]);
    for k in 0..photons {
        let (w, p, d, _, u) = g.trace_path(seed, k);
        if !(w > 0.0 && p[0] > 0.0) {
            continue;
        }
        // the launch's tangential part at the entry (0, d₀, d₁) against the chord's (0, p₁, p₂)
        let along = d[0] * p[1] + d[1] * p[2];
        if (launch > 0 && !(along > 0.0)) || (launch < 0 && !(along < 0.0)) {
            continue;
        }
        let nn = [p[0] / rho, p[1] / rho, p[2] / rho];
        let mu = (u[0] * nn[0] + u[1] * nn[1] + u[2] * nn[2]).clamp(0.0, 1.0);
        let (c, r) = pair_flow(p, nn, rho, u);
        let st = (1.0 - mu * mu).sqrt();
        let j = ((mu * COUPLING_BINS as f64) as usize).min(COUPLING_BINS - 1);
        let b = FLOW_EDGES.partition_point(|&e| e <= r / ell) * COUPLING_BINS + j;
        s1[b] += w;
        s2[b] += w * w;
        if st > 0.0 {
            let x = w * c / st;
            s1[n + b] += x;
            s2[n + b] += x * x;
        }
    }
    let (weight, stderr) = s1.iter().zip(&s2).map(|(&a, &b)| mean_stderr(a, b, photons)).unzip();
    Ok(super::exit::ExitBins { weight, stderr })
}

/// `work` over the chunk indices 0..`chunks` in parallel, results in index order: on a pool of
/// `threads` threads, or rayon's global pool for `None`.
fn map_chunks<T: Send>(threads: Option<usize>, chunks: u64, work: impl Fn(u64) -> T + Sync + Send) -> Result<Vec<T>> {
    match threads {
        Some(n) => Ok(rayon::ThreadPoolBuilder::new()
            .num_threads(n.max(1))
            .build()
            .map_err(|e| Error::Invalid(format!("curved transport: no thread pool ({e})")))?
            .install(|| (0..chunks).into_par_iter().map(work).collect())),
        None => Ok((0..chunks).into_par_iter().map(work).collect()),
    }
}

#[cfg(test)]
#[path = "curved_tests.rs"]
mod tests;
