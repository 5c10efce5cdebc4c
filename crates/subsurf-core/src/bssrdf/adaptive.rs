//! The geometry-aware profiles of `model = "adaptive"`: exact Monte Carlo reflection R(r; d) *and*
//! transmission T(r; d) profiles of the material cut into a finite slab of thickness d, on a grid
//! of thicknesses, one table per colour channel.
//!
//! Every other profile here assumes a flat semi-infinite medium. On a thin part (an ear, a leaf,
//! the rim of a lens) light also leaves through the far side, and less of it comes back on the
//! near side; on a small convex object (radius ~ the diffusion length) light escapes through the
//! curved surface sooner than in a half-space. The renderer (`render::adaptive`) measures the local
//! thickness d along −n with a probe ray and evaluates R(r; d) for entry points on the near side
//! and T(r; d) for entry points across the part. This module holds the tables:
//!
//! - [`SlabTally`]: the engine's radial tally ([`RadialTally`]) of the top (R) and, for the
//!   bottom face, of the transmitted weight (T), with per-photon second moments;
//! - [`thickness_nodes`]: d_j = ℓ·2^j (ℓ = the largest transport mean free path 1/σt' of the
//!   stack), j = −3, −2, …, up to the first node ≥ max(8ℓ, 6L) (L = 1/√(3σaσt') the diffusion
//!   length of the deepest layer; at most 2¹²ℓ), plus d = ∞ (the semi-infinite profile);
//! - [`build_node`]: one (channel, thickness) run of the engine — the stack cut at depth d
//!   ([`slab`]), air (the index above) below it, normal incidence, seed `seed + 64·channel + j`;
//! - [`AdaptiveTable`]: the assembled per-channel tables (energy-exact [`MonteCarloProfile`]s,
//!   per unit *entering* power, as the renderer's BSSRDF wants them) and their interpolation in d
//!   ([`AdaptiveTable::local`]): linear mixture of the two neighbouring nodes in ln d, and
//!   between the last finite node d_n and ∞ with weight d_n/d on the finite one (continuous; at
//!   d ≥ d_n the profile is within the Monte Carlo noise of the semi-infinite one).
//!
//! With them, per channel, the curvature data ([`super::curvature`]), the oblique-incidence
//! gain ([`super::oblique`]) the renderer applies to the transmitted irradiance, and the
//! azimuthal harmonic of collimated light ([`super::harmonic`]), and the exit term's angular
//! shape ([`super::exit`]).
//!
//! The tables are deterministic (fixed seeds per node, the engine's exact merging), so a cache
//! keyed by the stacks, the settings and the engine's version holds exactly what a rebuild makes
//! (`subsurf.bssrdf.AdaptiveTable`, HDF5).

use super::coupling::Coupling;
use super::curvature::{
    build_curvature, curvature_photons, cylinder_gather, sphere_gather, CurvatureData, Gathers, LocalScale, Scales,
};
use super::exit::{Exit, EXIT_BINS};
use super::flow::Flow;
use super::harmonic::Harmonic;
use super::monte_carlo::{default_edges, McSettings, MonteCarloProfile, RadialData, RadialTally};
use super::oblique::{Gain, OBLIQUE_THETA_DEG};
use super::RadialProfile;
use crate::error::{Error, Result};
use crate::mc::tally::{Channel, ChannelState};
use crate::mc::{run, Packet, RunConfig, Side, Source, Tally};
use crate::medium::{Layer, Stack};
use crate::render::material::RdTable;
use std::sync::atomic::{AtomicBool, AtomicU64};
use std::sync::Arc;

/// First thickness node, in transport mean free paths ℓ (d₀ = ℓ/8).
pub const FIRST_NODE_LOG2: i32 = -3;
/// Largest thickness node, in ℓ (2¹²).
pub const LAST_NODE_LOG2: i32 = 12;
/// Seeds: node j of channel c uses `seed + SEED_STRIDE·c + j` (j = the node's index; ∞ last).
pub const SEED_STRIDE: u64 = 64;

/// The transmitted weight on the engine's radial grid: [`RadialTally`] fed with the bottom
/// escapes of photons that scattered at least once. The unscattered ones (a pencil's straight
/// line through the slab) are the renderer's own exact term (`render::shade::unscattered`, the
/// chord's e^(−σt ℓ) along the actual ray): in T they would be counted twice, spread as diffuse
/// light at r⊥ = 0 (the validation matrix's 2 mm backlit marble slab: +4.5 % red against the
/// walk less that term, `docs/render.md`).
#[derive(Clone, Debug, PartialEq)]
pub struct BottomTally(pub RadialTally);

impl Tally for BottomTally {
    const POSITIONS: bool = false;
    #[inline]
    fn begin_photon(&mut self, _lane: usize, _photon: u64) {}
    #[inline]
    fn specular(&mut self, _lane: usize, _w: f64) {}
    #[inline]
    fn absorb(&mut self, _lane: usize, _p: &Packet, _dw: f64) {}
    #[inline]
    fn roulette(&mut self, _lane: usize, _p: &Packet, _dw: f64) {}
    #[inline]
    fn escape(&mut self, lane: usize, p: &Packet, side: Side, dir_out: [f64; 3], w: f64) {
        if side == Side::Bottom && p.order > 0 {
            self.0.escape(lane, p, Side::Top, dir_out, w);
        }
    }
    #[inline]
    fn end_photon(&mut self, lane: usize) {
        self.0.end_photon(lane);
    }
    fn channels(&self, out: &mut Vec<Channel>) {
        let start = out.len();
        self.0.channels(out);
        for c in &mut out[start..] {
            c.name = format!("transmitted_{}", c.name);
        }
    }
    fn drain_into(&mut self, state: &mut [ChannelState]) -> Option<usize> {
        self.0.drain_into(state)
    }
    fn load_from(&mut self, state: &[ChannelState], photons: u64) -> usize {
        self.0.load_from(state, photons)
    }
}

/// Reflected (top) and transmitted (bottom) radial weight of one run.
pub type SlabTally = (RadialTally, BottomTally);

/// What the table keeps of one (channel, thickness) run: its reflection and transmission data.
#[derive(Clone, Debug, PartialEq)]
pub struct SlabData {
    /// Thickness, mm (∞: the semi-infinite stack, whose `bottom` is all zeros).
    pub d: f64,
    /// Radial data of the weight leaving through the top (R).
    pub top: RadialData,
    /// Radial data of the weight leaving through the bottom (T).
    pub bottom: RadialData,
}

/// Largest transport mean free path 1/σt' over the layers that interact (mm).
pub(crate) fn transport_length(stack: &Stack) -> f64 {
    stack.layers.iter().filter(|l| l.sigma_t_prime() > 0.0).map(|l| 1.0 / l.sigma_t_prime()).fold(0.0, f64::max)
}

/// The thickness nodes (mm) of a stack (see the module docs), finite ones only.
pub fn thickness_nodes(stack: &Stack) -> Result<Vec<f64>> {
    let ell = transport_length(stack);
    if !(ell > 0.0 && ell.is_finite()) {
        return Err(Error::Invalid("adaptive: the stack has no scattering layer (no transport mean free path)".into()));
    }
    let deep = stack.layers.last().expect("a stack has a layer");
    let l_diff = if deep.mua > 0.0 { 1.0 / (3.0 * deep.mua * deep.sigma_t_prime()).sqrt() } else { f64::INFINITY };
    let goal = (8.0 * ell).max(6.0 * l_diff);
    let mut out = vec![];
    for j in FIRST_NODE_LOG2..=LAST_NODE_LOG2 {
        let d = ell * 2f64.powi(j);
        out.push(d);
        if d >= goal {
            break;
        }
    }
    Ok(out)
}

/// `stack` cut at depth `d` (mm; ∞ keeps it), with the index above also below it (an object in air).
pub fn slab(stack: &Stack, d: f64) -> Result<Stack> {
    if d == f64::INFINITY {
        return Ok(stack.clone());
    }
    if !(d > 0.0 && d.is_finite()) {
        return Err(Error::param("d", d, "a thickness > 0 (mm)"));
    }
    let mut layers: Vec<Layer> = vec![];
    let mut top = 0.0;
    for l in &stack.layers {
        let mut l = *l;
        let bottom = top + l.thickness;
        if bottom >= d {
            l.thickness = d - top;
            layers.push(l);
            return Stack::new(layers, stack.n_above, stack.n_above);
        }
        layers.push(l);
        top = bottom;
    }
    // A finite stack thinner than d: the object is the stack itself.
    Ok(stack.clone())
}

/// Settings of an adaptive table.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdaptiveSettings {
    /// Photons per (channel, thickness) node (≥ 2).
    pub photons: u64,
    /// Seed of node 0 of channel 0 (see [`SEED_STRIDE`]).
    pub seed: u64,
    /// Worker threads per run (`None`: all cores).
    pub threads: Option<usize>,
    /// Relative error beyond which a profile's tail is the fitted asymptote.
    pub max_rel_err: f64,
}

impl AdaptiveSettings {
    /// The settings of a material's Monte Carlo profile (photons, seed, threads).
    pub fn from_mc(mc: &McSettings) -> AdaptiveSettings {
        AdaptiveSettings { photons: mc.photons, seed: mc.seed, threads: mc.threads, max_rel_err: mc.max_rel_err }
    }
}

/// Trace node `j` (thickness `d`, mm; ∞ for the semi-infinite stack) of channel `channel`.
/// `None` when `cancel` stopped it.
pub fn build_node(
    stack: &Stack,
    d: f64,
    channel: usize,
    j: usize,
    s: &AdaptiveSettings,
    cancel: &AtomicBool,
    progress: &AtomicU64,
) -> Result<Option<SlabData>> {
    if s.photons < 2 {
        return Err(Error::param("photons", s.photons as f64, "an integer >= 2"));
    }
    let cut = slab(stack, d)?;
    // The grid of the semi-infinite stack, for every node (r_max = 10³ ℓ).
    let edges = default_edges(stack, &McSettings::default())?;
    let cfg = RunConfig {
        photons: s.photons,
        seed: s.seed.wrapping_add(SEED_STRIDE * channel as u64 + j as u64),
        threads: s.threads,
        source: Source::default(),
        isa: None,
    };
    let make = || (RadialTally::new(edges.clone()), BottomTally(RadialTally::new(edges.clone())));
    let out = run(&cut, &cfg, make, cancel, progress)?;
    if out.cancelled {
        return Ok(None);
    }
    Ok(Some(SlabData { d, top: out.tally.0.data(), bottom: out.tally.1 .0.data() }))
}

/// A node's profile: the energy-exact Monte Carlo profile with R_d looked up in a log–log table
/// (the renderer's [`RdTable`], ≤ 1.1·10⁻⁴ relative; the tree walk evaluates it at every sample,
/// and the lookup is cheaper than the profile's own spline). The concrete type, not a trait
/// object: [`Mix::value_ln`] inlines the lookups.
type Node = Arc<RdTable>;

fn node(d: &RadialData, max_rel_err: f64) -> Result<Node> {
    Ok(Arc::new(RdTable::new(Box::new(MonteCarloProfile::from_data(d.clone(), max_rel_err)?), 1.0)))
}

/// One channel's nodes as profiles.
#[derive(Clone)]
struct ChannelTable {
    /// Thicknesses (mm), increasing, the last ∞.
    d: Vec<f64>,
    r: Vec<Node>,
    /// `None` where nothing was transmitted (and at ∞).
    t: Vec<Option<Node>>,
    /// 1 / (1 − R_sp): per unit entering power.
    entering: f64,
    /// The oblique-incidence gain g(μ) ([`super::oblique`]).
    gain: Gain,
    /// The azimuthal harmonic's amplitudes ([`super::harmonic`]).
    harmonic: Harmonic,
    /// The exit term's angular shape ([`super::exit`]).
    exit: Exit,
    /// The exit direction's coupling to the light's ([`super::coupling`]).
    coupling: Coupling,
    /// The exit direction's flow along the light from each entry point ([`super::flow`]).
    flow: Flow,
}

/// The per-channel tables (see the module docs).
#[derive(Clone)]
pub struct AdaptiveTable {
    /// The largest median radius (mm) of the semi-infinite profiles: the renderer's curvature step.
    pub median_radius: f64,
    channels: Vec<ChannelTable>,
    data: Vec<Vec<SlabData>>,
    curvature: Vec<CurvatureData>,
    scales: Vec<Scales>,
    settings: AdaptiveSettings,
}

/// Where a thickness falls in a channel's nodes: node indices and mixture weights.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Local {
    /// Lower node.
    pub i: usize,
    /// Weight of node i + 1 (0 … 1).
    pub t: f64,
}

impl std::fmt::Debug for AdaptiveTable {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let d: Vec<&[f64]> = self.channels.iter().map(|c| c.d.as_slice()).collect();
        f.debug_struct("AdaptiveTable").field("thicknesses", &d).field("settings", &self.settings).finish()
    }
}

impl AdaptiveTable {
    /// Assemble a table from the nodes of each channel (`data[c]`: thickness nodes then ∞) and
    /// its curvature data (`curvature[c]`, [`crate::bssrdf::curvature`]).
    pub fn assemble(
        stacks: &[Stack],
        data: Vec<Vec<SlabData>>,
        curvature: Vec<CurvatureData>,
        settings: AdaptiveSettings,
    ) -> Result<AdaptiveTable> {
        if stacks.len() != data.len() || stacks.len() != curvature.len() || stacks.is_empty() {
            return Err(Error::Invalid(format!(
                "adaptive table: {} channels of nodes and {} of curvature data for {} stacks",
                data.len(),
                curvature.len(),
                stacks.len()
            )));
        }
        if !(settings.max_rel_err > 0.0 && settings.max_rel_err <= 1.0) {
            return Err(Error::param("max_rel_err", settings.max_rel_err, "a number in (0, 1]"));
        }
        let mut channels = vec![];
        for (c, (stack, nodes)) in stacks.iter().zip(&data).enumerate() {
            let want = thickness_nodes(stack)?;
            let ok = nodes.len() == want.len() + 1
                && nodes
                    .iter()
                    .zip(want.iter().chain([&f64::INFINITY]))
                    .all(|(n, &d)| n.d == d || (n.d - d).abs() <= 1e-12 * d);
            if !ok {
                return Err(Error::Invalid(format!(
                    "adaptive table: channel {c} has nodes at {:?} mm, its stack needs {want:?} and infinity",
                    nodes.iter().map(|n| n.d).collect::<Vec<_>>()
                )));
            }
            let mut r = vec![];
            let mut t = vec![];
            for n in nodes {
                r.push(node(&n.top, settings.max_rel_err)?);
                let has_t = n.d.is_finite() && n.bottom.weight.iter().any(|&w| w > 0.0);
                t.push(if has_t { Some(node(&n.bottom, settings.max_rel_err)?) } else { None });
            }
            let top = &stack.layers[0];
            let entering = 1.0 / (1.0 - crate::optics::fr_dielectric(1.0, stack.n_above, top.n));
            let oblique = &curvature[c].oblique;
            if oblique.len() != OBLIQUE_THETA_DEG.len() {
                return Err(Error::Invalid(format!(
                    "adaptive table: channel {c} has {} oblique runs, the table needs {} (at {OBLIQUE_THETA_DEG:?} degrees)",
                    oblique.len(),
                    OBLIQUE_THETA_DEG.len()
                )));
            }
            let gain = Gain::new(stack, nodes[nodes.len() - 1].top.total, oblique);
            let harmonic = Harmonic::new(&curvature[c].rho, &curvature[c].harmonic)?;
            let ex = &curvature[c].exit;
            if ex.weight.len() != EXIT_BINS || ex.stderr.len() != EXIT_BINS {
                return Err(Error::Invalid(format!(
                    "adaptive table: channel {c}'s exit histogram needs {EXIT_BINS} bins"
                )));
            }
            let exit = Exit::fit(top.n / stack.n_above, &ex.weight, &ex.stderr);
            let coupling = Coupling::new(top.n / stack.n_above, &curvature[c].coupling)?;
            let flow = Flow::new(top.n / stack.n_above, transport_length(stack), &curvature[c].flow)?;
            let d = nodes.iter().map(|n| n.d).collect();
            channels.push(ChannelTable { d, r, t, entering, gain, harmonic, exit, coupling, flow });
        }
        let median_radius = channels
            .iter()
            .map(|c| {
                let semi = Mix::new([Some(c.r[c.r.len() - 1].clone()), None], 0.0, 1.0);
                semi.radius_for_fraction(0.5)
            })
            .fold(0.0, f64::max);
        let mut table = AdaptiveTable { median_radius, channels, data, curvature, scales: vec![], settings };
        for (c, stack) in stacks.iter().enumerate() {
            let cd = &table.curvature[c];
            if cd.rho != super::curvature::curvature_nodes(stack)? {
                return Err(Error::Invalid(format!(
                    "adaptive table: channel {c}'s curvature nodes do not match its stack"
                )));
            }
            let n = table.channels[c].d.len();
            let semi = table.reflection(c, Local { i: n - 2, t: 1.0 });
            let flat = table.flat_diffuse(c, stack);
            let sphere = |rho: f64| {
                let at = table.local(c, 2.0 * rho);
                sphere_gather(&table.reflection(c, at), &table.transmission(c, at), rho)
            };
            let cylinder = |rho: f64| {
                let at = table.local(c, 2.0 * rho);
                cylinder_gather(&table.reflection(c, at), &table.transmission(c, at), rho)
            };
            let sc = Scales::new(cd, Gathers { sphere: &sphere, cylinder: &cylinder }, &semi, flat)?;
            table.scales.push(sc);
        }
        Ok(table)
    }

    /// Build every node here, channel by channel (each run uses the settings' threads); `None`
    /// when `cancel` stopped it.
    pub fn build(
        stacks: &[Stack],
        s: &AdaptiveSettings,
        cancel: &AtomicBool,
        progress: &AtomicU64,
    ) -> Result<Option<AdaptiveTable>> {
        let mut data = vec![];
        let mut curvature = vec![];
        for (c, stack) in stacks.iter().enumerate() {
            match build_curvature(stack, c, s, cancel, progress)? {
                Some(cd) => curvature.push(cd),
                None => return Ok(None),
            }
            let mut nodes = vec![];
            let ds = thickness_nodes(stack)?;
            for (j, &d) in ds.iter().chain([&f64::INFINITY]).enumerate() {
                match build_node(stack, d, c, j, s, cancel, progress)? {
                    Some(n) => nodes.push(n),
                    None => return Ok(None),
                }
            }
            data.push(nodes);
        }
        Self::assemble(stacks, data, curvature, *s).map(Some)
    }

    /// Photons a build of `stacks` traces (its progress total).
    pub fn photons(stacks: &[Stack], s: &AdaptiveSettings) -> u64 {
        let nodes: usize = stacks.iter().map(|st| thickness_nodes(st).map_or(0, |v| v.len() + 1)).sum();
        let curved: u64 = stacks.iter().map(|st| curvature_photons(st, s.photons)).sum();
        s.photons.saturating_mul(nodes as u64).saturating_add(curved)
    }

    /// The nodes each channel was built from.
    pub fn data(&self) -> &[Vec<SlabData>] {
        &self.data
    }
    /// The curvature data of each channel.
    pub fn curvature(&self) -> &[CurvatureData] {
        &self.curvature
    }
    /// The curvature scales (near side R per chord bin, far side T) of channel `c` at mean
    /// curvature `h` (mm⁻¹; > 0 convex, < 0 concave).
    pub fn curvature_scale(&self, c: usize, h: f64) -> LocalScale {
        self.scales[c].at(h)
    }
    /// The curvature scales of channel `c` at principal curvatures `k1`, `k2` (mm⁻¹; sphere,
    /// cylinder or cavity, [`Scales::at_principal`]).
    pub fn curvature_scale_principal(&self, c: usize, k1: f64, k2: f64) -> LocalScale {
        self.scales[c].at_principal(k1, k2)
    }
    /// The curvature scales of channel `c` (convex, concave) at its nodes.
    pub fn scales(&self, c: usize) -> &Scales {
        &self.scales[c]
    }
    /// The settings it was built with.
    pub fn settings(&self) -> &AdaptiveSettings {
        &self.settings
    }
    /// The oblique-incidence gain g_c(μ) = R(θi)/R(0) of channel `c` at μ = cos θi
    /// ([`super::oblique`]): the weight of light arriving at θi in the transmitted irradiance.
    pub fn oblique_gain(&self, c: usize, mu: f64) -> f64 {
        self.channels[c].gain.at(mu)
    }
    /// Channel `c`'s gain and its nodes.
    pub fn gain(&self, c: usize) -> &Gain {
        &self.channels[c].gain
    }
    /// The model's flat diffuse reflectance of channel `c` per unit incident power of uniform
    /// diffuse light: the semi-infinite kernel's total through the gain (what the curvature
    /// scales are relative to, [`super::curvature::Scales::new`]).
    pub fn flat_diffuse(&self, c: usize, stack: &Stack) -> f64 {
        let n = self.channels[c].d.len();
        self.reflection(c, Local { i: n - 2, t: 1.0 }).total() * self.channels[c].gain.diffuse_weight(stack)
    }
    /// Channel `c`'s azimuthal-harmonic amplitudes ([`super::harmonic`]).
    pub fn harmonic(&self, c: usize) -> &Harmonic {
        &self.channels[c].harmonic
    }
    /// Channel `c`'s exit shape ([`super::exit`]).
    pub fn exit(&self, c: usize) -> &Exit {
        &self.channels[c].exit
    }
    /// The exit term's factors s_c(μ_o) on the flat surface's F_t(η, μ_o)/(π c), per channel
    /// (the first three; [`super::exit`]).
    pub fn exit_factors(&self, mu: f64) -> [f64; 3] {
        std::array::from_fn(|c| self.channels[c.min(self.channels.len() - 1)].exit.factor(mu))
    }
    /// Channel `c`'s exit coupling ([`super::coupling`]).
    pub fn coupling(&self, c: usize) -> &Coupling {
        &self.channels[c].coupling
    }
    /// Whether any channel has an exit coupling.
    pub fn has_coupling(&self) -> bool {
        self.channels.iter().any(|c| !c.coupling.is_zero())
    }
    /// Channel `c`'s exit flow ([`super::flow`]).
    pub fn flow(&self, c: usize) -> &Flow {
        &self.channels[c].flow
    }
    /// Whether any channel has an exit flow and the flow is switched on ([`super::flow::enabled`]).
    pub fn has_flow(&self) -> bool {
        super::flow::enabled() && self.channels.iter().any(|c| !c.flow.is_zero())
    }
    /// Number of channels.
    pub fn channels(&self) -> usize {
        self.channels.len()
    }

    /// Where thickness `d` (mm, > 0; ∞ allowed) falls in channel `c`'s nodes.
    pub fn local(&self, c: usize, d: f64) -> Local {
        let ds = &self.channels[c].d;
        let n = ds.len() - 1; // finite nodes 0 … n−1, ∞ at n
        if !(d > ds[0]) {
            return Local { i: 0, t: 0.0 };
        }
        if d >= ds[n - 1] {
            return Local { i: n - 1, t: 1.0 - ds[n - 1] / d };
        }
        let i = ds[..n].partition_point(|&x| x <= d) - 1;
        Local { i, t: (d / ds[i]).ln() / (ds[i + 1] / ds[i]).ln() }
    }

    /// The reflection profile of channel `c` at `at` (per unit entering power).
    pub fn reflection(&self, c: usize, at: Local) -> Mix {
        let ch = &self.channels[c];
        Mix::new([Some(ch.r[at.i].clone()), Some(ch.r[at.i + 1].clone())], at.t, ch.entering)
    }

    /// The reflection and transmission profiles of channel `c` at `at`, scaled by `k.0` and `k.1`.
    pub fn scaled(&self, c: usize, at: Local, k: (f64, f64)) -> (Mix, Mix) {
        let ch = &self.channels[c];
        (
            Mix::new([Some(ch.r[at.i].clone()), Some(ch.r[at.i + 1].clone())], at.t, k.0 * ch.entering),
            Mix::new([ch.t[at.i].clone(), ch.t[at.i + 1].clone()], at.t, k.1 * ch.entering),
        )
    }

    /// The transmission profile of channel `c` at `at` (per unit entering power; 0 at d = ∞).
    pub fn transmission(&self, c: usize, at: Local) -> Mix {
        let ch = &self.channels[c];
        Mix::new([ch.t[at.i].clone(), ch.t[at.i + 1].clone()], at.t, ch.entering)
    }

    /// Total reflectance and transmittance (per unit entering power) of channel `c` at thickness `d`.
    pub fn totals(&self, c: usize, d: f64) -> (f64, f64) {
        let at = self.local(c, d);
        (self.reflection(c, at).total(), self.transmission(c, at).total())
    }
}

/// A mixture (1 − t)·a + t·b of two node profiles, scaled by k (a missing node is 0).
#[derive(Clone)]
pub struct Mix {
    p: [Option<Node>; 2],
    w: [f64; 2],
    total: f64,
}

impl Mix {
    fn new(p: [Option<Node>; 2], t: f64, k: f64) -> Mix {
        let w = [k * (1.0 - t), k * t];
        let total = (0..2).map(|i| p[i].as_ref().map_or(0.0, |q| w[i] * q.total())).sum();
        Mix { p, w, total }
    }
    #[inline(always)]
    fn each(&self, f: impl Fn(&RdTable) -> f64) -> f64 {
        (0..2)
            .map(|i| match &self.p[i] {
                Some(q) if self.w[i] != 0.0 => self.w[i] * f(q),
                _ => 0.0,
            })
            .sum()
    }
    /// [`RadialProfile::rd_ln`] without the trait object (the tables' lookups inlined,
    /// [`RdTable::value_ln`]): the adaptive kernel's tree walk.
    #[inline(always)]
    pub fn value_ln(&self, r: f64, ln_r: f64) -> f64 {
        self.each(|q| q.value_ln(r, ln_r))
    }
}

impl RadialProfile for Mix {
    fn rd(&self, r: f64) -> f64 {
        self.each(|q| q.rd(r))
    }
    fn rd_ln(&self, r: f64, ln_r: f64) -> f64 {
        self.value_ln(r, ln_r)
    }
    fn reach(&self) -> f64 {
        (0..2).filter(|&i| self.w[i] != 0.0).filter_map(|i| self.p[i].as_ref()).map(|q| q.reach()).fold(0.0, f64::max)
    }
    fn total(&self) -> f64 {
        self.total
    }
    fn cdf(&self, r: f64) -> f64 {
        if self.total > 0.0 {
            self.each(|q| q.total() * q.cdf(r)) / self.total
        } else {
            0.0
        }
    }
    fn sample_r(&self, u: f64) -> f64 {
        // The mixture's CDF lies between its components' inverses: bisect in ln r.
        let rs: Vec<f64> = self.p.iter().flatten().map(|q| q.sample_r(u)).collect();
        let (mut lo, mut hi) = rs.iter().fold((f64::INFINITY, 0.0f64), |(a, b), &r| (a.min(r), b.max(r)));
        if !(hi > lo) || !hi.is_finite() {
            return lo.min(hi);
        }
        for _ in 0..200 {
            let m = if lo > 0.0 { (lo * hi).sqrt() } else { 0.5 * hi };
            if self.cdf(m) < u {
                lo = m;
            } else {
                hi = m;
            }
            if hi - lo <= 1e-14 * hi {
                break;
            }
        }
        0.5 * (lo + hi)
    }
}

#[cfg(test)]
#[path = "adaptive_tests.rs"]
mod tests;
