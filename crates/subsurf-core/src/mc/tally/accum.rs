//! [`Accum`]: an array of bins with batch-means standard errors (or none at all).
//!
//! Photons are grouped in fixed batches of [`BATCH_PHOTONS`] consecutive indices (batch k =
//! photons [k·B, (k+1)·B), cut at the run's last photon; B divides the chunk size, so a chunk
//! holds whole batches). The run closes a batch with [`Accum::end_batch`] once all its photons
//! have ended. Each bin keeps the running batch total Tₖ in `cur` (one add per deposit, no
//! per-photon bookkeeping, so interleaved lanes need nothing special), and at the end of batch
//! k folds it into S₁ = Σ Tₖ and Q = Σ Tₖ²/nₖ (nₖ photons in batch k). With N photons in
//! K = ⌈N/B⌉ batches, the estimate is x̄ = S₁/N and the standard error of x̄ is √(σ̂²/N) with
//! σ̂² = (Q − N x̄²)/(K − 1), an unbiased estimate of the per-photon variance σ² for *any* batch
//! sizes: Tₖ − nₖ x̄ has variance nₖ σ² (1 − nₖ/N), so E[Σ (Tₖ − nₖx̄)²/nₖ] = σ² Σ (1 − nₖ/N)
//! = (K − 1) σ², and Σ (Tₖ − nₖx̄)²/nₖ = Q − N x̄². (Batches of one photon give back the
//! per-photon formula √((S₂/N − x̄²)/(N − 1)); the method of batch means, e.g. Kalos &
//! Whitlock, *Monte Carlo Methods*, 2nd ed., §3.3.) A bin touched for the first time in a
//! batch is listed, so closing a batch costs the bins it touched, not the whole grid. Without
//! errors, deposits go straight into S₁.
//!
//! The exact state of a run ([`super::ChannelState`]) holds S₁ and Q of every bin (in its
//! `s1` and `s2`): chunk sums are drained into it exactly, so batch means are as
//! partition-independent as the sums themselves.
//!
//! Escape tallies need no batches ([`Accum::per_photon`]): a photon escapes once, so its score
//! in a bin is the weight of that one escape and Q = Σ w² is the exact per-photon second
//! moment (batches of one photon, K = N), at the cost of one multiply per escape.

pub use crate::mc::config::BATCH_PHOTONS;

/// A flat array of bins (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct Accum {
    s1: Vec<f64>,
    /// Σ Tₖ²/nₖ (empty without errors).
    q: Vec<f64>,
    /// Current batch totals (empty without errors).
    cur: Vec<f64>,
    /// Bins deposited into in the current batch (may repeat; closing a batch zeroes `cur`).
    touched: List,
    /// Bins whose sums may be non-zero since the last drain (may repeat): every bin not listed
    /// has S₁ = Q = 0, so a drain walks the bins a chunk touched, not the whole grid.
    dirty: List,
    /// At most one deposit per photon (escapes): Q = Σ x², no batches.
    single: bool,
}

impl Accum {
    /// `n` empty bins, with batch-means errors if `errors` (`n = 0` gives a disabled
    /// accumulator that must not be deposited into).
    pub fn new(n: usize, errors: bool) -> Self {
        let e = if errors { n } else { 0 };
        Accum {
            s1: vec![0.0; n],
            q: vec![0.0; e],
            cur: vec![0.0; e],
            touched: List::default(),
            dirty: List::default(),
            single: false,
        }
    }

    /// `n` empty bins that each photon deposits into at most once (escapes), with exact
    /// per-photon errors if `errors` (see the module docs).
    pub fn per_photon(n: usize, errors: bool) -> Self {
        let e = if errors { n } else { 0 };
        Accum {
            s1: vec![0.0; n],
            q: vec![0.0; e],
            cur: Vec::new(),
            touched: List::default(),
            dirty: List::default(),
            single: errors,
        }
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
        !self.q.is_empty()
    }

    /// Add `x` to bin `bin` (the caller guarantees `bin < len()`).
    #[inline(always)]
    pub fn add(&mut self, bin: usize, x: f64) {
        if self.cur.is_empty() {
            self.add_once(bin, x);
        } else {
            let c = &mut self.cur[bin];
            let first = *c == 0.0;
            *c += x;
            self.touched.push_if(bin as u32, first);
        }
    }

    /// [`Accum::add`] for an accumulator without batches (made by [`Accum::per_photon`], or
    /// without errors): S₁ += x and, with per-photon errors, Q += x²; a bin whose S₁ was 0 is
    /// listed as dirty (only listed bins are non-zero; Q changes only with S₁). The escape
    /// tallies call it directly (one bounds check, no mode tests).
    #[inline(always)]
    pub fn add_once(&mut self, bin: usize, x: f64) {
        debug_assert!(self.cur.is_empty(), "add_once on a batched accumulator");
        let s1 = &mut self.s1[bin];
        let was = *s1;
        *s1 = was + x;
        if let Some(q) = self.q.get_mut(bin) {
            *q += x * x;
        }
        self.dirty.push_if(bin as u32, was == 0.0);
    }

    /// Close the current batch of `photons` photons (see the module docs).
    pub fn end_batch(&mut self, photons: u64) {
        let inv_n = 1.0 / photons.max(1) as f64;
        for &b in self.touched.as_slice() {
            let b = b as usize;
            self.dirty.push_if(b as u32, self.s1[b] == 0.0);
            let t = std::mem::take(&mut self.cur[b]);
            self.s1[b] += t;
            self.q[b] += t * t * inv_n;
        }
        self.touched.clear();
    }

    /// Add every bin's (S₁, Q) exactly into `state` (same length) and clear the bins for the
    /// next chunk (whose batches are all closed). `false` if a sum is outside the exact range.
    /// Costs the bins deposited into since the last drain, not the whole grid.
    pub fn drain_into(&mut self, state: &mut super::ChannelState) -> bool {
        debug_assert_eq!(self.len(), state.s1.len());
        debug_assert!(self.touched.as_slice().is_empty(), "drain with an open batch");
        let mut ok = true;
        for &i in self.dirty.as_slice() {
            let i = i as usize;
            let (s1, q) = (std::mem::take(&mut self.s1[i]), self.q.get_mut(i).map_or(0.0, std::mem::take));
            if s1 != 0.0 || q != 0.0 {
                ok &= state.add(i, s1, q);
            }
        }
        self.dirty.clear();
        debug_assert!(self.s1.iter().chain(&self.q).all(|&x| x == 0.0), "a bin was not listed");
        ok
    }

    /// Set every bin to the exact sums of `state`, rounded to f64 (for normalisation).
    pub fn load_from(&mut self, state: &super::ChannelState) {
        debug_assert_eq!(self.len(), state.s1.len());
        self.dirty.clear();
        for i in 0..self.s1.len() {
            let (s1, q) = state.get(i);
            self.s1[i] = s1;
            if let Some(x) = self.q.get_mut(i) {
                *x = q;
            }
            self.dirty.push_if(i as u32, s1 != 0.0 || q != 0.0);
        }
    }

    /// Σ of all deposits in bin `i` (closed batches).
    #[inline]
    pub fn sum(&self, i: usize) -> f64 {
        self.s1[i]
    }

    /// Mean per photon of bin `i` over `n` photons (in ⌈n / [`BATCH_PHOTONS`]⌉ batches) and its
    /// standard error (NaN without errors or with fewer than 2 batches; 0 if rounding makes the
    /// variance negative).
    pub fn mean_stderr(&self, i: usize, n: u64) -> (f64, f64) {
        if !self.has_errors() {
            return (self.s1[i] / n as f64, f64::NAN);
        }
        let batches = if self.single { n } else { n.div_ceil(BATCH_PHOTONS) };
        batch_mean_stderr(self.s1[i], self.q[i], n, batches)
    }
}

/// Mean and standard error from batch sums: S₁ = Σ Tₖ (`s1`), Q = Σ Tₖ²/nₖ (`q`), N photons
/// (`n`) in K batches (`batches`): x̄ = S₁/N, se = √((Q − N x̄²)/((K − 1) N)) (see the module
/// docs; with one-photon batches, Q = Σ x² and K = N, this is [`mean_stderr`]).
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

/// A list of bins whose appends are conditional without a branch: [`List::push_if`] always
/// writes the bin into the slot past the end and advances the length by the condition. Whether
/// a deposit is the first into its bin (the lists above) is a coin flip in a sparse grid: as a
/// branch it mispredicted 2.0 times per photon in case a with MCML's tally set (60 % of the
/// run's mispredictions, callgrind's branch simulation).
#[derive(Clone, Debug, Default)]
struct List {
    /// Slots; those at `len` and beyond are scratch.
    buf: Vec<u32>,
    len: usize,
}

impl List {
    /// Append `bin` if `cond`.
    #[inline(always)]
    fn push_if(&mut self, bin: u32, cond: bool) {
        match self.buf.get_mut(self.len) {
            Some(slot) => *slot = bin,
            None => self.grow(bin),
        }
        self.len += cond as usize;
    }

    /// Make room for more slots (doubling; out of line: a list grows to its largest length
    /// once and keeps its slots) and write `bin` into the slot at `len`.
    #[cold]
    #[inline(never)]
    fn grow(&mut self, bin: u32) {
        self.buf.resize((2 * self.buf.len()).max(64), 0);
        self.buf[self.len] = bin;
    }

    #[inline]
    fn as_slice(&self) -> &[u32] {
        &self.buf[..self.len]
    }

    #[inline]
    fn clear(&mut self) {
        self.len = 0;
    }
}

/// Equal when the listed bins are (the scratch slots do not count).
impl PartialEq for List {
    fn eq(&self, o: &Self) -> bool {
        self.as_slice() == o.as_slice()
    }
}

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

    /// Brute force: per-batch per-bin totals, then S₁ and Σ T²/n.
    fn brute(ev: &[(u64, usize, f64)], n_photons: u64, bins: usize) -> Vec<(f64, f64)> {
        let b = BATCH_PHOTONS;
        let nb = n_photons.div_ceil(b) as usize;
        let mut t = vec![vec![0.0; bins]; nb];
        for &(p, bin, x) in ev {
            t[(p / b) as usize][bin] += x;
        }
        (0..bins)
            .map(|bin| {
                let s1: f64 = t.iter().map(|r| r[bin]).sum();
                let q: f64 = (0..nb)
                    .map(|k| {
                        let nk = (n_photons - k as u64 * b).min(b) as f64;
                        t[k][bin] * t[k][bin] / nk
                    })
                    .sum();
                (s1, q)
            })
            .collect()
    }

    /// An accumulator fed photons [lo, hi) batch by batch (as the run does).
    fn fill(ev: &[(u64, usize, f64)], lo: u64, hi: u64, bins: usize, errors: bool) -> Accum {
        let b = BATCH_PHOTONS;
        let mut a = Accum::new(bins, errors);
        let mut k = lo / b;
        for &(p, bin, x) in ev.iter().filter(|e| e.0 >= lo && e.0 < hi) {
            while p / b > k {
                a.end_batch(b);
                k += 1;
            }
            a.add(bin, x);
        }
        while k * b < hi {
            a.end_batch((hi - k * b).min(b));
            k += 1;
        }
        a
    }

    fn channel(bins: usize) -> ChannelState {
        ChannelState::new(&Channel { name: "x".into(), len: bins, extremes: false })
    }

    /// Batch sums (the last batch short) against brute force, through the exact state; the
    /// error-free mode keeps the same sums.
    #[test]
    fn matches_brute_force_batch_moments() {
        let (n, bins) = (5 * BATCH_PHOTONS + 37, 13);
        let ev = events(n, bins, 7);
        let mut a = fill(&ev, 0, n, bins, true);
        let want = brute(&ev, n, bins);
        let mut st = channel(bins);
        assert!(a.drain_into(&mut st));
        assert!((0..bins).all(|b| a.sum(b) == 0.0));
        a.load_from(&st);
        let mut plain = fill(&ev, 0, n, bins, false);
        for b in 0..bins {
            let (s1, q) = want[b];
            assert!((a.sum(b) - s1).abs() < 1e-12 * (1.0 + s1.abs()), "bin {b}");
            assert!((a.q[b] - q).abs() < 1e-12 * (1.0 + q), "bin {b}");
            assert!((plain.sum(b) - s1).abs() < 1e-12 * (1.0 + s1.abs()), "bin {b}");
        }
        let mut st = channel(bins);
        assert!(plain.drain_into(&mut st));
        plain.load_from(&st);
        assert!(plain.mean_stderr(0, n).1.is_nan());
    }

    /// Batches of one photon give the per-photon formula; a hand-made case.
    #[test]
    fn stderr_formula() {
        // samples 1, 2, 3, 0 (one photon scored nothing): mean 1.5, sample variance 5/3,
        // stderr √(5/3/4).
        let (s1, q) = (6.0, 1.0 + 4.0 + 9.0);
        let (m, se) = batch_mean_stderr(s1, q, 4, 4);
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

    /// One deposit per photon: the per-photon formula, whatever the batches.
    #[test]
    fn per_photon_accumulator() {
        let mut a = Accum::per_photon(2, true);
        for x in [1.0, 2.0, 3.0] {
            a.add(1, x);
        }
        a.end_batch(4); // nothing to close
        let (m, se) = a.mean_stderr(1, 4);
        assert_eq!((m, se), mean_stderr(6.0, 14.0, 4));
        assert!(Accum::per_photon(2, false).mean_stderr(0, 4).1.is_nan());
    }

    /// `add_once` keeps the same sums and dirty bins as `add` on per-photon accumulators.
    #[test]
    fn add_once_is_add_for_per_photon_accumulators() {
        let ev = events(300, 17, 13);
        for errors in [true, false] {
            let (mut a, mut b) = (Accum::per_photon(17, errors), Accum::per_photon(17, errors));
            for &(_, bin, x) in &ev {
                a.add(bin, x);
                b.add_once(bin, x);
            }
            assert_eq!(a, b, "errors {errors}");
            let (mut sa, mut sb) = (channel(17), channel(17));
            assert!(a.drain_into(&mut sa) && b.drain_into(&mut sb));
            assert_eq!(sa, sb);
        }
    }

    /// A drain costs only the bins deposited into, yet clears every bin: an accumulator reused
    /// for chunk after chunk (deposits that cancel to exactly 0 included, all three modes) drains
    /// the same sums as a fresh one per chunk.
    #[test]
    fn sparse_drain_of_reused_accumulators() {
        let b = BATCH_PHOTONS;
        let bins = 40;
        let mut ev = events(6 * b, bins, 5);
        ev.extend([(b, 3, 0.5), (b, 3, -0.5), (b + 1, 3, 0.25), (2 * b, 7, 1.0), (2 * b, 7, -1.0)]);
        ev.sort_by_key(|e| e.0);
        for (errors, single) in [(true, false), (false, false), (true, true)] {
            let make = || if single { Accum::per_photon(bins, errors) } else { Accum::new(bins, errors) };
            let mut reused = make();
            for c in 0..3 {
                let (lo, hi) = (2 * c * b, 2 * (c + 1) * b);
                let mut fresh = make();
                for a in [&mut reused, &mut fresh] {
                    for &(_, bin, x) in ev.iter().filter(|e| e.0 >= lo && e.0 < hi) {
                        a.add(bin, x);
                    }
                    a.end_batch(b);
                }
                let (mut s_reused, mut s_fresh) = (channel(bins), channel(bins));
                assert!(reused.drain_into(&mut s_reused) && fresh.drain_into(&mut s_fresh));
                assert_eq!(s_reused, s_fresh, "chunk {c}, errors {errors}, single {single}");
                assert!((0..bins).all(|i| reused.sum(i) == 0.0 && reused.q.get(i).is_none_or(|&q| q == 0.0)));
            }
        }
    }

    /// Chunks (whole batches) drained into exact sums in any grouping and order give the same
    /// bits.
    #[test]
    fn exact_merge_of_chunks_is_partition_independent() {
        let b = BATCH_PHOTONS;
        let (n, bins) = (9 * b, 5);
        let ev = events(n, bins, 11);
        let chunk = |lo: u64, hi: u64| {
            let mut a = fill(&ev, lo, hi, bins, true);
            let mut st = channel(bins);
            assert!(a.drain_into(&mut st));
            st
        };
        let (c0, c1, c2) = (chunk(0, 3 * b), chunk(3 * b, 6 * b), chunk(6 * b, 9 * b));
        let mut left = c0.clone();
        left.merge(&c1);
        left.merge(&c2);
        let mut right = c2.clone();
        right.merge(&c1);
        let mut other = c0.clone();
        other.merge(&right);
        assert_eq!(left, other, "exact sums must not depend on grouping or order");
        let want = brute(&ev, n, bins);
        for bin in 0..bins {
            let (s1, q) = left.get(bin);
            assert!((s1 - want[bin].0).abs() < 1e-12 * (1.0 + s1.abs()));
            assert!((q - want[bin].1).abs() < 1e-12 * (1.0 + q));
        }
    }
}
