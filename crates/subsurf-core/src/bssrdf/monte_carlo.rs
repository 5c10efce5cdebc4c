//! The Monte Carlo profile: R_d(r) of any [`Stack`] (layered, finite, mismatched indices) from
//! the engine ([`crate::mc::run()`]) under a normally incident pencil beam.
//!
//! - [`RadialTally`] scores the weight escaping through the top on a log-spaced radial grid
//!   (bin 0 = [0, r_min), then `per_decade` bins per decade to r_max, then one overflow bin),
//!   with per-photon second moments ([`Accum`]), and the same for order-1 (single-scattering)
//!   escapes and for the total.
//! - [`MonteCarloProfile::from_data`] turns the bins into a profile that is
//!   1. **energy-exact**: every bin keeps its Monte Carlo weight, so the total is the Monte Carlo
//!      total diffuse reflectance (the sum of all bins, overflow included) to rounding;
//!   2. **monotone where the data allow**: the ring averages are made non-increasing by the
//!      pool-adjacent-violators algorithm weighted by ring area (which keeps each pooled
//!      block's energy, Ayer et al. 1955), except for blocks whose bins are inconsistent with a
//!      constant at p < 1e-3 (χ² with their standard errors) — there the data show structure;
//!   3. **smooth and positive**: the cumulative weight at the bin edges is interpolated by a
//!      monotone C¹ cubic ([`RadialCdf::from_cumulative`]), R_d = (dC/dr)/(2πr);
//!   4. **without a hard cut-off**: beyond the first bin past the median radius whose relative
//!      standard error exceeds `max_rel_err`, the profile is the diffusion asymptote
//!      R ∝ (1 + σr) e^{−σr}/r³ (the far field of a dipole, Farrell et al. 1992), whose energy
//!      beyond r_t is set to the Monte Carlo weight there (exact) and whose decay σ is fitted
//!      in closed form to the weight of the half decade before r_t:
//!      ∫_a^∞ 2πr (1 + σr) e^{−σr}/r³ dr = 2π e^{−σa}/a.
//!
//! Its CDF is exact at the bin edges and sampled by exact inversion.

use super::cdf::RadialCdf;
use super::RadialProfile;
use crate::error::{Error, Result};
use crate::mc::lanes::LANES;
use crate::mc::tally::accum::mean_stderr;
use crate::mc::tally::{Accum, Channel, ChannelState};
use crate::mc::{run, Packet, RunConfig, Side, Source, Tally};
use crate::medium::Stack;
use crate::stats::chi2_sf;
use std::f64::consts::PI;
use std::sync::atomic::{AtomicBool, AtomicU64};

/// Settings of a Monte Carlo profile run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct McSettings {
    /// Photon packets (≥ 1).
    pub photons: u64,
    /// Seed of the run.
    pub seed: u64,
    /// Worker threads (`None`: all cores).
    pub threads: Option<usize>,
    /// Inner edge of the log grid, mm (`None`: 10⁻³ of the smallest 1/σt of the stack).
    pub r_min: Option<f64>,
    /// Outer edge of the log grid, mm (`None`: 10³ of the largest 1/σt' of the stack).
    pub r_max: Option<f64>,
    /// Bins per decade of r (≥ 2).
    pub per_decade: usize,
    /// Relative standard error beyond which bins are replaced by the fitted asymptote.
    pub max_rel_err: f64,
}

impl Default for McSettings {
    fn default() -> Self {
        McSettings {
            photons: 100_000,
            seed: 0,
            threads: None,
            r_min: None,
            r_max: None,
            per_decade: 10,
            max_rel_err: 0.2,
        }
    }
}

/// The log grid's edges [0, r_min, …, r_max] (the overflow bin [r_max, ∞) is extra).
pub fn log_edges(r_min: f64, r_max: f64, per_decade: usize) -> Result<Vec<f64>> {
    if !(r_min > 0.0 && r_min.is_finite()) {
        return Err(Error::param("r_min", r_min, "a finite number > 0 (mm)"));
    }
    if !(r_max > r_min && r_max.is_finite()) {
        return Err(Error::param("r_max", r_max, "a finite number > r_min (mm)"));
    }
    if !(2..=1000).contains(&per_decade) {
        return Err(Error::param("per_decade", per_decade as f64, "an integer in [2, 1000]"));
    }
    let n = ((r_max / r_min).log10() * per_decade as f64).ceil() as usize;
    let mut e = vec![0.0];
    e.extend((0..=n).map(|k| r_min * 10f64.powf(k as f64 / per_decade as f64)));
    Ok(e)
}

/// Escaping weight on a log radial grid, all orders and order 1, and its total, with per-photon
/// moments (a photon escapes once: Σw² per bin; the total per lane, as `mc::tally::totals`).
#[derive(Clone, Debug, PartialEq)]
pub struct RadialTally {
    edges: Vec<f64>,
    ln_rmin: f64,
    per_ln: f64,
    all: Accum,
    single: Accum,
    /// The total: a partial score per lane, then Σx and Σx² over photons.
    total_cur: [f64; LANES],
    total_s1: f64,
    total_s2: f64,
    photons: u64,
}

impl RadialTally {
    /// Empty tally on `edges` (from [`log_edges`]).
    pub fn new(edges: Vec<f64>) -> Self {
        let n = edges.len(); // bins: edges.len() − 1 finite + 1 overflow
        let per_ln = (n as f64 - 2.0) / (edges[n - 1] / edges[1]).ln();
        RadialTally {
            ln_rmin: edges[1].ln(),
            per_ln,
            edges,
            all: Accum::per_photon(n, true),
            single: Accum::per_photon(n, true),
            total_cur: [0.0; LANES],
            total_s1: 0.0,
            total_s2: 0.0,
            photons: 0,
        }
    }

    #[inline]
    fn bin(&self, r: f64) -> usize {
        if r < self.edges[1] {
            return 0;
        }
        let n = self.edges.len();
        let k = 1 + ((r.ln() - self.ln_rmin) * self.per_ln) as usize;
        // Rounding of ln may put r one bin off at an edge; fix against the edges.
        let k = k.min(n - 1);
        if k < n - 1 && r >= self.edges[k + 1] {
            k + 1
        } else if r < self.edges[k] {
            k - 1
        } else {
            k
        }
    }

    /// Mean weights per photon (and standard errors) of every bin, the single-scattering bins,
    /// and the total.
    pub fn data(&self) -> RadialData {
        let n = self.edges.len();
        let col = |a: &Accum| -> (Vec<f64>, Vec<f64>) { (0..n).map(|i| a.mean_stderr(i, self.photons)).unzip() };
        let (w, s) = col(&self.all);
        let (w1, s1) = col(&self.single);
        let (t, ts) = mean_stderr(self.total_s1, self.total_s2, self.photons);
        RadialData {
            edges: self.edges.clone(),
            weight: w,
            stderr: s,
            single: w1,
            single_stderr: s1,
            total: t,
            total_stderr: ts,
            photons: self.photons,
        }
    }
}

impl Tally for RadialTally {
    const POSITIONS: bool = false;
    #[inline]
    fn begin_photon(&mut self, _lane: usize, _photon: u64) {}
    #[inline]
    fn specular(&mut self, _lane: usize, _w: f64) {}
    #[inline]
    fn absorb(&mut self, _lane: usize, _p: &Packet, _dw: f64) {}
    #[inline]
    fn escape(&mut self, lane: usize, p: &Packet, side: Side, _dir_out: [f64; 3], w: f64) {
        if side == Side::Top {
            let b = self.bin((p.pos[0] * p.pos[0] + p.pos[1] * p.pos[1]).sqrt());
            self.all.add(b, w);
            if p.order == 1 {
                self.single.add(b, w);
            }
            self.total_cur[lane] += w;
        }
    }
    #[inline]
    fn end_photon(&mut self, lane: usize) {
        self.photons += 1;
        let x = std::mem::take(&mut self.total_cur[lane]);
        self.total_s1 += x;
        self.total_s2 += x * x;
    }
    #[inline]
    fn roulette(&mut self, _lane: usize, _p: &Packet, _dw: f64) {}
    fn channels(&self, out: &mut Vec<Channel>) {
        for (name, len) in [("profile", self.all.len()), ("profile_single", self.single.len()), ("profile_total", 1)] {
            out.push(Channel { name: name.into(), len, extremes: false });
        }
    }
    fn drain_into(&mut self, state: &mut [ChannelState]) -> Option<usize> {
        let ok = self.all.drain_into(&mut state[0])
            & self.single.drain_into(&mut state[1])
            & state[2].add(0, self.total_s1, self.total_s2);
        (self.total_s1, self.total_s2) = (0.0, 0.0);
        self.photons = 0;
        ok.then_some(3)
    }
    fn load_from(&mut self, state: &[ChannelState], photons: u64) -> usize {
        self.all.load_from(&state[0]);
        self.single.load_from(&state[1]);
        (self.total_s1, self.total_s2) = state[2].get(0);
        self.photons = photons;
        3
    }
}

/// What a Monte Carlo profile is built from (and what a profile table stores per albedo).
#[derive(Clone, Debug, PartialEq)]
pub struct RadialData {
    /// Edges [0, r_min, …, r_max], mm; bin i = \[edges\[i\], edges\[i+1\]), the last bin \[r_max, ∞).
    pub edges: Vec<f64>,
    /// Mean escaping weight per photon in each bin (edges.len() bins).
    pub weight: Vec<f64>,
    /// Its standard error.
    pub stderr: Vec<f64>,
    /// Order-1 (single-scattering) weight per bin.
    pub single: Vec<f64>,
    /// Its standard error.
    pub single_stderr: Vec<f64>,
    /// Total diffuse reflectance (Σ weight) and its standard error.
    pub total: f64,
    /// Standard error of `total`.
    pub total_stderr: f64,
    /// Photons traced.
    pub photons: u64,
}

impl RadialData {
    /// Check shapes and values (for data read back from files).
    pub fn validate(&self) -> Result<()> {
        let n = self.edges.len();
        if n < 3 || self.edges[0] != 0.0 || self.edges.windows(2).any(|w| !(w[1] > w[0]) || !w[1].is_finite()) {
            return Err(Error::Invalid("radial data: edges must be 0 followed by increasing finite radii".into()));
        }
        for (name, v) in [
            ("weight", &self.weight),
            ("stderr", &self.stderr),
            ("single", &self.single),
            ("single_stderr", &self.single_stderr),
        ] {
            if v.len() != n || v.iter().any(|x| !(x.is_finite() && *x >= 0.0)) {
                return Err(Error::Invalid(format!("radial data: {name} must hold {n} finite values >= 0")));
            }
        }
        if !(self.total.is_finite() && (0.0..=1.0 + 1e-12).contains(&self.total)) {
            return Err(Error::param("total", self.total, "a reflectance in [0, 1]"));
        }
        Ok(())
    }
}

/// Monte Carlo profile (see the module docs).
#[derive(Clone, Debug)]
pub struct MonteCarloProfile {
    inner: RadialCdf,
    w_in: f64,
    w_tail: f64,
    r_t: f64,
    sigma: f64,
    total: f64,
    total_stderr: f64,
    single: Option<Box<MonteCarloProfile>>,
    data: RadialData,
}

/// Non-increasing weighted least squares fit (pool adjacent violators) with blocks that the
/// data contradict (χ² p < 1e-3) left unpooled. Returns the fitted values.
fn monotone(y: &[f64], w: &[f64], sigma: &[f64]) -> Vec<f64> {
    // blocks: (start, len, weighted mean, weight)
    let mut blocks: Vec<(usize, usize, f64, f64)> = Vec::new();
    for i in 0..y.len() {
        blocks.push((i, 1, y[i], w[i]));
        while blocks.len() > 1 {
            let (b, a) = (blocks[blocks.len() - 1], blocks[blocks.len() - 2]);
            if a.2 >= b.2 {
                break;
            }
            blocks.pop();
            let wt = a.3 + b.3;
            let m = if wt > 0.0 { (a.2 * a.3 + b.2 * b.3) / wt } else { 0.5 * (a.2 + b.2) };
            *blocks.last_mut().unwrap() = (a.0, a.1 + b.1, m, wt);
        }
    }
    let mut out = y.to_vec();
    for (s, len, m, _) in blocks {
        if len < 2 {
            continue;
        }
        let chi2: f64 = (s..s + len)
            .map(|i| {
                if sigma[i] > 0.0 {
                    ((y[i] - m) / sigma[i]).powi(2)
                } else if y[i] == m {
                    0.0
                } else {
                    f64::INFINITY
                }
            })
            .sum();
        let p = if chi2.is_finite() { chi2_sf(chi2, (len - 1) as f64).unwrap_or(0.0) } else { 0.0 };
        if p >= 1e-3 {
            out[s..s + len].iter_mut().for_each(|v| *v = m);
        }
    }
    out
}

impl MonteCarloProfile {
    /// Trace `s.photons` photons through `stack` and build the profile.
    pub fn simulate(stack: &Stack, s: &McSettings) -> Result<MonteCarloProfile> {
        Self::simulate_with(stack, s, &AtomicBool::new(false), &AtomicU64::new(0)).map(|x| x.0)
    }

    /// As [`simulate`](Self::simulate) with a cancel flag and a progress counter; also returns
    /// whether the run was cancelled (the profile then holds the completed photons).
    pub fn simulate_with(
        stack: &Stack,
        s: &McSettings,
        cancel: &AtomicBool,
        progress: &AtomicU64,
    ) -> Result<(MonteCarloProfile, bool)> {
        let edges = default_edges(stack, s)?;
        let cfg =
            RunConfig { photons: s.photons, seed: s.seed, threads: s.threads, source: Source::default(), isa: None };
        let out = run(stack, &cfg, || RadialTally::new(edges.clone()), cancel, progress)?;
        if out.photons < 2 {
            return Err(Error::Invalid("monte_carlo: the run was interrupted before two photons were traced".into()));
        }
        Ok((Self::from_data(out.tally.data(), s.max_rel_err)?, out.cancelled))
    }

    /// Build from tallied data (see the module docs); `max_rel_err` in (0, 1].
    pub fn from_data(data: RadialData, max_rel_err: f64) -> Result<MonteCarloProfile> {
        data.validate()?;
        if !(max_rel_err > 0.0 && max_rel_err <= 1.0) {
            return Err(Error::param("max_rel_err", max_rel_err, "a number in (0, 1]"));
        }
        let single = if data.single.iter().any(|&x| x > 0.0) {
            let mut d = data.clone();
            d.weight = data.single.clone();
            d.stderr = data.single_stderr.clone();
            d.total = data.single.iter().sum();
            d.single = vec![0.0; data.edges.len()];
            d.single_stderr = d.single.clone();
            Some(Box::new(Self::build(d, max_rel_err)))
        } else {
            None
        };
        let mut p = Self::build(data, max_rel_err);
        p.single = single;
        Ok(p)
    }

    fn build(data: RadialData, max_rel_err: f64) -> MonteCarloProfile {
        let e = &data.edges;
        let nb = e.len(); // bins, the last is overflow
        let w = &data.weight;
        let sum: f64 = w.iter().sum();
        // Truncation: first bin past the median whose relative error is too large.
        let mut acc = 0.0;
        let mut t = nb - 1;
        let mut past_median = false;
        for i in 0..nb - 1 {
            acc += w[i];
            if past_median && (w[i] <= 0.0 || data.stderr[i] > max_rel_err * w[i]) {
                t = i;
                break;
            }
            past_median |= acc >= 0.5 * sum;
        }
        let t = t.max(1);
        let area: Vec<f64> = (0..t).map(|i| PI * (e[i + 1] * e[i + 1] - e[i] * e[i])).collect();
        let y: Vec<f64> = (0..t).map(|i| w[i] / area[i]).collect();
        let sig: Vec<f64> = (0..t).map(|i| data.stderr[i] / area[i]).collect();
        let ym = monotone(&y, &area, &sig);
        let mut c = vec![0.0];
        for i in 0..t {
            c.push(c[i] + ym[i] * area[i]);
        }
        let w_in = c[t];
        let w_tail: f64 = w[t..].iter().sum();
        let r_t = e[t];
        // σ from the weight of the half decade [r_m, r_t) against the tail's.
        let m = t.saturating_sub(5).max(1);
        let r_m = e[m];
        let w_m: f64 = w[m..t].iter().sum();
        let sigma = if w_tail > 0.0 && t > m && r_t > r_m {
            (((w_m + w_tail) / w_tail).ln() - (r_t / r_m).ln()).max(0.0) / (r_t - r_m)
        } else {
            0.0
        };
        let end_slope = w_tail * (1.0 / r_t + sigma);
        let inner = RadialCdf::from_cumulative(e[..=t].to_vec(), c, end_slope);
        MonteCarloProfile {
            inner,
            w_in,
            w_tail,
            r_t,
            sigma,
            total: w_in + w_tail,
            total_stderr: data.total_stderr,
            single: None,
            data: RadialData { total: sum, ..data },
        }
    }

    /// The tallied data the profile was built from.
    pub fn data(&self) -> &RadialData {
        &self.data
    }
    /// Standard error of [`total`](RadialProfile::total).
    pub fn total_stderr(&self) -> f64 {
        self.total_stderr
    }
    /// Start of the fitted tail (mm) and its decay constant σ (mm⁻¹).
    pub fn tail(&self) -> (f64, f64) {
        (self.r_t, self.sigma)
    }

    fn tail_cdf(&self, r: f64) -> f64 {
        if r <= self.r_t {
            0.0
        } else if r == f64::INFINITY {
            1.0
        } else {
            1.0 - (self.r_t / r) * (-self.sigma * (r - self.r_t)).exp()
        }
    }
}

/// The grid of [`McSettings`] for `stack`: r_min = 10⁻³ min 1/σt, r_max = 10³ max 1/σt'
/// (over layers that interact), unless given.
pub fn default_edges(stack: &Stack, s: &McSettings) -> Result<Vec<f64>> {
    let live: Vec<_> = stack.layers.iter().filter(|l| l.sigma_t() > 0.0).collect();
    if live.is_empty() {
        return Err(Error::Invalid("monte_carlo: the stack has no scattering or absorbing layer".into()));
    }
    let lo = s.r_min.unwrap_or_else(|| 1e-3 * live.iter().map(|l| 1.0 / l.sigma_t()).fold(f64::INFINITY, f64::min));
    let hi = s.r_max.unwrap_or_else(|| 1e3 * live.iter().map(|l| 1.0 / l.sigma_t_prime()).fold(0.0, f64::max));
    log_edges(lo, hi, s.per_decade)
}

impl MonteCarloProfile {
    /// The radial density 2πr R_d(r) (mm⁻¹, integrating to the total): finite at r = 0, 0 at ∞.
    fn density(&self, r: f64) -> f64 {
        if !(r >= 0.0) || r == f64::INFINITY {
            return 0.0;
        }
        if r < self.r_t {
            self.w_in * self.inner.density(r)
        } else {
            self.w_tail * (self.r_t / r) * (-self.sigma * (r - self.r_t)).exp() * (1.0 / r + self.sigma)
        }
    }
}

impl RadialProfile for MonteCarloProfile {
    fn rd(&self, r: f64) -> f64 {
        if !(r > 0.0) || self.total == 0.0 {
            return if r == 0.0 && self.total > 0.0 { f64::INFINITY } else { 0.0 };
        }
        self.density(r) / (2.0 * PI * r)
    }
    fn total(&self) -> f64 {
        self.total
    }
    fn pdf(&self, r: f64) -> f64 {
        if self.total > 0.0 {
            self.density(r) / self.total
        } else {
            0.0
        }
    }
    fn cdf(&self, r: f64) -> f64 {
        if self.total == 0.0 {
            return 0.0;
        }
        (self.w_in * self.inner.cdf(r) + self.w_tail * self.tail_cdf(r)) / self.total
    }
    fn sample_r(&self, u: f64) -> f64 {
        let v = u.clamp(0.0, 1.0) * self.total;
        if v < self.w_in || self.w_tail == 0.0 {
            return self.inner.sample(if self.w_in > 0.0 { v / self.w_in } else { 0.0 });
        }
        let q = ((v - self.w_in) / self.w_tail).min(1.0);
        if q >= 1.0 {
            return f64::INFINITY;
        }
        // Solve ln(r/r_t) + σ(r − r_t) = −ln(1 − q) for x = ln r by Newton (convex, from above).
        let l = -(-q).ln_1p();
        let lt = self.r_t.ln();
        let mut x = lt + l;
        for _ in 0..100 {
            let ex = x.exp();
            let h = x - lt + self.sigma * (ex - self.r_t) - l;
            let step = h / (1.0 + self.sigma * ex);
            x -= step;
            if step.abs() < 1e-15 * x.abs().max(1.0) {
                break;
            }
        }
        x.exp()
    }
    fn single_scattering(&self) -> Option<&dyn RadialProfile> {
        self.single.as_deref().map(|s| s as &dyn RadialProfile)
    }
}

#[cfg(test)]
#[path = "monte_carlo_tests.rs"]
mod tests;
