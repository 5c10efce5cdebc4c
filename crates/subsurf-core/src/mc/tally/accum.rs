//! [`Accum`]: an array of bins with batch-means standard errors (or none at all).
//!
//! Photons are grouped in fixed batches of consecutive indices (the run closes a batch with
//! [`Accum::end_batch`] once all its photons have ended). Each bin keeps the running batch
//! total Tₖ in `cur` (one add per deposit, no per-photon bookkeeping), and at the end of
//! batch k folds it into S₁ = Σ Tₖ and Q = Σ Tₖ²/nₖ (nₖ photons in batch k). With N = Σ nₖ
//! photons in K batches, the estimate is x̄ = S₁/N and the standard error of x̄ is
//! √(σ̂²/N) with σ̂² = (Q − N x̄²)/(K − 1), an unbiased estimate of the per-photon variance
//! σ² for *any* batch sizes: Tₖ − nₖ x̄ has variance nₖ σ² (1 − nₖ/N), so
//! E[Σ (Tₖ − nₖx̄)²/nₖ] = σ² Σ (1 − nₖ/N) = (K − 1) σ², and Σ (Tₖ − nₖx̄)²/nₖ = Q − N x̄².
//! (Batches of one photon give back the per-photon formula √((S₂/N − x̄²)/(N − 1)); the
//! method of batch means, e.g. Kalos & Whitlock, *Monte Carlo Methods*, 2nd ed., §3.3.)
//! A bin touched for the first time in a batch is listed, so closing a batch costs the bins
//! it touched, not the whole grid. Without errors, deposits go straight into S₁.

/// A flat array of bins (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct Accum {
    s1: Vec<f64>,
    /// Σ Tₖ²/nₖ (empty without errors).
    q: Vec<f64>,
    /// Current batch totals (empty without errors).
    cur: Vec<f64>,
    /// Bins deposited into in the current batch (may repeat; closing a batch zeroes `cur`).
    touched: Vec<u32>,
}

impl Accum {
    /// `n` empty bins, with batch-means errors if `errors` (`n = 0` gives a disabled
    /// accumulator that must not be deposited into).
    pub fn new(n: usize, errors: bool) -> Self {
        let e = if errors { n } else { 0 };
        Accum { s1: vec![0.0; n], q: vec![0.0; e], cur: vec![0.0; e], touched: Vec::new() }
    }

    /// Number of bins.
    #[inline]
    pub fn len(&self) -> usize {
        self.s1.len()
    }

    /// Whether there are no bins (a disabled tally).
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.s1.is_empty()
    }

    /// Whether standard errors are kept.
    #[inline]
    pub fn has_errors(&self) -> bool {
        !self.cur.is_empty()
    }

    /// Add `x` to bin `bin` (the caller guarantees `bin < len()`).
    #[inline]
    pub fn add(&mut self, bin: usize, x: f64) {
        if self.cur.is_empty() {
            self.s1[bin] += x;
        } else {
            let c = &mut self.cur[bin];
            if *c == 0.0 {
                self.touched.push(bin as u32);
            }
            *c += x;
        }
    }

    /// Close the current batch of `photons` photons (see the module docs).
    pub fn end_batch(&mut self, photons: u64) {
        let inv_n = 1.0 / photons.max(1) as f64;
        for &b in &self.touched {
            let b = b as usize;
            let t = self.cur[b];
            self.s1[b] += t;
            self.q[b] += t * t * inv_n;
            self.cur[b] = 0.0;
        }
        self.touched.clear();
    }

    /// Add another accumulator of the same size with no open batch (whole batches, as chunks
    /// of a run are). Deterministic: the result depends only on the operands and the order of
    /// merges.
    pub fn merge(&mut self, other: &Accum) {
        debug_assert_eq!(self.len(), other.len());
        debug_assert!(other.touched.is_empty(), "merge of an accumulator with an open batch");
        for (a, b) in self.s1.iter_mut().zip(&other.s1) {
            *a += *b;
        }
        for (a, b) in self.q.iter_mut().zip(&other.q) {
            *a += *b;
        }
    }

    /// Σ of all deposits in bin `i` (closed batches).
    #[inline]
    pub fn sum(&self, i: usize) -> f64 {
        self.s1[i]
    }

    /// Mean per photon of bin `i` over `n` photons in `batches` batches, and its standard
    /// error (NaN without errors or with fewer than 2 batches; 0 if rounding makes the
    /// variance negative).
    pub fn mean_stderr(&self, i: usize, n: u64, batches: u64) -> (f64, f64) {
        let m = self.s1[i] / n as f64;
        if !self.has_errors() {
            return (m, f64::NAN);
        }
        batch_mean_stderr(self.s1[i], self.q[i], n, batches)
    }
}

/// Mean and standard error from batch sums: S₁ = Σ Tₖ (`s1`), Q = Σ Tₖ²/nₖ (`q`), N photons
/// (`n`) in K batches (`batches`): x̄ = S₁/N, se = √((Q − N x̄²)/((K − 1) N)) (see the
/// module docs; with one-photon batches, Q = Σ x² and K = N, this is [`mean_stderr`]).
pub fn batch_mean_stderr(s1: f64, q: f64, n: u64, batches: u64) -> (f64, f64) {
    if n == 0 {
        return (f64::NAN, f64::NAN);
    }
    let nf = n as f64;
    let m = s1 / nf;
    if batches < 2 {
        return (m, f64::NAN);
    }
    let var = ((q - nf * m * m) / (batches - 1) as f64).max(0.0);
    (m, (var / nf).sqrt())
}

pub use super::totals::mean_stderr;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stats::SplitMix64;

    /// Random deposits: (photon, bin, x) with several deposits per photon, some repeated bins,
    /// negative values included.
    fn events(n_photons: u64, bins: usize, seed: u64) -> Vec<(u64, usize, f64)> {
        let mut s = SplitMix64::new(seed);
        let mut ev = Vec::new();
        for p in 0..n_photons {
            let k = s.next_u64() % 7;
            for _ in 0..k {
                let b = (s.next_u64() % bins as u64) as usize;
                ev.push((p, b, s.next_f64() - 0.2));
            }
        }
        ev
    }

    /// Brute force: per-batch per-bin totals, then S₁ and Σ T²/n.
    fn brute(ev: &[(u64, usize, f64)], n_photons: u64, batch: u64, bins: usize) -> Vec<(f64, f64)> {
        let nb = n_photons.div_ceil(batch) as usize;
        let mut t = vec![vec![0.0; bins]; nb];
        for &(p, b, x) in ev {
            t[(p / batch) as usize][b] += x;
        }
        (0..bins)
            .map(|b| {
                let s1: f64 = t.iter().map(|r| r[b]).sum();
                let q: f64 = (0..nb)
                    .map(|k| {
                        let nk = (n_photons - k as u64 * batch).min(batch) as f64;
                        t[k][b] * t[k][b] / nk
                    })
                    .sum();
                (s1, q)
            })
            .collect()
    }

    fn fill(ev: &[(u64, usize, f64)], lo: u64, hi: u64, batch: u64, bins: usize, errors: bool) -> Accum {
        let mut a = Accum::new(bins, errors);
        let mut k = lo / batch;
        for &(p, b, x) in ev.iter().filter(|e| e.0 >= lo && e.0 < hi) {
            while p / batch > k {
                a.end_batch(batch);
                k += 1;
            }
            a.add(b, x);
        }
        while k * batch < hi {
            a.end_batch((hi - k * batch).min(batch));
            k += 1;
        }
        a
    }

    /// Batch sums (last batch short) against brute force, merge of chunk accumulators, and
    /// the error-free mode keeps the same sums.
    #[test]
    fn matches_brute_force_batch_moments_and_merges() {
        let (n, bins, batch) = (1000u64, 13, 64u64);
        let ev = events(n, bins, 7);
        let whole = fill(&ev, 0, n, batch, bins, true);
        let want = brute(&ev, n, batch, bins);
        for b in 0..bins {
            let (s1, q) = want[b];
            assert!((whole.sum(b) - s1).abs() < 1e-12 * (1.0 + s1.abs()), "bin {b}");
            assert!((whole.q[b] - q).abs() < 1e-12 * (1.0 + q), "bin {b}");
        }
        let mut merged = Accum::new(bins, true);
        for (lo, hi) in [(0, 320), (320, 640), (640, 1000)] {
            merged.merge(&fill(&ev, lo, hi, batch, bins, true));
        }
        let plain = fill(&ev, 0, n, batch, bins, false);
        assert!(!plain.has_errors() && plain.mean_stderr(0, n, 16).1.is_nan());
        for b in 0..bins {
            assert!((merged.sum(b) - whole.sum(b)).abs() < 1e-12 * (1.0 + whole.sum(b).abs()));
            assert!((merged.q[b] - whole.q[b]).abs() < 1e-12 * (1.0 + whole.q[b]));
            assert!((plain.sum(b) - whole.sum(b)).abs() < 1e-12 * (1.0 + whole.sum(b).abs()));
        }
    }

    /// Batches of one photon give the per-photon formula; a hand-made case.
    #[test]
    fn stderr_formula() {
        // samples 1, 2, 3, 0 (one photon scored nothing): mean 1.5, sample variance 5/3,
        // stderr √(5/3/4).
        let mut a = Accum::new(1, true);
        for x in [1.0, 2.0, 3.0, 0.0] {
            a.add(0, x);
            a.end_batch(1);
        }
        let (m, se) = a.mean_stderr(0, 4, 4);
        assert_eq!(m, 1.5);
        assert!((se - (5.0f64 / 3.0 / 4.0).sqrt()).abs() < 1e-15);
        assert_eq!(mean_stderr(14.0, 14.0, 4), batch_mean_stderr(14.0, 14.0, 4, 4));
        assert!(batch_mean_stderr(1.0, 1.0, 8, 1).1.is_nan());
        // A deposit that cancels to exactly 0 and is touched again is listed twice: harmless.
        let mut a = Accum::new(2, true);
        for x in [1.0, -1.0, 2.0] {
            a.add(1, x);
        }
        a.end_batch(2);
        assert_eq!((a.sum(1), a.q[1]), (2.0, 2.0));
    }
}
