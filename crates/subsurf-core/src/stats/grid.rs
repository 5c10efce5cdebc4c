//! The χ² goodness-of-fit test on a grid of cells (1-D, or 2-D such as (cos θ, φ)), after
//! Mitsuba 3's `chi2.py`: the samples are histogrammed, the claimed density is integrated over
//! every cell by Gauss–Legendre quadrature on sub-cells refined (1, 2, 4, … per axis) until no
//! cell probability changes by more than [`PROBABILITY_TOL`], and Pearson's statistic is formed
//! with pooling of low-expectation cells ([`chi2_pooled`]) and one extra cell for the samples
//! outside the grid, whose expectation is n − Σ E (so an out-of-domain sample or a density of
//! integral ≠ 1 is detected).
//!
//! The density is evaluated in batches (one call per row of cells and refinement), so that a
//! vectorised density — a Python function of numpy arrays (`subsurf.testing`) — is cheap; the
//! Rust tests and the Python kit run exactly this code.

use super::{chi2_pooled, gauss_legendre, Chi2};
use crate::error::{Error, Result};

/// Refinement stops when no cell probability changes by more than this between two levels.
pub const PROBABILITY_TOL: f64 = 1e-10;

/// Below this fraction of the samples, the expected count outside the grid is quadrature noise
/// and counts as 0 (so that any sample outside is then an immediate rejection).
const OUTSIDE_NOISE: f64 = 1e-6;

/// A batch density: `pdf(coordinates)` with one slice per axis (all of equal length) returns
/// one value per point.
pub type BatchPdf<'a> = dyn FnMut(&[Vec<f64>]) -> Result<Vec<f64>> + 'a;

/// Check that `e` has at least 2 finite, strictly increasing edges.
pub fn check_edges(name: &str, e: &[f64]) -> Result<()> {
    if e.len() < 2 {
        return Err(Error::Invalid(format!("{name}: need at least 2 edges, got {}", e.len())));
    }
    for (i, p) in e.windows(2).enumerate() {
        if !(p[0].is_finite() && p[1].is_finite() && p[1] > p[0]) {
            return Err(Error::param(format!("{name}[{}]", i + 1), p[1], "finite and strictly increasing"));
        }
    }
    Ok(())
}

fn find_bin(edges: &[f64], v: f64) -> Option<usize> {
    let n = edges.len() - 1;
    if !(v >= edges[0] && v <= edges[n]) {
        return None;
    }
    // first edge > v, minus one; the top edge belongs to the last cell.
    let k = edges.partition_point(|&e| e <= v);
    Some(k.saturating_sub(1).min(n - 1))
}

fn check_grid(edges: &[&[f64]]) -> Result<()> {
    if !(1..=2).contains(&edges.len()) {
        return Err(Error::Invalid(format!("grid: 1 or 2 axes, got {}", edges.len())));
    }
    for (k, e) in edges.iter().enumerate() {
        check_edges(&format!("edges[{k}]"), e)?;
    }
    Ok(())
}

/// Histogram samples (one slice of coordinates per axis, equally long) on the grid of `edges`
/// (row-major, the first axis slowest). Returns the counts and the number of samples outside.
pub fn histogram(samples: &[&[f64]], edges: &[&[f64]]) -> Result<(Vec<f64>, usize)> {
    check_grid(edges)?;
    if samples.len() != edges.len() || samples.iter().any(|s| s.len() != samples[0].len()) {
        return Err(Error::Invalid("samples: one array per axis, all of equal length".into()));
    }
    let dims: Vec<usize> = edges.iter().map(|e| e.len() - 1).collect();
    let mut counts = vec![0.0; dims.iter().product()];
    let mut outside = 0;
    for i in 0..samples[0].len() {
        let mut cell = Some(0);
        for (k, e) in edges.iter().enumerate() {
            cell = cell.zip(find_bin(e, samples[k][i])).map(|(c, b)| c * dims[k] + b);
        }
        match cell {
            Some(c) => counts[c] += 1.0,
            None => outside += 1,
        }
    }
    Ok((counts, outside))
}

/// Samples (cos θ, φ) on the grid `cos_edges` × `phi_edges` (see [`histogram`]).
pub fn histogram_cos_phi(samples: &[(f64, f64)], cos_edges: &[f64], phi_edges: &[f64]) -> Result<(Vec<f64>, usize)> {
    let (c, p): (Vec<f64>, Vec<f64>) = samples.iter().copied().unzip();
    histogram(&[&c, &p], &[cos_edges, phi_edges])
}

/// ∫ pdf over every cell of the grid (row-major) by `q`-point Gauss–Legendre rules on `sub`
/// equal sub-cells per axis and cell; the density is called once per row of the first axis.
fn integrate_cells(edges: &[&[f64]], pdf: &mut BatchPdf, q: usize, sub: usize) -> Result<Vec<f64>> {
    let (x, w) = gauss_legendre(q);
    // nodes and weights on [0, 1] split into `sub` parts
    let t: Vec<f64> =
        (0..sub).flat_map(|k| x.iter().map(move |xi| (k as f64 + 0.5 * (xi + 1.0)) / sub as f64)).collect();
    let wt: Vec<f64> = (0..sub).flat_map(|_| w.iter().map(|wi| 0.5 * wi / sub as f64)).collect();
    let m = t.len();
    let rest: &[f64] = if edges.len() == 2 { edges[1] } else { &[0.0, 1.0] };
    let (n0, n1) = (edges[0].len() - 1, rest.len() - 1);
    let mut out = Vec::with_capacity(n0 * n1);
    for i in 0..n0 {
        let (a0, b0) = (edges[0][i], edges[0][i + 1]);
        let mut coords = vec![Vec::with_capacity(n1 * m * m); edges.len()];
        for j in 0..n1 {
            let (a1, b1) = (rest[j], rest[j + 1]);
            for &ti in &t {
                if edges.len() == 2 {
                    for &tj in &t {
                        coords[0].push(a0 + (b0 - a0) * ti);
                        coords[1].push(a1 + (b1 - a1) * tj);
                    }
                } else {
                    coords[0].push(a0 + (b0 - a0) * ti);
                }
            }
        }
        let per_cell = if edges.len() == 2 { m * m } else { m };
        let v = pdf(&coords)?;
        if v.len() != n1 * per_cell || v.iter().any(|x| !(x.is_finite() && *x >= 0.0)) {
            return Err(Error::Invalid(
                "pdf: must return one finite, non-negative value per point (sr^-1 or per unit length)".into(),
            ));
        }
        for j in 0..n1 {
            let vals = &v[j * per_cell..(j + 1) * per_cell];
            let s: f64 = if edges.len() == 2 {
                (0..m).map(|a| wt[a] * (0..m).map(|b| wt[b] * vals[a * m + b]).sum::<f64>()).sum()
            } else {
                (0..m).map(|a| wt[a] * vals[a]).sum()
            };
            let width1 = if edges.len() == 2 { rest[j + 1] - rest[j] } else { 1.0 };
            out.push(s * (b0 - a0) * width1);
        }
    }
    Ok(out)
}

/// Probability of every cell of the grid (row-major) under `pdf`, by `quad_points`-point
/// Gauss–Legendre on 1, 2, 4, … up to `max_subdivisions` sub-cells per axis, stopping when no
/// cell changes by more than [`PROBABILITY_TOL`]. Returns the probabilities and the last change.
pub fn cell_probabilities(
    edges: &[&[f64]],
    pdf: &mut BatchPdf,
    quad_points: usize,
    max_subdivisions: usize,
) -> Result<(Vec<f64>, f64)> {
    check_grid(edges)?;
    if !(1..=64).contains(&quad_points) {
        return Err(Error::param_int("quad_points", quad_points as i128, "an integer in [1, 64]"));
    }
    if !(1..=4096).contains(&max_subdivisions) {
        return Err(Error::param_int("max_subdivisions", max_subdivisions as i128, "an integer in [1, 4096]"));
    }
    let mut sub = 1;
    let mut prev = integrate_cells(edges, pdf, quad_points, sub)?;
    let mut change = f64::INFINITY;
    while sub < max_subdivisions {
        sub = (2 * sub).min(max_subdivisions);
        let cur = integrate_cells(edges, pdf, quad_points, sub)?;
        change = prev.iter().zip(&cur).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        prev = cur;
        if change < PROBABILITY_TOL {
            break;
        }
    }
    Ok((prev, change))
}

/// Outcome of [`chi2_test_grid`].
#[derive(Clone, Debug, PartialEq)]
pub struct GridChi2 {
    /// Pearson's statistic, degrees of freedom, p-value and pooled cells.
    pub chi2: Chi2,
    /// Samples outside the grid.
    pub outside: usize,
    /// ∫ pdf over the grid (1 when the grid covers the density's domain).
    pub pdf_integral: f64,
    /// The last refinement's largest change of a cell's expected count (in counts).
    pub quadrature_error: f64,
}

/// The whole test: [`histogram`] of the samples, [`cell_probabilities`] of `pdf`, and Pearson's
/// χ² with pooling below `min_expected` and an extra cell for the samples outside the grid.
/// `names` name the edge arrays in errors (e.g. `["cos_edges", "phi_edges"]`).
#[allow(clippy::too_many_arguments)]
pub fn chi2_test_grid(
    samples: &[&[f64]],
    edges: &[&[f64]],
    names: &[&str],
    pdf: &mut BatchPdf,
    min_expected: f64,
    quad_points: usize,
    max_subdivisions: usize,
) -> Result<GridChi2> {
    for (e, name) in edges.iter().zip(names) {
        check_edges(name, e)?;
    }
    let (mut obs, outside) = histogram(samples, edges)?;
    let (prob, change) = cell_probabilities(edges, pdf, quad_points, max_subdivisions)?;
    let n = samples[0].len() as f64;
    let mut exp: Vec<f64> = prob.iter().map(|p| p * n).collect();
    let rest = n - exp.iter().sum::<f64>();
    obs.push(outside as f64);
    exp.push(if rest < OUTSIDE_NOISE * n { 0.0 } else { rest });
    Ok(GridChi2 {
        chi2: chi2_pooled(&obs, &exp, min_expected)?,
        outside,
        pdf_integral: prob.iter().sum(),
        quadrature_error: change * n,
    })
}

/// The test for directions (cos θ, φ) against a density with respect to solid angle
/// (dω = d cos θ dφ): [`chi2_test_grid`] with 6-point rules refined up to 64 sub-cells and
/// pooling below 5 expected samples.
pub fn chi2_test_cos_phi(
    samples: &[(f64, f64)],
    pdf: &dyn Fn(f64, f64) -> f64,
    cos_edges: &[f64],
    phi_edges: &[f64],
) -> Result<Chi2> {
    let (c, p): (Vec<f64>, Vec<f64>) = samples.iter().copied().unzip();
    let mut batch = |x: &[Vec<f64>]| Ok(x[0].iter().zip(&x[1]).map(|(&a, &b)| pdf(a, b)).collect());
    let names = ["cos_edges", "phi_edges"];
    Ok(chi2_test_grid(&[&c, &p], &[cos_edges, phi_edges], &names, &mut batch, 5.0, 6, 64)?.chi2)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn histogram_edges_and_outside() {
        let (c, out) =
            histogram_cos_phi(&[(-1.0, 0.0), (1.0, 6.0), (0.0, 3.0), (1.5, 0.0)], &[-1.0, 0.0, 1.0], &[0.0, 2.0 * PI])
                .unwrap();
        assert_eq!((c, out), (vec![1.0, 2.0], 1));
        assert!(histogram_cos_phi(&[], &[0.0, 0.0], &[0.0, 1.0]).is_err());
        let (c, out) = histogram(&[&[0.1, 0.9, 2.0]], &[&[0.0, 0.5, 1.0]]).unwrap();
        assert_eq!((c, out), (vec![1.0, 1.0], 1));
    }

    #[test]
    fn cell_probabilities_of_known_densities() {
        // 1-D: p(x) = 3x² on [0, 1] — cells [0, ½], [½, 1] hold 1/8 and 7/8 (exact for GL)
        let mut cube = |x: &[Vec<f64>]| Ok(x[0].iter().map(|v| 3.0 * v * v).collect());
        let (p, _) = cell_probabilities(&[&[0.0, 0.5, 1.0]], &mut cube, 4, 4).unwrap();
        assert!((p[0] - 0.125).abs() < 1e-15 && (p[1] - 0.875).abs() < 1e-15);
        // 2-D: cos θ / π over the upper hemisphere in 3 × 2 cells sums to 1, each cell exact
        let mut lambert = |x: &[Vec<f64>]| Ok(x[0].iter().map(|c| c.max(0.0) / PI).collect());
        let (p, _) = cell_probabilities(&[&[0.0, 0.3, 0.6, 1.0], &[0.0, PI, 2.0 * PI]], &mut lambert, 3, 2).unwrap();
        assert!((p.iter().sum::<f64>() - 1.0).abs() < 1e-14);
        assert!((p[0] - 0.045).abs() < 1e-15); // ∫₀^0.3 c dc · π / π
                                               // a density returning NaN or the wrong count is refused
        let mut bad = |x: &[Vec<f64>]| Ok(vec![f64::NAN; x[0].len()]);
        assert!(cell_probabilities(&[&[0.0, 1.0]], &mut bad, 4, 4).is_err());
        assert!(cell_probabilities(&[&[0.0, 1.0]], &mut cube, 0, 4).is_err());
    }
}
