//! The totals every run reports: specular and diffuse reflectance, transmittance (and its
//! unscattered part), absorbed fraction in total and per layer, each with its standard error.
//!
//! Every quantity X is a mean over photons of a per-photon score xᵢ (the weight the photon
//! contributed); the scores are accumulated between `begin_photon` and `end_photon`, and the
//! run keeps S₁ = Σ xᵢ and S₂ = Σ xᵢ². Estimate and standard error of the mean:
//! X̂ = S₁/N, SE = √((S₂/N − X̂²)/(N − 1)) (the sample variance of the scores over N; e.g.
//! Kalos & Whitlock, *Monte Carlo Methods*, 2nd ed., §2.6). This accounts for the correlation
//! of all the weight a photon leaves in one quantity, which MCML's per-bin formula does not.
//! The smallest and largest per-photon score are kept too: a quantity that every photon scores
//! identically (the specular reflectance of a pencil beam) is reported as that score with a
//! standard error of exactly 0, not with rounding noise.
//!
//! Absorption: `absorbed_per_layer` holds the physical deposits w σa/σt only (MCML's A_l), so it
//! is never negative and exactly 0 in a layer with σa = 0. The total `absorbed` is the weight
//! that did not leave the stack, 1 − R_sp − R_d − T for every photon: the physical deposits plus
//! the Russian-roulette term ([`Total::Roulette`], zero mean; see `mc::kernel`), which makes the
//! energy balance exact in every run. Since roulette plays below 10⁻⁴ of the entering weight
//! and a survivor never weighs more than 10⁻³ of it, a photon never leaves with more than it
//! brought, so `absorbed` is never negative either.

use super::{Channel, ChannelState, Tally};
use crate::mc::lanes::math::sel;
use crate::mc::lanes::LANES;
use crate::mc::packet::{Packet, Side};

/// Index of each total in the accumulator arrays.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Total {
    /// Specular reflectance at the top surface on launch (MCML's Rsp).
    Specular = 0,
    /// Diffuse reflectance: weight escaping through the top (MCML's Rd).
    Diffuse = 1,
    /// Total transmittance through the bottom (MCML's Tt), including the unscattered part.
    Transmittance = 2,
    /// The unscattered part of the transmittance (order 0; interface reflections allowed).
    Unscattered = 3,
    /// Weight that did not leave the stack: Σ absorbed_per_layer + [`Total::Roulette`]
    /// (= 1 − R_sp − R_d − T per photon, ≥ 0).
    Absorbed = 4,
    /// The Russian-roulette control term (zero mean) and the weight of packets that could not
    /// leave; part of [`Total::Absorbed`], not of the per-layer absorption or the histograms.
    Roulette = 5,
}

/// Number of [`Total`] quantities.
pub const NQ: usize = 6;

impl Total {
    /// Every total, in index order.
    pub const ALL: [Total; NQ] =
        [Total::Specular, Total::Diffuse, Total::Transmittance, Total::Unscattered, Total::Absorbed, Total::Roulette];
}

/// Names of the [`Total`]s, in index order (the Python result's attribute names).
pub const TOTAL_NAMES: [&str; NQ] = [
    "specular_reflectance",
    "diffuse_reflectance",
    "transmittance",
    "unscattered_transmittance",
    "absorbed",
    "roulette",
];

/// Slots per block of [`Totals`]' arrays (one AVX-512 register of f64).
const W: usize = 8;

/// [`W`] slots on a cache line of their own (64-byte aligned and sized): the totals write
/// their blocks at every photon, and a block that shared a line with another thread's
/// allocation (tallies move between workers) would be falsely shared.
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug, PartialEq)]
struct Block([f64; W]);

impl std::ops::Deref for Block {
    type Target = [f64; W];
    #[inline(always)]
    fn deref(&self) -> &[f64; W] {
        &self.0
    }
}

impl std::ops::DerefMut for Block {
    #[inline(always)]
    fn deref_mut(&mut self) -> &mut [f64; W] {
        &mut self.0
    }
}

/// Totals with per-photon second moments and extremes. Scores are kept in slots: the
/// [`Total`]s, then one absorbed fraction per layer, in blocks of 8 (the last one padded
/// with slots that stay 0), so that a photon's scores are added up with a few whole-block
/// vector operations.
#[derive(Clone, Debug, PartialEq)]
pub struct Totals {
    photons: u64,
    layers: usize,
    /// Blocks per set of slots: ⌈(NQ + layers)/W⌉.
    blocks: usize,
    /// Each lane's current photon's scores, lane-major (`cur[lane · blocks + block]`). Zero
    /// between photons: `end_photon` clears them as it reads them ([`Total::Absorbed`] is
    /// set there, never added to).
    cur: Vec<Block>,
    /// Over photons, per slot: Σx, Σx², and the bounds of x (a chunk keeps only whether x was
    /// the same for every photon — cheaper than min/max per photon — as bounds (x, x), or
    /// (−∞, ∞) when it varied; merged states then hold the true "all equal" answer, which is
    /// all [`Totals::get`] needs).
    sum: Vec<Block>,
    sum2: Vec<Block>,
    min: Vec<Block>,
    max: Vec<Block>,
}

/// Sample mean and standard error of the mean from Σx = `s1` and Σx² = `s2` over `n` samples
/// (the samples include zeros for photons that did not score): m = s1/n,
/// se = √((s2/n − m²)/(n − 1)). Shared by every tally.
pub fn mean_stderr(s1: f64, s2: f64, n: u64) -> (f64, f64) {
    if n == 0 {
        return (f64::NAN, f64::NAN);
    }
    let nf = n as f64;
    let m = s1 / nf;
    if n < 2 {
        return (m, f64::NAN);
    }
    let var = (s2 / nf - m * m).max(0.0);
    (m, (var / (nf - 1.0)).sqrt())
}

impl Totals {
    /// Empty totals for a stack of `layers` layers.
    pub fn new(layers: usize) -> Self {
        let blocks = (NQ + layers).div_ceil(W);
        Totals {
            photons: 0,
            layers,
            blocks,
            cur: vec![Block([0.0; W]); blocks * LANES],
            sum: vec![Block([0.0; W]); blocks],
            sum2: vec![Block([0.0; W]); blocks],
            min: vec![Block([f64::INFINITY; W]); blocks],
            max: vec![Block([f64::NEG_INFINITY; W]); blocks],
        }
    }

    /// Slot `i` of a blocked array.
    #[inline]
    fn at(a: &[Block], i: usize) -> f64 {
        a[i / W][i % W]
    }

    /// Slot `i` of a blocked array, to write.
    #[inline]
    fn at_mut(a: &mut [Block], i: usize) -> &mut f64 {
        &mut a[i / W][i % W]
    }

    /// Lane `lane`'s first block of current scores (the [`Total`]s): one index, where
    /// `cur[lane · blocks..][0]` checked the slice's two bounds and then its length (a few
    /// instructions at every photon of a short history).
    #[inline(always)]
    fn cur0(&mut self, lane: usize) -> &mut [f64; W] {
        &mut self.cur[lane * self.blocks]
    }

    /// Back to no photons, keeping the allocations (a tally is reused chunk after chunk).
    fn clear(&mut self) {
        self.photons = 0;
        for (a, x) in [(&mut self.cur, 0.0), (&mut self.sum, 0.0), (&mut self.sum2, 0.0)]
            .into_iter()
            .chain([(&mut self.min, f64::INFINITY), (&mut self.max, f64::NEG_INFINITY)])
        {
            a.fill(Block([x; W]));
        }
    }

    /// Photons scored.
    pub fn photons(&self) -> u64 {
        self.photons
    }

    /// (estimate, standard error) of slot `i`: the common score and 0 when every photon scored
    /// the same, else [`mean_stderr`].
    fn estimate(&self, i: usize) -> (f64, f64) {
        let (min, max) = (Self::at(&self.min, i), Self::at(&self.max, i));
        if self.photons > 0 && min == max {
            return (min, 0.0);
        }
        mean_stderr(Self::at(&self.sum, i), Self::at(&self.sum2, i), self.photons)
    }

    /// (estimate, standard error) of a total, as a fraction of the incident power.
    pub fn get(&self, q: Total) -> (f64, f64) {
        self.estimate(q as usize)
    }

    /// (estimate, standard error) of the absorbed fraction in each layer.
    pub fn absorbed_per_layer(&self) -> Vec<(f64, f64)> {
        (NQ..NQ + self.layers).map(|i| self.estimate(i)).collect()
    }

    /// (specular + diffuse + transmittance + absorbed)/N (1 up to rounding in every run).
    pub fn energy_balance(&self) -> f64 {
        let s = |q: Total| Self::at(&self.sum, q as usize);
        (s(Total::Specular) + s(Total::Diffuse) + s(Total::Transmittance) + s(Total::Absorbed)) / self.photons as f64
    }

    /// The channels of the totals of a stack of `layers` layers.
    pub fn layout(layers: usize) -> Vec<Channel> {
        vec![
            Channel { name: "totals".into(), len: NQ, extremes: true },
            Channel { name: "absorbed_per_layer".into(), len: layers, extremes: true },
        ]
    }
}

/// Score one photon's block of slots `x` into `sum`, `sum2`, `min`, `max`: Σx, Σx², and the
/// "all equal" bounds (x, x) on the chunk's first photon, (−∞, ∞) once a value differs.
/// Branch-free over the slots (the per-photon cost of the totals, which short histories pay
/// at every photon: a few vector operations per block).
#[inline(always)]
fn score(first: bool, x: &[f64; W], sum: &mut [f64; W], sum2: &mut [f64; W], min: &mut [f64; W], max: &mut [f64; W]) {
    for i in 0..W {
        sum[i] += x[i];
        sum2[i] += x[i] * x[i];
    }
    if first {
        (*min, *max) = (*x, *x);
    } else {
        for i in 0..W {
            let varied = x[i] != min[i];
            min[i] = sel(varied, f64::NEG_INFINITY, min[i]);
            max[i] = sel(varied, f64::INFINITY, max[i]);
        }
    }
}

impl Tally for Totals {
    const POSITIONS: bool = false;
    const TRACKS: bool = false;
    #[inline]
    fn begin_photon(&mut self, _lane: usize, _photon: u64) {}
    #[inline]
    fn specular(&mut self, lane: usize, w: f64) {
        self.cur0(lane)[Total::Specular as usize] += w;
    }
    #[inline]
    fn absorb(&mut self, lane: usize, p: &Packet, dw: f64) {
        let k = NQ + p.layer;
        self.cur[lane * self.blocks + k / W][k % W] += dw;
    }
    #[inline]
    fn roulette(&mut self, lane: usize, _p: &Packet, dw: f64) {
        self.cur0(lane)[Total::Roulette as usize] += dw;
    }
    #[inline]
    fn escape(&mut self, lane: usize, p: &Packet, side: Side, _dir_out: [f64; 3], w: f64) {
        let cur = self.cur0(lane);
        match side {
            Side::Top => cur[Total::Diffuse as usize] += w,
            Side::Bottom => {
                cur[Total::Transmittance as usize] += w;
                if p.order == 0 {
                    cur[Total::Unscattered as usize] += w;
                }
            }
        }
    }
    // (always: compiled inside the lane kernel's instruction-set entry, with its vector width)
    #[inline(always)]
    fn end_photon(&mut self, lane: usize) {
        self.photons += 1;
        let first = self.photons == 1;
        let nl = self.layers;
        let cur = &mut self.cur[lane * self.blocks..(lane + 1) * self.blocks];
        // The scores are read slot by slot: the history's last scores were single-slot stores
        // (escape, roulette), and one vector load (or a gather) over them cannot be forwarded
        // from the store buffer (perf put the stall at up to 10 % of case a's time). Volatile
        // loads are neither combined nor, as `black_box` was, routed through the stack (whose
        // one slot serialised them).
        // SAFETY: `x` is a reference to an initialised f64.
        let slot = |x: &f64| unsafe { std::ptr::read_volatile(x) };
        let read = |b: &Block| -> [f64; W] { std::array::from_fn(|k| slot(&b[k])) };
        // (block 0 is read once: its layer slots are summed from the copy, in slot order as
        // before, so the bits are those of a sum read slot by slot)
        let mut x = read(&cur[0]);
        let physical = x[NQ..(NQ + nl).min(W)].iter().fold(0.0, |a, &v| a + v);
        let physical = (W..NQ + nl).fold(physical, |a, i| a + slot(&cur[i / W][i % W]));
        x[Total::Absorbed as usize] = physical + x[Total::Roulette as usize];
        score(first, &x, &mut self.sum[0], &mut self.sum2[0], &mut self.min[0], &mut self.max[0]);
        cur[0].0 = [0.0; W];
        for (b, c) in cur.iter_mut().enumerate().skip(1) {
            score(first, &read(c), &mut self.sum[b], &mut self.sum2[b], &mut self.min[b], &mut self.max[b]);
            c.0 = [0.0; W];
        }
    }
    fn channels(&self, out: &mut Vec<Channel>) {
        out.extend(Totals::layout(self.layers));
    }
    fn drain_into(&mut self, state: &mut [ChannelState]) -> Option<usize> {
        let mut ok = true;
        for (k, (lo, hi)) in [(0, NQ), (NQ, NQ + self.layers)].into_iter().enumerate() {
            for i in lo..hi {
                if self.photons > 0 {
                    ok &= state[k].add(i - lo, Self::at(&self.sum, i), Self::at(&self.sum2, i));
                    state[k].add_extremes(i - lo, Self::at(&self.min, i), Self::at(&self.max, i));
                }
            }
        }
        self.clear();
        ok.then_some(2)
    }
    fn load_from(&mut self, state: &[ChannelState], photons: u64) -> usize {
        self.clear();
        self.photons = photons;
        for (k, lo) in [0, NQ].into_iter().enumerate() {
            for j in 0..state[k].s1.len() {
                let (s1, s2) = state[k].get(j);
                *Self::at_mut(&mut self.sum, lo + j) = s1;
                *Self::at_mut(&mut self.sum2, lo + j) = s2;
                *Self::at_mut(&mut self.min, lo + j) = state[k].min[j];
                *Self::at_mut(&mut self.max, lo + j) = state[k].max[j];
            }
        }
        2
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pkt() -> Packet {
        Packet { pos: [0.0; 3], dir: [0.0, 0.0, -1.0], w: 1.0, layer: 0, order: 1, reflections: 0, path: 0.0 }
    }

    #[test]
    fn mean_and_stderr_of_known_scores() {
        // Scores 1, 0, 0, 1 on Diffuse: mean 1/2, sample variance 1/3, SE = √(1/12).
        let mut t = Totals::new(1);
        let p = pkt();
        for x in [1.0, 0.0, 0.0, 1.0] {
            t.begin_photon(0, 0);
            t.specular(0, 0.25);
            t.escape(0, &p, Side::Top, p.dir, x);
            t.absorb(0, &p, 1.0 - x);
            t.end_photon(0);
        }
        let (m, se) = t.get(Total::Diffuse);
        assert_eq!(m, 0.5);
        assert!((se - (1.0f64 / 12.0).sqrt()).abs() < 1e-15);
        assert_eq!(t.get(Total::Absorbed).0, 0.5);
        assert_eq!(t.absorbed_per_layer()[0].0, 0.5);
        // every photon scored 0.25 specularly: exactly 0.25 ± 0
        assert_eq!(t.get(Total::Specular), (0.25, 0.0));
        // drain and load: exact state round trip
        let mut chans = Vec::new();
        t.channels(&mut chans);
        let mut st: Vec<ChannelState> = chans.iter().map(ChannelState::new).collect();
        let before = (t.get(Total::Diffuse), t.get(Total::Specular));
        assert_eq!(t.drain_into(&mut st), Some(2));
        assert_eq!(t.photons(), 0);
        let mut u = Totals::new(1);
        assert_eq!(u.load_from(&st, 4), 2);
        assert_eq!((u.get(Total::Diffuse), u.get(Total::Specular)), before);
    }

    #[test]
    fn roulette_is_in_the_total_not_in_the_layers() {
        let mut t = Totals::new(2);
        let mut p = pkt();
        t.begin_photon(0, 0);
        t.absorb(0, &p, 0.75);
        p.layer = 1;
        t.roulette(0, &p, -0.25);
        t.escape(0, &p, Side::Top, p.dir, 0.5);
        t.end_photon(0);
        assert_eq!(t.get(Total::Absorbed).0, 0.5);
        assert_eq!(t.get(Total::Roulette).0, -0.25);
        assert_eq!(t.absorbed_per_layer()[1].0, 0.0);
        assert_eq!(t.energy_balance(), 1.0);
    }

    /// Layers past the first block of slots (NQ + 5 > W): per-layer sums, the "all equal"
    /// rule and the exact state round trip hold there too, lane by lane.
    #[test]
    fn layers_in_a_second_block() {
        let mut t = Totals::new(5);
        let mut p = pkt();
        for (k, x) in [0.5, 0.25, 0.125].into_iter().enumerate() {
            let lane = 3 * k % LANES;
            t.begin_photon(lane, k as u64);
            p.layer = 3;
            t.absorb(lane, &p, 0.25); // the same in every photon
            p.layer = 4;
            t.absorb(lane, &p, x);
            t.escape(lane, &p, Side::Top, p.dir, 0.75 - x);
            t.end_photon(lane);
        }
        let layers = t.absorbed_per_layer();
        assert_eq!(layers[3], (0.25, 0.0));
        let (m, se) = layers[4];
        assert_eq!(m, 0.875 / 3.0);
        assert_eq!((m, se), mean_stderr(0.875, 0.25 + 0.0625 + 0.015625, 3));
        assert_eq!(layers[0], (0.0, 0.0));
        assert_eq!(t.get(Total::Absorbed).0, (0.75 + 0.5 + 0.375) / 3.0);
        assert!((t.energy_balance() - 1.0).abs() < 1e-15);
        let mut chans = Vec::new();
        t.channels(&mut chans);
        let mut st: Vec<ChannelState> = chans.iter().map(ChannelState::new).collect();
        assert_eq!(t.drain_into(&mut st), Some(2));
        let mut u = Totals::new(5);
        u.load_from(&st, 3);
        assert_eq!(u.absorbed_per_layer(), layers);
    }
}
