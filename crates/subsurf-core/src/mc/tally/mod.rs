//! Tallies: what the kernel scores. The kernel is generic over [`Tally`] (static dispatch,
//! monomorphised per tally set, so a run that asks only for totals pays nothing for grids).
//!
//! The lane kernel (`mc::lanes`) follows up to [`crate::mc::lanes::LANES`] photon histories at
//! once, so every event names its lane: between `begin_photon(lane, …)` and
//! `end_photon(lane)` the events of that lane belong to one photon, while events of
//! different lanes interleave. Standard errors: the totals keep per-photon second moments
//! (a per-lane partial score); histograms keep batch means over fixed photon batches
//! ([`accum`]), closed by [`Tally::end_batch`] when every photon of the batch has ended.

pub mod totals;

use super::lanes::LANES;
use super::packet::{Packet, Side};

/// The absorption deposits of one step of the lane kernel: lane `i` deposits `dep[i]` at
/// (`x[i]`, `y[i]`, `z[i]`) in layer `layer[i]` when bit `i` of `mask` is set. Handed to
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

    /// The packet of lane `i` as [`Tally::absorb`] sees it (position and layer; the rest is
    /// not known here and set to neutral values).
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

/// Receiver of the kernel's events. All weights are in units of the launched packet weight (1).
pub trait Tally: Send {
    /// Whether [`Tally::absorb`] needs each deposit with its position. `false` (the totals):
    /// the kernel may add up a lane's deposits in one layer and report them together, with
    /// the packet where the sum is handed over (its `layer` is right, its position is not).
    const POSITIONS: bool = true;
    /// Whether the tally needs [`Tally::end_batch`] calls (batch-means standard errors); a run
    /// then traces each batch to its end before starting the next.
    fn batched(&self) -> bool {
        false
    }
    /// Lane `lane` starts a new photon history; `photon` is its global index (0 … N−1).
    fn begin_photon(&mut self, lane: usize, photon: u64);
    /// Weight reflected specularly at the top surface on launch.
    fn specular(&mut self, lane: usize, w: f64);
    /// Weight `dw` deposited (absorbed) at the packet's position `p.pos` in layer `p.layer`.
    /// `dw` can be negative: Russian roulette deposits its zero-mean control term here, so that
    /// energy balance holds exactly in every run (see `mc::kernel`).
    fn absorb(&mut self, lane: usize, p: &Packet, dw: f64);
    /// The deposits of one lane step (see [`Deposits`]); by default one [`Tally::absorb`] per
    /// lane. Absorption tallies override it to bin all lanes at once (vectorised).
    #[inline]
    fn absorb_lanes(&mut self, d: &Deposits) {
        for i in d.lanes() {
            self.absorb(i, &d.packet(i), d.dep[i]);
        }
    }
    /// The packet leaves through `side` with weight `w`. `p` is its state at the exit point
    /// (inside, before refraction); `dir_out` is its unit direction in the ambient medium after
    /// refraction (`dir_out[2] < 0` for `Side::Top`, `> 0` for `Side::Bottom`).
    fn escape(&mut self, lane: usize, p: &Packet, side: Side, dir_out: [f64; 3], w: f64);
    /// The history on lane `lane` has ended.
    fn end_photon(&mut self, lane: usize);
    /// The photons of one batch (`photons` of them, all ended) are done (see [`accum`]).
    fn end_batch(&mut self, _photons: u64) {}
    /// Add another tally of the same configuration into this one (deterministic: the run
    /// merges chunk tallies in chunk order).
    fn merge(&mut self, other: &Self);
}

/// The empty tally: scores nothing (for runs that need only the engine's own counters).
impl Tally for () {
    const POSITIONS: bool = false;
    #[inline]
    fn begin_photon(&mut self, _lane: usize, _photon: u64) {}
    #[inline]
    fn specular(&mut self, _lane: usize, _w: f64) {}
    #[inline]
    fn absorb(&mut self, _lane: usize, _p: &Packet, _dw: f64) {}
    #[inline]
    fn escape(&mut self, _lane: usize, _p: &Packet, _side: Side, _dir_out: [f64; 3], _w: f64) {}
    #[inline]
    fn end_photon(&mut self, _lane: usize) {}
    #[inline]
    fn merge(&mut self, _other: &Self) {}
}

/// Two tallies side by side, e.g. `(Totals, TallySet)`: each sees every event.
impl<A: Tally, B: Tally> Tally for (A, B) {
    const POSITIONS: bool = A::POSITIONS || B::POSITIONS;
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
    #[inline(always)]
    fn absorb_lanes(&mut self, d: &Deposits) {
        self.0.absorb_lanes(d);
        self.1.absorb_lanes(d);
    }
    #[inline]
    fn escape(&mut self, lane: usize, p: &Packet, side: Side, dir_out: [f64; 3], w: f64) {
        self.0.escape(lane, p, side, dir_out, w);
        self.1.escape(lane, p, side, dir_out, w);
    }
    #[inline]
    fn end_photon(&mut self, lane: usize) {
        self.0.end_photon(lane);
        self.1.end_photon(lane);
    }
    #[inline]
    fn end_batch(&mut self, photons: u64) {
        self.0.end_batch(photons);
        self.1.end_batch(photons);
    }
    #[inline]
    fn merge(&mut self, other: &Self) {
        self.0.merge(&other.0);
        self.1.merge(&other.1);
    }
}

pub mod accum;
pub mod config;
pub mod histogram;
pub mod set;

pub use accum::Accum;
pub use config::TallyConfig;
pub use histogram::HistogramOut;
pub use set::TallySet;
