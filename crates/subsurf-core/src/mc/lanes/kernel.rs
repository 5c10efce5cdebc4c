//! The lane loop: MCML's hop–drop–spin–roulette (see `mc::kernel` for the physics and its
//! references) on [`LANES`] photons at once.
//!
//! Each step of the loop advances every live lane by one event, in phases that are loops over
//! the lanes with branch-free bodies (vectorised):
//! 1. **step and interaction** ([`advance`]): draw an optical depth where the last one is used
//!    up; a lane whose step stays in its layer moves there and interacts (absorption by
//!    weight, Henyey–Greenstein cos θ, azimuth, MCML's direction update; a weight below the
//!    roulette threshold, relative to the entering weight, is flagged);
//! 2. **interface** ([`interfaces`], skipped when no lane reached one): move onto it, Fresnel
//!    reflection or refraction, layer change, escape.
//!
//! Then the absorption deposits of all lanes go to the tally at once (`Tally::absorb_lanes`)
//! and, lane by lane, the rare events: Russian roulette (`step::roulette`, its control term
//! for `Tally::roulette`), layer changes, escapes, the termination
//! rules of `mc::kernel` (trapped packets, clear-layer bounces), ends of histories and refills
//! with the next photon index. Each lane computes with the same correctly rounded operations
//! whatever its neighbours or the instruction set, so a photon's history depends on its own
//! stream only.

mod step;

use super::math::{cos_sin_2pi_f32, neg, neg_ln_f32, open01_f32, open01_f32_fine, sel, sel_f32, to_f32_up};
use super::{Isa, LANES};
use crate::mc::config::{ROULETTE_M, ROULETTE_THRESHOLD};
use crate::mc::kernel::{KLayer, Kernel};
use crate::mc::packet::{Packet, Side};
use crate::mc::tally::{Deposits, Tally};
use crate::optics::Phase;
use crate::rng::{philox4x32_10, u32_to_open01, PhotonRng};
use std::ops::Range;
use std::sync::atomic::{AtomicBool, Ordering};
use step::{advance, interfaces, roulette, sample};
#[cfg(test)]
pub(super) use step::{hg_one_minus_cos, spin_word};

const L: usize = LANES;
type F = [f64; L];
/// f32 lanes: the direction (see "Precision" in the module docs of `mc::lanes`).
type F32 = [f32; L];
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

/// The lanes whose mask in `m` is set, as bits (bit i: lane i): a vector shift and an OR
/// reduction.
#[inline(always)]
fn lane_bits(m: &B) -> u32 {
    let mut bits = 0u32;
    for (i, &x) in m.iter().enumerate() {
        bits |= (((x as i64) < 0) as u32) << i;
    }
    bits
}

/// [`lane_bits`] of masks that are 0 or all ones (`mk`): bit i of lane i's mask, a vector AND
/// with the lanes' bits and an OR reduction. (On AVX2 LLVM built [`lane_bits`]' sign bits
/// partly in scalar code, about 70 instructions for 16 lanes; with this form for the deposits
/// and the interface hits, callgrind per event with MCML's tally set: avx2 c −7.5 %, d −9.3 %,
/// sse c −4.7 %, d −5.0 %. `Scratch::att` holds sign bits only, and the same form with a
/// shift for it was +1.6 % on avx2.)
#[inline(always)]
fn lane_bits_full(m: &B) -> u32 {
    let mut bits = 0u64;
    for (i, &x) in m.iter().enumerate() {
        bits |= x & (1 << i);
    }
    bits as u32
}

use crate::mc::kernel::{clear_bounces, Crossing, CLEAR_HITS_STEPWISE, MAX_HITS_WITHOUT_INTERACTION, STOP_POLL_STEPS};
/// One layer as the lanes copy it into their state, in the order of [`LaneLayer`]'s arrays.
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
    /// HG constants 1 − g, 2g, 1 − g² in f32 (see [`step::hg_one_minus_cos`]).
    hg: [f32; 3],
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
            hg: [k.hg.one_minus_g as f32, k.hg.two_g as f32, k.hg.one_minus_g2 as f32],
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
/// [`LLayer`] field (and three for its HG constants).
macro_rules! lane_layer {
    ($($f:ident),*) => {
        #[derive(Clone, Debug, Default)]
        struct LaneLayer {
            $($f: F,)*
            hg: [F32; 3],
        }

        impl LaneLayer {
            #[inline(always)]
            fn set(&mut self, i: usize, l: &LLayer) {
                $(self.$f[i] = l.$f;)*
                for k in 0..3 {
                    self.hg[k][i] = l.hg[k];
                }
            }
        }
    };
}

lane_layer!(z0, z1, n, sigma_t, inv_sigma_t, keep_frac, n_up, n_down, eta_up, eta_down, cc_up, cc_down);

/// The lanes' state, structure of arrays.
#[derive(Clone, Debug, Default)]
struct Lanes {
    x: F,
    y: F,
    z: F,
    /// Unit direction, f32, renormalised at each scattering ([`step::spin_word`]).
    ux: F32,
    uy: F32,
    uz: F32,
    w: F,
    /// Unused optical depth.
    s_left: F,
    path: F,
    layer: U,
    order: U,
    refl: U,
    /// Interface hits since the last interaction (see `mc::kernel`'s termination rules).
    hits: U,
    /// Without clear layers: the scattering order at the lane's last interface hit (a hit at
    /// another order is the first since an interaction, see `step::fresnel`).
    hit_order: U,
    /// Scattering events of the photons that ended: each adds its scattering order when it
    /// ends (`order` counts exactly the events; no per-step work for the count).
    events: u64,
    /// Roulette threshold of the lane's photon: `ROULETTE_THRESHOLD` × its entering weight.
    w_min: F,
    /// xoshiro128++ state words s0…s3 of each lane.
    s: [U; 4],
    photon: [u64; L],
    live: B,
    /// Weight absorbed and not yet handed to a tally without positions (`Tally::PENDING`:
    /// `Tally::absorb_pending`), and the layer it was absorbed in.
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
    /// Its weight fell below the roulette threshold: Russian roulette is played lane by lane
    /// (`step::roulette`), then it keeps moving or died.
    pub const ROULETTE: u64 = 8;
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
    /// A pencil beam's launch as the lanes store it (direction in f32 as [`refill`] converts
    /// it, and the specular reflectance), computed once; `None` for a diffuse source.
    pencil: Option<([f32; 3], f64)>,
}

/// A launch direction as the lanes store it: f32, |uz| rounded up ([`to_f32_up`]).
#[inline(always)]
fn dir_f32(d: [f64; 3]) -> [f32; 3] {
    [d[0] as f32, d[1] as f32, to_f32_up(d[2])]
}

impl<'a> LaneKernel<'a> {
    fn new(k: &'a Kernel) -> Self {
        let lay: Vec<LLayer> = k.layers.iter().map(LLayer::from).collect();
        let last = (lay.len() - 1) as u32;
        let mixture = if k.any_mixture { k.layers.iter().map(|l| l.phase).collect() } else { Vec::new() };
        let matched = lay.iter().all(|l| l.n == l.n_up && l.n == l.n_down);
        let any_clear = lay.iter().any(|l| l.sigma_t == 0.0);
        let pencil = k.launcher.pencil().map(|(d, rsp)| (dir_f32(d), rsp));
        LaneKernel { k, lay, last, matched, any_clear, mixture, pencil }
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
        // features were detected on this machine (`RunConfig::validate` and `Isa::forced` check a
        // forced one).
        #[cfg(target_arch = "x86_64")]
        Isa::Avx512 => unsafe { avx512(&lk, seed, range, tally, cancel) },
        #[cfg(target_arch = "x86_64")]
        Isa::Avx2 => unsafe { avx2(&lk, seed, range, tally, cancel) },
        #[cfg(target_arch = "x86_64")]
        Isa::Sse4 => unsafe { sse4(&lk, seed, range, tally, cancel) },
        #[cfg(target_arch = "aarch64")]
        Isa::Neon => unsafe { neon(&lk, seed, range, tally, cancel) },
        _ => run_lanes(&lk, seed, range, tally, cancel, FEW_HITS_SCALAR),
    }
}

/// The lane loop compiled for one instruction set (std's `#[target_feature]`; the loop is
/// `#[inline(always)]`, so all of it is generated with these features).
macro_rules! isa_entry {
    ($arch:literal, $name:ident, $features:literal, $few:expr) => {
        #[cfg(target_arch = $arch)]
        #[target_feature(enable = $features)]
        unsafe fn $name<T: Tally>(
            lk: &LaneKernel,
            seed: u64,
            range: Range<u64>,
            tally: &mut T,
            cancel: &AtomicBool,
        ) -> Option<u64> {
            run_lanes(lk, seed, range, tally, cancel, $few)
        }
    };
}

// The last argument: up to how many lanes at an interface in one step are handled lane by lane
// instead of by the interface phase's vector loops (`step::interfaces`), whose cost does not
// depend on how many lanes hit. Chosen from callgrind's instruction and branch-miss counts (avx2,
// sse: 2 and 6 lanes; a branch miss costs avx2 more than it saves above 2) and timings (avx512);
// NEON as sse (the same width); the baseline always lane by lane (its loops are mostly scalar).
// AVX2 and AVX-512 also take x86-64-v3's integer features (BMI1/2, LZCNT, POPCNT: the count of
// interface hits was 15 instructions without POPCNT; callgrind, avx2: a −1.1 %, c −0.4 %).
const FEW_HITS_SCALAR: u32 = L as u32;
isa_entry!("x86_64", avx512, "avx512f,avx512vl,avx512dq,avx2,fma,bmi1,bmi2,lzcnt,popcnt", 2);
isa_entry!("x86_64", avx2, "avx2,fma,bmi1,bmi2,lzcnt,popcnt", 2);
isa_entry!("x86_64", sse4, "sse4.1,sse4.2,popcnt", 6);
isa_entry!("aarch64", neon, "neon", 6);

/// The packet of lane `i`, as the tallies see it.
#[inline(always)]
fn packet(st: &Lanes, i: usize) -> Packet {
    Packet {
        pos: [st.x[i], st.y[i], st.z[i]],
        dir: [st.ux[i] as f64, st.uy[i] as f64, st.uz[i] as f64],
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
        // (one unsigned comparison: a photon before `first` wraps to a large offset)
        let mut j = photon.wrapping_sub(self.first);
        if j >= self.len {
            self.fill(seed, photon);
            j = 0;
        }
        let j = j as usize % L;
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
        let (dir, rsp) = match lk.pencil {
            Some(p) => p,
            None => {
                let (d, rsp) = lk.k.launcher.launch(&mut rng);
                (dir_f32(d), rsp)
            }
        };
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

/// Hand lane `i`'s pending absorbed weight to the tally (`Tally::absorb_pending`).
#[inline(always)]
fn flush_absorbed<T: Tally>(st: &mut Lanes, i: usize, tally: &mut T) {
    if st.absorbed[i] != 0.0 {
        let mut p = packet(st, i);
        p.layer = st.absorbed_layer[i] as usize;
        tally.absorb_pending(i, &p, st.absorbed[i]);
        st.absorbed[i] = 0.0;
    }
    st.absorbed_layer[i] = st.layer[i];
}

/// Per-step scratch arrays of the lane loop.
#[derive(Default)]
struct Scratch {
    /// The step's three random words per lane (see [`draw_words`]).
    words: [U; 3],
    hit: B,
    fate: [u64; L],
    dep: F,
    /// Lanes that need the scalar pass: a fate other than `MOVING` or a roulette played (set
    /// by [`advance`] and [`interfaces`] from the masks they hold, so the pass reads one array
    /// as wide as it was written).
    att: B,
    /// Lanes that interacted with a non-zero deposit in `dep` (for `Tally::absorb_lanes`; a
    /// mask like `att`, turned into lane bits the same way).
    deposit: B,
    /// 1 − cos θ per lane when the stack has phase-function mixtures (sampled lane by lane).
    one_minus_cos: F32,
    /// A fresh optical depth and the direction after a scattering, per lane ([`sample`]).
    tau: F32,
    nx: F32,
    ny: F32,
    nz: F32,
    ox: F,
    oy: F,
    oz: F,
    /// Fresnel reflectance and cos θt at the interface each lane hit, whether a Fresnel word
    /// decides (a mask), and that word (`step::interfaces`).
    fr: F,
    cos_t: F,
    need: B,
    fword: U,
}

/// Every lane step consumes three words of the lane's stream, drawn here at once whether or
/// not the step uses them (so no lane waits on a mask): [0] the optical depth −ln ξ (used
/// when the previous one is spent), [1] the phase-function ξ, [2] the azimuth. A Fresnel ξ,
/// drawn in [`interfaces`] only by a lane at an interface with 0 < R < 1, or the roulette word
/// (survives when ≤ 2³²/M − ½, i.e. ξ ≤ 1/M), drawn in [`roulette`] only by a lane that plays
/// it, follows them. The words a photon consumes depend on its own history only.
#[inline(always)]
fn draw_words(st: &mut Lanes, sc: &mut Scratch) {
    for i in 0..L {
        let mut t = [st.s[0][i], st.s[1][i], st.s[2][i], st.s[3][i]];
        for k in 0..3 {
            sc.words[k][i] = crate::rng::xoshiro128pp_next(&mut t);
        }
        for k in 0..4 {
            st.s[k][i] = t[k];
        }
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
        (st.ux[i], st.uy[i], st.uz[i]) = (p.dir[0] as f32, p.dir[1] as f32, to_f32_up(p.dir[2]));
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
    few: u32,
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
                sc.one_minus_cos[i] = (1.0 - lk.mixture[j].sample(u32_to_open01(sc.words[1][i]))) as f32;
            }
        }
        if mixture {
            sample::<true>(&st, &mut sc);
        } else {
            sample::<false>(&st, &mut sc);
        }
        if lk.any_clear {
            advance::<true>(&mut st, &mut sc, T::PENDING, T::POSITIONS, T::TRACKS);
        } else {
            advance::<false>(&mut st, &mut sc, T::PENDING, T::POSITIONS, T::TRACKS);
        }
        if sc.hit.iter().any(|&h| on(h)) {
            // (no trapping count in a matched stack: nothing reflects, so a packet that does not
            // interact meets at most one interface per layer on its straight way out, far below
            // `MAX_HITS_WITHOUT_INTERACTION`; with clear layers `advance` counts the hits)
            match (lk.matched, lk.any_clear) {
                (true, _) => interfaces::<true, false>(&mut st, &mut sc, last, T::TRACKS, few),
                (false, true) => interfaces::<false, false>(&mut st, &mut sc, last, T::TRACKS, few),
                (false, false) => interfaces::<false, true>(&mut st, &mut sc, last, T::TRACKS, few),
            }
        }
        // Phase 4: absorption deposits (tallies with positions), then, only for the lanes that
        // need it: layer changes, ends of histories, refills.
        // (the union of the `att` masks first, read as wide as they were written: in long
        // histories most steps need no attention, and then the lane bits are not gathered)
        let any = sc.att.iter().fold(0, |a, &m| a | m);
        let mut attention = if any != 0 { lane_bits(&sc.att) } else { 0 };
        let deposits = if T::POSITIONS { lane_bits_full(&sc.deposit) } else { 0 };
        if T::POSITIONS && deposits != 0 {
            let d = Deposits { x: &st.x, y: &st.y, z: &st.z, layer: &st.layer, dep: &sc.dep, mask: deposits };
            tally.absorb_lanes(&d);
        }
        while attention != 0 {
            let i = attention.trailing_zeros() as usize;
            attention &= attention - 1;
            let mut f = sc.fate[i];
            if f == fate::ROULETTE {
                let (control, survived) = roulette(&mut st, i);
                tally.roulette(i, &packet(&st, i), control);
                f = if survived { fate::MOVING } else { fate::DIED };
            }
            if f == fate::MOVING {
                continue;
            }
            if T::PENDING {
                flush_absorbed(&mut st, i, tally);
            }
            if f == fate::CROSSED {
                let j = st.layer[i];
                st.l.set(i, &lk.lay[j as usize]);
                st.l_layer[i] = j;
                continue;
            }
            // (the packet is built in each arm: one built before the match had to be kept whole
            // in memory for `bounce_out`, and the escape, whose tally may read only a field or
            // two, paid for all of it)
            match f {
                fate::ESCAPE_TOP | fate::ESCAPE_BOTTOM => {
                    let side = if f == fate::ESCAPE_TOP { Side::Top } else { Side::Bottom };
                    tally.escape(i, &packet(&st, i), side, [sc.ox[i], sc.oy[i], sc.oz[i]], st.w[i]);
                }
                fate::CLEAR_DOWN => {
                    let p = packet(&st, i);
                    tally.escape(i, &p, Side::Bottom, p.dir, p.w);
                }
                fate::TRAPPED => tally.roulette(i, &packet(&st, i), st.w[i]),
                fate::BOUNCES => {
                    let mut p = packet(&st, i);
                    if bounce_out(lk, &mut st, i, &mut p, tally) {
                        continue; // still inside after its bounces: keeps moving
                    }
                }
                _ => {}
            }
            tally.end_photon(i);
            st.events += st.order[i] as u64;
            if !refill(lk, &mut q, seed, &mut next, range.end, &mut st, i, tally) {
                n_live -= 1;
            }
        }
        if n_live == 0 {
            return Some(st.events);
        }
    }
}
