//! `hierarchical`: H. W. Jensen and J. Buhler, "A rapid hierarchical rendering technique for
//! translucent materials", ACM TOG 21(3) (SIGGRAPH 2002).
//!
//! 1. Irradiance samples spread evenly over each translucent object: every triangle is cut
//!    into k² congruent sub-triangles (k = ⌈√A / Δ⌉) and a sample sits at each centroid,
//!    carrying the sub-triangle's area. The spacing Δ is `spacing` × the smallest median
//!    radius of the object's profiles (the radius holding half of R_d's energy), so the
//!    density follows the mean free path as in the paper (§3.1).
//! 2. The transmitted irradiance E_t = ∫ F_t L_i cos dω at each sample
//!    ([`super::irradiance`]; for `adaptive` each direction also weighted by the oblique gain): every light by shadow rays (`light_samples` each) and the rest
//!    (the visible environment, light reflected by other surfaces) by `env_samples` cosine
//!    gathering rays. Translucent surfaces those rays reach are black in a first gathering; if
//!    any ray reached one, the samples are gathered again with the first trees as their
//!    radiance (one bounce of light between translucent surfaces; a quarter of the rays that
//!    reach a translucent surface evaluate it, weighted 4×: Russian roulette, the same
//!    expectation at a quarter of the tree walks; those walks use coarser clusters evaluated at
//!    their sigma points, [`Cut`]).
//! 3. An octree over the samples; each node keeps its area, its power Σ E_t A per channel and
//!    the power-weighted centroid (§3.2).
//! 4. At a shading point x_o the tree is walked: a node is used as a whole when its solid
//!    angle ΔΩ = A_node/‖x_o − centroid‖² is below `epsilon` and x_o is outside its box
//!    (the paper's error criterion, §3.3); otherwise its children (or samples) are visited.
//!    Nodes wholly beyond the kernel's reach (10⁻⁶ of its energy) are skipped.
//!    M_o = Σ R_d(‖x_o − x_j‖) P_j, and L_o = F_t(η, ω_o) M_o /(π c(η)) (see `material`),
//!    plus the single-scattering term S⁽¹⁾ ([`super::shade::single_scattering`]). For
//!    `adaptive` under lights every pair (sample or cluster) is also weighted by the entry's
//!    azimuthal factor ([`crate::bssrdf::harmonic`]: the samples carry their lights' harmonic,
//!    the nodes its power-weighted mean), and the near class' radiance carries the exit
//!    direction's coupling to the light's ([`crate::bssrdf::coupling`]: the samples carry their
//!    lights' vector D, the nodes its power-weighted mean, [`Tree::exitance_coupled`]).

use super::accel::Hit;
use super::driver::Control;
use super::fastmath;
use super::irradiance::{irradiance_and_harmonic, transmitted_irradiance, Coupled, Entry, Unlit};
use super::material::Translucent;
use super::math::{add, dot, length, madd, mul, scale, sub, Rgb, V3};
use super::scene::Scene;
use super::shade::{ft, single_scattering, tint, Translucency};
use super::texture::shading_medium;
use crate::bssrdf::harmonic::{factors, AtRho, Lobe};
use crate::bssrdf::RadialProfile;
use crate::error::{Error, Result};
use crate::rng::PhotonRng;
use rayon::prelude::*;
use std::f64::consts::PI;
use std::sync::atomic::Ordering;

/// Settings of the hierarchical method.
#[derive(Clone, Copy, Debug)]
pub struct HierarchicalParams {
    /// Sample spacing as a fraction of the smallest median profile radius.
    pub spacing: f64,
    /// Largest solid angle (sr) of a node used as a cluster.
    pub epsilon: f64,
    /// Cosine-weighted gathering rays per irradiance sample (environment and light reflected
    /// by other surfaces; see [`super::irradiance`]).
    pub env_samples: u32,
    /// Samples of each light per irradiance sample.
    pub light_samples: u32,
    /// Most irradiance samples per object (Δ grows to respect it). The default, 250 000, binds
    /// only where the profile is short against the object (a 10 mm sphere of ≥ 5 marble
    /// diffusion lengths): the near field then integrates the profile's peak exactly over a
    /// mean irradiance, and the set-up costs an eighth of 2 000 000 samples' (the validation
    /// matrix's 100 L sphere: object means within their seed-to-seed noise, `docs/render.md`).
    pub max_samples: usize,
}

impl Default for HierarchicalParams {
    fn default() -> Self {
        HierarchicalParams { spacing: 0.35, epsilon: 0.05, env_samples: 64, light_samples: 16, max_samples: 250_000 }
    }
}

impl HierarchicalParams {
    pub fn validate(&self) -> Result<()> {
        if !(self.spacing > 0.0 && self.spacing.is_finite()) {
            return Err(Error::param("hierarchical.spacing", self.spacing, "a finite number > 0"));
        }
        if !(self.epsilon >= 0.0 && self.epsilon.is_finite()) {
            return Err(Error::param("hierarchical.epsilon", self.epsilon, "a finite number >= 0 (sr)"));
        }
        if self.light_samples == 0 || self.max_samples == 0 {
            return Err(Error::Invalid("hierarchical.light_samples and max_samples must be >= 1".into()));
        }
        Ok(())
    }
}

/// One irradiance sample.
#[derive(Clone, Copy, Debug)]
pub struct Sample {
    pub p: V3,
    pub area: f64,
    /// Transmitted irradiance E_t per channel.
    pub e: Rgb,
    /// The surface normal (unit).
    pub n: V3,
    /// The azimuthal harmonic of its light per class and channel (`adaptive` under lights; else
    /// none).
    pub m: [[Lobe; 3]; 2],
    /// Its light's exit-coupling vector per channel ([`Coupled`]; `adaptive` under lights; else 0).
    pub d: Coupled,
}

#[derive(Clone, Copy, Debug)]
struct Node {
    lo: V3,
    hi: V3,
    area: f64,
    power: Rgb,
    centroid: V3,
    /// The unit mean normal, and per class and channel the lobe of the power-weighted mean
    /// harmonic vector Σ m E_t A / Σ E_t A.
    n: V3,
    m: [[Lobe; 3]; 2],
    /// Per channel the power-weighted mean exit-coupling vector Σ d E_t A / Σ E_t A.
    d: Coupled,
    /// The cluster's sigma points are centroid ± each of these: √3 × the columns of a square
    /// root of the power-weighted covariance of the members' positions ([`sigma_axes`]).
    axes: [V3; 3],
    /// The largest over the smallest of the members' irradiance (channel sums; ∞ with a dark one).
    contrast: f64,
    /// Children `first .. first + count` (nodes) or samples (leaf).
    first: u32,
    count: u32,
    leaf: bool,
}

/// The samples of one object and their octree.
pub struct Tree {
    pub samples: Vec<Sample>,
    nodes: Vec<Node>,
    /// Radius ρ₀ of the near field (mm): [`NEAR_FIELD`] sample spacings.
    pub rho0: f64,
    /// Whether any sample has a harmonic (then every pair is weighted by its factor).
    harm: bool,
    /// Whether any sample has an exit-coupling vector ([`Tree::exitance_coupled`]).
    pub coupled: bool,
}

const LEAF_SIZE: usize = 8;

/// The near field's radius in sample spacings Δ (see [`Tree::exitance`]).
pub const NEAR_FIELD: f64 = 2.0;

impl Tree {
    pub(crate) fn build(mut samples: Vec<Sample>, delta: f64) -> Tree {
        let mut nodes = vec![];
        let n = samples.len();
        build_node(&mut samples, 0, n, &mut nodes, 0);
        let harm = samples.iter().any(|s| s.m.iter().flatten().any(|l| l.a != 0.0));
        let coupled = samples.iter().any(|s| s.d.iter().flatten().any(|&x| x != 0.0));
        Tree { samples, nodes, rho0: NEAR_FIELD * delta, harm, coupled }
    }

    /// Σ R_d(‖x − x_j‖) E_j A_j with clusters under `epsilon` (0: exact all-pairs sum), with the
    /// peak of R_d near x integrated exactly (singularity subtraction): R_d = R_far + R_near with
    /// R_far = min(R_d, R_d(ρ₀)) (flat-topped inside ρ₀, sampled at the points x_j, which the
    /// point rule integrates accurately) and R_near = (R_d − R_d(ρ₀))₊, whose energy
    /// total·cdf(ρ₀) − πρ₀² R_d(ρ₀) is given the mean irradiance of the samples within ρ₀
    /// (the surface taken as flat there). Profiles that peak at r → 0 on the scale of the sample
    /// spacing (single scattering: photon beam diffusion, normalized diffusion, Monte Carlo)
    /// otherwise lose or gain 6–10 % of a flat slab's exitance (measured; the point rule
    /// under-samples a convex peak).
    pub fn exitance(&self, m: &Translucent, x: V3, epsilon: f64) -> Rgb {
        self.exitance_with(&Flat(m.profiles()), x, epsilon)
    }

    /// [`exitance`](Self::exitance) with the profiles chosen per pair by `pp` (the adaptive
    /// model's near side and far side, `render::adaptive`); each class has its own near field.
    /// A node of the far class (1) whose lateral offsets r⊥ may reach below ρ₀ (centroid's r⊥ <
    /// ρ₀ + the box's diagonal) is never a cluster, so the far class' own near field (the samples
    /// behind x, far from x in space) always reaches the leaves and its peak is counted. (Without
    /// this, those samples were clustered and the far class' near-field energy was lost: an
    /// optically small ketchup sphere, 10 mm at 0.59 × ketchup, under uniform light: red −37 %
    /// against the all-pairs sum; `docs/render.md`.)
    pub fn exitance_with(&self, pp: &dyn PairProfiles, x: V3, epsilon: f64) -> Rgb {
        let [a, b] = self.exitance_classes(pp, x, epsilon);
        add(a, b)
    }

    /// [`exitance_with`](Self::exitance_with) per class of `pp` (0: the near side, 1: across):
    /// the adaptive model gives each class its own exit term.
    pub fn exitance_classes(&self, pp: &dyn PairProfiles, x: V3, epsilon: f64) -> [Rgb; 2] {
        self.exitance_cut(pp, x, Cut { epsilon, sigma: false, coarse: 0.0 })
    }

    /// [`exitance_classes`](Self::exitance_classes) with the clusters of `cut`.
    pub fn exitance_cut(&self, pp: &dyn PairProfiles, x: V3, cut: Cut) -> [Rgb; 2] {
        self.sums(pp, x, cut, false).0
    }

    /// [`exitance_cut`](Self::exitance_cut) and, per channel, the near class' sum of each pair's
    /// contribution × its entry's exit-coupling vector ([`Coupled`]; the clusters' power-weighted
    /// mean, the near field's area-weighted): the near class' radiance leaving towards ω_o is then
    /// (near + V·ω_o,t) × its exit term ([`crate::bssrdf::coupling`]).
    pub fn exitance_coupled(&self, pp: &dyn PairProfiles, x: V3, cut: Cut) -> ([Rgb; 2], Coupled) {
        self.sums(pp, x, cut, true)
    }

    fn sums(&self, pp: &dyn PairProfiles, x: V3, cut: Cut, coupled: bool) -> ([Rgb; 2], Coupled) {
        let epsilon = cut.epsilon;
        let rho0 = self.rho0;
        let cap: [Rgb; 2] = std::array::from_fn(|c| std::array::from_fn(|k| pp.profile(c, k).rd(rho0)));
        let rd = |c: usize, r: f64| -> Rgb {
            let ln_r = fastmath::ln(r); // once for the three channels' profiles
            std::array::from_fn(|k| {
                pp.profile(c, k).rd_ln(r, ln_r).min(if r < rho0 { cap[c][k] } else { f64::INFINITY })
            })
        };
        let (mut acc, mut near_e, mut near_a) = ([[0.0; 3]; 2], [[0.0; 3]; 2], [0.0; 2]);
        let (mut vd, mut near_d) = ([[0.0; 3]; 3], [[0.0; 3]; 3]);
        let target = pp.target();
        let mut mass = [0.0; 3]; // Σ profile × area (for `target`)
        let mut stack = vec![0u32];
        while let Some(i) = stack.pop() {
            let nd = &self.nodes[i as usize];
            // nodes wholly beyond the kernel's reach hold none of its energy
            if pp.beyond(x, nd.lo, nd.hi, rho0) {
                continue;
            }
            if nd.leaf {
                for s in &self.samples[nd.first as usize..(nd.first + nd.count) as usize] {
                    let (c, r) = pp.class(x, s.p);
                    let p = rd(c, r);
                    let v = mul(p, s.e);
                    let v = if self.harm { mul(v, factors(&s.m[c], s.n, sub(x, s.p))) } else { v };
                    acc[c] = add(acc[c], scale(v, s.area));
                    if coupled && c == 0 {
                        for k in 0..3 {
                            vd[k] = madd(vd[k], s.d[k], v[k] * s.area);
                        }
                    }
                    if target.is_some() {
                        mass = madd(mass, p, s.area);
                    }
                    if r < rho0 {
                        near_e[c] = madd(near_e[c], s.e, s.area);
                        near_a[c] += s.area;
                        if coupled && c == 0 {
                            for k in 0..3 {
                                near_d[k] = madd(near_d[k], s.d[k], s.e[k] * s.area);
                            }
                        }
                    }
                }
                continue;
            }
            let d = sub(x, nd.centroid);
            let d2 = dot(d, d);
            let inside = (0..3).all(|k| x[k] >= nd.lo[k] && x[k] <= nd.hi[k]);
            let fine = nd.area < epsilon * d2;
            let coarse = !fine && nd.area < cut.coarse * d2 && nd.contrast <= MAX_CONTRAST;
            if !inside && (fine || coarse) {
                let sigma = cut.sigma || coarse;
                let (c, r) = pp.class(x, nd.centroid);
                // A far-class node that may hold samples within ρ₀ of r⊥ = 0 is opened (every
                // member is within the box's diagonal of the centroid, and r⊥ is 1-Lipschitz).
                if c == 0 || r >= rho0 + length(sub(nd.hi, nd.lo)) {
                    // The kernel at the centroid, or the members' mean of it by the sigma points
                    // (exact to second order in the cluster's extent: the centroid alone misses
                    // the kernel's curvature and undercounts a convex profile).
                    let mut point = |q: V3, w: f64| {
                        let (c, r) = if w == 1.0 { (c, r) } else { pp.class(x, q) };
                        let p = scale(rd(c, r), w);
                        if target.is_some() {
                            mass = madd(mass, p, nd.area);
                        }
                        let v = mul(p, nd.power);
                        let v = if self.harm { mul(v, factors(&nd.m[c], nd.n, sub(x, nd.centroid))) } else { v };
                        acc[c] = add(acc[c], v);
                        if coupled && c == 0 {
                            for k in 0..3 {
                                vd[k] = madd(vd[k], nd.d[k], v[k]);
                            }
                        }
                    };
                    if !sigma {
                        point(nd.centroid, 1.0);
                        continue;
                    }
                    let live = nd.axes.iter().take_while(|a| a.iter().any(|&v| v != 0.0)).count();
                    if live < 3 {
                        point(nd.centroid, (3 - live) as f64 / 3.0);
                    }
                    for a in nd.axes.iter().take(live) {
                        point(add(nd.centroid, *a), 1.0 / 6.0);
                        point(sub(nd.centroid, *a), 1.0 / 6.0);
                    }
                    continue;
                }
            }
            stack.extend(nd.first..nd.first + nd.count);
        }
        for c in 0..2 {
            if near_a[c] > 0.0 {
                let peak: Rgb = std::array::from_fn(|k| {
                    let p = pp.profile(c, k);
                    (p.total() * p.cdf(rho0) - PI * rho0 * rho0 * cap[c][k]).max(0.0)
                });
                acc[c] = add(acc[c], std::array::from_fn(|k| peak[k] * near_e[c][k] / near_a[c]));
                mass = add(mass, peak);
                if coupled && c == 0 {
                    for k in 0..3 {
                        vd[k] = madd(vd[k], near_d[k], peak[k] / near_a[c]);
                    }
                }
            }
        }
        match target {
            Some(t) => {
                let norm = |a: Rgb| -> Rgb {
                    std::array::from_fn(|k| if mass[k] > 0.0 { a[k] * t[k] / mass[k] } else { a[k] })
                };
                let vd = std::array::from_fn(|k| if mass[k] > 0.0 { scale(vd[k], t[k] / mass[k]) } else { vd[k] });
                (acc.map(norm), vd)
            }
            None => (acc, vd),
        }
    }
}

/// The squared distance from `x` to the box `lo`–`hi` (0 inside).
pub fn box_distance2(x: V3, lo: V3, hi: V3) -> f64 {
    (0..3).map(|k| (lo[k] - x[k]).max(x[k] - hi[k]).max(0.0).powi(2)).sum()
}

fn add_classes([a, b]: [Rgb; 2]) -> Rgb {
    add(a, b)
}

/// Which nodes of the tree walk are clusters and how a cluster is evaluated.
#[derive(Clone, Copy, Debug)]
pub struct Cut {
    /// A node of area A whose centroid is at distance ρ from x (outside its box) is a cluster
    /// when A < `epsilon` ρ² (its solid angle, sr).
    pub epsilon: f64,
    /// Evaluate a cluster's kernel at its sigma points (centroid ± the node's `axes`, weight 1/6
    /// each: the members' mean to second order in the cluster's extent) rather than at its
    /// centroid alone: a coarser `epsilon` at the same accuracy.
    pub sigma: bool,
    /// A node that is not a cluster by `epsilon` is one, evaluated at its sigma points, when
    /// A < `coarse` ρ² and its irradiance varies by at most [`MAX_CONTRAST`] (0: never).
    pub coarse: f64,
}

/// The largest ratio of the members' irradiance (channel sums) in a node that [`Cut::coarse`]
/// may cluster: where it varies more (a shadowed point lit through the part: the torus' inner
/// ring) the sigma points' second order is not enough (the matrix's torus: −0.06 % at 2, −0.2 %
/// at 4, −1.1 % at any contrast, 1 sr; `docs/render.md`).
pub const MAX_CONTRAST: f64 = 2.0;

/// The pixels' coarse clusters: `coarse` = this × `epsilon` ([`Cut`]; 0.5 sr at the default).
pub const COARSE_FACTOR: f64 = 10.0;

/// The profiles of a pair (x_o, x_i) in [`Tree::exitance_with`]: a class (0: the near side; 1:
/// across the object) and the radius to evaluate that class' profile at.
pub trait PairProfiles {
    /// Class and radius (mm) of the entry point `q` seen from the shading point `x`.
    fn class(&self, x: V3, q: V3) -> (usize, f64);
    /// The profile of class `c` (0 or 1) for channel `k`.
    fn profile(&self, c: usize, k: usize) -> &dyn RadialProfile;
    /// The profiles' integral over the surface (per channel) that [`Tree::exitance_with`]
    /// normalises the gathered sum to, if any: the sum is then scaled by this over the same
    /// profiles' integral over the tree's samples (their areas, with the same clusters and near
    /// field), so only how the light is distributed over the surface comes from the mesh.
    fn target(&self) -> Option<Rgb> {
        None
    }
    /// Whether every entry point in the box `lo`–`hi` is beyond the profiles' reach from `x`
    /// ([`RadialProfile::reach`], at least `near`, the near field's radius): the tree walk skips
    /// such nodes. Never, by default.
    fn beyond(&self, x: V3, lo: V3, hi: V3, near: f64) -> bool {
        let _ = (x, lo, hi, near);
        false
    }
}

/// One class, the material's profiles at the straight distance (every model but `adaptive`).
struct Flat<'a>(&'a super::material::Profiles);

impl PairProfiles for Flat<'_> {
    fn class(&self, x: V3, q: V3) -> (usize, f64) {
        (0, length(sub(x, q)))
    }
    fn profile(&self, _c: usize, k: usize) -> &dyn RadialProfile {
        &*self.0[k]
    }
    fn beyond(&self, x: V3, lo: V3, hi: V3, near: f64) -> bool {
        let reach = self.0.iter().map(|p| p.reach()).fold(near, f64::max);
        box_distance2(x, lo, hi) > reach * reach
    }
}

fn build_node(s: &mut [Sample], a: usize, b: usize, nodes: &mut Vec<Node>, depth: u32) -> u32 {
    let idx = nodes.len() as u32;
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    let (mut area, mut power, mut wsum, mut c, mut ca) = (0.0, [0.0; 3], 0.0, [0.0; 3], [0.0; 3]);
    let (mut nsum, mut msum, mut dsum) = ([0.0; 3], [[[0.0; 3]; 3]; 2], [[0.0; 3]; 3]);
    let o = s[a].p; // second moments about the first member (no cancellation)
    let (mut sw, mut sa) = ([[0.0; 3]; 3], [[0.0; 3]; 3]);
    let (mut emin, mut emax) = (f64::INFINITY, 0.0f64);
    for x in &s[a..b] {
        let es = x.e[0] + x.e[1] + x.e[2];
        emin = emin.min(es);
        emax = emax.max(es);
        nsum = madd(nsum, x.n, x.area);
        for k in 0..3 {
            dsum[k] = madd(dsum[k], x.d[k], x.e[k] * x.area);
        }
        for (mc, xc) in msum.iter_mut().zip(&x.m) {
            for k in 0..3 {
                mc[k] = madd(mc[k], xc[k].vector(), x.e[k] * x.area);
            }
        }
        for k in 0..3 {
            lo[k] = lo[k].min(x.p[k]);
            hi[k] = hi[k].max(x.p[k]);
        }
        area += x.area;
        power = madd(power, x.e, x.area);
        let w = (x.e[0] + x.e[1] + x.e[2]) * x.area;
        wsum += w;
        c = madd(c, x.p, w);
        ca = madd(ca, x.p, x.area);
        let q = sub(x.p, o);
        for i in 0..3 {
            sw[i] = madd(sw[i], q, w * q[i]);
            sa[i] = madd(sa[i], q, x.area * q[i]);
        }
    }
    let centroid = if wsum > 0.0 { scale(c, 1.0 / wsum) } else { scale(ca, 1.0 / area.max(1e-300)) };
    let (sm, ws) = if wsum > 0.0 { (sw, wsum) } else { (sa, area.max(1e-300)) };
    let d = sub(centroid, o);
    let axes = sigma_axes(std::array::from_fn(|i| std::array::from_fn(|j| sm[i][j] / ws - d[i] * d[j])));
    let nl = length(nsum);
    let n = if nl > 0.0 { scale(nsum, 1.0 / nl) } else { [0.0; 3] };
    let m = msum.map(|mc| {
        std::array::from_fn(|k| if power[k] > 0.0 { Lobe::new(scale(mc[k], 1.0 / power[k])) } else { Lobe::default() })
    });
    let contrast = if emin > 0.0 { emax / emin } else { f64::INFINITY };
    let dmean = std::array::from_fn(|k| if power[k] > 0.0 { scale(dsum[k], 1.0 / power[k]) } else { [0.0; 3] });
    nodes.push(Node {
        lo,
        hi,
        area,
        power,
        centroid,
        n,
        m,
        d: dmean,
        axes,
        contrast,
        first: a as u32,
        count: (b - a) as u32,
        leaf: true,
    });
    if b - a <= LEAF_SIZE || depth > 40 || (0..3).all(|k| hi[k] - lo[k] <= 0.0) {
        return idx;
    }
    // Partition into octants about the box centre (in place, one axis at a time).
    let mid: V3 = std::array::from_fn(|k| 0.5 * (lo[k] + hi[k]));
    let mut bounds = vec![a, b];
    for k in 0..3 {
        let mut nb = vec![a];
        for w in bounds.windows(2) {
            let part = &mut s[w[0]..w[1]];
            let mut i = 0;
            for j in 0..part.len() {
                if part[j].p[k] < mid[k] {
                    part.swap(i, j);
                    i += 1;
                }
            }
            nb.push(w[0] + i);
            nb.push(w[1]);
        }
        nb.dedup();
        bounds = nb;
    }
    let ranges: Vec<(usize, usize)> = bounds.windows(2).map(|w| (w[0], w[1])).filter(|r| r.1 > r.0).collect();
    if ranges.len() < 2 {
        return idx;
    }
    // Children must be contiguous: reserve their slots first, then fill them.
    let first = nodes.len() as u32;
    let placeholder = nodes[idx as usize];
    nodes.extend(std::iter::repeat_n(placeholder, ranges.len()));
    for (j, &(ra, rb)) in ranges.iter().enumerate() {
        let child_start = nodes.len();
        let built = build_node(s, ra, rb, nodes, depth + 1);
        // The subtree root was appended at `built`; move it into its reserved slot.
        nodes[first as usize + j] = nodes[built as usize];
        debug_assert_eq!(built as usize, child_start);
    }
    let nd = &mut nodes[idx as usize];
    nd.leaf = false;
    nd.first = first;
    nd.count = ranges.len() as u32;
    idx
}

/// √3 × the columns of the lower Cholesky factor L of the covariance `s` (L Lᵀ = s; a column
/// whose pivot vanishes, a flat or collinear cluster, is 0): the symmetric sigma points
/// c ± these, weight 1/6 each, have the cluster's mean and covariance.
fn sigma_axes(s: [[f64; 3]; 3]) -> [V3; 3] {
    let tiny = 1e-12 * (s[0][0] + s[1][1] + s[2][2]);
    let mut l = [[0.0; 3]; 3];
    for j in 0..3 {
        let d = s[j][j] - (0..j).map(|k| l[j][k] * l[j][k]).sum::<f64>();
        if !(d > tiny) {
            continue;
        }
        let dj = d.sqrt();
        l[j][j] = dj;
        for i in j + 1..3 {
            l[i][j] = (s[i][j] - (0..j).map(|k| l[i][k] * l[j][k]).sum::<f64>()) / dj;
        }
    }
    let mut axes: [V3; 3] = std::array::from_fn(|j| std::array::from_fn(|i| 3f64.sqrt() * l[i][j]));
    // the non-zero axes first (the walk visits `live` of them)
    axes.sort_by_key(|a| a[0] == 0.0 && a[1] == 0.0 && a[2] == 0.0);
    axes
}

/// The hierarchical method: one octree per translucent object.
pub struct Hierarchical {
    pub trees: Vec<Option<Tree>>,
    pub params: HierarchicalParams,
}

impl Hierarchical {
    /// Place the samples, compute their irradiance (in parallel, reproducibly: sample j uses
    /// the stream (seed ⊕ 0x4a42_2002, j), in the second gathering (seed ⊕ 0x4a42_2003, j)) and
    /// build the trees.
    pub fn new(scene: &Scene, params: &HierarchicalParams, seed: u64) -> Result<Hierarchical> {
        Ok(Self::new_with(scene, params, seed, &Control::default())?.expect("never cancelled"))
    }

    /// [`new`](Self::new), cancellable: adds the number of irradiance samples to `ctl.total`
    /// (again before a second gathering), counts the finished ones in `ctl.done` and polls
    /// `ctl.cancel` before each; `None` when cancelled.
    pub fn new_with(
        scene: &Scene,
        params: &HierarchicalParams,
        seed: u64,
        ctl: &Control,
    ) -> Result<Option<Hierarchical>> {
        params.validate()?;
        let spots: Vec<Option<(Spots, f64)>> = (0..scene.objects.len())
            .map(|oi| {
                let delta = spacing(scene, oi, params)?;
                Some((place_samples(scene, oi, delta), delta))
            })
            .collect();
        let spots: Vec<Option<(Spots, f64)>> =
            spots.into_iter().enumerate().map(|(oi, sp)| sp.map(|(s, d)| (with_amplitudes(scene, oi, s), d))).collect();
        let n_all: usize = spots.iter().flatten().map(|(s, _)| s.len()).sum();
        ctl.total.fetch_add(n_all as u64, Ordering::Relaxed);
        // First gathering: translucent surfaces black; again with that estimate if a ray saw one.
        let unlit = Unlit::default();
        let Some(trees) = gather(scene, params, &spots, seed ^ 0x4a42_2002, ctl, &unlit) else { return Ok(None) };
        let mut h = Hierarchical { trees, params: *params };
        if unlit.reached.load(Ordering::Relaxed) {
            ctl.total.fetch_add(n_all as u64, Ordering::Relaxed);
            let cut = Cut { epsilon: h.params.epsilon.max(GATHER_EPSILON), sigma: true, coarse: 0.0 };
            let coarse = Coarse { inner: &h, cut };
            let rr = Roulette { inner: &coarse, keep: SECOND_GATHER_KEEP };
            let Some(trees) = gather(scene, params, &spots, seed ^ 0x4a42_2003, ctl, &rr) else { return Ok(None) };
            h.trees = trees;
        }
        Ok(Some(h))
    }
}

/// The sample spacing Δ (mm) of translucent object `oi`: `spacing` × the smallest median
/// profile radius (over every texel material of a textured one), larger where the object would
/// get more than `max_samples`; `None` for an opaque object.
fn spacing(scene: &Scene, oi: usize, params: &HierarchicalParams) -> Option<f64> {
    let m = scene.material(oi).translucent()?;
    let median = match m.texture.as_ref().and_then(|t| t.radius_range(0.5)) {
        Some((lo, _)) => lo[0].min(lo[1]).min(lo[2]),
        None => (0..3).map(|k| m.profiles()[k].radius_for_fraction(0.5)).fold(f64::INFINITY, f64::min),
    };
    let total = scene.objects[oi].mesh.total_area();
    let delta = params.spacing * median;
    if !(delta > 0.0 && delta.is_finite()) || total / (delta * delta) > params.max_samples as f64 {
        return Some((total / params.max_samples as f64).sqrt());
    }
    Some(delta)
}

/// The hierarchical method's samples of translucent object `oi` with E_t = 1 and their octree
/// (default settings): [`Tree::exitance_with`] then integrates a kernel over the object's
/// surface (the `probe` method's normalisation of a tube's saddle, `render::adaptive`).
pub fn area_tree(scene: &Scene, oi: usize) -> Option<Tree> {
    let delta = spacing(scene, oi, &HierarchicalParams::default())?;
    let samples = place_samples(scene, oi, delta)
        .into_iter()
        .map(|(h, area, _)| Sample { p: h.p, area, e: [1.0; 3], n: h.n, m: Default::default(), d: Default::default() })
        .collect();
    Some(Tree::build(samples, delta))
}

/// The second gathering's cluster bound (sr; the pixels' is `epsilon`, default 0.05), its clusters
/// evaluated at their sigma points ([`Cut`]): the radiance a gathering ray brings back is
/// averaged over its sample's rays and over the samples under the profile, so it needs less
/// than a pixel's accuracy. Measured (`docs/render.md`, the validation matrix's bowl, 64², 4 spp):
/// object means +0.29, −0.52, −2.97 % with the pixels' clusters, +0.29, −0.51, −2.97 % with
/// these (−0.01, −0.82, −3.26 % at this bound evaluated at the centroids), the set-up's tree
/// walks evaluate 3× fewer samples.
const GATHER_EPSILON: f64 = 0.5;

/// The fraction of the second gathering's rays that reach a translucent surface and are
/// evaluated (Russian roulette, [`Roulette`]). Such a ray costs a tree walk (≈ 10–20 µs with the
/// adaptive kernel, measured on a torus: 80 % of the set-up) where a ray that misses costs a
/// BVH traversal (< 1 µs); the light it carries (one bounce between translucent surfaces) is a
/// small part of E_t, so evaluating a quarter of them, weighted 4×, keeps the expectation and
/// adds little variance.
const SECOND_GATHER_KEEP: f64 = 0.25;

/// Russian roulette on the radiance of a translucent surface: `inner`'s radiance / `keep` with
/// probability `keep`, else 0 (the same expectation; one uniform of the caller's stream), its
/// trees walked with the cluster bound `epsilon` ([`Hierarchical::radiance_with`]).
struct Roulette<'a> {
    inner: &'a dyn Translucency,
    keep: f64,
}

/// The hierarchical method's radiance with other clusters (the second gathering's: sigma points
/// at [`GATHER_EPSILON`]).
struct Coarse<'a> {
    inner: &'a Hierarchical,
    cut: Cut,
}

impl Translucency for Coarse<'_> {
    fn radiance(&self, scene: &Scene, hit: &Hit, wo: V3, depth: u32, rng: &mut PhotonRng) -> Rgb {
        self.inner.radiance_with(scene, hit, wo, depth, rng, self.cut)
    }
}

impl Translucency for Roulette<'_> {
    fn radiance(&self, scene: &Scene, hit: &Hit, wo: V3, depth: u32, rng: &mut PhotonRng) -> Rgb {
        if rng.uniform() >= self.keep {
            return [0.0; 3];
        }
        scale(self.inner.radiance(scene, hit, wo, depth, rng), 1.0 / self.keep)
    }
}

/// The trees of every translucent object, its samples' irradiance from
/// [`transmitted_irradiance`] with `tr` for the translucent surfaces the gathering rays reach
/// (sample j of all objects in order uses the stream (`key`, j)); `None` when cancelled.
fn gather(
    scene: &Scene,
    params: &HierarchicalParams,
    spots: &[Option<(Spots, f64)>],
    key: u64,
    ctl: &Control,
    tr: &dyn Translucency,
) -> Option<Vec<Option<Tree>>> {
    let mut trees = Vec::with_capacity(scene.objects.len());
    let mut base = 0u64;
    for (oi, spot) in spots.iter().enumerate() {
        let (Some(m), Some((spots, delta))) = (scene.material(oi).translucent(), spot) else {
            trees.push(None);
            continue;
        };
        // the exit coupling needs the lights' directions (`bssrdf::coupling`)
        let coupled = !scene.lights.is_empty() && m.adaptive.as_deref().is_some_and(|t| t.has_coupling());
        let samples: Option<Vec<Sample>> = spots
            .par_iter()
            .enumerate()
            .with_max_len(16) // small tasks: a sample's cost varies with the shape (second gathering)
            .map(|(j, (h, area, amps))| {
                if ctl.cancel.load(Ordering::Relaxed) {
                    return None;
                }
                let mut rng = PhotonRng::new(key, base + j as u64);
                let (nl, nr) = (params.light_samples, params.env_samples);
                let (e, hm, d) = if amps.is_some() || coupled {
                    let (e, hm, d) =
                        irradiance_and_harmonic(scene, h, Entry::of(m), nl, nr, 0, &mut rng, tr, amps.as_ref());
                    (e, hm.map(|mc| mc.map(Lobe::new)), d)
                } else {
                    let e = transmitted_irradiance(scene, h, Entry::of(m), nl, nr, 0, &mut rng, tr);
                    (e, [[Lobe::default(); 3]; 2], [[0.0; 3]; 3])
                };
                ctl.done.fetch_add(1, Ordering::Relaxed);
                Some(Sample { p: h.p, area: *area, e, n: h.n, m: hm, d })
            })
            .collect();
        base += spots.len() as u64;
        trees.push(Some(Tree::build(samples?, *delta)));
    }
    Some(trees)
}

/// Irradiance sample positions (as hits) with their areas (mm²) and, for `adaptive` under
/// lights, their azimuthal-harmonic amplitudes.
type Spots = Vec<(Hit, f64, Option<[AtRho; 3]>)>;

/// `spots` of object `oi` with their amplitudes ([`super::adaptive::entry_amplitudes`] at the
/// centroid of the sample's triangle: probed once, used by both gatherings) where its material
/// is `adaptive` and the scene has lights.
fn with_amplitudes(scene: &Scene, oi: usize, spots: Spots) -> Spots {
    let Some(t) = scene.material(oi).translucent().and_then(|m| m.adaptive.as_deref()) else { return spots };
    if scene.lights.is_empty() {
        return spots;
    }
    // Probed once per triangle, at its centroid (the curvature varies on the scale of the mesh,
    // and several samples share a triangle where the profile is finer than the facets).
    let mut tris: Vec<u32> = spots.iter().map(|(h, _, _)| h.tri).collect();
    tris.sort_unstable();
    tris.dedup();
    let third = 1.0 / 3.0;
    let amps: Vec<Option<[AtRho; 3]>> = tris
        .par_iter()
        .map(|&gi| {
            let n = scene.accel.tris[gi as usize].n;
            let p = scene.accel.point(gi as usize, third, third);
            let h = Hit { t: 0.0, tri: gi, object: oi, b1: third, b2: third, p, n };
            super::adaptive::entry_amplitudes(scene, t, &h)
        })
        .collect();
    spots
        .into_iter()
        .map(|(h, a, _)| {
            let i = tris.binary_search(&h.tri).expect("every sample's triangle was probed");
            (h, a, amps[i])
        })
        .collect()
}

/// The irradiance samples of object `oi` as hits, with their areas: triangles larger than Δ²
/// are cut into k² congruent sub-triangles (a sample at each centroid); smaller ones are visited
/// in Morton order of their centroids and a sample is placed (at the centroid) each time the
/// running area passes a multiple of Δ² (systematic sampling along a space-filling curve), so a
/// finely tessellated mesh gets about area/Δ² evenly spread samples, not one per triangle.
fn place_samples(scene: &Scene, oi: usize, delta: f64) -> Spots {
    let acc = &scene.accel;
    let mut out = vec![];
    let mut small = vec![];
    for (gi, t) in acc.tris.iter().enumerate() {
        if t.object as usize != oi {
            continue;
        }
        let a = acc.area(gi);
        let k = ((a.sqrt() / delta).ceil() as usize).max(1);
        if k == 1 {
            small.push(gi);
            continue;
        }
        let sub_area = a / (k * k) as f64;
        let kf = k as f64;
        let mut push = |b1: f64, b2: f64| {
            let p = acc.point(gi, b1, b2);
            out.push((Hit { t: 0.0, tri: gi as u32, object: oi, b1, b2, p, n: t.n }, sub_area, None));
        };
        for i in 0..k {
            for j in 0..k - i {
                push((i as f64 + 1.0 / 3.0) / kf, (j as f64 + 1.0 / 3.0) / kf);
                if j + 1 < k - i {
                    push((i as f64 + 2.0 / 3.0) / kf, (j as f64 + 2.0 / 3.0) / kf);
                }
            }
        }
    }
    let third = 1.0 / 3.0;
    let key = |gi: usize| morton(acc, acc.point(gi, third, third));
    small.sort_by_cached_key(|&gi| key(gi));
    let cell = delta * delta;
    let (mut run, mut next, mut placed) = (0.0, 0.5 * cell, 0usize);
    let sample = |gi: usize, area: f64| {
        let p = acc.point(gi, third, third);
        (Hit { t: 0.0, tri: gi as u32, object: oi, b1: third, b2: third, p, n: acc.tris[gi].n }, area, None)
    };
    for &gi in &small {
        run += acc.area(gi);
        while run >= next {
            out.push(sample(gi, cell));
            placed += 1;
            next += cell;
        }
    }
    // The area not yet assigned (|·| ≤ Δ²/2) goes to the last sample, so the areas sum exactly.
    if placed > 0 {
        out.last_mut().expect("placed > 0").1 += run - placed as f64 * cell;
    } else if let Some(&gi) = small.first() {
        out.push(sample(gi, run));
    }
    out
}

/// 63-bit Morton code of `p` in the scene's bounding box (21 bits per axis).
fn morton(acc: &super::accel::Accel, p: V3) -> u64 {
    let spread = |mut x: u64| {
        x &= 0x1f_ffff;
        x = (x | x << 32) & 0x1f00000000ffff;
        x = (x | x << 16) & 0x1f0000ff0000ff;
        x = (x | x << 8) & 0x100f00f00f00f00f;
        x = (x | x << 4) & 0x10c30c30c30c30c3;
        (x | x << 2) & 0x1249249249249249
    };
    let q = |k: usize| {
        let f = (p[k] - acc.lo[k]) / (acc.hi[k] - acc.lo[k]).max(1e-300);
        (f.clamp(0.0, 1.0) * 2_097_151.0) as u64
    };
    spread(q(0)) | spread(q(1)) << 1 | spread(q(2)) << 2
}

impl Translucency for Hierarchical {
    fn radiance(&self, scene: &Scene, hit: &Hit, wo: V3, depth: u32, rng: &mut PhotonRng) -> Rgb {
        let e = self.params.epsilon;
        self.radiance_with(scene, hit, wo, depth, rng, Cut { epsilon: e, sigma: false, coarse: COARSE_FACTOR * e })
    }
}

impl Hierarchical {
    /// [`Translucency::radiance`] with the trees walked at the cluster bound `epsilon`.
    fn radiance_with(&self, scene: &Scene, hit: &Hit, wo: V3, depth: u32, rng: &mut PhotonRng, cut: Cut) -> Rgb {
        // A textured material's profile is its texel's at the shading point x_o.
        let (Some(m), Some(tree)) = (shading_medium(scene, hit), self.trees[hit.object].as_ref()) else {
            return [0.0; 3];
        };
        let mu_o = dot(wo, hit.n);
        let mo = match &m.adaptive {
            Some(t) => {
                // the exit term's angular shape on the near class (`bssrdf::exit`); across a part, none
                let k = super::adaptive::Kernel::at(scene, t, hit);
                if tree.coupled {
                    // and its coupling to the light's direction (`bssrdf::coupling`)
                    let ([near, far], v) = tree.exitance_coupled(&k, hit.p, cut);
                    let ot = sub(wo, scale(hit.n, mu_o));
                    let near: Rgb = std::array::from_fn(|c| near[c] + dot(v[c], ot));
                    add(mul(near, t.exit_factors(mu_o)), far)
                } else {
                    let [near, far] = tree.exitance_cut(&k, hit.p, cut);
                    add(mul(near, t.exit_factors(mu_o)), far)
                }
            }
            None => add_classes(tree.exitance_cut(&Flat(m.profiles()), hit.p, cut)),
        };
        let f = ft(m.eta, mu_o) / (PI * m.c_norm);
        let mut l = scale(mul(mo, tint(scene, hit)), f);
        if m.single_scattering {
            l = add(l, single_scattering(scene, m, hit, wo, depth, rng, self));
        }
        l
    }
}

#[cfg(test)]
#[path = "hierarchical_tests.rs"]
mod tests;
