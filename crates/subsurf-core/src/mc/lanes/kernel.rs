//! The lane loop: MCML's hop–drop–spin–roulette (see `mc::kernel` for the physics and its
//! references) on [`LANES`] photons at once.
//!
//! Each step of the loop advances every live lane by one event, in phases that are loops over
//! the lanes with branch-free bodies (vectorised):
//! 1. **step and interaction** ([`advance`]): draw an optical depth where the last one is used
//!    up; a lane whose step stays in its layer moves there and interacts (absorption by
//!    weight, Henyey–Greenstein cos θ, azimuth, MCML's direction update, Russian roulette
//!    relative to the entering weight, its control term for `Tally::roulette`);
//! 2. **interface** ([`interfaces`], skipped when no lane reached one): move onto it, Fresnel
//!    reflection or refraction, layer change, escape.
//!
//! Then the absorption deposits of all lanes go to the tally at once (`Tally::absorb_lanes`)
//! and, lane by lane, the rare events: roulette terms, layer changes, escapes, the termination
//! rules of `mc::kernel` (trapped packets, clear-layer bounces), ends of histories and refills
//! with the next photon index. Each lane computes with the same correctly rounded operations
//! whatever its neighbours or the instruction set, so a photon's history depends on its own
//! stream only.

use super::math::{cos_sin_2pi, neg_ln, sel};
use super::{Isa, LANES};
use crate::mc::config::{ROULETTE_M, ROULETTE_THRESHOLD};
use crate::mc::kernel::{KLayer, Kernel};
use crate::mc::packet::{Packet, Side};
use crate::mc::tally::{Deposits, Tally};
use crate::optics::Phase;
use crate::rng::{philox4x32_10, u32_to_open01, PhotonRng};
use std::ops::Range;
use std::sync::atomic::{AtomicBool, Ordering};

const L: usize = LANES;
type F = [f64; L];
type U = [u32; L];
/// A mask per lane: 0 or all ones, as u64 (the width of the f64 lanes: no conversions).
type B = [u64; L];

#[inline(always)]
fn mk(c: bool) -> u64 {
    0u64.wrapping_sub(c as u64)
}

#[inline(always)]
fn on(m: u64) -> bool {
    m != 0
}

use crate::mc::kernel::{clear_bounces, Crossing, CLEAR_HITS_STEPWISE, MAX_HITS_WITHOUT_INTERACTION, STOP_POLL_STEPS};
/// One layer as the lanes copy it into their state: f64 fields only (`iso` is 1.0 for an
/// isotropic layer), in the order of [`LaneLayer`]'s arrays.
#[derive(Clone, Copy, Debug, Default)]
struct LLayer {
    z0: f64,
    z1: f64,
    n: f64,
    sigma_t: f64,
    inv_sigma_t: f64,
    /// σs/σt: the weight kept at an interaction (w′ = w σs/σt, deposit w − w′, exact as in
    /// `mc::kernel`).
    keep_frac: f64,
    /// HG constants 1 + g², 1/(2g), 1 − g², 1 − g, 2g (as `mc::kernel::hg_cos`).
    hg: [f64; 5],
    iso: f64,
    n_up: f64,
    n_down: f64,
    eta_up: f64,
    eta_down: f64,
    cc_up: f64,
    cc_down: f64,
}

impl From<&KLayer> for LLayer {
    fn from(k: &KLayer) -> Self {
        LLayer {
            z0: k.z0,
            z1: k.z1,
            n: k.n,
            sigma_t: k.sigma_t,
            inv_sigma_t: k.inv_sigma_t,
            keep_frac: k.keep_frac,
            hg: [k.hg.one_plus_g2, k.hg.inv_two_g, k.hg.one_minus_g2, k.hg.one_minus_g, k.hg.two_g],
            iso: if k.hg.isotropic { 1.0 } else { 0.0 },
            n_up: k.n_up,
            n_down: k.n_down,
            eta_up: k.eta_up,
            eta_down: k.eta_down,
            cc_up: k.cos_crit_up,
            cc_down: k.cos_crit_down,
        }
    }
}

/// `LaneLayer`: the parameters of each lane's current layer, copied in when the lane enters the
/// layer (at launch and at each crossing, both rare next to interactions), so the vector loops
/// read plain arrays instead of gathering from the layer table at every step. One array per
/// [`LLayer`] field (and five for its HG constants).
macro_rules! lane_layer {
    ($($f:ident),*) => {
        #[derive(Clone, Debug, Default)]
        struct LaneLayer {
            $($f: F,)*
            hg: [F; 5],
        }

        impl LaneLayer {
            #[inline(always)]
            fn set(&mut self, i: usize, l: &LLayer) {
                $(self.$f[i] = l.$f;)*
                for k in 0..5 {
                    self.hg[k][i] = l.hg[k];
                }
            }
        }
    };
}

lane_layer!(z0, z1, n, sigma_t, inv_sigma_t, keep_frac, iso, n_up, n_down, eta_up, eta_down, cc_up, cc_down);

/// The lanes' state, structure of arrays.
#[derive(Clone, Debug, Default)]
struct Lanes {
    x: F,
    y: F,
    z: F,
    ux: F,
    uy: F,
    uz: F,
    w: F,
    /// Unused optical depth.
    s_left: F,
    path: F,
    layer: U,
    order: U,
    refl: U,
    /// Interface hits since the last interaction (see `mc::kernel`'s termination rules).
    hits: U,
    /// Roulette threshold of the lane's photon: `ROULETTE_THRESHOLD` × its entering weight.
    w_min: F,
    /// xoshiro128++ state words s0…s3 of each lane.
    s: [U; 4],
    photon: [u64; L],
    live: B,
    /// Weight absorbed and not yet handed to a tally without positions (`Tally::POSITIONS`
    /// false), and the layer it was absorbed in.
    absorbed: F,
    absorbed_layer: U,
    /// Which layer's parameters `l` holds for each lane.
    l_layer: U,
    /// The current layer's parameters.
    l: LaneLayer,
}

/// One xoshiro128++ step on lane `i` where `need` (the state advances only there; see
/// [`crate::rng`]); returns the output word (meaningless where `!need`).
#[inline(always)]
fn draw(s: &mut [U; 4], i: usize, need: bool) -> u32 {
    let mut t = [s[0][i], s[1][i], s[2][i], s[3][i]];
    let r = crate::rng::xoshiro128pp_next(&mut t);
    for k in 0..4 {
        s[k][i] = selu(need, t[k], s[k][i]);
    }
    r
}

// Branch-free selects on bit patterns (see [`sel`]).
#[inline(always)]
fn selu(c: bool, a: u32, b: u32) -> u32 {
    let m = 0u32.wrapping_sub(c as u32);
    (a & m) | (b & !m)
}

#[inline(always)]
fn selq(c: bool, a: u64, b: u64) -> u64 {
    let m = mk(c);
    (a & m) | (b & !m)
}

/// What happened to a lane in one step, for the scalar pass (a `u64` per lane).
mod fate {
    /// Still moving.
    pub const MOVING: u64 = 0;
    /// Left through the top / bottom with direction (ox, oy, oz).
    pub const ESCAPE_TOP: u64 = 1;
    pub const ESCAPE_BOTTOM: u64 = 2;
    /// Died: roulette, or complete absorption (the deposit is in `dep`).
    pub const DIED: u64 = 3;
    /// Down a semi-infinite clear layer: transmitted in its own direction (see `mc::kernel`).
    pub const CLEAR_DOWN: u64 = 4;
    /// Trapped (see `mc::kernel`): its weight goes to `Tally::roulette`.
    pub const TRAPPED: u64 = 5;
    /// Crossed into another layer: its parameters are copied in.
    pub const CROSSED: u64 = 6;
    /// More than `CLEAR_HITS_STEPWISE` hits in a finite clear layer: the rest of its bounces
    /// are sampled at once (`mc::kernel::clear_bounces`), lane by lane.
    pub const BOUNCES: u64 = 7;
}

/// Tables prepared once per run for the lanes.
struct LaneKernel<'a> {
    k: &'a Kernel,
    lay: Vec<LLayer>,
    last: u32,
    /// Every layer and both ambient media have the same index: interfaces never reflect.
    matched: bool,
    /// Some layer is clear (σt = 0): [`advance`] checks `mc::kernel`'s clear-layer rules.
    any_clear: bool,
    mixture: Vec<Phase>,
}

impl<'a> LaneKernel<'a> {
    fn new(k: &'a Kernel) -> Self {
        let lay: Vec<LLayer> = k.layers.iter().map(LLayer::from).collect();
        let last = (lay.len() - 1) as u32;
        let mixture = if k.any_mixture { k.layers.iter().map(|l| l.phase).collect() } else { Vec::new() };
        let matched = lay.iter().all(|l| l.n == l.n_up && l.n == l.n_down);
        let any_clear = lay.iter().any(|l| l.sigma_t == 0.0);
        LaneKernel { k, lay, last, matched, any_clear, mixture }
    }
}

/// Trace photons `range` of the run with `seed` into `tally` on the instruction set `isa`;
/// returns the number of scattering events, or `None` if `cancel` was raised (the tally then
/// holds a part of the range and must be discarded).
pub(crate) fn trace_range<T: Tally>(
    isa: Isa,
    k: &Kernel,
    seed: u64,
    range: Range<u64>,
    tally: &mut T,
    cancel: &AtomicBool,
) -> Option<u64> {
    let lk = LaneKernel::new(k);
    match isa {
        // Safety: an `Isa` other than `Scalar` comes from `Isa::available()`, i.e. its
        // features were detected on this machine (`RunConfig::validate` checks a forced one).
        #[cfg(target_arch = "x86_64")]
        Isa::Avx512 => unsafe { avx512(&lk, seed, range, tally, cancel) },
        #[cfg(target_arch = "x86_64")]
        Isa::Avx2 => unsafe { avx2(&lk, seed, range, tally, cancel) },
        #[cfg(target_arch = "aarch64")]
        Isa::Neon => unsafe { neon(&lk, seed, range, tally, cancel) },
        _ => run_lanes(&lk, seed, range, tally, cancel),
    }
}

/// The lane loop compiled for one instruction set (std's `#[target_feature]`; the loop is
/// `#[inline(always)]`, so all of it is generated with these features).
macro_rules! isa_entry {
    ($arch:literal, $name:ident, $features:literal) => {
        #[cfg(target_arch = $arch)]
        #[target_feature(enable = $features)]
        unsafe fn $name<T: Tally>(
            lk: &LaneKernel,
            seed: u64,
            range: Range<u64>,
            tally: &mut T,
            cancel: &AtomicBool,
        ) -> Option<u64> {
            run_lanes(lk, seed, range, tally, cancel)
        }
    };
}

isa_entry!("x86_64", avx512, "avx512f,avx512vl,avx512dq,avx2,fma");
isa_entry!("x86_64", avx2, "avx2,fma");
isa_entry!("aarch64", neon, "neon");

/// The packet of lane `i`, as the tallies see it.
#[inline(always)]
fn packet(st: &Lanes, i: usize) -> Packet {
    Packet {
        pos: [st.x[i], st.y[i], st.z[i]],
        dir: [st.ux[i], st.uy[i], st.uz[i]],
        w: st.w[i],
        layer: st.layer[i] as usize,
        order: st.order[i],
        reflections: st.refl[i],
        path: st.path[i],
    }
}

/// Philox states of the next photons to launch, computed [`L`] at a time (a vectorised loop:
/// the 32×32→64-bit multiplies of Philox's rounds run lane-parallel).
struct SeedQueue {
    first: u64,
    len: u64,
    states: [[u32; L]; 4],
}

impl SeedQueue {
    fn new() -> Self {
        SeedQueue { first: 0, len: 0, states: [[0; L]; 4] }
    }

    /// The Philox state of photon `photon` (refilling the queue from it when needed).
    #[inline(always)]
    fn state(&mut self, seed: u64, photon: u64) -> [u32; 4] {
        if photon < self.first || photon >= self.first + self.len {
            self.fill(seed, photon);
        }
        let j = (photon - self.first) as usize % L;
        [self.states[0][j], self.states[1][j], self.states[2][j], self.states[3][j]]
    }

    #[inline(always)]
    fn fill(&mut self, seed: u64, first: u64) {
        let key = [seed as u32, (seed >> 32) as u32];
        for j in 0..L {
            let p = first.wrapping_add(j as u64);
            let c = philox4x32_10([p as u32, (p >> 32) as u32, 0, 0], key);
            for k in 0..4 {
                self.states[k][j] = c[k];
            }
        }
        self.first = first;
        self.len = L as u64;
    }
}

/// Start the next photon of `range` with some weight on lane `i` (a photon that enters with
/// weight 0 — impossible for the sources allowed — has its history ended at once, as in
/// `mc::kernel`); returns `false`, and marks the lane dead, when the range is exhausted.
/// (`live` is written only when it changes: the step reads it full width, and a lane store
/// just before that load would stall it.)
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn refill<T: Tally>(
    lk: &LaneKernel,
    q: &mut SeedQueue,
    seed: u64,
    next: &mut u64,
    end: u64,
    st: &mut Lanes,
    i: usize,
    tally: &mut T,
) -> bool {
    while *next < end {
        let photon = *next;
        *next += 1;
        let mut rng = PhotonRng::from_state(q.state(seed, photon));
        tally.begin_photon(i, photon);
        let (dir, rsp) = lk.k.launcher.launch(&mut rng);
        tally.specular(i, rsp);
        let w0 = 1.0 - rsp;
        if !(w0 > 0.0) {
            tally.end_photon(i);
            continue;
        }
        let s = rng.state();
        for k in 0..4 {
            st.s[k][i] = s[k];
        }
        (st.x[i], st.y[i], st.z[i]) = (0.0, 0.0, 0.0);
        (st.ux[i], st.uy[i], st.uz[i]) = (dir[0], dir[1], dir[2]);
        st.w[i] = w0;
        st.w_min[i] = ROULETTE_THRESHOLD * w0;
        st.s_left[i] = 0.0;
        st.path[i] = 0.0;
        st.layer[i] = 0;
        st.order[i] = 0;
        st.refl[i] = 0;
        st.hits[i] = 0;
        st.photon[i] = photon;
        if st.live[i] == 0 {
            st.live[i] = !0;
        }
        st.absorbed[i] = 0.0;
        st.absorbed_layer[i] = 0;
        if st.l_layer[i] != 0 {
            st.l.set(i, &lk.lay[0]);
            st.l_layer[i] = 0;
        }
        return true;
    }
    st.live[i] = 0;
    false
}

/// Hand lane `i`'s pending absorbed weight to a tally without positions.
#[inline(always)]
fn flush_absorbed<T: Tally>(st: &mut Lanes, i: usize, tally: &mut T) {
    if st.absorbed[i] != 0.0 {
        let mut p = packet(st, i);
        p.layer = st.absorbed_layer[i] as usize;
        tally.absorb(i, &p, st.absorbed[i]);
        st.absorbed[i] = 0.0;
    }
    st.absorbed_layer[i] = st.layer[i];
}

/// Per-step scratch arrays of the lane loop.
#[derive(Default)]
struct Scratch {
    /// The step's four random words per lane (see [`draw_words`]).
    words: [U; 4],
    hit: B,
    fate: [u64; L],
    dep: F,
    /// Roulette control term of the step (0 where no roulette was played).
    rou: F,
    /// Lanes that need the scalar pass: a fate other than `MOVING` or a roulette played (set
    /// by [`advance`] and [`interfaces`] from the masks they hold, so the pass reads one array
    /// as wide as it was written).
    att: B,
    interact: B,
    /// cos θ per lane when the stack has phase-function mixtures (sampled lane by lane).
    cos_theta: F,
    ox: F,
    oy: F,
    oz: F,
}

/// Every lane step consumes four words of the lane's stream, drawn here at once whether or
/// not the step uses them (so no lane waits on a mask): [0] the optical depth −ln ξ (used
/// when the previous one is spent), [1] the phase-function ξ, [2] the azimuth, [3] the
/// roulette ξ. A Fresnel ξ, drawn in [`interfaces`] only by a lane at an interface with
/// 0 < R < 1, follows them. The words a photon consumes depend on its own history only.
#[inline(always)]
fn draw_words(st: &mut Lanes, sc: &mut Scratch) {
    for i in 0..L {
        let mut t = [st.s[0][i], st.s[1][i], st.s[2][i], st.s[3][i]];
        for k in 0..4 {
            sc.words[k][i] = crate::rng::xoshiro128pp_next(&mut t);
        }
        for k in 0..4 {
            st.s[k][i] = t[k];
        }
    }
}

/// cos θ from a Henyey–Greenstein lobe by inverting its CDF (MCML eq. 3.28; as
/// `mc::kernel::hg_cos`, constants `k` = 1 + g², 1/(2g), 1 − g², 1 − g, 2g), or 2u − 1 for
/// an isotropic layer.
#[inline(always)]
pub(super) fn hg_cos(k: [f64; 5], iso: bool, u: f64) -> f64 {
    let [a, b, c, d, e] = k;
    let t = c / (d + e * u);
    // (max/min, not clamp: clamp's NaN assertions keep LLVM from vectorising.)
    #[allow(clippy::manual_clamp)]
    let ct = ((a - t * t) * b).max(-1.0).min(1.0);
    sel(iso, 2.0 * u - 1.0, ct)
}

/// MCML's direction update (Wang et al. 1995, eq. 3.30; [`crate::optics::spin`]) of the unit
/// direction (ux, uy, uz) by the polar cosine `cth` and the azimuth φ = 2πu of the 32-bit
/// `word` ([`cos_sin_2pi`]), with one square root and one division:
/// q = sin θ / √(1 − uz²), u′x = q (ux uz cos φ − uy sin φ) + ux cos θ,
/// u′y = q (uy uz cos φ + ux sin φ) + uy cos θ, u′z = −q cos φ (1 − uz²) + uz cos θ; for
/// |uz| > 1 − 10⁻¹² the normal-incidence form (sin θ cos φ, sin θ sin φ, ± cos θ).
#[inline(always)]
pub(super) fn spin_word(ux: f64, uy: f64, uz: f64, cth: f64, word: u32) -> (f64, f64, f64) {
    let (cp, sp) = cos_sin_2pi(word);
    let t2 = 1.0 - uz * uz;
    let normal = uz.abs() > crate::optics::SPIN_POLE_COS;
    let den = sel(normal, 1.0, t2);
    let q = ((1.0 - cth * cth).max(0.0) / den).sqrt();
    let (a, b) = (q * cp, q * sp);
    let gx = a * ux * uz - b * uy + ux * cth;
    let gy = a * uy * uz + b * ux + uy * cth;
    let gz = -a * t2 + uz * cth;
    let nz_normal = sel(uz > 0.0, cth, -cth);
    (sel(normal, a, gx), sel(normal, b, gy), sel(normal, nz_normal, gz))
}

/// Phase 1, one loop over the lanes: step every live lane to its interaction point or to the
/// interface ahead; a lane that stays inside its layer then interacts: absorption by weight,
/// scattering (cos θ from its Henyey–Greenstein lobe, MCML eq. 3.28 as `mc::kernel::hg_cos`,
/// or from `sc.cos_theta` when `mixture`; azimuth from its word; MCML's direction update as
/// `mc::kernel::spin_disc`) and roulette. Lanes that hit an interface go to [`interfaces`].
/// Returns the number of scattering events. (`positions` and `mixture` are constant per run:
/// their branches are hoisted; `CLEAR` is false when no layer is clear, which removes the
/// clear-layer rules' masks from the loop.)
#[inline(always)]
fn advance<const CLEAR: bool>(st: &mut Lanes, sc: &mut Scratch, positions: bool, mixture: bool) -> u32 {
    let mut n_int = [0u32; L];
    for i in 0..L {
        // Step.
        let live = on(st.live[i]);
        let (sigma_t, inv_sigma_t, z0, z1) = (st.l.sigma_t[i], st.l.inv_sigma_t[i], st.l.z0[i], st.l.z1[i]);
        let clear = CLEAR && sigma_t == 0.0;
        let need = live & (st.s_left[i] <= 0.0) & !clear;
        let fresh = neg_ln(u32_to_open01(sc.words[0][i]));
        let sl = sel(need, fresh, st.s_left[i]);
        let s = sl * inv_sigma_t;
        let (x, y, z) = (st.x[i], st.y[i], st.z[i]);
        let (ux, uy, uz) = (st.ux[i], st.uy[i], st.uz[i]);
        let zn = z + s * uz;
        let crossed = clear | (zn > z1) | (zn < z0);
        // `mc::kernel`'s termination rules: down a semi-infinite clear layer the packet is
        // transmitted; an interface hit counts towards the trapping limit (parallel to the
        // faces of a clear layer it is trapped at once); after `CLEAR_HITS_STEPWISE` hits in a
        // finite clear layer its remaining bounces are sampled at once. All three are rare
        // and handled lane by lane.
        let h1 = st.hits[i].wrapping_add(1);
        let clear_down = live & clear & (uz > 0.0) & (z1 == f64::INFINITY);
        let trapped = live & !clear_down & ((clear & (uz == 0.0)) | (crossed & (h1 > MAX_HITS_WITHOUT_INTERACTION)));
        let bounces = live & clear & !clear_down & !trapped & (h1 > CLEAR_HITS_STEPWISE) & (z1 < f64::INFINITY);
        let moving = live & !clear_down & !trapped & !bounces;
        let h = moving & crossed;
        // A lane that reaches an interface is moved onto it by `interfaces` (the distance
        // needs a division, which the common path does without).
        let stp = sel(moving & !h, s, 0.0);
        st.x[i] = x + stp * ux;
        st.y[i] = y + stp * uy;
        st.z[i] = z + stp * uz;
        st.path[i] += st.l.n[i] * stp;
        st.s_left[i] = sel(moving & !h, 0.0, sl);
        st.hits[i] = selu(h | bounces, h1, selu(moving, 0, st.hits[i]));
        sc.hit[i] = mk(h);
        let f = selq(clear_down, fate::CLEAR_DOWN, fate::MOVING);
        let f = selq(trapped, fate::TRAPPED, f);
        let f = selq(bounces, fate::BOUNCES, f);
        // Interaction.
        let it = moving & !h;
        sc.interact[i] = mk(it);
        let w0 = st.w[i];
        let w1 = w0 * st.l.keep_frac[i];
        let dw = w0 - w1;
        let absorbed_all = w1 <= 0.0;
        let scatter = it & !absorbed_all;
        let cth = if mixture {
            sc.cos_theta[i]
        } else {
            let hg = &st.l.hg;
            let k = [hg[0][i], hg[1][i], hg[2][i], hg[3][i], hg[4][i]];
            hg_cos(k, st.l.iso[i] != 0.0, u32_to_open01(sc.words[1][i]))
        };
        let (nx, ny, nz) = spin_word(ux, uy, uz, cth, sc.words[2][i]);
        st.ux[i] = sel(scatter, nx, ux);
        st.uy[i] = sel(scatter, ny, uy);
        st.uz[i] = sel(scatter, nz, uz);
        st.order[i] = st.order[i].wrapping_add(scatter as u32);
        n_int[i] = scatter as u32;
        // Russian roulette below `ROULETTE_THRESHOLD` × the entering weight; its zero-mean
        // control term goes to `Tally::roulette` (not to absorption), lane by lane.
        let low = scatter & (w1 < st.w_min[i]);
        let ur = u32_to_open01(sc.words[3][i]);
        let survive = ur * ROULETTE_M <= 1.0;
        let (kept, boosted) = (-(ROULETTE_M - 1.0) * w1, w1 * ROULETTE_M);
        let control = sel(survive, kept, w1);
        sc.rou[i] = sel(low, control, 0.0);
        let dep = sel(it, dw, 0.0);
        sc.dep[i] = dep;
        if !positions {
            st.absorbed[i] += dep;
        }
        let w_low = sel(survive, boosted, 0.0);
        let w2 = sel(low, w_low, w1);
        st.w[i] = sel(it, w2, w0);
        let died = it & (absorbed_all | (low & !survive));
        sc.fate[i] = selq(died, fate::DIED, f);
        sc.att[i] = mk(died | clear_down | trapped | bounces | low);
    }
    n_int.iter().sum()
}

/// The sign bit of a lane mask: [`interfaces`] adds it to `Scratch::att` (OR-ing all ones
/// there makes LLVM emit a masked store, which the next load cannot forward from).
const SIGN: u64 = 1 << 63;

/// Phase 2: Fresnel reflection or refraction of the lanes that hit an interface.
#[inline(always)]
fn interfaces<const MATCHED: bool>(st: &mut Lanes, sc: &mut Scratch, last: u32) {
    for i in 0..L {
        let l = &st.l;
        let h = on(sc.hit[i]);
        let uz = st.uz[i];
        let up = uz < 0.0;
        let n_t = sel(up, l.n_up[i], l.n_down[i]);
        let eta = sel(up, l.eta_up[i], l.eta_down[i]);
        let cc = sel(up, l.cc_up[i], l.cc_down[i]);
        let ni = l.n[i];
        // Onto the interface ahead, keeping the unused optical depth (MCML's HitBoundary).
        let zb = sel(up, l.z0[i], l.z1[i]);
        let db = (zb - st.z[i]) / uz;
        let d = sel(h, db, 0.0);
        st.x[i] += d * st.ux[i];
        st.y[i] += d * st.uy[i];
        st.z[i] = sel(h, zb, st.z[i]);
        st.path[i] += ni * d;
        st.s_left[i] -= d * l.sigma_t[i];
        let ci = uz.abs().min(1.0);
        if MATCHED {
            // Every index equal (`MATCHED`): no reflection, no refraction, no draw.
            let layer = st.layer[i];
            let out = (up & (layer == 0)) | (!up & (layer == last));
            let cross = h & !out;
            sc.ox[i] = st.ux[i];
            sc.oy[i] = st.uy[i];
            sc.oz[i] = uz;
            let (dn, upl) = (layer.wrapping_add(1), layer.wrapping_sub(1));
            st.layer[i] = selu(cross, selu(up, upl, dn), layer);
            let esc = selq(up, fate::ESCAPE_TOP, fate::ESCAPE_BOTTOM);
            sc.fate[i] = selq(h & out, esc, selq(cross, fate::CROSSED, sc.fate[i]));
            sc.att[i] |= mk(h) & SIGN;
            continue;
        }
        // Fresnel (as optics::fr_dielectric_cos_t): sin²θt = η²(1 − cos²θi).
        let st2 = eta * eta * (1.0 - ci * ci).max(0.0);
        let ct = (1.0 - st2).max(0.0).sqrt();
        let rs = (ni * ci - n_t * ct) / (ni * ci + n_t * ct);
        let rp = (n_t * ci - ni * ct) / (n_t * ci + ni * ct);
        let tir = (ci <= cc) | (st2 >= 1.0);
        let matched = ni == n_t;
        let rf = 0.5 * (rs * rs + rp * rp);
        let r = sel(matched, 0.0, rf);
        let r = sel(tir, 1.0, r);
        let cos_t = sel(matched, ci, ct);
        let cos_t = sel(tir, 0.0, cos_t);
        let need = h & (r > 0.0) & (r < 1.0);
        let u = u32_to_open01(draw(&mut st.s, i, need));
        let transmit = (r <= 0.0) | (need & (u > r));
        let layer = st.layer[i];
        let out = transmit & ((up & (layer == 0)) | (!up & (layer == last)));
        let cross = h & transmit & !out;
        let refl = h & !transmit;
        let nz = sel(up, -cos_t, cos_t);
        let (ox, oy) = (st.ux[i] * eta, st.uy[i] * eta);
        sc.ox[i] = ox;
        sc.oy[i] = oy;
        sc.oz[i] = nz;
        st.ux[i] = sel(cross, ox, st.ux[i]);
        st.uy[i] = sel(cross, oy, st.uy[i]);
        let uz_new = sel(refl, -uz, uz);
        st.uz[i] = sel(cross, nz, uz_new);
        let (dn, upl) = (layer.wrapping_add(1), layer.wrapping_sub(1));
        let next = selu(up, upl, dn);
        st.layer[i] = selu(cross, next, layer);
        st.refl[i] = st.refl[i].wrapping_add(refl as u32);
        let esc = selq(up, fate::ESCAPE_TOP, fate::ESCAPE_BOTTOM);
        let f = selq(cross, fate::CROSSED, sc.fate[i]);
        sc.fate[i] = selq(h & out, esc, f);
        sc.att[i] |= mk(cross | (h & out)) & SIGN;
    }
}

/// The rest of the bounces of lane `i` in its finite clear layer, sampled at once
/// ([`clear_bounces`]) from the lane's own stream, then refraction out of the layer (as
/// `mc::kernel`). Returns whether the packet is still inside the stack (its state written
/// back into the lane); else it escaped (scored) or was trapped (booked to roulette).
#[inline(never)]
fn bounce_out<T: Tally>(lk: &LaneKernel, st: &mut Lanes, i: usize, p: &mut Packet, tally: &mut T) -> bool {
    let lay = &lk.k.layers[p.layer];
    let mut rng = PhotonRng::from_state([st.s[0][i], st.s[1][i], st.s[2][i], st.s[3][i]]);
    let inside = match clear_bounces(p, lay, &mut rng) {
        None => {
            tally.roulette(i, p, p.w); // both faces reflect totally: trapped
            false
        }
        Some(up) => matches!(lk.k.transmit(i, p, lay, up, tally), Crossing::Inside),
    };
    let s = rng.state();
    for k in 0..4 {
        st.s[k][i] = s[k];
    }
    if inside {
        (st.x[i], st.y[i], st.z[i]) = (p.pos[0], p.pos[1], p.pos[2]);
        (st.ux[i], st.uy[i], st.uz[i]) = (p.dir[0], p.dir[1], p.dir[2]);
        st.path[i] = p.path;
        st.refl[i] = p.reflections;
        let j = p.layer as u32;
        if j != st.layer[i] {
            st.layer[i] = j;
            st.l.set(i, &lk.lay[j as usize]);
            st.l_layer[i] = j;
            // (the pending absorption was handed over before: later deposits are in layer j)
            st.absorbed_layer[i] = j;
        }
    }
    inside
}

/// The lane loop over `range` (see the module docs).
#[inline(always)]
fn run_lanes<T: Tally>(
    lk: &LaneKernel,
    seed: u64,
    range: Range<u64>,
    tally: &mut T,
    cancel: &AtomicBool,
) -> Option<u64> {
    let last = lk.last;
    let mut st = Lanes::default();
    let mut q = SeedQueue::new();
    for i in 0..L {
        st.l.set(i, &lk.lay[0]);
    }
    let mut next = range.start;
    let mut n_live = 0;
    for i in 0..L {
        n_live += refill(lk, &mut q, seed, &mut next, range.end, &mut st, i, tally) as u32;
    }
    let mut events = 0u64;
    let mut steps = 0u32;
    let mut sc = Scratch::default();
    loop {
        steps = steps.wrapping_add(1);
        if steps.is_multiple_of(STOP_POLL_STEPS) && cancel.load(Ordering::Relaxed) {
            return None;
        }
        draw_words(&mut st, &mut sc);
        let mixture = !lk.mixture.is_empty();
        if mixture {
            for i in 0..L {
                let j = (st.layer[i] as usize).min(lk.mixture.len() - 1);
                sc.cos_theta[i] = lk.mixture[j].sample(u32_to_open01(sc.words[1][i]));
            }
        }
        events += if lk.any_clear {
            advance::<true>(&mut st, &mut sc, T::POSITIONS, mixture)
        } else {
            advance::<false>(&mut st, &mut sc, T::POSITIONS, mixture)
        } as u64;
        if sc.hit.iter().any(|&h| on(h)) {
            if lk.matched {
                interfaces::<true>(&mut st, &mut sc, last);
            } else {
                interfaces::<false>(&mut st, &mut sc, last);
            }
        }
        // Phase 4: absorption deposits (tallies with positions), then, only for the lanes that
        // need it: layer changes, ends of histories, refills.
        // (the union of the `att` masks first, read as wide as they were written: most steps
        // need no attention, and then the lane bits are not gathered)
        let any = sc.att.iter().fold(0, |a, &m| a | m);
        let mut attention = 0u32;
        if any != 0 {
            for i in 0..L {
                attention |= ((sc.att[i] >> 63) as u32) << i;
            }
        }
        let mut deposits = 0u32;
        if T::POSITIONS {
            for i in 0..L {
                // (bit i of the mask; `interact` is all ones or zero)
                deposits |= ((sc.interact[i] & (sc.dep[i] != 0.0) as u64) as u32) << i;
            }
        }
        if T::POSITIONS && deposits != 0 {
            let d = Deposits { x: &st.x, y: &st.y, z: &st.z, layer: &st.layer, dep: &sc.dep, mask: deposits };
            tally.absorb_lanes(&d);
        }
        while attention != 0 {
            let i = attention.trailing_zeros() as usize;
            attention &= attention - 1;
            if sc.rou[i] != 0.0 {
                tally.roulette(i, &packet(&st, i), sc.rou[i]);
            }
            let f = sc.fate[i];
            if f == fate::MOVING {
                continue;
            }
            if !T::POSITIONS {
                flush_absorbed(&mut st, i, tally);
            }
            if f == fate::CROSSED {
                let j = st.layer[i];
                st.l.set(i, &lk.lay[j as usize]);
                st.l_layer[i] = j;
                continue;
            }
            let mut p = packet(&st, i);
            match f {
                fate::ESCAPE_TOP => tally.escape(i, &p, Side::Top, [sc.ox[i], sc.oy[i], sc.oz[i]], p.w),
                fate::ESCAPE_BOTTOM => tally.escape(i, &p, Side::Bottom, [sc.ox[i], sc.oy[i], sc.oz[i]], p.w),
                fate::CLEAR_DOWN => tally.escape(i, &p, Side::Bottom, p.dir, p.w),
                fate::TRAPPED => tally.roulette(i, &p, p.w),
                // still inside after its bounces: keeps moving
                fate::BOUNCES if bounce_out(lk, &mut st, i, &mut p, tally) => continue,
                _ => {}
            }
            tally.end_photon(i);
            if !refill(lk, &mut q, seed, &mut next, range.end, &mut st, i, tally) {
                n_live -= 1;
            }
        }
        if n_live == 0 {
            return Some(events);
        }
    }
}
