//! The totals every run reports: specular and diffuse reflectance, transmittance (and its
//! unscattered part), absorbed fraction in total and per layer, each with its standard error.
//!
//! Every quantity X is a mean over photons of a per-photon score xᵢ (the weight the photon
//! contributed); the scores are accumulated between `begin_photon` and `end_photon`, and the
//! run keeps S₁ = Σ xᵢ and S₂ = Σ xᵢ². Estimate and standard error of the mean:
//! X̂ = S₁/N, SE = √((S₂/N − X̂²)/(N − 1)) (the sample variance of the scores over N; e.g.
//! Kalos & Whitlock, *Monte Carlo Methods*, 2nd ed., §2.6). This accounts for the correlation
//! of all the weight a photon leaves in one quantity, which MCML's per-bin formula does not.

use crate::mc::lanes::LANES;
use crate::mc::packet::{Packet, Side};
use crate::mc::tally::{Deposits, Tally};

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
    /// Absorbed fraction in the whole stack (MCML's A), including roulette's zero-mean term.
    Absorbed = 4,
}

const NQ: usize = 5;

/// Totals with per-photon second moments (a partial score per lane, see [`Tally`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Totals {
    photons: u64,
    layers: usize,
    cur: [[f64; NQ]; LANES],
    sum: [f64; NQ],
    sum2: [f64; NQ],
    /// Lane-major: `cur_layer[lane * layers + layer]`.
    cur_layer: Vec<f64>,
    sum_layer: Vec<f64>,
    sum2_layer: Vec<f64>,
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
        Totals {
            photons: 0,
            layers,
            cur: [[0.0; NQ]; LANES],
            sum: [0.0; NQ],
            sum2: [0.0; NQ],
            cur_layer: vec![0.0; layers * LANES],
            sum_layer: vec![0.0; layers],
            sum2_layer: vec![0.0; layers],
        }
    }

    /// Photons scored.
    pub fn photons(&self) -> u64 {
        self.photons
    }

    /// (estimate, standard error) of a total, as a fraction of the incident power.
    pub fn get(&self, q: Total) -> (f64, f64) {
        let i = q as usize;
        mean_stderr(self.sum[i], self.sum2[i], self.photons)
    }

    /// (estimate, standard error) of the absorbed fraction in each layer.
    pub fn absorbed_per_layer(&self) -> Vec<(f64, f64)> {
        self.sum_layer.iter().zip(&self.sum2_layer).map(|(&s1, &s2)| mean_stderr(s1, s2, self.photons)).collect()
    }

    /// specular + diffuse + transmittance + absorbed (1 up to rounding in every run).
    pub fn energy_balance(&self) -> f64 {
        (self.sum[0] + self.sum[1] + self.sum[2] + self.sum[4]) / self.photons as f64
    }
}

impl Tally for Totals {
    const POSITIONS: bool = false;
    /// The lane's partial scores are zero here: `end_photon` clears them as it reads them.
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
    #[inline(always)]
    fn absorb_lanes(&mut self, d: &Deposits) {
        for i in d.lanes() {
            self.cur_layer[i * self.layers + d.layer[i] as usize] += d.dep[i];
        }
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
    #[inline]
    fn end_photon(&mut self, lane: usize) {
        self.photons += 1;
        let nl = self.layers;
        let mut a = 0.0;
        for j in 0..nl {
            let c = std::mem::take(&mut self.cur_layer[lane * nl + j]);
            a += c;
            self.sum_layer[j] += c;
            self.sum2_layer[j] += c * c;
        }
        let cur = &mut self.cur[lane];
        cur[Total::Absorbed as usize] = a;
        for i in 0..NQ {
            let x = cur[i];
            self.sum[i] += x;
            self.sum2[i] += x * x;
        }
        *cur = [0.0; NQ];
    }
    fn merge(&mut self, other: &Self) {
        self.photons += other.photons;
        for i in 0..NQ {
            self.sum[i] += other.sum[i];
            self.sum2[i] += other.sum2[i];
        }
        for (a, b) in self.sum_layer.iter_mut().zip(&other.sum_layer) {
            *a += *b;
        }
        for (a, b) in self.sum2_layer.iter_mut().zip(&other.sum2_layer) {
            *a += *b;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mean_and_stderr_of_known_scores() {
        // Scores 1, 0, 0, 1 on Diffuse: mean 1/2, sample variance 1/3, SE = √(1/12).
        let mut t = Totals::new(1);
        let p = Packet { pos: [0.0; 3], dir: [0.0, 0.0, -1.0], w: 1.0, layer: 0, order: 1, reflections: 0, path: 0.0 };
        // Two lanes interleaved: lane 1's events do not leak into lane 0's photon.
        for x in [1.0, 0.0] {
            t.begin_photon(0, 0);
            t.begin_photon(1, 1);
            t.escape(0, &p, Side::Top, p.dir, x);
            t.escape(1, &p, Side::Top, p.dir, 1.0 - x);
            t.absorb(0, &p, 1.0 - x);
            t.absorb(1, &p, x);
            t.end_photon(1);
            t.end_photon(0);
        }
        let (m, se) = t.get(Total::Diffuse);
        assert_eq!(m, 0.5);
        assert!((se - (1.0f64 / 12.0).sqrt()).abs() < 1e-15);
        assert_eq!(t.get(Total::Absorbed).0, 0.5);
        assert_eq!(t.absorbed_per_layer()[0].0, 0.5);
        let mut u = Totals::new(1);
        u.merge(&t);
        u.merge(&t);
        assert_eq!(u.photons(), 8);
        assert_eq!(u.get(Total::Diffuse).0, 0.5);
    }
}
