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

/// Totals with per-photon second moments and extremes. Scores are kept in one array: the
/// [`Total`]s, then one absorbed fraction per layer.
#[derive(Clone, Debug, PartialEq)]
pub struct Totals {
    photons: u64,
    layers: usize,
    /// Each lane's current photon's scores: the [`Total`]s, and (lane-major,
    /// `cur_layer[lane · layers + layer]`) the physical absorption per layer. Zero between
    /// photons: `end_photon` clears them as it reads them.
    cur: [[f64; NQ]; LANES],
    cur_layer: Vec<f64>,
    /// Over photons, slots of the [`Total`]s then of the layers: Σx, Σx², and the bounds of x
    /// (a chunk keeps only whether x was the same for every photon — cheaper than min/max per
    /// photon — as bounds (x, x), or (−∞, ∞) when it varied; merged states then hold the true
    /// "all equal" answer, which is all [`Totals::get`] needs).
    sum: Vec<f64>,
    sum2: Vec<f64>,
    min: Vec<f64>,
    max: Vec<f64>,
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
        let n = NQ + layers;
        Totals {
            photons: 0,
            layers,
            cur: [[0.0; NQ]; LANES],
            cur_layer: vec![0.0; layers * LANES],
            sum: vec![0.0; n],
            sum2: vec![0.0; n],
            min: vec![f64::INFINITY; n],
            max: vec![f64::NEG_INFINITY; n],
        }
    }

    /// Photons scored.
    pub fn photons(&self) -> u64 {
        self.photons
    }

    /// (estimate, standard error) of slot `i`: the common score and 0 when every photon scored
    /// the same, else [`mean_stderr`].
    fn estimate(&self, i: usize) -> (f64, f64) {
        if self.photons > 0 && self.min[i] == self.max[i] {
            return (self.min[i], 0.0);
        }
        mean_stderr(self.sum[i], self.sum2[i], self.photons)
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
        let s = &self.sum;
        (s[Total::Specular as usize]
            + s[Total::Diffuse as usize]
            + s[Total::Transmittance as usize]
            + s[Total::Absorbed as usize])
            / self.photons as f64
    }

    /// The channels of the totals of a stack of `layers` layers.
    pub fn layout(layers: usize) -> Vec<Channel> {
        vec![
            Channel { name: "totals".into(), len: NQ, extremes: true },
            Channel { name: "absorbed_per_layer".into(), len: layers, extremes: true },
        ]
    }
}

/// Score one photon's values `xs` into the slots `sum`, `sum2`, `min`, `max` (each at least
/// `xs.len()` long): Σx, Σx², and the "all equal" bounds (x, x) on the chunk's first photon,
/// (−∞, ∞) once a value differs. Branch-free over the slots (the per-photon cost of the
/// totals, which short histories pay at every photon).
#[inline(always)]
fn score(first: bool, xs: &[f64], sum: &mut [f64], sum2: &mut [f64], min: &mut [f64], max: &mut [f64]) {
    let n = xs.len();
    let (sum, sum2, min, max) = (&mut sum[..n], &mut sum2[..n], &mut min[..n], &mut max[..n]);
    for i in 0..n {
        let x = xs[i];
        sum[i] += x;
        sum2[i] += x * x;
    }
    if first {
        min.copy_from_slice(xs);
        max.copy_from_slice(xs);
    } else {
        for i in 0..n {
            let varied = xs[i] != min[i];
            min[i] = if varied { f64::NEG_INFINITY } else { min[i] };
            max[i] = if varied { f64::INFINITY } else { max[i] };
        }
    }
}

impl Tally for Totals {
    const POSITIONS: bool = false;
    #[inline]
    fn begin_photon(&mut self, _lane: usize, _photon: u64) {}
    #[inline]
    fn specular(&mut self, lane: usize, w: f64) {
        self.cur[lane][Total::Specular as usize] += w;
    }
    #[inline]
    fn absorb(&mut self, lane: usize, p: &Packet, dw: f64) {
        self.cur_layer[lane * self.layers + p.layer] += dw;
    }
    #[inline]
    fn roulette(&mut self, lane: usize, _p: &Packet, dw: f64) {
        self.cur[lane][Total::Roulette as usize] += dw;
    }
    #[inline]
    fn escape(&mut self, lane: usize, p: &Packet, side: Side, _dir_out: [f64; 3], w: f64) {
        let cur = &mut self.cur[lane];
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
        let lay = &mut self.cur_layer[lane * nl..(lane + 1) * nl];
        let physical = lay.iter().fold(0.0, |a, &x| a + x);
        let cur = &mut self.cur[lane];
        // The scores slot by slot: the history's last scores were single-slot stores (escape,
        // roulette), and one vector load (or a gather) over them cannot be forwarded from the
        // store buffer (perf put the stall at up to 10 % of case a's time; A/B medians of 9
        // pairs 1.02–1.04×); a load through an opaque reference is not combined with others.
        let mut xs: [f64; NQ] = std::array::from_fn(|k| *std::hint::black_box(&cur[k]));
        xs[Total::Absorbed as usize] = physical + xs[Total::Roulette as usize];
        let (sum, sum2, min, max) = (&mut self.sum, &mut self.sum2, &mut self.min, &mut self.max);
        score(first, &xs, &mut sum[..NQ], &mut sum2[..NQ], &mut min[..NQ], &mut max[..NQ]);
        score(first, lay, &mut sum[NQ..], &mut sum2[NQ..], &mut min[NQ..], &mut max[NQ..]);
        *cur = [0.0; NQ];
        // (store by store: `fill` on this short, variable-length slice became a call to
        // memset, 2.6 % of case a's time)
        for x in lay.iter_mut() {
            *std::hint::black_box(x) = 0.0;
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
                    ok &= state[k].add(i - lo, self.sum[i], self.sum2[i]);
                    state[k].add_extremes(i - lo, self.min[i], self.max[i]);
                }
            }
        }
        *self = Totals::new(self.layers);
        ok.then_some(2)
    }
    fn load_from(&mut self, state: &[ChannelState], photons: u64) -> usize {
        *self = Totals::new(self.layers);
        self.photons = photons;
        for (k, lo) in [0, NQ].into_iter().enumerate() {
            for j in 0..state[k].s1.len() {
                (self.sum[lo + j], self.sum2[lo + j]) = state[k].get(j);
                self.min[lo + j] = state[k].min[j];
                self.max[lo + j] = state[k].max[j];
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
}
