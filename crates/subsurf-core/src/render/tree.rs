//! The octree of irradiance samples of the hierarchical method ([`super::hierarchical`], Jensen &
//! Buhler 2002 §3.2–3.3): the samples, the nodes' power-weighted sums, and the tree walk that sums
//! a profile's pairs at a shading point (clusters by solid angle, evaluated at their centroids or
//! sigma points; the near field integrated exactly; the kernel's reach; the adaptive model's
//! classes, harmonic and exit coupling).

use super::fastmath;
use super::irradiance::Coupled;
use super::material::Translucent;
use super::math::{add, dot, length, madd, mul, scale, sub, Rgb, V3};
use crate::bssrdf::flow::Flow;
use crate::bssrdf::harmonic::{factors, Lobe};
use crate::bssrdf::RadialProfile;
use std::f64::consts::PI;

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
    pub fn exitance_with<P: PairProfiles + ?Sized>(&self, pp: &P, x: V3, epsilon: f64) -> Rgb {
        let [a, b] = self.exitance_classes(pp, x, epsilon);
        add(a, b)
    }

    /// [`exitance_with`](Self::exitance_with) per class of `pp` (0: the near side, 1: across):
    /// the adaptive model gives each class its own exit term.
    pub fn exitance_classes<P: PairProfiles + ?Sized>(&self, pp: &P, x: V3, epsilon: f64) -> [Rgb; 2] {
        self.exitance_cut(pp, x, Cut { epsilon, sigma: false, coarse: 0.0 })
    }

    /// [`exitance_classes`](Self::exitance_classes) with the clusters of `cut`.
    pub fn exitance_cut<P: PairProfiles + ?Sized>(&self, pp: &P, x: V3, cut: Cut) -> [Rgb; 2] {
        self.sums(pp, x, cut, false, None).0
    }

    /// [`exitance_cut`](Self::exitance_cut) and, per channel, the near class' sum of each pair's
    /// contribution × its entry's exit-coupling vector ([`Coupled`]; the clusters' power-weighted
    /// mean, the near field's area-weighted): the near class' radiance leaving towards ω_o is then
    /// (near + V·ω_o,t) × its exit term ([`crate::bssrdf::coupling`]).
    pub fn exitance_coupled<P: PairProfiles + ?Sized>(&self, pp: &P, x: V3, cut: Cut) -> ([Rgb; 2], Coupled) {
        let (a, v, _) = self.sums(pp, x, cut, true, None);
        (a, v)
    }

    /// [`exitance_coupled`](Self::exitance_coupled) (its vector 0 unless the tree is
    /// [`coupled`](Self::coupled)) and, per channel, the near class' exit flow
    /// ([`crate::bssrdf::flow`]): the sum of each pair's contribution without the entry harmonic
    /// × B_k(r) t̂, t̂ the unit tangential part (about `flow.normal`) of x − x_i (a cluster's
    /// centroid or sigma point); the near class' radiance towards ω_o is then
    /// (near + V·ω_o,t + F·ω_o,t) × its exit term. The near field's peak (the profile above
    /// R(ρ₀) within ρ₀) adds −π ∇E ∫₀^ρ₀ (R − R(ρ₀)) B r² dr, ∇E the tangential gradient of the
    /// samples' irradiance within ρ₀ (least squares; the peak is symmetric about x, so only the
    /// irradiance's slope across it has a direction).
    pub fn exitance_flow<P: PairProfiles + ?Sized>(
        &self,
        pp: &P,
        x: V3,
        cut: Cut,
        flow: &FlowAt,
    ) -> ([Rgb; 2], Coupled, Coupled) {
        self.sums(pp, x, cut, self.coupled, Some(flow))
    }

    fn sums<P: PairProfiles + ?Sized>(
        &self,
        pp: &P,
        x: V3,
        cut: Cut,
        coupled: bool,
        flow: Option<&FlowAt>,
    ) -> ([Rgb; 2], Coupled, Coupled) {
        let epsilon = cut.epsilon;
        let rho0 = self.rho0;
        let cap: [Rgb; 2] = std::array::from_fn(|c| std::array::from_fn(|k| pp.profile(c, k).rd(rho0)));
        // the profiles of class c at r given ln r (once for the three channels, the flow's too),
        // flat-topped within ρ₀
        let rd = |c: usize, r: f64, ln_r: f64| -> Rgb {
            let v = pp.rd3(c, r, ln_r);
            std::array::from_fn(|k| v[k].min(if r < rho0 { cap[c][k] } else { f64::INFINITY }))
        };
        let (mut acc, mut near_e, mut near_a) = ([[0.0; 3]; 2], [[0.0; 3]; 2], [0.0; 2]);
        let (mut vd, mut near_d) = ([[0.0; 3]; 3], [[0.0; 3]; 3]);
        // the flow vector per channel, and the near field's irradiance moments for its gradient
        let mut vf = [[0.0; 3]; 3];
        let mut grad = Moments::default();
        // B_k(r) t̂ · w for a near-class pair of weight w (per channel) from entry point q
        let add_flow = |vf: &mut Coupled, q: V3, r: f64, ln_r: f64, w: Rgb| {
            let Some(f) = flow else { return };
            let d = sub(x, q);
            let t = sub(d, scale(f.normal, dot(d, f.normal)));
            let tl = length(t);
            if !(tl > 0.0 && r > 0.0) {
                return;
            }
            for k in 0..3 {
                vf[k] = madd(vf[k], t, w[k] * f.b[k].at_ln(ln_r) / tl);
            }
        };
        let target = pp.target();
        let mut mass = [0.0; 3]; // Σ profile × area (for `target`)
        let mut stack = vec![0u32];
        while let Some(i) = stack.pop() {
            let nd = &self.nodes[i as usize];
            // nodes wholly beyond the kernel's reach hold none of its energy
            if pp.beyond(x, nd.lo, nd.hi, rho0) {
                continue;
            }
            let d = sub(x, nd.centroid);
            let d2 = dot(d, d);
            let inside = (0..3).all(|k| x[k] >= nd.lo[k] && x[k] <= nd.hi[k]);
            let fine = nd.area < epsilon * d2;
            let coarse = !fine && nd.area < cut.coarse * d2 && nd.contrast <= MAX_CONTRAST;
            let sigma = cut.sigma || coarse;
            if !inside && (fine || coarse) && (!nd.leaf || evaluations(nd, sigma) < nd.count as usize) {
                let (c, r) = pp.class(x, nd.centroid);
                // A far-class node that may hold samples within ρ₀ of r⊥ = 0 is opened (every
                // member is within the box's diagonal of the centroid, and r⊥ is 1-Lipschitz).
                if c == 0 || r >= rho0 + length(sub(nd.hi, nd.lo)) {
                    // The kernel at the centroid, or the members' mean of it by the sigma points
                    // (exact to second order in the cluster's extent: the centroid alone misses
                    // the kernel's curvature and undercounts a convex profile).
                    let mut point = |q: V3, w: f64| {
                        let (c, r) = if w == 1.0 { (c, r) } else { pp.class(x, q) };
                        let ln_r = fastmath::ln(r);
                        let p = scale(rd(c, r, ln_r), w);
                        if target.is_some() {
                            mass = madd(mass, p, nd.area);
                        }
                        let v = mul(p, nd.power);
                        if c == 0 {
                            add_flow(&mut vf, q, r, ln_r, v);
                        }
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
            if nd.leaf {
                for s in &self.samples[nd.first as usize..(nd.first + nd.count) as usize] {
                    let (c, r) = pp.class(x, s.p);
                    let ln_r = fastmath::ln(r);
                    let p = rd(c, r, ln_r);
                    let v = mul(p, s.e);
                    if c == 0 {
                        add_flow(&mut vf, s.p, r, ln_r, scale(v, s.area));
                    }
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
                        if let (Some(f), 0) = (flow, c) {
                            grad.add(f.normal, sub(s.p, x), s.e, s.area);
                        }
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
                if let (Some(f), 0) = (flow, c) {
                    let g = grad.gradient();
                    for k in 0..3 {
                        let m2 = f.peak_moment(pp.profile(0, k), k, rho0, cap[0][k]);
                        vf[k] = madd(vf[k], g[k], -PI * m2);
                    }
                }
            }
        }
        match target {
            Some(t) => {
                let norm = |a: Rgb| -> Rgb {
                    std::array::from_fn(|k| if mass[k] > 0.0 { a[k] * t[k] / mass[k] } else { a[k] })
                };
                let vn = |v: Coupled| -> Coupled {
                    std::array::from_fn(|k| if mass[k] > 0.0 { scale(v[k], t[k] / mass[k]) } else { v[k] })
                };
                (acc.map(norm), vn(vd), vn(vf))
            }
            None => (acc, vd, vf),
        }
    }
}

/// The kernel evaluations of node `nd` as a cluster: its centroid, or its sigma points (a leaf
/// is a cluster only where these are fewer than its samples).
fn evaluations(nd: &Node, sigma: bool) -> usize {
    if !sigma {
        return 1;
    }
    let live = nd.axes.iter().take_while(|a| a.iter().any(|&v| v != 0.0)).count();
    2 * live + usize::from(live < 3)
}

/// What [`Tree::exitance_flow`] needs of the shading point: its unit normal and the channels'
/// flow amplitudes B_k(r) ([`crate::bssrdf::flow`]).
pub struct FlowAt<'a> {
    pub normal: V3,
    pub b: [&'a Flow; 3],
}

/// Midpoints of [`FlowAt::peak_moment`].
const PEAK_STEPS: usize = 16;

impl FlowAt<'_> {
    /// ∫₀^ρ₀ (R(r) − R(ρ₀))₊ B_k(r) r² dr of channel `k`'s near-class profile `p` (`cap` = R(ρ₀);
    /// midpoint rule in r, [`PEAK_STEPS`] steps).
    fn peak_moment(&self, p: &dyn RadialProfile, k: usize, rho0: f64, cap: f64) -> f64 {
        let h = rho0 / PEAK_STEPS as f64;
        (0..PEAK_STEPS)
            .map(|i| {
                let r = (i as f64 + 0.5) * h;
                (p.rd(r) - cap).max(0.0) * self.b[k].at_ln(r.ln()) * r * r * h
            })
            .sum()
    }
}

/// Area-weighted moments of the near field's samples (offsets q = x_i − x in the tangent plane,
/// irradiance E per channel) for the least-squares plane E ≈ E₀ + g·q.
#[derive(Default)]
struct Moments {
    w: f64,
    q: [f64; 2],
    qq: [[f64; 2]; 2],
    e: Rgb,
    eq: [[f64; 2]; 3],
    frame: Option<(V3, V3)>,
}

impl Moments {
    fn add(&mut self, n: V3, q: V3, e: Rgb, a: f64) {
        let (t, b) = *self.frame.get_or_insert_with(|| {
            let f = super::math::Frame::new(n);
            (f.t, f.b)
        });
        let u = [dot(q, t), dot(q, b)];
        self.w += a;
        for i in 0..2 {
            self.q[i] += a * u[i];
            for j in 0..2 {
                self.qq[i][j] += a * u[i] * u[j];
            }
        }
        for k in 0..3 {
            self.e[k] += a * e[k];
            for i in 0..2 {
                self.eq[k][i] += a * e[k] * u[i];
            }
        }
    }

    /// The fitted tangential gradient per channel (0 with fewer than 3 samples' worth of spread).
    fn gradient(&self) -> Coupled {
        let Some((t, b)) = self.frame else { return [[0.0; 3]; 3] };
        if !(self.w > 0.0) {
            return [[0.0; 3]; 3];
        }
        let m = [self.q[0] / self.w, self.q[1] / self.w];
        let c = [
            [self.qq[0][0] / self.w - m[0] * m[0], self.qq[0][1] / self.w - m[0] * m[1]],
            [self.qq[1][0] / self.w - m[1] * m[0], self.qq[1][1] / self.w - m[1] * m[1]],
        ];
        let det = c[0][0] * c[1][1] - c[0][1] * c[1][0];
        if !(det > 1e-12 * (c[0][0] + c[1][1]).powi(2)) {
            return [[0.0; 3]; 3];
        }
        std::array::from_fn(|k| {
            let em = self.e[k] / self.w;
            let s = [self.eq[k][0] / self.w - em * m[0], self.eq[k][1] / self.w - em * m[1]];
            let g0 = (c[1][1] * s[0] - c[0][1] * s[1]) / det;
            let g1 = (c[0][0] * s[1] - c[1][0] * s[0]) / det;
            add(scale(t, g0), scale(b, g1))
        })
    }
}

/// The squared distance from `x` to the box `lo`–`hi` (0 inside).
pub fn box_distance2(x: V3, lo: V3, hi: V3) -> f64 {
    (0..3).map(|k| (lo[k] - x[k]).max(x[k] - hi[k]).max(0.0).powi(2)).sum()
}

pub(super) fn add_classes([a, b]: [Rgb; 2]) -> Rgb {
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
    /// The three channels' profiles of class `c` at `r` (mm) given `ln_r` = ln r
    /// ([`RadialProfile::rd_ln`]): the tree walk's one call per pair, which an implementation
    /// may answer without the trait objects (the adaptive kernel's, `render::adaptive`).
    #[inline]
    fn rd3(&self, c: usize, r: f64, ln_r: f64) -> Rgb {
        std::array::from_fn(|k| self.profile(c, k).rd_ln(r, ln_r))
    }
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
pub(super) struct Flat<'a>(pub(super) &'a super::material::Profiles);

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
pub(super) fn sigma_axes(s: [[f64; 3]; 3]) -> [V3; 3] {
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
