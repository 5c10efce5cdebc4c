//! Tallies: what the kernel scores. The kernel is generic over [`Tally`] (static dispatch,
//! monomorphised per tally set, so a run that asks only for totals pays nothing for grids).
//!
//! Standard errors come from per-photon second moments: every tally sees
//! [`Tally::begin_photon`] / [`Tally::end_photon`] around each photon's history.

pub mod totals;

use super::packet::{Packet, Side};

/// Receiver of the kernel's events. All weights are in units of the launched packet weight (1).
pub trait Tally: Send {
    /// A new photon history starts; `photon` is its global index (0 … N−1).
    fn begin_photon(&mut self, photon: u64);
    /// Weight reflected specularly at the top surface on launch.
    fn specular(&mut self, w: f64);
    /// Weight `dw` deposited (absorbed) at the packet's position `p.pos` in layer `p.layer`.
    /// `dw` can be negative: Russian roulette deposits its zero-mean control term here, so that
    /// energy balance holds exactly in every run (see `mc::kernel`).
    fn absorb(&mut self, p: &Packet, dw: f64);
    /// The packet leaves through `side` with weight `w`. `p` is its state at the exit point
    /// (inside, before refraction); `dir_out` is its unit direction in the ambient medium after
    /// refraction (`dir_out[2] < 0` for `Side::Top`, `> 0` for `Side::Bottom`).
    fn escape(&mut self, p: &Packet, side: Side, dir_out: [f64; 3], w: f64);
    /// The current photon history has ended.
    fn end_photon(&mut self);
    /// Add another tally of the same configuration into this one (deterministic: the run
    /// merges chunk tallies in chunk order).
    fn merge(&mut self, other: &Self);
}

/// The empty tally: scores nothing (for runs that need only the engine's own counters).
impl Tally for () {
    #[inline]
    fn begin_photon(&mut self, _photon: u64) {}
    #[inline]
    fn specular(&mut self, _w: f64) {}
    #[inline]
    fn absorb(&mut self, _p: &Packet, _dw: f64) {}
    #[inline]
    fn escape(&mut self, _p: &Packet, _side: Side, _dir_out: [f64; 3], _w: f64) {}
    #[inline]
    fn end_photon(&mut self) {}
    #[inline]
    fn merge(&mut self, _other: &Self) {}
}

/// Two tallies side by side, e.g. `(Totals, TallySet)`: each sees every event.
impl<A: Tally, B: Tally> Tally for (A, B) {
    #[inline]
    fn begin_photon(&mut self, photon: u64) {
        self.0.begin_photon(photon);
        self.1.begin_photon(photon);
    }
    #[inline]
    fn specular(&mut self, w: f64) {
        self.0.specular(w);
        self.1.specular(w);
    }
    #[inline]
    fn absorb(&mut self, p: &Packet, dw: f64) {
        self.0.absorb(p, dw);
        self.1.absorb(p, dw);
    }
    #[inline]
    fn escape(&mut self, p: &Packet, side: Side, dir_out: [f64; 3], w: f64) {
        self.0.escape(p, side, dir_out, w);
        self.1.escape(p, side, dir_out, w);
    }
    #[inline]
    fn end_photon(&mut self) {
        self.0.end_photon();
        self.1.end_photon();
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
