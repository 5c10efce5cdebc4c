//! [`HistogramOut`], the core side of `subsurf.result.Histogram`, and the bin geometry the
//! tallies normalise by: axes ([`AxisKind`]) with their edges, their exact per-bin measures
//! (annulus areas, ring solid angles, projected solid angles, widths) and whether their last
//! bin collects everything beyond the grid.

use std::f64::consts::PI;

use super::accum::Accum;
use crate::error::{Error, Result};

/// A finished histogram: plain vectors, converted by the binding into `subsurf.result.Histogram`.
/// `values` and `stderr` are row-major (C order) with `shape[k] = edges[k].len() - 1`.
#[derive(Clone, Debug, PartialEq)]
pub struct HistogramOut {
    /// Tally name, e.g. `"rd_r"` (see docs/architecture.md).
    pub name: String,
    /// Normalised bin values.
    pub values: Vec<f64>,
    /// Standard errors of `values` from per-photon second moments.
    pub stderr: Vec<f64>,
    /// Number of bins per axis.
    pub shape: Vec<usize>,
    /// Bin edges per axis.
    pub edges: Vec<Vec<f64>>,
    /// Axis names (`"r"`, `"theta"`, `"z"`, `"t"`, `"cos_theta"`, `"phi"`, `"order"`).
    pub axes: Vec<String>,
    /// Unit of each axis (`"mm"`, `"rad"`, `"ps"`, `"1"`).
    pub edge_units: Vec<String>,
    /// Per axis, the measure of each bin that `values` are per (mm² annulus area for r, sr of
    /// solid angle or of projected solid angle for θ, mm for z, ps for t, …): the bin weight
    /// (fraction of the launched power) is `values` × the product of the axes' measures.
    pub measures: Vec<Vec<f64>>,
    /// Per axis, whether its last bin also collects everything beyond its last edge (r, z and t
    /// as in MCML; the "more than K" bin of a scattering-order axis).
    pub overflow: Vec<bool>,
    /// Unit of `values`.
    pub units: String,
    /// One line saying what it is.
    pub description: String,
}

impl HistogramOut {
    /// Whether `other` holds the same numbers bit for bit (NaN bins included) and the same
    /// metadata.
    pub fn same_bits(&self, other: &HistogramOut) -> bool {
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<u64>>();
        bits(&self.values) == bits(&other.values)
            && bits(&self.stderr) == bits(&other.stderr)
            && HistogramOut { values: vec![], stderr: vec![], ..self.clone() }
                == HistogramOut { values: vec![], stderr: vec![], ..other.clone() }
    }
}

/// The kinds of histogram axes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AxisKind {
    /// Radius r = √(x² + y²), mm; measure: annulus area π(r₁² − r₀²), mm². Last bin: overflow.
    Radius,
    /// Depth z, mm; measure: width, mm. Last bin: overflow.
    Depth,
    /// Time t, ps; measure: width, ps. Last bin: overflow.
    Time,
    /// Exit angle θ ∈ [0, π/2], rad; measure: ring solid angle 2π(cos θ₀ − cos θ₁), sr.
    Theta,
    /// Exit angle θ ∈ [0, π/2], rad; measure: projected solid angle ∫cos θ dω = π(sin²θ₁ − sin²θ₀), sr.
    ThetaProjected,
    /// μ = cos θ ∈ [0, 1]; measure: (μ₁² − μ₀²)/2 (with the φ measure Δφ: ∫cos θ dω of the bin).
    CosTheta,
    /// Azimuth φ ∈ [0, 2π), rad; measure: Δφ, rad.
    Phi,
    /// Scattering order 0 … K and "> K" (last bin: overflow); measure 1.
    Order,
    /// The single order-1 bin [1, 2) of the `*_single_direct` tallies; measure 1.
    OrderOne,
}

impl AxisKind {
    /// All kinds with their names as [`AxisKind::from_name`] accepts them.
    pub const NAMES: [(&'static str, AxisKind); 9] = [
        ("r", AxisKind::Radius),
        ("z", AxisKind::Depth),
        ("t", AxisKind::Time),
        ("theta", AxisKind::Theta),
        ("theta_projected", AxisKind::ThetaProjected),
        ("cos_theta", AxisKind::CosTheta),
        ("phi", AxisKind::Phi),
        ("order", AxisKind::Order),
        ("order_one", AxisKind::OrderOne),
    ];

    /// The kind named `name` (see [`AxisKind::NAMES`]).
    pub fn from_name(name: &str) -> Result<Self> {
        AxisKind::NAMES.iter().find(|(n, _)| *n == name).map(|&(_, k)| k).ok_or_else(|| {
            let names: Vec<&str> = AxisKind::NAMES.iter().map(|(n, _)| *n).collect();
            Error::Invalid(format!("axis = {name:?} is not an axis kind: must be one of {names:?}"))
        })
    }

    /// The axis name a histogram shows (`"theta"` for both θ kinds, `"order"` for both orders).
    pub fn axis_name(self) -> &'static str {
        match self {
            AxisKind::Radius => "r",
            AxisKind::Depth => "z",
            AxisKind::Time => "t",
            AxisKind::Theta | AxisKind::ThetaProjected => "theta",
            AxisKind::CosTheta => "cos_theta",
            AxisKind::Phi => "phi",
            AxisKind::Order | AxisKind::OrderOne => "order",
        }
    }

    /// Unit of the edges.
    pub fn unit(self) -> &'static str {
        match self {
            AxisKind::Radius | AxisKind::Depth => "mm",
            AxisKind::Time => "ps",
            AxisKind::Theta | AxisKind::ThetaProjected | AxisKind::Phi => "rad",
            AxisKind::CosTheta | AxisKind::Order | AxisKind::OrderOne => "1",
        }
    }

    /// Whether the last bin also collects everything beyond the last edge.
    pub fn overflow(self) -> bool {
        matches!(self, AxisKind::Radius | AxisKind::Depth | AxisKind::Time | AxisKind::Order)
    }

    /// The exact measure of the bin [e₀, e₁] (see each kind).
    pub fn bin_measure(self, e0: f64, e1: f64) -> f64 {
        match self {
            AxisKind::Radius => PI * (e1 - e0) * (e1 + e0),
            AxisKind::Depth | AxisKind::Time | AxisKind::Phi => e1 - e0,
            AxisKind::Theta => ring_solid_angle(e0, e1),
            AxisKind::ThetaProjected => ring_projected_solid_angle(e0, e1),
            AxisKind::CosTheta => 0.5 * (e1 - e0) * (e1 + e0),
            AxisKind::Order | AxisKind::OrderOne => 1.0,
        }
    }

    /// Measures of all bins of `edges` (validated: at least 2 finite, increasing edges).
    pub fn measures(self, edges: &[f64]) -> Result<Vec<f64>> {
        if edges.len() < 2 {
            return Err(Error::Invalid(format!("edges: need at least 2, got {}", edges.len())));
        }
        for (i, w) in edges.windows(2).enumerate() {
            if !(w[0].is_finite() && w[1].is_finite() && w[1] > w[0]) {
                return Err(Error::param(format!("edges[{}]", i + 1), w[1], "finite and strictly increasing"));
            }
        }
        Ok(edges.windows(2).map(|w| self.bin_measure(w[0], w[1])).collect())
    }
}

/// One histogram axis: its kind and edges.
#[derive(Clone, Debug)]
pub(crate) struct Axis {
    pub kind: AxisKind,
    pub edges: Vec<f64>,
}

impl Axis {
    /// `n` bins of width `w` from 0 (the last one also collects overflow).
    pub fn uniform(kind: AxisKind, n: usize, w: f64) -> Self {
        Axis { kind, edges: (0..=n).map(|i| i as f64 * w).collect() }
    }
    /// `n` bins over [lo, hi], last edge exactly `hi`.
    pub fn span(kind: AxisKind, n: usize, lo: f64, hi: f64) -> Self {
        let mut edges: Vec<f64> = (0..=n).map(|i| lo + (hi - lo) * i as f64 / n as f64).collect();
        edges[n] = hi;
        Axis { kind, edges }
    }
    /// Order axis 0, 1, …, K+2: bins 0…K and "more than K".
    pub fn order(k: u32) -> Self {
        Axis { kind: AxisKind::Order, edges: (0..=k as usize + 2).map(|i| i as f64).collect() }
    }
    /// The single-bin axis [1, 2) of the order-1 `*_single_direct` tallies.
    pub fn order_one() -> Self {
        Axis { kind: AxisKind::OrderOne, edges: vec![1.0, 2.0] }
    }
    pub fn len(&self) -> usize {
        self.edges.len() - 1
    }
    pub fn measures(&self) -> Vec<f64> {
        self.edges.windows(2).map(|w| self.kind.bin_measure(w[0], w[1])).collect()
    }
}

/// Bin index ⌊x / w⌋ clamped to `[0, n − 1]` (the last bin collects overflow, as MCML);
/// negative and NaN give 0. `n` ≥ 1 and below 2³¹ (grids are limited to 10⁷ bins).
#[inline(always)]
pub fn bin_clamped(x: f64, inv_w: f64, n: usize) -> usize {
    // Clamped in floating point (`max` maps NaN to 0), then a plain truncation: unlike the
    // saturating `as`, it vectorises (the bins of all lanes are computed at once).
    // ((n − 1) as i64: one signed conversion instruction, where usize → f64 takes several
    // without AVX-512; the same value, n < 2³²)
    let v = (x * inv_w).max(0.0).min((n - 1) as i64 as f64);
    // SAFETY: v is finite and in [0, n − 1] ⊂ [0, 2³¹) (n ≤ 10⁷), so the truncation is
    // defined. (To i32: one instruction per vector, where u32 takes several below AVX-512.)
    unsafe { v.to_int_unchecked::<i32>() as usize }
}

/// Bins of the polar angle θ = acos μ ∈ [0, π/2] in `n` equal widths Δθ = π/(2n), found from
/// μ without an `acos` per escape: a cheap guess (Abramowitz & Stegun 4.4.45,
/// acos μ ≈ √(1 − μ)(a₀ + a₁μ + a₂μ² + a₃μ³), |error| ≤ 6.7·10⁻⁵ rad on [0, 1]) corrected
/// against the exact bin edges cos(kΔθ): θ lies in bin k iff cos((k+1)Δθ) < μ ≤ cos(kΔθ), the
/// same bins as ⌊acos(μ)/Δθ⌋ (up to the rounding of the edges). The correction takes at most
/// 6.7·10⁻⁵/Δθ + 1 steps; above 1000 bins the guess is `acos` itself.
#[derive(Clone, Debug, PartialEq)]
pub struct ThetaBins {
    /// cos(kΔθ), k = 0 … n.
    cos_edge: Vec<f64>,
    inv_da: f64,
    exact_guess: bool,
}

impl ThetaBins {
    /// `n` ≥ 1 bins over [0, π/2].
    pub fn new(n: usize) -> Self {
        let da = std::f64::consts::FRAC_PI_2 / n as f64;
        ThetaBins {
            cos_edge: (0..=n).map(|k| (k as f64 * da).cos()).collect(),
            inv_da: 1.0 / da,
            exact_guess: n > 1000,
        }
    }

    /// The bin of direction cosine `mu` ∈ [0, 1] (NaN gives 0).
    #[inline(always)]
    pub fn bin(&self, mu: f64) -> usize {
        self.refine(mu, self.guess(mu))
    }

    /// The guess of [`ThetaBins::bin`] (for many `mu` at once: without the `acos` of more than
    /// 1000 bins, a loop of guesses vectorises).
    #[inline(always)]
    pub fn guess(&self, mu: f64) -> usize {
        let n = self.cos_edge.len() - 1;
        let theta = if self.exact_guess {
            mu.acos()
        } else {
            let m = mu.clamp(0.0, 1.0);
            (1.0 - m).sqrt() * (1.570_728_8 + m * (-0.212_114_4 + m * (0.074_261_0 - 0.018_729_3 * m)))
        };
        bin_clamped(theta, self.inv_da, n)
    }

    /// The bin of `mu` from a guess `k` < n (see the type's docs).
    #[inline(always)]
    pub fn refine(&self, mu: f64, mut k: usize) -> usize {
        let n = self.cos_edge.len() - 1;
        while k > 0 && mu > self.cos_edge[k] {
            k -= 1;
        }
        while k + 1 < n && mu <= self.cos_edge[k + 1] {
            k += 1;
        }
        k
    }
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

/// Build a histogram from an accumulator: bin `i` (row-major over `axes`) gets
/// value = S₁/N · `factor` / Π measures and stderr likewise (see [`Accum::mean_stderr`]).
pub(crate) fn histogram(
    name: &str,
    acc: &Accum,
    photons: u64,
    axes: &[Axis],
    units: &str,
    description: &str,
    factor: f64,
) -> HistogramOut {
    let shape: Vec<usize> = axes.iter().map(Axis::len).collect();
    debug_assert_eq!(shape.iter().product::<usize>(), acc.len());
    let measures: Vec<Vec<f64>> = axes.iter().map(Axis::measures).collect();
    let (mut values, mut stderr) = (Vec::with_capacity(acc.len()), Vec::with_capacity(acc.len()));
    for i in 0..acc.len() {
        // row-major: the last axis varies fastest
        let (mut rest, mut measure) = (i, 1.0);
        for (m, &n) in measures.iter().zip(&shape).rev() {
            measure *= m[rest % n];
            rest /= n;
        }
        let (m, se) = acc.mean_stderr(i, photons);
        let s = factor / measure;
        values.push(m * s);
        stderr.push(se * s);
    }
    HistogramOut {
        name: name.to_string(),
        values,
        stderr,
        shape,
        edges: axes.iter().map(|a| a.edges.clone()).collect(),
        axes: axes.iter().map(|a| a.kind.axis_name().to_string()).collect(),
        edge_units: axes.iter().map(|a| a.kind.unit().to_string()).collect(),
        measures,
        overflow: axes.iter().map(|a| a.kind.overflow()).collect(),
        units: units.to_string(),
        description: description.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn total(kind: AxisKind, a: &Axis) -> f64 {
        kind.measures(&a.edges).unwrap().iter().sum()
    }

    /// The θ bins from μ agree with ⌊acos(μ)/Δθ⌋ except within rounding of an edge.
    #[test]
    fn theta_bins_match_acos() {
        let mut rng = crate::stats::SplitMix64::new(3);
        for n in [1, 2, 30, 90, 1000, 1001, 5000] {
            let t = ThetaBins::new(n);
            let da = std::f64::consts::FRAC_PI_2 / n as f64;
            let mut mus: Vec<f64> = (0..20_000).map(|_| rng.next_f64()).collect();
            mus.extend([0.0, 1.0, 1e-300, 1.0 - 1e-16, f64::NAN]);
            mus.extend((0..=n).map(|k| (k as f64 * da).cos()));
            for mu in mus {
                let (got, want) = (t.bin(mu), bin_clamped(mu.acos(), 1.0 / da, n));
                if got != want {
                    let theta = mu.acos();
                    let edge = (theta / da).round() * da;
                    assert!((theta - edge).abs() < 1e-12, "n {n} mu {mu}: {got} vs {want}");
                }
            }
        }
    }

    #[test]
    fn measures_sum_to_the_whole() {
        // annuli tile the disc of radius n dr
        let (n, dr) = (37, 0.013);
        let r = Axis::uniform(AxisKind::Radius, n, dr);
        assert!((total(AxisKind::Radius, &r) - PI * (n as f64 * dr).powi(2)).abs() < 1e-13);
        // rings tile the hemisphere: 2π sr, projected π sr
        let a = Axis::span(AxisKind::Theta, 29, 0.0, PI / 2.0);
        assert!((total(AxisKind::Theta, &a) - 2.0 * PI).abs() < 1e-12);
        assert!((total(AxisKind::ThetaProjected, &a) - PI).abs() < 1e-12);
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
        // equal-solid-angle cos bins × φ bins tile π sr of projected solid angle
        let c = Axis::span(AxisKind::CosTheta, 7, 0.0, 1.0);
        let p = Axis::span(AxisKind::Phi, 5, 0.0, 2.0 * PI);
        assert!((total(AxisKind::CosTheta, &c) * total(AxisKind::Phi, &p) - PI).abs() < 1e-13);
        // annulus i of width dr: π dr² (2i + 1)
        assert!((AxisKind::Radius.bin_measure(3.0 * dr, 4.0 * dr) / (PI * dr * dr * 7.0) - 1.0).abs() < 1e-14);
        assert!(AxisKind::Depth.measures(&[0.0]).is_err());
        assert!(AxisKind::Depth.measures(&[0.0, 1.0, 1.0]).unwrap_err().to_string().starts_with("edges[2]"));
        assert_eq!(AxisKind::from_name("theta_projected").unwrap(), AxisKind::ThetaProjected);
        assert!(AxisKind::from_name("x").is_err());
    }

    #[test]
    fn overflow_flags() {
        let over: Vec<bool> = AxisKind::NAMES.iter().map(|(_, k)| k.overflow()).collect();
        assert_eq!(over, [true, true, true, false, false, false, false, true, false]);
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
