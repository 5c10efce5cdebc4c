//! [`Accum`]: an array of bins that keeps, per bin, the sum of the scores and the sum of the
//! squares of the *per-photon* scores, so that every bin has a standard error from the
//! per-photon second moment (the batch-free estimator used e.g. by MCML 2.0 and MCX).
//!
//! A photon may score into the same bin many times (absorption along its path). The per-photon
//! score Xᵢ of a bin is the sum of those deposits; the standard error of the bin mean needs
//! Σ Xᵢ². Each bin therefore keeps the current photon's partial sum and the id of the photon
//! that owns it; when another photon first touches the bin, the partial is squared into the
//! second moment ("lazy flush"). This is O(1) per deposit, with no per-photon sweep over the
//! bins. [`Accum::drain_into`] squares the outstanding partials when the chunk is merged.

/// Owner id meaning "no partial pending".
const NONE: u64 = u64::MAX;

/// One bin: Σ deposits, Σ (per-photon score)², the pending photon's partial score and its id.
/// 32 bytes, so one deposit touches one cache line.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
struct Cell {
    sum: f64,
    sum2: f64,
    cur: f64,
    owner: u64,
}

const EMPTY: Cell = Cell { sum: 0.0, sum2: 0.0, cur: 0.0, owner: NONE };

/// A flat array of bins with per-photon second moments (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct Accum {
    cells: Vec<Cell>,
}

impl Accum {
    /// `n` empty bins (`n = 0` gives a disabled accumulator that must not be deposited into).
    pub fn new(n: usize) -> Self {
        Accum { cells: vec![EMPTY; n] }
    }

    /// Number of bins.
    #[inline]
    pub fn len(&self) -> usize {
        self.cells.len()
    }

    /// Whether there are no bins (a disabled tally).
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.cells.is_empty()
    }

    /// Add `x` to bin `bin` on behalf of photon `photon` (a global photon index, never `u64::MAX`).
    /// The caller guarantees `bin < len()`.
    #[inline]
    pub fn add(&mut self, bin: usize, x: f64, photon: u64) {
        let c = &mut self.cells[bin];
        c.sum += x;
        if c.owner == photon {
            c.cur += x;
        } else {
            c.sum2 += c.cur * c.cur;
            c.cur = x;
            c.owner = photon;
        }
    }

    /// Add every bin's (S₁, S₂) exactly into `state` (same length) and clear the bins for the
    /// next chunk. `false` if a sum is outside the exact range.
    pub fn drain_into(&mut self, state: &mut super::ChannelState) -> bool {
        debug_assert_eq!(self.len(), state.s1.len());
        let mut ok = true;
        for (i, c) in self.cells.iter_mut().enumerate() {
            if c.owner != NONE {
                ok &= state.add(i, c.sum, c.sum2 + c.cur * c.cur);
                *c = EMPTY;
            } else if c.sum != 0.0 || c.sum2 != 0.0 {
                ok &= state.add(i, c.sum, c.sum2);
                *c = EMPTY;
            }
        }
        ok
    }

    /// Set every bin to the exact sums of `state`, rounded to f64 (for normalisation).
    pub fn load_from(&mut self, state: &super::ChannelState) {
        debug_assert_eq!(self.len(), state.s1.len());
        for (i, c) in self.cells.iter_mut().enumerate() {
            let (sum, sum2) = state.get(i);
            *c = Cell { sum, sum2, cur: 0.0, owner: NONE };
        }
    }

    /// Σ of all deposits in bin `i`.
    #[inline]
    pub fn sum(&self, i: usize) -> f64 {
        self.cells[i].sum
    }

    /// Σ over photons of the squared per-photon score of bin `i`, including the pending partial.
    #[inline]
    pub fn sum2(&self, i: usize) -> f64 {
        let c = &self.cells[i];
        c.sum2 + if c.owner != NONE { c.cur * c.cur } else { 0.0 }
    }

    /// Mean per photon and its standard error for bin `i` over `n` photons:
    /// m = S₁/n, se = √((S₂/n − m²)/(n − 1)) (NaN for n < 2; 0 if rounding makes the variance
    /// negative).
    pub fn mean_stderr(&self, i: usize, n: u64) -> (f64, f64) {
        mean_stderr(self.sum(i), self.sum2(i), n)
    }
}

pub use super::totals::mean_stderr;

#[cfg(test)]
mod tests {
    use super::super::{Channel, ChannelState};
    use super::*;
    use crate::stats::SplitMix64;

    /// Random deposits: (photon, bin, x) with several deposits per photon, some repeated bins,
    /// negative values included.
    fn events(n_photons: u64, bins: usize, seed: u64) -> Vec<(u64, usize, f64)> {
        let mut rng = SplitMix64::new(seed);
        let mut ev = Vec::new();
        for p in 0..n_photons {
            let k = rng.next_u64() % 7;
            for _ in 0..k {
                let b = (rng.next_u64() % bins as u64) as usize;
                ev.push((p, b, rng.next_f64() - 0.2));
            }
        }
        ev
    }

    /// Brute force: per-photon per-bin scores in a dense matrix.
    fn brute(ev: &[(u64, usize, f64)], n_photons: u64, bins: usize) -> Vec<(f64, f64)> {
        let mut m = vec![vec![0.0; bins]; n_photons as usize];
        for &(p, b, x) in ev {
            m[p as usize][b] += x;
        }
        (0..bins)
            .map(|b| {
                let s1: f64 = m.iter().map(|r| r[b]).sum();
                let s2: f64 = m.iter().map(|r| r[b] * r[b]).sum();
                (s1, s2)
            })
            .collect()
    }

    fn channel(bins: usize) -> ChannelState {
        ChannelState::new(&Channel { name: "x".into(), len: bins, extremes: false })
    }

    #[test]
    fn matches_brute_force_second_moments() {
        let (n, bins) = (500, 13);
        let ev = events(n, bins, 7);
        let mut a = Accum::new(bins);
        for &(p, b, x) in &ev {
            a.add(b, x, p);
        }
        let want = brute(&ev, n, bins);
        for b in 0..bins {
            let (s1, s2) = want[b];
            assert!((a.sum(b) - s1).abs() < 1e-12 * (1.0 + s1.abs()), "bin {b}");
            assert!((a.sum2(b) - s2).abs() < 1e-12 * (1.0 + s2), "bin {b}");
        }
        // draining into exact sums and loading back keeps the moments and clears the bins
        let mut st = channel(bins);
        assert!(a.drain_into(&mut st));
        assert!((0..bins).all(|b| a.sum(b) == 0.0 && a.sum2(b) == 0.0));
        a.load_from(&st);
        for b in 0..bins {
            let (s1, s2) = want[b];
            assert!((a.sum(b) - s1).abs() < 1e-12 * (1.0 + s1.abs()), "bin {b}");
            assert!((a.sum2(b) - s2).abs() < 1e-12 * (1.0 + s2), "bin {b}");
        }
    }

    #[test]
    fn stderr_formula() {
        // samples 1, 2, 3, 0 (one photon scored nothing): mean 1.5, sample variance 5/3,
        // stderr √(5/3/4).
        let mut a = Accum::new(1);
        a.add(0, 1.0, 0);
        a.add(0, 1.5, 1);
        a.add(0, 0.5, 1);
        a.add(0, 3.0, 2);
        let (m, se) = a.mean_stderr(0, 4);
        assert_eq!(m, 1.5);
        assert!((se - (5.0f64 / 3.0 / 4.0).sqrt()).abs() < 1e-15);
        assert!(mean_stderr(1.0, 1.0, 1).1.is_nan());
    }

    /// Chunks drained into exact sums in any grouping and order give the same bits.
    #[test]
    fn exact_merge_of_chunks_is_partition_independent() {
        let (n, bins) = (900, 5);
        let ev = events(n, bins, 11);
        let chunk = |lo: u64, hi: u64| {
            let mut a = Accum::new(bins);
            for &(p, b, x) in ev.iter().filter(|e| e.0 >= lo && e.0 < hi) {
                a.add(b, x, p);
            }
            let mut st = channel(bins);
            assert!(a.drain_into(&mut st));
            st
        };
        let (c0, c1, c2) = (chunk(0, 300), chunk(300, 600), chunk(600, 900));
        let mut left = c0.clone();
        left.merge(&c1);
        left.merge(&c2);
        let mut right = c2.clone();
        right.merge(&c1);
        let mut other = c0.clone();
        other.merge(&right);
        assert_eq!(left, other, "exact sums must not depend on grouping or order");
        let want = brute(&ev, n, bins);
        for b in 0..bins {
            let (s1, s2) = left.get(b);
            assert!((s1 - want[b].0).abs() < 1e-12 * (1.0 + s1.abs()));
            assert!((s2 - want[b].1).abs() < 1e-12 * (1.0 + s2));
        }
    }
}
