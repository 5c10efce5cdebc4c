//! Statistics and quadrature used to *test* samplers: a χ² goodness-of-fit kit.
//!
//! Every sampler in the project is checked the same way (after Mitsuba 3's `chi2.py`, Jakob et
//! al.): draw N samples, histogram them on a grid, integrate the claimed pdf over every cell to
//! get expected counts, pool cells whose expected count is below 5 into one cell (Cochran's rule,
//! Cochran 1952), compute Pearson's statistic X² = Σ (O − E)²/E with `cells − 1` degrees of
//! freedom, and reject when its p-value is below a Šidák-corrected significance.
//!
//! Contents:
//! - [`ln_gamma`], [`gamma_q`] (regularised upper incomplete gamma), [`chi2_sf`] (χ² survival).
//! - [`sidak_alpha`]: per-test significance for m independent tests at overall level α.
//! - [`chi2_pooled`]: Pearson's statistic with pooling of low-expected cells.
//! - [`gauss_legendre`], [`integrate_adaptive`]: quadrature.
//! - [`uniform_edges`], [`graded_cos_edges`]: cell edges.
//! - [`grid`]: the test on a grid of cells — [`histogram`], [`cell_probabilities`],
//!   [`chi2_test_grid`], and [`chi2_test_cos_phi`] for directions (cos θ, φ). The Python kit
//!   (`subsurf.testing`) calls these too.

use crate::error::{Error, Result};
use std::f64::consts::PI;

pub mod grid;

pub use grid::{cell_probabilities, chi2_test_cos_phi, chi2_test_grid, histogram, histogram_cos_phi, GridChi2};

/// SplitMix64 (Steele, Lea & Flood 2014): a tiny, fast, statistically sound generator for
/// *tests* with fixed seeds. Not the simulation RNG (that is [`crate::rng`]).
#[derive(Clone, Debug)]
pub struct SplitMix64(u64);

impl SplitMix64 {
    /// A generator started from `seed`.
    pub fn new(seed: u64) -> Self {
        SplitMix64(seed)
    }

    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform double in [0, 1) with 53 random bits.
    pub fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
}

// ---------------------------------------------------------------------------------------------
// Special functions
// ---------------------------------------------------------------------------------------------

/// ln Γ(x) for x > 0 by the Lanczos approximation (g = 7, n = 9; Lanczos 1964, coefficients as
/// in Numerical Recipes 3rd ed. §6.1 / Boost), with the reflection formula not needed (x > 0).
/// Relative accuracy ≈ 1e-15.
pub fn ln_gamma(x: f64) -> f64 {
    const G: f64 = 7.0;
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Reflection: Γ(x)Γ(1−x) = π / sin(πx).
        return (PI / (PI * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + G + 0.5;
    for (i, &c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * (2.0 * PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// Regularised upper incomplete gamma Q(a, x) = Γ(a, x)/Γ(a), for a > 0, x ≥ 0.
///
/// Series for P = 1 − Q when x < a + 1, Lentz's continued fraction for Q otherwise
/// (Numerical Recipes 3rd ed. §6.2, eqs. 6.2.5 and 6.2.7). Relative accuracy ~1e-14.
pub fn gamma_q(a: f64, x: f64) -> Result<f64> {
    if !(a.is_finite() && a > 0.0) {
        return Err(Error::param("a", a, "a finite number > 0"));
    }
    if x.is_nan() || x < 0.0 {
        return Err(Error::param("x", x, "a number >= 0"));
    }
    if x == 0.0 {
        return Ok(1.0);
    }
    if x.is_infinite() {
        return Ok(0.0);
    }
    let ln_pre = a * x.ln() - x - ln_gamma(a);
    if x < a + 1.0 {
        // P(a,x) = e^{-x} x^a / Γ(a+1) Σ x^n / ((a+1)…(a+n))
        let (mut ap, mut del, mut sum) = (a, 1.0 / a, 1.0 / a);
        for _ in 0..10_000 {
            ap += 1.0;
            del *= x / ap;
            sum += del;
            if del.abs() < sum.abs() * 1e-17 {
                break;
            }
        }
        Ok((1.0 - sum * ln_pre.exp()).clamp(0.0, 1.0))
    } else {
        // Continued fraction Q = e^{-x} x^a/Γ(a) · 1/(x+1−a− 1·(1−a)/(x+3−a− …)), modified Lentz.
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..10_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let del = d * c;
            h *= del;
            if (del - 1.0).abs() < 1e-16 {
                break;
            }
        }
        Ok((ln_pre.exp() * h).clamp(0.0, 1.0))
    }
}

/// Survival function of the χ² distribution with `dof` degrees of freedom:
/// P(X² ≥ stat) = Q(dof/2, stat/2). `dof` must be > 0; `stat` = +∞ gives 0.
pub fn chi2_sf(stat: f64, dof: f64) -> Result<f64> {
    if !(dof.is_finite() && dof > 0.0) {
        return Err(Error::param("dof", dof, "a finite number > 0"));
    }
    if stat.is_nan() {
        return Err(Error::param("statistic", stat, "a number >= 0"));
    }
    gamma_q(0.5 * dof, 0.5 * stat.max(0.0))
}

/// Šidák correction: the per-test significance α_i = 1 − (1 − α)^(1/m) that keeps the
/// probability of any false rejection among `m` independent tests at α (Šidák 1967).
pub fn sidak_alpha(alpha: f64, m: usize) -> Result<f64> {
    if !(alpha > 0.0 && alpha < 1.0) {
        return Err(Error::param("significance", alpha, "a number in (0, 1)"));
    }
    if m == 0 {
        return Err(Error::param_int("tests", 0, "an integer >= 1"));
    }
    Ok(-((-alpha).ln_1p() / m as f64).exp_m1())
}

// ---------------------------------------------------------------------------------------------
// Pearson's χ² with pooling
// ---------------------------------------------------------------------------------------------

/// Result of a χ² goodness-of-fit test.
#[derive(Clone, Debug, PartialEq)]
pub struct Chi2 {
    /// Pearson's statistic Σ (O − E)² / E over the (pooled) cells.
    pub statistic: f64,
    /// Degrees of freedom: cells after pooling − 1.
    pub dof: usize,
    /// P(X² ≥ statistic) under the null hypothesis (0 when a sample fell where E = 0).
    pub p_value: f64,
    /// How many original cells were pooled into the merged low-expectation cell.
    pub pooled_cells: usize,
}

/// Pearson's χ² of `observed` against `expected` counts, pooling every cell with expected
/// count below `min_expected` (5 is the usual rule) into one merged cell, as Mitsuba 3's
/// `chi2.py`. If the merged cell still has expected < `min_expected`, it is merged into the
/// smallest remaining cell. A sample in a cell of zero expected count gives statistic = ∞
/// and p = 0 (the sampler produced an impossible value).
///
/// The caller makes Σ E = Σ O = N when the pdf is normalised; a misnormalised pdf shows as a
/// large statistic. Errors: lengths differ, negative/NaN counts, or fewer than 2 cells left.
pub fn chi2_pooled(observed: &[f64], expected: &[f64], min_expected: f64) -> Result<Chi2> {
    if observed.len() != expected.len() {
        return Err(Error::Invalid(format!(
            "chi2: observed has {} cells but expected has {}",
            observed.len(),
            expected.len()
        )));
    }
    for (i, (&o, &e)) in observed.iter().zip(expected).enumerate() {
        if !(o >= 0.0 && o.is_finite()) {
            return Err(Error::param(format!("observed[{i}]"), o, "a finite count >= 0"));
        }
        if !(e >= 0.0 && e.is_finite()) {
            return Err(Error::param(format!("expected[{i}]"), e, "a finite count >= 0"));
        }
    }
    if observed.iter().zip(expected).any(|(&o, &e)| e == 0.0 && o > 0.0) {
        // A sample where the pdf says none can be: reject outright (before pooling hides it).
        let dof = expected.iter().filter(|&&e| e > 0.0).count().max(2) - 1;
        return Ok(Chi2 { statistic: f64::INFINITY, dof, p_value: 0.0, pooled_cells: 0 });
    }
    let mut idx: Vec<usize> = (0..expected.len()).collect();
    idx.sort_by(|&a, &b| expected[a].total_cmp(&expected[b]));
    let (mut pool_o, mut pool_e, mut pooled) = (0.0, 0.0, 0usize);
    let mut cells: Vec<(f64, f64)> = Vec::with_capacity(idx.len());
    for &i in &idx {
        if expected[i] < min_expected {
            pool_o += observed[i];
            pool_e += expected[i];
            pooled += 1;
        } else {
            cells.push((observed[i], expected[i]));
        }
    }
    if pooled > 0 {
        if pool_e >= min_expected || cells.is_empty() {
            cells.push((pool_o, pool_e));
        } else {
            // cells are sorted ascending: merge into the smallest remaining cell.
            cells[0].0 += pool_o;
            cells[0].1 += pool_e;
        }
    }
    let mut stat = 0.0;
    for &(o, e) in &cells {
        if e > 0.0 {
            stat += (o - e) * (o - e) / e;
        } else if o > 0.0 {
            stat = f64::INFINITY;
        }
    }
    if cells.len() < 2 {
        return Err(Error::Invalid(format!(
            "chi2: only {} cell(s) left after pooling cells with expected count < {min_expected}; \
             use more samples or fewer, larger cells",
            cells.len()
        )));
    }
    let dof = cells.len() - 1;
    let p_value = if stat.is_finite() { chi2_sf(stat, dof as f64)? } else { 0.0 };
    Ok(Chi2 { statistic: stat, dof, p_value, pooled_cells: pooled })
}

// ---------------------------------------------------------------------------------------------
// Quadrature
// ---------------------------------------------------------------------------------------------

/// Gauss–Legendre nodes and weights on [−1, 1] with `n` ≥ 1 points, by Newton iteration on
/// the three-term recurrence of P_n (Golub & Welsch give the same; Numerical Recipes §4.6
/// `gauleg`). Exact for polynomials of degree ≤ 2n − 1.
pub fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    let n = n.max(1);
    let mut x = vec![0.0; n];
    let mut w = vec![0.0; n];
    let m = n.div_ceil(2);
    for i in 0..m {
        let mut z = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut pp = 1.0;
        for _ in 0..100 {
            let (mut p1, mut p2) = (1.0, 0.0);
            for j in 0..n {
                let p3 = p2;
                p2 = p1;
                p1 = ((2 * j + 1) as f64 * z * p2 - j as f64 * p3) / (j + 1) as f64;
            }
            pp = n as f64 * (z * p1 - p2) / (z * z - 1.0);
            let z1 = z;
            z = z1 - p1 / pp;
            if (z - z1).abs() < 1e-15 {
                break;
            }
        }
        x[i] = -z;
        x[n - 1 - i] = z;
        w[i] = 2.0 / ((1.0 - z * z) * pp * pp);
        w[n - 1 - i] = w[i];
    }
    (x, w)
}

/// 10-point Gauss–Legendre rule on [a, b] (nodes computed once per call).
fn gl_panel(f: &mut dyn FnMut(f64) -> f64, a: f64, b: f64, x: &[f64], w: &[f64]) -> f64 {
    let (c, h) = (0.5 * (a + b), 0.5 * (b - a));
    x.iter().zip(w).map(|(&xi, &wi)| wi * f(c + h * xi)).sum::<f64>() * h
}

/// ∫_a^b f by adaptive bisection of 10-point Gauss–Legendre panels: a panel is accepted when
/// its estimate and the sum over its two halves differ by less than `tol` scaled by the panel
/// width (so the total error is ≲ `tol` in practice); `tol` is floored at 1e-14 of the
/// integral's first estimate, and the recursion depth is capped at 30. A non-finite panel
/// (NaN or ±∞ integrand) ends the refinement there, so the result is then non-finite at once
/// rather than after 2³⁰ panels.
pub fn integrate_adaptive(f: &mut dyn FnMut(f64) -> f64, a: f64, b: f64, tol: f64) -> f64 {
    let (x, w) = gauss_legendre(10);
    let whole = gl_panel(f, a, b, &x, &w);
    // Never ask for more than rounding allows: floor the tolerance at 1e-15 of the integral.
    let tol = tol.max(1e-14 * whole.abs());
    adapt(f, a, b, whole, tol / (b - a).abs().max(f64::MIN_POSITIVE), &x, &w, 0)
}

#[allow(clippy::too_many_arguments)]
fn adapt(
    f: &mut dyn FnMut(f64) -> f64,
    a: f64,
    b: f64,
    whole: f64,
    tol_per_len: f64,
    x: &[f64],
    w: &[f64],
    depth: u32,
) -> f64 {
    let m = 0.5 * (a + b);
    let left = gl_panel(f, a, m, x, w);
    let right = gl_panel(f, m, b, x, w);
    let both = left + right;
    if depth >= 30 || !both.is_finite() || (both - whole).abs() <= tol_per_len * (b - a).abs() {
        return both;
    }
    adapt(f, a, m, left, tol_per_len, x, w, depth + 1) + adapt(f, m, b, right, tol_per_len, x, w, depth + 1)
}

// ---------------------------------------------------------------------------------------------
// The (cos θ, φ) grid
// ---------------------------------------------------------------------------------------------

/// Bin edges `n` equal cells over [lo, hi].
pub fn uniform_edges(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    (0..=n).map(|i| lo + (hi - lo) * i as f64 / n as f64).collect()
}

/// Edges on [−1, 1] refined geometrically towards both poles, for peaked pdfs (HG with
/// |g| → 1): `n_end` cells on each side whose widths grow geometrically from `min_gap` at
/// ±1 to a total of 0.1, and `n_mid` equal cells over [−0.9, 0.9]. Errors: `min_gap` not a
/// finite number > 0.
pub fn graded_cos_edges(n_end: usize, n_mid: usize, min_gap: f64) -> Result<Vec<f64>> {
    if !(min_gap.is_finite() && min_gap > 0.0) {
        return Err(Error::param("min_gap", min_gap, "a finite number > 0"));
    }
    let n_end = n_end.max(1);
    let min_gap = min_gap.clamp(1e-12, 0.1 / n_end as f64);
    // distances from the pole: 0, min_gap·r^0 … geometric up to 0.1
    let dist: Vec<f64> = if n_end == 1 {
        vec![0.0, 0.1]
    } else {
        let ratio = (0.1 / min_gap).powf(1.0 / (n_end - 1) as f64);
        std::iter::once(0.0).chain((0..n_end).map(|k| min_gap * ratio.powi(k as i32))).collect()
    };
    let mut e: Vec<f64> = dist.iter().map(|d| -1.0 + d).collect();
    let mid = uniform_edges(-0.9, 0.9, n_mid.max(1));
    e.extend_from_slice(&mid[1..mid.len() - 1]);
    e.extend(dist.iter().rev().map(|d| 1.0 - d));
    Ok(e)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn q_integer(n: u32, x: f64) -> f64 {
        // Q(n, x) = e^{-x} Σ_{k<n} x^k / k!  (closed form for integer a)
        let (mut term, mut sum) = (1.0, 0.0);
        for k in 0..n {
            if k > 0 {
                term *= x / k as f64;
            }
            sum += term;
        }
        (-x).exp() * sum
    }

    #[test]
    fn ln_gamma_known_values() {
        assert!((ln_gamma(0.5) - 0.572_364_942_924_700_1).abs() < 1e-14); // ln √π
        assert!((ln_gamma(10.0) - 362_880f64.ln()).abs() < 1e-13);
        assert!(ln_gamma(1.0).abs() < 1e-14 && ln_gamma(2.0).abs() < 1e-14);
        assert!((ln_gamma(100.5) - 361.435_540_467_777_6).abs() < 1e-9); // Python math.lgamma
    }

    #[test]
    fn gamma_q_against_closed_forms_and_tables() {
        for n in [1u32, 2, 5, 10, 50] {
            for x in [0.01, 0.5, 1.0, 3.0, 10.0, 49.0, 51.0, 100.0] {
                let (q, r) = (gamma_q(n as f64, x).unwrap(), q_integer(n, x));
                assert!((q - r).abs() <= 1e-13 + 1e-11 * r, "Q({n},{x}) = {q} vs {r}");
            }
        }
        // χ² critical values (standard tables, e.g. Abramowitz & Stegun Table 26.8).
        let table = [
            (3.841_458_820_694_124, 1.0, 0.05),
            (6.634_896_601_021_214, 1.0, 0.01),
            (18.307_038_053_275_146, 10.0, 0.05),
            (23.209_251_158_954_356, 10.0, 0.01),
            (124.342_113_404_004_07, 100.0, 0.05),
        ];
        for (x, k, p) in table {
            let sf = chi2_sf(x, k).unwrap();
            assert!((sf - p).abs() < 1e-10, "chi2_sf({x}, {k}) = {sf}");
        }
        // dof = 1: sf(x) = erfc(√(x/2)); erfc(1) = 0.157299207050285…
        assert!((chi2_sf(2.0, 1.0).unwrap() - 0.157_299_207_050_285_13).abs() < 1e-13);
        assert_eq!(chi2_sf(0.0, 3.0).unwrap(), 1.0);
        assert_eq!(chi2_sf(f64::INFINITY, 3.0).unwrap(), 0.0);
        assert!(chi2_sf(1.0, 0.0).is_err() && gamma_q(-1.0, 1.0).is_err() && gamma_q(1.0, f64::NAN).is_err());
    }

    #[test]
    fn sidak() {
        assert!((sidak_alpha(0.01, 1).unwrap() - 0.01).abs() < 1e-16);
        assert!((sidak_alpha(0.05, 2).unwrap() - (1.0 - 0.95f64.sqrt())).abs() < 1e-16);
        let a = sidak_alpha(0.01, 8).unwrap();
        assert!((1.0 - (1.0 - a).powi(8) - 0.01).abs() < 1e-15);
        assert!(sidak_alpha(0.0, 3).is_err() && sidak_alpha(0.5, 0).is_err());
    }

    #[test]
    fn pooling_by_hand() {
        // Cells with E = 1, 2, 3 pool into one cell (E = 6, O = 1 + 4 + 2 = 7).
        let o = [10.0, 1.0, 4.0, 2.0, 12.0];
        let e = [12.0, 1.0, 2.0, 3.0, 10.0];
        let r = chi2_pooled(&o, &e, 5.0).unwrap();
        let want = (10.0f64 - 12.0).powi(2) / 12.0 + 1.0 / 6.0 + (12.0f64 - 10.0).powi(2) / 10.0;
        assert!((r.statistic - want).abs() < 1e-14 && r.dof == 2 && r.pooled_cells == 3);
        // A pool still below 5 merges into the smallest big cell: E = (1+2) + 6 = 9, O = 1+1+8.
        let r = chi2_pooled(&[1.0, 1.0, 8.0, 20.0], &[1.0, 2.0, 6.0, 21.0], 5.0).unwrap();
        let want = (10.0f64 - 9.0).powi(2) / 9.0 + 1.0 / 21.0;
        assert!((r.statistic - want).abs() < 1e-14 && r.dof == 1);
        // A sample where E = 0 everywhere in its pool: impossible value → p = 0.
        let r = chi2_pooled(&[5.0, 5.0, 1.0], &[5.5, 5.5, 0.0], 0.5).unwrap();
        assert!(r.statistic.is_infinite() && r.p_value == 0.0);
        assert!(chi2_pooled(&[1.0], &[1.0, 2.0], 5.0).is_err());
        assert!(chi2_pooled(&[3.0, 3.0], &[3.0, 3.0], 5.0).is_err()); // one cell left
    }

    #[test]
    fn p_values_are_calibrated() {
        // Under the null the p-value is uniform: of 400 independent tests of an exact uniform
        // sampler (20 cells × 400 samples), the count with p < 0.1 is Binomial(400, 0.1):
        // mean 40, σ = 6; accept within 4σ.
        let mut rng = SplitMix64::new(42);
        let mut low = 0;
        for _ in 0..400 {
            let mut o = vec![0.0; 20];
            for _ in 0..400 {
                o[(rng.next_f64() * 20.0) as usize] += 1.0;
            }
            if chi2_pooled(&o, &[20.0; 20], 5.0).unwrap().p_value < 0.1 {
                low += 1;
            }
        }
        assert!((low as f64 - 40.0).abs() < 24.0, "{low} of 400 below 0.1");
    }

    #[test]
    fn quadrature() {
        let (x, w) = gauss_legendre(7);
        for k in 0..14 {
            let q: f64 = x.iter().zip(&w).map(|(xi, wi)| wi * xi.powi(k)).sum();
            let exact = if k % 2 == 1 { 0.0 } else { 2.0 / (k + 1) as f64 };
            assert!((q - exact).abs() < 1e-14, "k {k}");
        }
        let i = integrate_adaptive(&mut |t: f64| t.sqrt(), 0.0, 1.0, 1e-12);
        assert!((i - 2.0 / 3.0).abs() < 1e-11);
        let mut calls = 0;
        let nan = integrate_adaptive(
            &mut |_| {
                calls += 1;
                f64::NAN
            },
            0.0,
            1.0,
            1e-12,
        );
        assert!(nan.is_nan() && calls < 100, "{calls} evaluations");
        assert!(graded_cos_edges(10, 20, 0.0).is_err());
        let e = graded_cos_edges(10, 20, 1e-5).unwrap();
        assert_eq!(e.len(), 41);
        assert!(e.windows(2).all(|p| p[1] > p[0]) && e[0] == -1.0 && e[40] == 1.0);
        assert!((e[1] + 1.0 - 1e-5).abs() < 1e-15);
    }
}
