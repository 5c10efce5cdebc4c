//! [`TallyConfig`]: which histograms a run scores and on which grids (mirrors the Python
//! `subsurf.Tallies` dataclass field by field).

use crate::error::{Error, Result};

/// Largest number of bins allowed in one histogram (each bin costs 24 bytes per chunk tally).
pub const MAX_BINS: usize = 10_000_000;
/// Largest scattering order `K` of the per-order split.
pub const MAX_ORDER: u32 = 10_000;

/// Grids and switches of the optional tallies. Radial, depth and time axes start at 0 and
/// their last bin also collects everything beyond the grid (MCML's convention, Wang et al.
/// 1995 §4.2), so that every histogram integrates to its total exactly.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TallyConfig {
    /// Number of radial bins (≥ 1).
    pub nr: usize,
    /// Radial bin width, mm (> 0).
    pub dr: f64,
    /// Number of depth bins (≥ 1).
    pub nz: usize,
    /// Depth bin width, mm (> 0).
    pub dz: f64,
    /// Number of exit-angle bins over θ ∈ [0, π/2] (≥ 1); width π/(2 na), rad.
    pub na: usize,
    /// Number of time bins (0 disables the time-resolved tallies).
    pub nt: usize,
    /// Time bin width, ps (> 0).
    pub dt: f64,
    /// `Some((n_cos, n_phi))`: BRDF/BTDF on `n_cos` bins uniform in cos θ ∈ [0, 1] times `n_phi`
    /// bins uniform in φ ∈ [0, 2π) (equal solid angle); dimensionless counts ≥ 1.
    pub brdf: Option<(usize, usize)>,
    /// `Some(K)`: split totals (and BRDF/BTDF) by scattering order 0 … K and > K, and score the
    /// `*_single_direct` tallies.
    pub max_order: Option<u32>,
    /// R(r), T(r), A(z), A(r,z), fluence (and R(r,t) with `nt > 0`).
    pub spatial: bool,
    /// R(θ), T(θ) (and R(r,θ), T(r,θ) with `spatial`).
    pub angular: bool,
    /// Keep standard errors of the histograms (batch means, see [`super::accum`]); `false`
    /// skips them entirely (stderr NaN) and makes every deposit a single add.
    pub errors: bool,
}

impl Default for TallyConfig {
    /// The defaults of `subsurf.Tallies()`.
    fn default() -> Self {
        TallyConfig {
            nr: 100,
            dr: 0.01,
            nz: 100,
            dz: 0.01,
            na: 30,
            nt: 0,
            dt: 1.0,
            brdf: None,
            max_order: None,
            spatial: true,
            angular: true,
            errors: true,
        }
    }
}

fn check_count(field: &str, n: usize, min: usize) -> Result<()> {
    if n < min || n > MAX_BINS {
        let allowed = if min == 0 { "an integer in [0, 10000000]" } else { "an integer in [1, 10000000]" };
        return Err(Error::param(field, n as f64, allowed));
    }
    Ok(())
}

fn check_width(field: &str, w: f64) -> Result<()> {
    if w.is_finite() && w > 0.0 {
        Ok(())
    } else {
        Err(Error::param(field, w, "a finite number > 0"))
    }
}

fn check_product(what: &str, dims: &[usize]) -> Result<()> {
    let total = dims.iter().try_fold(1usize, |a, &d| a.checked_mul(d));
    match total {
        Some(t) if t <= MAX_BINS => Ok(()),
        _ => Err(Error::Invalid(format!(
            "tallies: the {what} histogram would have {dims:?} bins, more than {MAX_BINS} in all; use coarser grids"
        ))),
    }
}

impl TallyConfig {
    /// Check every field (names as in `subsurf.Tallies`).
    pub fn validate(&self) -> Result<()> {
        check_count("tallies.nr", self.nr, 1)?;
        check_width("tallies.dr", self.dr)?;
        check_count("tallies.nz", self.nz, 1)?;
        check_width("tallies.dz", self.dz)?;
        check_count("tallies.na", self.na, 1)?;
        check_count("tallies.nt", self.nt, 0)?;
        check_width("tallies.dt", self.dt)?;
        if let Some((nc, np)) = self.brdf {
            check_count("tallies.brdf[0]", nc, 1)?;
            check_count("tallies.brdf[1]", np, 1)?;
        }
        if let Some(k) = self.max_order {
            if k > MAX_ORDER {
                return Err(Error::param("tallies.max_order", k as f64, "an integer in [0, 10000]"));
            }
        }
        if self.spatial {
            check_product("a_rz", &[self.nr, self.nz])?;
            if self.angular {
                check_product("rd_ra", &[self.nr, self.na])?;
            }
            check_product("rd_rt", &[self.nr, self.nt.max(1)])?;
        }
        if let (Some((nc, np)), Some(k)) = (self.brdf, self.max_order) {
            check_product("brdf_order", &[k as usize + 2, nc, np])?;
        }
        Ok(())
    }

    /// Angular bin width π/(2 na), rad.
    pub fn da(&self) -> f64 {
        std::f64::consts::FRAC_PI_2 / self.na as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn validation_names_fields() {
        assert!(TallyConfig::default().validate().is_ok());
        let bad = |f: fn(&mut TallyConfig)| {
            let mut c = TallyConfig::default();
            f(&mut c);
            c.validate().unwrap_err().to_string()
        };
        assert!(bad(|c| c.nr = 0).starts_with("tallies.nr = 0"));
        assert!(bad(|c| c.dr = 0.0).starts_with("tallies.dr = 0"));
        assert!(bad(|c| c.dz = f64::NAN).starts_with("tallies.dz = NaN"));
        assert!(bad(|c| c.na = 0).starts_with("tallies.na"));
        assert!(bad(|c| c.dt = -1.0).starts_with("tallies.dt"));
        assert!(bad(|c| c.brdf = Some((0, 4))).starts_with("tallies.brdf[0]"));
        assert!(bad(|c| c.brdf = Some((4, 0))).starts_with("tallies.brdf[1]"));
        assert!(bad(|c| c.max_order = Some(20_000)).starts_with("tallies.max_order"));
        assert!(bad(|c| {
            c.nr = 10_000;
            c.nz = 10_000
        })
        .contains("a_rz"));
        let ok = TallyConfig { nt: 0, brdf: Some((10, 1)), max_order: Some(0), ..Default::default() };
        assert!(ok.validate().is_ok());
    }
}
