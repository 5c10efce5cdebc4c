//! [`Accum`]: an array of bins that keeps, per bin, the sum of the scores and the sum of the
//! squares of the *per-photon* scores, so that every bin has a standard error from the
//! per-photon second moment (the batch-free estimator used e.g. by MCML 2.0 and MCX).
//!
//! A photon may score into the same bin many times (absorption along its path). The per-photon
//! score Xᵢ of a bin is the sum of those deposits; the standard error of the bin mean needs
//! Σ Xᵢ². Each bin therefore keeps the current photon's partial sum and the id of the photon
//! that owns it; when another photon first touches the bin, the partial is squared into the
//! second moment ("lazy flush"). This is O(1) per deposit, with no per-photon sweep over the
//! bins. [`Accum::flush`] squares the outstanding partials (at merge and finalize).

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

    /// Square every pending partial into the second moment.
    pub fn flush(&mut self) {
        for c in &mut self.cells {
            if c.owner != NONE {
                c.sum2 += c.cur * c.cur;
                c.cur = 0.0;
                c.owner = NONE;
            }
        }
    }

    /// Add another accumulator of the same size (its photons must be disjoint from ours, as
    /// chunks of a run are). Deterministic: the result depends only on the operands and the
    /// order of merges.
    pub fn merge(&mut self, other: &Accum) {
        debug_assert_eq!(self.len(), other.len());
        self.flush();
        for (c, o) in self.cells.iter_mut().zip(&other.cells) {
            c.sum += o.sum;
            c.sum2 += o.sum2;
            if o.owner != NONE {
                c.sum2 += o.cur * o.cur;
            }
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
    use super::*;

    /// A tiny deterministic generator for the tests (SplitMix64).
    fn splitmix(state: &mut u64) -> u64 {
        *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = *state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Random deposits: (photon, bin, x) with several deposits per photon, some repeated bins,
    /// negative values included.
    fn events(n_photons: u64, bins: usize, seed: u64) -> Vec<(u64, usize, f64)> {
        let mut s = seed;
        let mut ev = Vec::new();
        for p in 0..n_photons {
            let k = splitmix(&mut s) % 7;
            for _ in 0..k {
                let b = (splitmix(&mut s) % bins as u64) as usize;
                let x = (splitmix(&mut s) >> 11) as f64 / (1u64 << 53) as f64 - 0.2;
                ev.push((p, b, x));
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
        // flushing does not change the moments
        let before: Vec<f64> = (0..bins).map(|b| a.sum2(b)).collect();
        a.flush();
        for b in 0..bins {
            assert!((a.sum2(b) - before[b]).abs() < 1e-12 * (1.0 + before[b]));
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

    #[test]
    fn merge_of_chunks_equals_single_run_and_is_deterministic() {
        let (n, bins) = (900, 5);
        let ev = events(n, bins, 11);
        let mut whole = Accum::new(bins);
        for &(p, b, x) in &ev {
            whole.add(b, x, p);
        }
        let chunk = |lo: u64, hi: u64| {
            let mut a = Accum::new(bins);
            for &(p, b, x) in ev.iter().filter(|e| e.0 >= lo && e.0 < hi) {
                a.add(b, x, p);
            }
            a
        };
        let (c0, c1, c2) = (chunk(0, 300), chunk(300, 600), chunk(600, 900));
        let mut left = Accum::new(bins);
        for c in [&c0, &c1, &c2] {
            left.merge(c);
        }
        let mut right = c1.clone();
        right.merge(&c2);
        let mut assoc = c0.clone();
        assoc.merge(&right);
        let mut again = Accum::new(bins);
        for c in [&c0, &c1, &c2] {
            again.merge(c);
        }
        assert_eq!(left, again, "same merge order must be bit-identical");
        for b in 0..bins {
            for other in [&whole, &assoc] {
                assert!((left.sum(b) - other.sum(b)).abs() < 1e-12 * (1.0 + left.sum(b).abs()));
                assert!((left.sum2(b) - other.sum2(b)).abs() < 1e-12 * (1.0 + left.sum2(b)));
            }
        }
    }
}
