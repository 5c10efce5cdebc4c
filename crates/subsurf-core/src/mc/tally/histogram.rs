//! [`HistogramOut`], the core side of `subsurf.result.Histogram`, and the bin geometry
//! (edges, exact annulus areas, exact ring solid angles) the tallies normalise by.

use std::f64::consts::PI;

use super::accum::Accum;

/// A finished histogram: plain vectors, converted by the binding into `subsurf.result.Histogram`.
/// `values` and `stderr` are row-major (C order) with `shape[k] = edges[k].len() - 1`.
#[derive(Clone, Debug, PartialEq)]
pub struct HistogramOut {
    /// Tally name, e.g. `"rd_r"` (see docs/architecture.md).
    pub name: String,
    /// Normalised bin values.
    pub values: Vec<f64>,
    /// Standard errors of `values` (batch means; NaN when the run kept no errors).
    pub stderr: Vec<f64>,
    /// Number of bins per axis.
    pub shape: Vec<usize>,
    /// Bin edges per axis.
    pub edges: Vec<Vec<f64>>,
    /// Axis names (`"r"`, `"theta"`, `"z"`, `"t"`, `"cos_theta"`, `"phi"`, `"order"`).
    pub axes: Vec<String>,
    /// Unit of each axis (`"mm"`, `"rad"`, `"ps"`, `"1"`).
    pub edge_units: Vec<String>,
    /// Unit of `values`.
    pub units: String,
    /// One line saying what it is.
    pub description: String,
}

/// One histogram axis: name, unit, edges.
#[derive(Clone, Debug)]
pub(crate) struct Axis {
    pub name: &'static str,
    pub unit: &'static str,
    pub edges: Vec<f64>,
}

impl Axis {
    /// `n` bins of width `w` from 0 (the last one also collects overflow).
    pub fn uniform(name: &'static str, unit: &'static str, n: usize, w: f64) -> Self {
        Axis { name, unit, edges: (0..=n).map(|i| i as f64 * w).collect() }
    }
    /// `n` bins over [lo, hi], last edge exactly `hi`.
    pub fn span(name: &'static str, unit: &'static str, n: usize, lo: f64, hi: f64) -> Self {
        let mut edges: Vec<f64> = (0..=n).map(|i| lo + (hi - lo) * i as f64 / n as f64).collect();
        edges[n] = hi;
        Axis { name, unit, edges }
    }
    /// Order axis 0, 1, …, K+2: bins 0…K and "more than K".
    pub fn order(k: u32) -> Self {
        Axis { name: "order", unit: "1", edges: (0..=k as usize + 2).map(|i| i as f64).collect() }
    }
    /// The single-bin axis [1, 2) of the order-1 `*_single_direct` tallies.
    pub fn order_one() -> Self {
        Axis { name: "order", unit: "1", edges: vec![1.0, 2.0] }
    }
    pub fn len(&self) -> usize {
        self.edges.len() - 1
    }
}

/// Bin index ⌊x / w⌋ clamped to `[0, n − 1]` (the last bin collects overflow, as MCML);
/// negative and NaN give 0. `n` ≥ 1 and below 2³² (grids are limited to 10⁷ bins).
#[inline(always)]
pub fn bin_clamped(x: f64, inv_w: f64, n: usize) -> usize {
    // Clamped in floating point (`max` maps NaN to 0), then a plain truncation: unlike the
    // saturating `as`, it vectorises (the bins of all lanes are computed at once).
    let v = (x * inv_w).max(0.0).min((n - 1) as f64);
    // SAFETY: v is finite and in [0, n − 1] ⊂ [0, 2³²), so the truncation is defined.
    unsafe { v.to_int_unchecked::<u32>() as usize }
}

/// Exact area of annulus `i` of width `dr`: π(r_{i+1}² − r_i²) = π dr² (2i + 1), mm².
/// (Equal to MCML's 2π (i + ½) dr², which is exact too.)
pub fn annulus_area(i: usize, dr: f64) -> f64 {
    PI * dr * dr * (2 * i + 1) as f64
}

/// Exact solid angle of the ring θ ∈ [θ₀, θ₁]: 2π (cos θ₀ − cos θ₁), sr. MCML's `Rd_a`
/// uses the midpoint approximation 2π sin θ_c Δθ instead (Wang et al. 1995, §4.2).
pub fn ring_solid_angle(t0: f64, t1: f64) -> f64 {
    // 2π (cos t0 − cos t1) = 4π sin((t0+t1)/2) sin((t1−t0)/2), cancellation-free.
    4.0 * PI * (0.5 * (t0 + t1)).sin() * (0.5 * (t1 - t0)).sin()
}

/// Exact projected solid angle ∫ cos θ dω of the ring θ ∈ [θ₀, θ₁]: π (sin²θ₁ − sin²θ₀), sr.
/// MCML's `Rd_ra` divides by cos θ_c × (ring solid angle) instead.
pub fn ring_projected_solid_angle(t0: f64, t1: f64) -> f64 {
    // sin²b − sin²a = sin(b + a) sin(b − a)
    PI * (t1 + t0).sin() * (t1 - t0).sin()
}

/// ∫ cos θ dω over the bin μ ∈ [μ₀, μ₁] × an azimuth range of width Δφ: Δφ (μ₁² − μ₀²)/2, sr.
pub fn cos_bin_projected_solid_angle(mu0: f64, mu1: f64, dphi: f64) -> f64 {
    0.5 * dphi * (mu1 - mu0) * (mu1 + mu0)
}

/// Build a histogram from an accumulator over `(photons, batches)`: bin `i` (row-major over
/// `axes`) gets value = S₁/N · `scale(i)` and stderr = se · `scale(i)` (see
/// [`Accum::mean_stderr`]; NaN when the run kept no errors).
pub(crate) fn histogram(
    name: &str,
    acc: &Accum,
    (photons, batches): (u64, u64),
    axes: &[Axis],
    units: &str,
    description: &str,
    scale: impl Fn(usize) -> f64,
) -> HistogramOut {
    let shape: Vec<usize> = axes.iter().map(Axis::len).collect();
    debug_assert_eq!(shape.iter().product::<usize>(), acc.len());
    let (mut values, mut stderr) = (Vec::with_capacity(acc.len()), Vec::with_capacity(acc.len()));
    for i in 0..acc.len() {
        let (m, se) = acc.mean_stderr(i, photons, batches);
        let s = scale(i);
        values.push(m * s);
        stderr.push(se * s);
    }
    HistogramOut {
        name: name.to_string(),
        values,
        stderr,
        shape,
        edges: axes.iter().map(|a| a.edges.clone()).collect(),
        axes: axes.iter().map(|a| a.name.to_string()).collect(),
        edge_units: axes.iter().map(|a| a.unit.to_string()).collect(),
        units: units.to_string(),
        description: description.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn measures_sum_to_the_whole() {
        // annuli tile the disc of radius n dr
        let (n, dr) = (37, 0.013);
        let s: f64 = (0..n).map(|i| annulus_area(i, dr)).sum();
        assert!((s - PI * (n as f64 * dr).powi(2)).abs() < 1e-13);
        // rings tile the hemisphere: 2π sr, projected π sr
        let na = 29;
        let a = Axis::span("theta", "rad", na, 0.0, PI / 2.0);
        let (mut w, mut p) = (0.0, 0.0);
        for i in 0..na {
            w += ring_solid_angle(a.edges[i], a.edges[i + 1]);
            p += ring_projected_solid_angle(a.edges[i], a.edges[i + 1]);
        }
        assert!((w - 2.0 * PI).abs() < 1e-12, "{w}");
        assert!((p - PI).abs() < 1e-12, "{p}");
        // direct formulas against quadrature of sin θ and sin θ cos θ (midpoint rule, 10⁵ steps)
        let (t0, t1) = (0.3, 0.7);
        let m = 100_000;
        let h = (t1 - t0) / m as f64;
        let (mut qa, mut qp) = (0.0, 0.0);
        for k in 0..m {
            let t = t0 + (k as f64 + 0.5) * h;
            qa += 2.0 * PI * t.sin() * h;
            qp += 2.0 * PI * t.sin() * t.cos() * h;
        }
        assert!((ring_solid_angle(t0, t1) - qa).abs() < 1e-9);
        assert!((ring_projected_solid_angle(t0, t1) - qp).abs() < 1e-9);
        // equal-solid-angle cos bins: n_cos × n_phi bins tile π sr of projected solid angle
        let (nc, np) = (7, 5);
        let c = Axis::span("cos_theta", "1", nc, 0.0, 1.0);
        let s: f64 = (0..nc)
            .map(|i| np as f64 * cos_bin_projected_solid_angle(c.edges[i], c.edges[i + 1], 2.0 * PI / np as f64))
            .sum();
        assert!((s - PI).abs() < 1e-13);
    }

    #[test]
    fn clamped_bins() {
        assert_eq!(bin_clamped(0.0, 10.0, 5), 0);
        assert_eq!(bin_clamped(0.0999, 10.0, 5), 0);
        assert_eq!(bin_clamped(0.1001, 10.0, 5), 1);
        assert_eq!(bin_clamped(7.0, 10.0, 5), 4);
        assert_eq!(bin_clamped(f64::INFINITY, 10.0, 5), 4);
        assert_eq!(bin_clamped(-1.0, 10.0, 5), 0);
        assert_eq!(bin_clamped(f64::NAN, 10.0, 5), 0);
    }
}
