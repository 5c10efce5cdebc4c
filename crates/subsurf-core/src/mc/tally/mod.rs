//! Tallies: what the kernel scores. The kernel is generic over [`Tally`] (static dispatch,
//! monomorphised per tally set, so a run that asks only for totals pays nothing for grids).
//!
//! Standard errors: the totals keep per-photon second moments (a partial score per lane, between
//! [`Tally::begin_photon`] and [`Tally::end_photon`]); histograms keep batch means over fixed
//! photon batches ([`accum`]), closed by [`Tally::end_batch`] when every photon of the batch
//! has ended.
//!
//! Merging: a tally scores one chunk of photons in f64 (a fixed, sequential order), then
//! [`Tally::drain_into`] adds its sums *exactly* into the run's [`ChannelState`]s (fixed-point,
//! see [`exact`]), so the merged sums do not depend on how the photons were split into chunks'
//! groups (threads, resume points, workers). [`Tally::load_from`] puts the rounded exact sums
//! back into a tally for normalisation.

pub mod accum;
pub mod config;
mod escapes;
pub mod exact;
pub mod histogram;
pub mod set;
pub mod totals;

use super::lanes::LANES;
use super::packet::{Packet, Side};
use exact::{Sum1, Sum2};

/// The physical absorption deposits of one step of the lane kernel: lane `i` deposits `dep[i]`
/// at (`x[i]`, `y[i]`, `z[i]`) in layer `layer[i]` when bit `i` of `mask` is set. Handed to
/// [`Tally::absorb_lanes`] so that a tally can compute its bins for all lanes at once.
#[derive(Clone, Copy, Debug)]
pub struct Deposits<'a> {
    pub x: &'a [f64; LANES],
    pub y: &'a [f64; LANES],
    pub z: &'a [f64; LANES],
    pub layer: &'a [u32; LANES],
    pub dep: &'a [f64; LANES],
    pub mask: u32,
}

impl Deposits<'_> {
    /// The lanes with a deposit, in increasing order.
    #[inline]
    pub fn lanes(&self) -> impl Iterator<Item = usize> {
        let mut m = self.mask;
        std::iter::from_fn(move || {
            (m != 0).then(|| {
                let i = m.trailing_zeros() as usize;
                m &= m - 1;
                i
            })
        })
    }

    /// The packet of lane `i` as [`Tally::absorb`] sees it (position and layer; the rest is not
    /// known here and set to neutral values).
    #[inline]
    pub fn packet(&self, i: usize) -> Packet {
        Packet {
            pos: [self.x[i], self.y[i], self.z[i]],
            dir: [0.0, 0.0, 1.0],
            w: 0.0,
            layer: self.layer[i] as usize,
            order: 0,
            reflections: 0,
            path: 0.0,
        }
    }
}

pub use accum::Accum;
pub use config::{TallyConfig, TallyInput, TallyValue};
pub use histogram::HistogramOut;
pub use set::TallySet;

/// One array ("channel") of a tally's exact state: `len` bins, each with the exact S₁ and S₂
/// of the per-photon scores; `extremes`: also the smallest and largest per-photon score (kept
/// by the totals, so that a quantity every photon scores identically has a standard error of
/// exactly 0).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Channel {
    /// A stable name (the histogram or total it feeds).
    pub name: String,
    /// Number of bins.
    pub len: usize,
    /// Whether per-photon minima and maxima are kept.
    pub extremes: bool,
}

/// The exact sums of one [`Channel`] over the photons merged so far.
#[derive(Clone, Debug, PartialEq)]
pub struct ChannelState {
    /// Σ score per bin.
    pub s1: Vec<Sum1>,
    /// Σ (per-photon score)² per bin.
    pub s2: Vec<Sum2>,
    /// Smallest and largest per-photon score per bin (empty unless the channel keeps them;
    /// +∞/−∞ before any photon).
    pub min: Vec<f64>,
    /// See `min`.
    pub max: Vec<f64>,
}

impl ChannelState {
    /// Empty sums for `c`.
    pub fn new(c: &Channel) -> Self {
        let e = if c.extremes { c.len } else { 0 };
        ChannelState {
            s1: vec![Sum1::ZERO; c.len],
            s2: vec![Sum2::ZERO; c.len],
            min: vec![f64::INFINITY; e],
            max: vec![f64::NEG_INFINITY; e],
        }
    }

    /// Add a chunk's (S₁, S₂) of bin `i` exactly; `false` if a value is out of the exact range.
    #[inline]
    pub fn add(&mut self, i: usize, s1: f64, s2: f64) -> bool {
        self.s1[i].add_f64(s1) & self.s2[i].add_f64(s2)
    }

    /// Fold a chunk's per-photon extremes of bin `i` in.
    #[inline]
    pub fn add_extremes(&mut self, i: usize, min: f64, max: f64) {
        self.min[i] = self.min[i].min(min);
        self.max[i] = self.max[i].max(max);
    }

    /// Add another state of the same channel (exact, order independent).
    pub fn merge(&mut self, o: &ChannelState) {
        for (a, b) in self.s1.iter_mut().zip(&o.s1) {
            a.add(b);
        }
        for (a, b) in self.s2.iter_mut().zip(&o.s2) {
            a.add(b);
        }
        for (i, (&lo, &hi)) in o.min.iter().zip(&o.max).enumerate() {
            self.add_extremes(i, lo, hi);
        }
    }

    /// (S₁, S₂) of bin `i` rounded to f64.
    #[inline]
    pub fn get(&self, i: usize) -> (f64, f64) {
        (self.s1[i].to_f64(), self.s2[i].to_f64())
    }
}

/// Receiver of the kernel's events. All weights are in units of the launched packet weight (1).
///
/// The lane kernel (`mc::lanes`) follows up to [`LANES`] photon histories at once, so every
/// event names its lane: between `begin_photon(lane, …)` and `end_photon(lane)` the events of
/// that lane belong to one photon, while events of different lanes interleave.
pub trait Tally: Send {
    /// Whether [`Tally::absorb`] needs each deposit with its position. `false` (the totals):
    /// the kernel may add up a lane's deposits in one layer and report them together, with the
    /// packet where the sum is handed over (its `layer` is right, its position is not).
    const POSITIONS: bool = true;
    /// Whether some part of the tally takes the lane kernel's per-lane sums of deposits
    /// ([`Tally::absorb_pending`]): a tally without positions; of a pair, either side.
    const PENDING: bool = !Self::POSITIONS;
    /// Whether the tally reads a packet's lateral position (`p.pos[0]`, `p.pos[1]`) or its
    /// optical path (`p.path`) in any event. `false` (the totals, the empty tally): the lane
    /// kernel does not track them (they read 0; depth, layer, direction, weight and order are
    /// always right).
    const TRACKS: bool = true;
    /// Whether the tally needs [`Tally::end_batch`] calls (batch-means standard errors); the
    /// kernel then traces each batch of [`crate::mc::config::BATCH_PHOTONS`] to its end
    /// before starting the next.
    fn batched(&self) -> bool {
        false
    }
    /// Lane `lane` starts a new photon history; `photon` is its global index (0 … N−1).
    fn begin_photon(&mut self, lane: usize, photon: u64);
    /// Weight reflected specularly at the top surface on launch.
    fn specular(&mut self, lane: usize, w: f64);
    /// Weight `dw ≥ 0` physically absorbed (w σa/σt at an interaction) at the packet's position
    /// `p.pos` in layer `p.layer`.
    fn absorb(&mut self, lane: usize, p: &Packet, dw: f64);
    /// A lane's deposits summed by the lane kernel since it entered the layer `p.layer` (the
    /// kernel's pending sum, handed over at each layer change and at the end of the history;
    /// `p.pos` is where it was handed over, not where the weight was absorbed): what a tally
    /// without positions scores, instead of [`Tally::absorb_lanes`]. By default
    /// [`Tally::absorb`] for a tally without positions, nothing for one with positions (it
    /// has seen every deposit in [`Tally::absorb_lanes`]).
    #[inline]
    fn absorb_pending(&mut self, lane: usize, p: &Packet, dw: f64) {
        if !Self::POSITIONS {
            self.absorb(lane, p, dw);
        }
    }
    /// The physical deposits of one lane step (see [`Deposits`]); by default one
    /// [`Tally::absorb`] per lane. Absorption tallies override it to bin all lanes at once.
    #[inline]
    fn absorb_lanes(&mut self, d: &Deposits) {
        for i in d.lanes() {
            self.absorb(i, &d.packet(i), d.dep[i]);
        }
    }
    /// Weight `dw` removed from (dw > 0) or added to (dw < 0) the packet by Russian roulette —
    /// its zero-mean control term, so that energy balance holds exactly in every run — or the
    /// weight of a packet that can never leave (see `mc::kernel`). Not absorption: the totals
    /// book it in `absorbed` (which is then 1 − R_sp − R_d − T exactly, and never negative),
    /// the histograms and per-layer absorption do not.
    fn roulette(&mut self, lane: usize, p: &Packet, dw: f64);
    /// The packet leaves through `side` with weight `w`. `p` is its state at the exit point
    /// (inside, before refraction); `dir_out` is its unit direction in the ambient medium after
    /// refraction (`dir_out[2] < 0` for `Side::Top`, `> 0` for `Side::Bottom`).
    fn escape(&mut self, lane: usize, p: &Packet, side: Side, dir_out: [f64; 3], w: f64);
    /// The history on lane `lane` has ended.
    fn end_photon(&mut self, lane: usize);
    /// The photons of one batch (`photons` of them, all ended) are done (see [`accum`]).
    fn end_batch(&mut self, _photons: u64) {}
    /// Append the descriptions of this tally's channels to `out` (fixed for a configuration).
    fn channels(&self, out: &mut Vec<Channel>);
    /// Add this tally's sums exactly into `state` (its own channels first, in the order of
    /// [`Tally::channels`]) and clear the tally for the next chunk. Returns how many channels it
    /// used, or `None` when a sum lies outside the exact range (see [`exact`]).
    fn drain_into(&mut self, state: &mut [ChannelState]) -> Option<usize>;
    /// Replace this tally's sums by the exact sums of `state` (rounded to f64) for a run of
    /// `photons` photons, ready for normalisation. Returns how many channels it used.
    fn load_from(&mut self, state: &[ChannelState], photons: u64) -> usize;
}

/// The empty tally: scores nothing (for runs that need only the engine's own counters).
impl Tally for () {
    const POSITIONS: bool = false;
    const TRACKS: bool = false;
    #[inline]
    fn begin_photon(&mut self, _lane: usize, _photon: u64) {}
    #[inline]
    fn specular(&mut self, _lane: usize, _w: f64) {}
    #[inline]
    fn absorb(&mut self, _lane: usize, _p: &Packet, _dw: f64) {}
    #[inline]
    fn roulette(&mut self, _lane: usize, _p: &Packet, _dw: f64) {}
    #[inline]
    fn escape(&mut self, _lane: usize, _p: &Packet, _side: Side, _dir_out: [f64; 3], _w: f64) {}
    #[inline]
    fn end_photon(&mut self, _lane: usize) {}
    fn channels(&self, _out: &mut Vec<Channel>) {}
    fn drain_into(&mut self, _state: &mut [ChannelState]) -> Option<usize> {
        Some(0)
    }
    fn load_from(&mut self, _state: &[ChannelState], _photons: u64) -> usize {
        0
    }
}

/// Two tallies side by side, e.g. `(Totals, TallySet)`: each sees every event, absorption
/// in the form it takes: the lane kernel's per-lane sums ([`Tally::absorb_pending`]) for a
/// side without positions (the totals: no vector pass over the lanes at every step), the
/// step's deposits ([`Tally::absorb_lanes`]) for a side with positions.
impl<A: Tally, B: Tally> Tally for (A, B) {
    const POSITIONS: bool = A::POSITIONS || B::POSITIONS;
    const PENDING: bool = A::PENDING || B::PENDING;
    const TRACKS: bool = A::TRACKS || B::TRACKS;
    fn batched(&self) -> bool {
        self.0.batched() || self.1.batched()
    }
    #[inline]
    fn begin_photon(&mut self, lane: usize, photon: u64) {
        self.0.begin_photon(lane, photon);
        self.1.begin_photon(lane, photon);
    }
    #[inline]
    fn specular(&mut self, lane: usize, w: f64) {
        self.0.specular(lane, w);
        self.1.specular(lane, w);
    }
    #[inline]
    fn absorb(&mut self, lane: usize, p: &Packet, dw: f64) {
        self.0.absorb(lane, p, dw);
        self.1.absorb(lane, p, dw);
    }
    #[inline]
    fn absorb_pending(&mut self, lane: usize, p: &Packet, dw: f64) {
        self.0.absorb_pending(lane, p, dw);
        self.1.absorb_pending(lane, p, dw);
    }
    #[inline(always)]
    fn absorb_lanes(&mut self, d: &Deposits) {
        if A::POSITIONS {
            self.0.absorb_lanes(d);
        }
        if B::POSITIONS {
            self.1.absorb_lanes(d);
        }
    }
    #[inline]
    fn roulette(&mut self, lane: usize, p: &Packet, dw: f64) {
        self.0.roulette(lane, p, dw);
        self.1.roulette(lane, p, dw);
    }
    #[inline]
    fn escape(&mut self, lane: usize, p: &Packet, side: Side, dir_out: [f64; 3], w: f64) {
        self.0.escape(lane, p, side, dir_out, w);
        self.1.escape(lane, p, side, dir_out, w);
    }
    // (always: compiled inside the lane kernel's instruction-set entry; as a call it ran at the
    // baseline's width, 179 instructions per photon of case a with MCML's tally set on AVX2)
    #[inline(always)]
    fn end_photon(&mut self, lane: usize) {
        self.0.end_photon(lane);
        self.1.end_photon(lane);
    }
    #[inline]
    fn end_batch(&mut self, photons: u64) {
        self.0.end_batch(photons);
        self.1.end_batch(photons);
    }
    fn channels(&self, out: &mut Vec<Channel>) {
        self.0.channels(out);
        self.1.channels(out);
    }
    fn drain_into(&mut self, state: &mut [ChannelState]) -> Option<usize> {
        let a = self.0.drain_into(state)?;
        Some(a + self.1.drain_into(&mut state[a..])?)
    }
    fn load_from(&mut self, state: &[ChannelState], photons: u64) -> usize {
        let a = self.0.load_from(state, photons);
        a + self.1.load_from(&state[a..], photons)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Records the absorption calls it receives; `P`: its `POSITIONS`.
    #[derive(Default)]
    struct Rec<const P: bool> {
        calls: Vec<(&'static str, usize, f64)>,
    }

    impl<const P: bool> Tally for Rec<P> {
        const POSITIONS: bool = P;
        fn begin_photon(&mut self, _lane: usize, _photon: u64) {}
        fn specular(&mut self, _lane: usize, _w: f64) {}
        fn absorb(&mut self, lane: usize, _p: &Packet, dw: f64) {
            self.calls.push(("absorb", lane, dw));
        }
        fn roulette(&mut self, _lane: usize, _p: &Packet, _dw: f64) {}
        fn escape(&mut self, _lane: usize, _p: &Packet, _side: Side, _dir_out: [f64; 3], _w: f64) {}
        fn end_photon(&mut self, _lane: usize) {}
        fn channels(&self, _out: &mut Vec<Channel>) {}
        fn drain_into(&mut self, _state: &mut [ChannelState]) -> Option<usize> {
            Some(0)
        }
        fn load_from(&mut self, _state: &[ChannelState], _photons: u64) -> usize {
            0
        }
    }

    /// A pair hands the kernel's per-lane sums to its side without positions only, and the
    /// step's deposits to its side with positions only; `PENDING` and `POSITIONS` combine.
    #[test]
    fn pairs_route_absorption_by_kind() {
        type Pair = (Rec<false>, Rec<true>);
        const { assert!(Pair::PENDING && Pair::POSITIONS) };
        const { assert!(!<(Rec<true>, Rec<true>)>::PENDING && !<(Rec<false>, ())>::POSITIONS) };
        let mut t: Pair = Default::default();
        let p = Packet { pos: [0.0; 3], dir: [0.0, 0.0, 1.0], w: 1.0, layer: 0, order: 0, reflections: 0, path: 0.0 };
        t.absorb_pending(3, &p, 0.25);
        let zero = [0.0; LANES];
        let mut dep = [0.0; LANES];
        dep[1] = 0.5;
        let d = Deposits { x: &zero, y: &zero, z: &zero, layer: &[0; LANES], dep: &dep, mask: 1 << 1 };
        t.absorb_lanes(&d);
        assert_eq!(t.0.calls, vec![("absorb", 3, 0.25)]);
        assert_eq!(t.1.calls, vec![("absorb", 1, 0.5)]);
    }
}
