//! Levenberg–Marquardt least squares with the covariance of the parameters (Marquardt 1963;
//! Press et al., *Numerical Recipes* 3rd ed., §15.5).
//!
//! Minimises χ² = Σ ((y_i − f_i(p))/σ_i)² over positive parameters, internally in q = ln p (so
//! they stay positive and the steps are relative). The Jacobian is by central differences
//! (h = 1e-4 in q). At the minimum, with Gaussian noise of the stated σ, the covariance of q is
//! (JᵀWJ)⁻¹ (W = diag 1/σ²), and that of p is cov_ij = p_i p_j cov(q)_ij (first-order
//! propagation), which is what [`Fit::cov`] reports.
//!
//! A fit is reported only when the data identify it ([`check_signal`] before, [`Fit::identified`]
//! after): some datum stands out of its noise, χ² is finite at the start and at the minimum, and
//! the covariance is finite with every relative standard uncertainty σ_p/p ≤
//! [`MAX_RELATIVE_STDERR`]. Otherwise the "best" parameters are wherever the iteration stopped
//! (the start value on a flat or overflowing χ²), and their "uncertainties" are 0 or 1e85:
//! numbers that look like a result and are not one.

use crate::error::{Error, Result};

/// A fit's result.
#[derive(Clone, Debug, PartialEq)]
pub struct Fit {
    /// Best parameters.
    pub params: Vec<f64>,
    /// Their covariance matrix (row-major, n × n).
    pub cov: Vec<f64>,
    /// χ² at the minimum.
    pub chi2: f64,
    /// Degrees of freedom (data − parameters).
    pub dof: usize,
    /// Iterations used.
    pub iterations: usize,
}

impl Fit {
    /// Standard uncertainties √cov_ii.
    pub fn stderr(&self) -> Vec<f64> {
        let n = self.params.len();
        (0..n).map(|i| self.cov[i * n + i].max(0.0).sqrt()).collect()
    }
}

/// Largest relative standard uncertainty σ_p/p (that of ln p, the fitted variable) of a fitted
/// parameter: beyond it the data leave the parameter free over more than a factor e either way,
/// which is not a measurement of it.
pub const MAX_RELATIVE_STDERR: f64 = 1.0;

/// Refuse data without signal: every |yᵢ| ≤ σᵢ (all zero, or all within their noise) determines
/// no parameter; `what` names the data in the message.
pub fn check_signal(y: &[f64], sigma: &[f64], what: &str) -> Result<()> {
    if y.iter().zip(sigma).any(|(v, s)| v.abs() > *s) {
        return Ok(());
    }
    Err(Error::Invalid(format!(
        "fit: the data hold no signal (every {what} is within its standard deviation of 0); nothing can be fitted"
    )))
}

impl Fit {
    /// This fit if the data identify its parameters (see the module docs); otherwise an error
    /// naming the first undetermined parameter of `names`.
    pub fn identified(self, names: &[&str]) -> Result<Fit> {
        if !self.chi2.is_finite() {
            return Err(Error::Invalid(
                "fit: χ² is not finite at the parameters reached (standard deviations far too small for the \
                 data, or data the model cannot reach); nothing was fitted"
                    .into(),
            ));
        }
        for (k, (&p, se)) in self.params.iter().zip(self.stderr()).enumerate() {
            let name = names.get(k).copied().unwrap_or("parameter");
            let rel = se / p;
            if !(rel.is_finite() && rel <= MAX_RELATIVE_STDERR && self.cov[k * self.params.len() + k] > 0.0) {
                return Err(Error::Invalid(format!(
                    "fit: the data do not determine {name} (best {}, relative standard uncertainty {rel:.2e} > {}); \
                     measure more or less noisy data",
                    crate::error::fmt_value(p),
                    crate::error::fmt_value(MAX_RELATIVE_STDERR)
                )));
            }
        }
        Ok(self)
    }
}

/// Solve the symmetric positive system A x = b (n ≤ ~10) by Gaussian elimination with partial
/// pivoting; `None` if singular.
fn solve(a: &[f64], b: &[f64], n: usize) -> Option<Vec<f64>> {
    let mut m: Vec<f64> = a.to_vec();
    let mut x = b.to_vec();
    for c in 0..n {
        let p = (c..n).max_by(|&i, &j| m[i * n + c].abs().total_cmp(&m[j * n + c].abs()))?;
        if m[p * n + c].abs() < 1e-300 {
            return None;
        }
        for k in 0..n {
            m.swap(c * n + k, p * n + k);
        }
        x.swap(c, p);
        for i in c + 1..n {
            let f = m[i * n + c] / m[c * n + c];
            for k in c..n {
                m[i * n + k] -= f * m[c * n + k];
            }
            x[i] -= f * x[c];
        }
    }
    for c in (0..n).rev() {
        let s: f64 = (c + 1..n).map(|k| m[c * n + k] * x[k]).sum();
        x[c] = (x[c] - s) / m[c * n + c];
    }
    Some(x)
}

/// Inverse of an n × n matrix by solving for each unit vector.
fn inverse(a: &[f64], n: usize) -> Option<Vec<f64>> {
    let mut inv = vec![0.0; n * n];
    for j in 0..n {
        let mut e = vec![0.0; n];
        e[j] = 1.0;
        let col = solve(a, &e, n)?;
        for i in 0..n {
            inv[i * n + j] = col[i];
        }
    }
    Some(inv)
}

fn chi2(f: &[f64], y: &[f64], s: &[f64]) -> f64 {
    f.iter().zip(y).zip(s).map(|((fi, yi), si)| ((yi - fi) / si).powi(2)).sum()
}

/// Fit positive parameters `p0` of `model` (returns one prediction per datum) to data `y` with
/// standard deviations `sigma` (> 0).
pub fn levenberg_marquardt(
    model: &dyn Fn(&[f64]) -> Result<Vec<f64>>,
    y: &[f64],
    sigma: &[f64],
    p0: &[f64],
) -> Result<Fit> {
    let (m, n) = (y.len(), p0.len());
    if sigma.len() != m {
        return Err(Error::Invalid(format!("fit: {} data but {} uncertainties", m, sigma.len())));
    }
    if m < n {
        return Err(Error::Invalid(format!("fit: {m} data cannot determine {n} parameters")));
    }
    for (i, (&v, &s)) in y.iter().zip(sigma).enumerate() {
        if !v.is_finite() {
            return Err(Error::param(format!("data[{i}]"), v, "a finite number"));
        }
        if !(s > 0.0 && s.is_finite()) {
            return Err(Error::param(format!("sigma[{i}]"), s, "a finite number > 0 (the datum's standard deviation)"));
        }
    }
    for (i, &p) in p0.iter().enumerate() {
        if !(p > 0.0 && p.is_finite()) {
            return Err(Error::param(format!("initial[{i}]"), p, "a finite number > 0"));
        }
    }
    let eval = |q: &[f64]| -> Result<Vec<f64>> {
        let p: Vec<f64> = q.iter().map(|x| x.exp()).collect();
        model(&p)
    };
    let jac = |q: &[f64]| -> Result<Vec<f64>> {
        let h = 1e-4;
        let mut j = vec![0.0; m * n];
        for k in 0..n {
            let (mut a, mut b) = (q.to_vec(), q.to_vec());
            a[k] += h;
            b[k] -= h;
            let (fa, fb) = (eval(&a)?, eval(&b)?);
            for i in 0..m {
                j[i * n + k] = (fa[i] - fb[i]) / (2.0 * h) / sigma[i];
            }
        }
        Ok(j)
    };
    let mut q: Vec<f64> = p0.iter().map(|p| p.ln()).collect();
    let mut f = eval(&q)?;
    let mut c2 = chi2(&f, y, sigma);
    if !c2.is_finite() {
        return Err(Error::Invalid(format!(
            "fit: χ² = {} at the initial parameters (standard deviations far too small for the data's scale, \
             or initial values the model cannot evaluate); nothing was fitted",
            crate::error::fmt_value(c2)
        )));
    }
    let mut lambda = 1e-3;
    let mut it = 0;
    let mut j = jac(&q)?;
    while it < 200 {
        it += 1;
        let r: Vec<f64> = (0..m).map(|i| (y[i] - f[i]) / sigma[i]).collect();
        let mut jtj = vec![0.0; n * n];
        let mut jtr = vec![0.0; n];
        for a in 0..n {
            for i in 0..m {
                jtr[a] += j[i * n + a] * r[i];
            }
            for b in 0..n {
                jtj[a * n + b] = (0..m).map(|i| j[i * n + a] * j[i * n + b]).sum();
            }
        }
        let mut damped = jtj.clone();
        for a in 0..n {
            damped[a * n + a] *= 1.0 + lambda;
        }
        let Some(step) = solve(&damped, &jtr, n) else {
            lambda *= 10.0;
            continue;
        };
        let qn: Vec<f64> = q.iter().zip(&step).map(|(a, b)| a + b.clamp(-2.0, 2.0)).collect();
        // A trial step the model refuses (e.g. outside a table) is a rejected step.
        let (fnew, cn) = match eval(&qn) {
            Ok(v) => {
                let c = chi2(&v, y, sigma);
                (v, c)
            }
            Err(_) => (Vec::new(), f64::INFINITY),
        };
        if cn.is_finite() && cn <= c2 {
            let done = (c2 - cn) <= 1e-10 * c2.max(1e-300) && step.iter().all(|s| s.abs() < 1e-8);
            q = qn;
            f = fnew;
            c2 = cn;
            lambda = (lambda / 10.0).max(1e-12);
            j = jac(&q)?;
            if done {
                break;
            }
        } else {
            lambda *= 10.0;
            if lambda > 1e12 {
                break;
            }
        }
    }
    let mut jtj = vec![0.0; n * n];
    for a in 0..n {
        for b in 0..n {
            jtj[a * n + b] = (0..m).map(|i| j[i * n + a] * j[i * n + b]).sum();
        }
    }
    let covq = inverse(&jtj, n)
        .ok_or_else(|| Error::Invalid("fit: the data do not determine the parameters (singular Jacobian)".into()))?;
    let p: Vec<f64> = q.iter().map(|x| x.exp()).collect();
    let cov = (0..n * n).map(|k| p[k / n] * p[k % n] * covq[k]).collect();
    Ok(Fit { params: p, cov, chi2: c2, dof: m - n, iterations: it })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Straight line y = a x + b with known noise: the covariance equals the textbook
    /// (XᵀWX)⁻¹ (Press et al. §15.2) at the solution.
    #[test]
    fn line_fit_covariance() {
        let x: Vec<f64> = (1..=20).map(|i| i as f64).collect();
        let s = vec![0.5; 20];
        let mut rng = crate::stats::SplitMix64::new(3);
        let y: Vec<f64> = x
            .iter()
            .map(|&xi| {
                let (u1, u2) = (rng.next_f64().max(1e-300), rng.next_f64());
                2.0 * xi + 3.0 + 0.5 * (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
            })
            .collect();
        let model = |p: &[f64]| Ok(x.iter().map(|&xi| p[0] * xi + p[1]).collect());
        let fit = levenberg_marquardt(&model, &y, &s, &[1.0, 1.0]).unwrap();
        let (sw, sx, sxx) = (20.0 / 0.25, x.iter().sum::<f64>() / 0.25, x.iter().map(|v| v * v).sum::<f64>() / 0.25);
        let det = sw * sxx - sx * sx;
        assert!((fit.cov[0] - sw / det).abs() < 1e-6 * sw / det, "{:?}", fit.cov);
        assert!((fit.cov[3] - sxx / det).abs() < 1e-6 * sxx / det);
        assert!((fit.params[0] - 2.0).abs() < 4.0 * fit.stderr()[0]);
        assert_eq!(fit.dof, 18);
    }
}
