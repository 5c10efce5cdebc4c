//! The geometry-aware BSSRDF of `model = "adaptive"` at a shading point x_o: the local thickness
//! d (a probe ray along −n_o to the object's far surface; ∞ if it leaves the object open) picks
//! the slab profiles R(r; d) and T(r; d) of [`crate::bssrdf::adaptive::AdaptiveTable`], and each
//! entry point x_i is put on the near side or across the part by its depth below x_o's tangent
//! plane, h = (x_o − x_i)·n_o:
//!
//! - h ≤ d/2 (the near side): R(‖x_o − x_i‖; d), the finite slab's reflection;
//! - d/2 < h ≤ [`BEYOND`]·d (across): T(r⊥; d) with r⊥ = √(‖x_o − x_i‖² − h²), the lateral
//!   offset in the slab tangent at x_o — light that crossed a thin part (ears, leaves, a cup's
//!   handle);
//! - deeper: nothing (another part of the object, across air: the far side of a ring).
//!
//! Curvature: the principal curvatures κ₁ ≥ κ₂ at x_o (mm⁻¹; > 0 convex) are estimated from the
//! surface's sags one step (`median_radius`, at most d/4) away on both sides of three tangents
//! (six probe rays, [`principal_curvatures`]), and the profiles are scaled by the table's scales
//! there ([`AdaptiveTable::curvature_scale_principal`], [`crate::bssrdf::curvature`]): R per
//! chord bin of radius 1/κ₁ ([`Binned`]) and T as a whole, so that this kernel, integrated over
//! each bin of the near half and over the far half of a sphere (κ₂ = κ₁) or an infinite cylinder
//! (κ₂ = 0) of that radius, gives the exact escape there of diffuse light entering it (traced by
//! [`crate::bssrdf::curved`]); in between the two sets of scales are mixed, and concave points
//! (mean curvature < 0) scale R by the cavity's total.
//! The thickness part is inside those integrals (the sphere's probed d is its diameter), so a
//! sphere's (a tube's) light is counted once. (The mean-chord slab
//! d/(1 + dH) used before moved light into T, to the far side, where on a sphere the extra light
//! leaves near where it entered; measured worse on spheres and the torus, see `docs/render.md`.)
//!
//! Saddles of a tube ([`is_tube_saddle`]: the inside of a torus' ring) take the tube's scales,
//! but more of their surface lies near x than on the tube (the ring rises above the tangent
//! plane along κ₂: +8 % of the kernel's integral at a marble torus' inner equator); there the
//! gathered sum is normalised to the kernel's integral over the tangent cylinder
//! ([`Kernel::target`]; `hierarchical` in its tree walk, `probe` by [`Kernel::normalisation`]).
//!
//! Direction: each pair is weighted by the azimuthal factor of the entry point's light
//! ([`crate::bssrdf::harmonic`]; `hierarchical` and `probe` apply it, [`entry_amplitudes`]
//! gives an entry point's amplitudes at its own probed curvature): light from a light source
//! that enters obliquely leaves forward of its entry point, as the curved transport tallies.
//!
//! On a flat surface of a thick object (d ≥ the table's last node, several diffusion lengths)
//! this is the semi-infinite Monte Carlo profile, so exitance = total × E_t as for
//! `monte_carlo`. The BSSRDF is the renderer's (`material`): F_t R F_t /(π c) and the same
//! for T, both per unit entering power.

use super::accel::Hit;
use super::math::{dot, length, madd, neg, sub, Frame, Rgb, V3};
use super::scene::Scene;
use super::tree::{box_distance2, PairProfiles, Tree};
use crate::bssrdf::adaptive::{AdaptiveTable, Mix};
use crate::bssrdf::curvature::Binned;
use crate::bssrdf::harmonic::AtRho;
use crate::bssrdf::RadialProfile;
use std::f64::consts::FRAC_1_SQRT_2;

/// Entry points deeper than this many local thicknesses below x's tangent plane are in another
/// part of the object, across air (the far side of a ring, of a cup's handle): not gathered.
pub const BEYOND: f64 = 1.5;

/// The sag, in probe steps, counted for a side of a curvature probe that falls off an edge. An
/// empirical constant, not derived: chosen on a rotated 12 mm marble cube (object means −4.4,
/// −5.6, −6.5 % off the random walk with no edge term, +12, +6.9, +5.0 % with 1, +1.4, −0.9,
/// −2.0 % with 0.3) and checked on cubes it was not chosen on (`docs/render.md`).
pub const EDGE_SAG: f64 = 0.3;

/// Most surfaces a thickness probe passes (other objects' or back faces) before it gives up (∞).
const MAX_CROSSINGS: usize = 16;

/// The local thickness (mm) of the object of `hit` along −n: distance to the first surface of
/// the same object; ∞ if there is none (an open mesh).
pub fn thickness(scene: &Scene, hit: &Hit) -> f64 {
    let d = neg(hit.n);
    let mut o = scene.accel.offset(hit.p, hit.n, -1.0);
    let (mut skip, mut travelled) = (hit.tri, 0.0);
    for _ in 0..MAX_CROSSINGS {
        let Some(h) = scene.accel.intersect(o, d, f64::INFINITY, skip) else { return f64::INFINITY };
        travelled += h.t;
        if h.object == hit.object {
            return travelled;
        }
        o = h.p;
        skip = h.tri;
    }
    f64::INFINITY
}

/// Mean curvature H (mm⁻¹, > 0 convex) of the object of `hit`: the mean of
/// [`principal_curvatures`].
pub fn mean_curvature(scene: &Scene, hit: &Hit, s: f64) -> f64 {
    let (k1, k2) = principal_curvatures(scene, hit, s);
    0.5 * (k1 + k2)
}

/// Depth (mm) below x's tangent plane of the object's surface one step `s` (mm) along the unit
/// tangent `t`: a probe ray along −n from x + s·t + s·n; `None` when it finds no front face of
/// the object within 3s.
fn sag(scene: &Scene, hit: &Hit, t: V3, s: f64) -> Option<f64> {
    let mut origin = madd(madd(hit.p, t, s), hit.n, s);
    let (mut skip, mut travelled) = (u32::MAX, 0.0);
    for _ in 0..MAX_CROSSINGS {
        let h = scene.accel.intersect(origin, neg(hit.n), 3.0 * s - travelled, skip)?;
        travelled += h.t;
        if h.object == hit.object && dot(h.n, hit.n) > 0.0 {
            return Some(travelled - s);
        }
        origin = h.p;
        skip = h.tri;
    }
    None
}

/// Normal curvature (mm⁻¹, > 0 convex) of the object of `hit` along the unit tangent `t`: the
/// circle tangent at x that sags δ at u = ±s has κ = 2δ/(s² + δ²), with δ the mean of the sags on
/// both sides (the symmetric mean cancels a tilt of the facet normal n to first order, and uses
/// positions, not the flat facets' normals). A side whose probe finds no surface within 3s has
/// an edge within s (a box's flat face near its edge): it counts as a sag of [`EDGE_SAG`]·s.
/// Also whether a side did (an edge).
fn normal_curvature(scene: &Scene, hit: &Hit, t: V3, s: f64) -> (f64, bool) {
    let (d, edge) = match (sag(scene, hit, t, s), sag(scene, hit, neg(t), s)) {
        (Some(a), Some(b)) => (0.5 * (a + b), false),
        (Some(a), None) | (None, Some(a)) => (0.5 * (a + EDGE_SAG * s), true),
        (None, None) => (EDGE_SAG * s, true),
    };
    (2.0 * d / (s * s + d * d), edge)
}

/// Principal curvatures κ₁ ≥ κ₂ (mm⁻¹, > 0 convex) of the object of `hit`: the normal
/// curvatures along three tangents t, b and (t + b)/√2 (six probe rays, `normal_curvature`)
/// give the symmetric shape operator [[κ_t, m], [m, κ_b]] with m = κ₄₅ − (κ_t + κ_b)/2 (Euler:
/// κ(θ) = κ_t cos²θ + 2m sinθ cosθ + κ_b sin²θ), and κ₁,₂ are its eigenvalues.
pub fn principal_curvatures(scene: &Scene, hit: &Hit, s: f64) -> (f64, f64) {
    principal_curvatures_edge(scene, hit, s).0
}

/// [`principal_curvatures`], and whether a probe fell off an edge (then the curvatures are the
/// edge's model, [`EDGE_SAG`], not a smooth surface's).
fn principal_curvatures_edge(scene: &Scene, hit: &Hit, s: f64) -> ((f64, f64), bool) {
    let f = Frame::new(hit.n);
    let diag = madd(f.t, f.b, 1.0);
    let diag = [diag[0] * FRAC_1_SQRT_2, diag[1] * FRAC_1_SQRT_2, diag[2] * FRAC_1_SQRT_2];
    let [(kt, et), (kb, eb), (kd, ed)] = [f.t, f.b, diag].map(|t| normal_curvature(scene, hit, t, s));
    let mean = 0.5 * (kt + kb);
    let m = kd - mean;
    let root = (0.25 * (kt - kb).powi(2) + m * m).sqrt();
    ((mean + root, mean - root), et || eb || ed)
}

/// The thickness and the principal curvatures at `hit` as [`Kernel::at`] probes them: d (mm)
/// and (κ₁, κ₂) (mm⁻¹), and whether a curvature probe fell off an edge.
fn local_geometry(scene: &Scene, table: &AdaptiveTable, hit: &Hit) -> (f64, (f64, f64), bool) {
    let d = thickness(scene, hit);
    let s = table.median_radius.min(0.25 * d);
    let (k, edge) = if s > 0.0 { principal_curvatures_edge(scene, hit, s) } else { ((0.0, 0.0), false) };
    (d, k, edge)
}

/// The azimuthal-harmonic amplitudes of an entry point `hit` per channel, at its principal
/// curvatures probed as [`Kernel::at`] does ([`crate::bssrdf::harmonic`]); `None` when they are
/// all 0 (no factor to apply).
pub fn entry_amplitudes(scene: &Scene, table: &AdaptiveTable, hit: &Hit) -> Option<[AtRho; 3]> {
    let (_, (k1, k2), _) = local_geometry(scene, table, hit);
    let a: [AtRho; 3] = std::array::from_fn(|k| table.harmonic(k.min(table.channels() - 1)).at_principal(k1, k2));
    (!a.iter().all(AtRho::is_zero)).then_some(a)
}

/// The adaptive BSSRDF at one shading point (see the module docs).
pub struct Kernel {
    p: V3,
    n: V3,
    /// Local thickness, mm.
    pub d: f64,
    /// Local mean curvature, mm⁻¹ (> 0 convex).
    pub h: f64,
    /// Local principal curvatures κ₁ ≥ κ₂, mm⁻¹ (> 0 convex).
    pub k: (f64, f64),
    r: [Binned; 3],
    t: [Mix; 3],
    /// At a tube's saddle ([`is_tube_saddle`], no edge): per channel the kernel's integral over the
    /// tangent cylinder of radius 1/κ₁, which [`Tree::exitance_with`] makes its integral over the mesh
    /// ([`PairProfiles::target`]; `probe`: [`Kernel::normalisation`]); `None` elsewhere.
    pub target: Option<Rgb>,
    /// [`Kernel::t_reach`].
    t_reach: f64,
    /// Per channel R's reach ([`RadialProfile::reach`]; `beyond` asks at every node).
    r_reach: [f64; 3],
    /// Whether the channels' R have the same chord bins ([`Binned::same_bins`]; the bins' radius
    /// is the curvature's, so they do: one bin look-up per pair).
    one_bins: bool,
}

impl Kernel {
    /// The kernel at `hit` with the material's table.
    pub fn at(scene: &Scene, table: &AdaptiveTable, hit: &Hit) -> Kernel {
        let (d, (k1, k2), edge) = local_geometry(scene, table, hit);
        let pair = |k: usize| {
            let c = k.min(table.channels() - 1);
            let sc = table.curvature_scale_principal(c, k1, k2);
            let (r, t) = table.scaled(c, table.local(c, d), (1.0, sc.far));
            (Binned::new(r, &sc), t)
        };
        let [a, b, c] = [pair(0), pair(1), pair(2)];
        let (r, t) = ([a.0, b.0, c.0], [a.1, b.1, c.1]);
        let target =
            (!edge && is_tube_saddle(d, k1, k2)).then(|| std::array::from_fn(|k| r[k].cylinder_mass(&t[k], 1.0 / k1)));
        let t_reach = Kernel::t_reach(&r, &t);
        let r_reach = std::array::from_fn(|k| r[k].reach());
        let one_bins = r[0].same_bins(&r[1]) && r[0].same_bins(&r[2]);
        Kernel { p: hit.p, n: hit.n, d, h: 0.5 * (k1 + k2), k: (k1, k2), r, t, target, t_reach, r_reach, one_bins }
    }

    /// The profile value per channel (mm⁻²) for light entering at `q`.
    pub fn value(&self, q: V3) -> Rgb {
        self.value_class(q).1
    }

    /// The class of `q` ([`PairProfiles::class`]) and [`Kernel::value`].
    pub fn value_class(&self, q: V3) -> (usize, Rgb) {
        let (c, r) = self.class(self.p, q);
        (c, std::array::from_fn(|k| self.profile(c, k).rd(r)))
    }
}

/// Largest |ln(d κ₁/2)| at which a saddle is normalised to its tube ([`is_tube_saddle`]): a
/// chosen tolerance (ln 1.25), not fitted; the torus of `docs/render.md` has d κ₁/2 = 1.00.
pub const TUBE_MATCH: f64 = 0.22;

/// A tube's saddle: κ₁ > 0 > κ₂ with mean curvature > 0, and a thickness d within 25 % of the
/// tube's diameter 2/κ₁ (the inside of a torus' ring). The scales there are the tube's, but the
/// surface rises above the tangent plane along κ₂, so more of it lies within a given distance
/// of x than on the tube. Where d is not the diameter (a thin wall) the point is not on a tube,
/// and where a curvature probe fell off an edge (a box's edge: [`Kernel::at`] asks) the
/// curvatures are the edge's model: nothing is normalised there.
pub fn is_tube_saddle(d: f64, k1: f64, k2: f64) -> bool {
    k1 > 0.0 && k2 < 0.0 && k1 + k2 > 0.0 && (0.5 * d * k1).ln().abs() < TUBE_MATCH
}

impl Kernel {
    /// The factor per channel that makes this kernel's integral over the object's surface (the
    /// samples of `tree`, E_t = 1) its [`Kernel::target`]; 1 without a target.
    pub fn normalisation(&self, tree: &Tree, epsilon: f64) -> Rgb {
        let Some(t) = self.target else { return [1.0; 3] };
        let mass = tree.exitance_with(&Unnormalised(self), self.p, epsilon);
        std::array::from_fn(|k| if mass[k] > 0.0 { t[k] / mass[k] } else { 1.0 })
    }
}

/// A kernel without its [`Kernel::target`]: the plain sum.
pub struct Unnormalised<'a>(pub &'a Kernel);

impl PairProfiles for Unnormalised<'_> {
    fn class(&self, x: V3, q: V3) -> (usize, f64) {
        self.0.class(x, q)
    }
    fn profile(&self, c: usize, k: usize) -> &dyn RadialProfile {
        self.0.profile(c, k)
    }
    fn rd3(&self, c: usize, r: f64, ln_r: f64) -> Rgb {
        self.0.rd3(c, r, ln_r)
    }
    fn beyond(&self, x: V3, lo: V3, hi: V3, near: f64) -> bool {
        self.0.beyond(x, lo, hi, near)
    }
}

impl PairProfiles for Kernel {
    fn class(&self, x: V3, q: V3) -> (usize, f64) {
        let v = sub(x, q);
        let h = dot(v, self.n);
        let r = length(v);
        if h > BEYOND * self.d {
            (1, f64::INFINITY) // past the part's far face: another part of the object, across air
        } else if h > 0.5 * self.d {
            (1, (r * r - h * h).max(0.0).sqrt())
        } else {
            (0, r)
        }
    }
    fn profile(&self, c: usize, k: usize) -> &dyn RadialProfile {
        if c == 0 {
            &self.r[k]
        } else {
            &self.t[k]
        }
    }
    /// [`Binned::value_ln`] or [`Mix::value_ln`] per channel (the same values as `profile`'s,
    /// without the trait objects).
    #[inline]
    fn rd3(&self, c: usize, r: f64, ln_r: f64) -> Rgb {
        if c == 0 {
            if self.one_bins {
                let b = self.r[0].bin(r);
                std::array::from_fn(|k| self.r[k].value_ln_in(b, r, ln_r))
            } else {
                std::array::from_fn(|k| self.r[k].value_ln(r, ln_r))
            }
        } else {
            std::array::from_fn(|k| self.t[k].value_ln(r, ln_r))
        }
    }
    fn target(&self) -> Option<Rgb> {
        self.target
    }
    /// Beyond R's reach from x, and beyond T's (`Kernel::t_reach`): an entry point across the
    /// part (d/2 < h ≤ [`BEYOND`]·d) with r⊥ within it is within √(reach² + (d/2)²) of x − d·n.
    fn beyond(&self, x: V3, lo: V3, hi: V3, near: f64) -> bool {
        let r = self.r_reach.iter().copied().fold(near, f64::max);
        if box_distance2(x, lo, hi) <= r * r {
            return false;
        }
        let t = self.t_reach;
        if t == 0.0 || !self.d.is_finite() {
            return true;
        }
        let t = t.max(near);
        box_distance2(madd(x, self.n, -self.d), lo, hi) > t * t + 0.25 * self.d * self.d
    }
}

impl Kernel {
    /// The lateral offset (mm) beyond which T holds at most 10⁻⁶ of R's energy, per channel the
    /// largest (0 when T holds less than that in all): a thick part's T (a sphere of 100
    /// diffusion lengths: 10⁻⁵ of R) is a noisy table whose own 1 − 10⁻⁶ radius is meaningless.
    fn t_reach(r: &[Binned; 3], t: &[Mix; 3]) -> f64 {
        (0..3)
            .map(|k| {
                let (rt, tt) = (r[k].total(), t[k].total());
                let q = 1.0 - 1e-6 * rt / tt.max(1e-300);
                if tt <= 0.0 || q <= 0.0 {
                    0.0
                } else {
                    t[k].sample_r(q).min(t[k].reach())
                }
            })
            .fold(0.0, f64::max)
    }
}

#[cfg(test)]
#[path = "adaptive_tests.rs"]
pub(super) mod tests;
