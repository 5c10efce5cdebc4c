//! [`TallyConfig`]: which histograms a run scores and on which grids (mirrors the Python
//! `subsurf.Tallies` dataclass field by field).

use crate::error::{Error, Result};

/// Largest number of bins allowed in one histogram (each bin costs 32 bytes per chunk tally in
/// flight and 72 bytes of exact sums per thread and per run; see `mc::run::memory_estimate`).
pub const MAX_BINS: usize = 10_000_000;
/// Largest scattering order `K` of the per-order split.
pub const MAX_ORDER: u32 = 10_000;
/// Smallest bin width (dr, dz in mm; dt in ps): bin measures (dr² for annuli) and their
/// reciprocals stay normal floating-point numbers.
pub const MIN_WIDTH: f64 = 1e-100;
/// Largest bin width (same units as [`MIN_WIDTH`]).
pub const MAX_WIDTH: f64 = 1e100;

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

fn count_allowed(min: usize) -> &'static str {
    if min == 0 {
        "an integer in [0, 10000000]"
    } else {
        "an integer in [1, 10000000]"
    }
}

fn check_count(field: &str, n: usize, min: usize) -> Result<()> {
    if n < min || n > MAX_BINS {
        return Err(Error::param_int(field, n as i128, count_allowed(min)));
    }
    Ok(())
}

/// A bin count given as any number (negative, huge or fractional values get the range message).
fn count_from(field: &str, v: f64, min: usize) -> Result<usize> {
    if v == v.trunc() && v >= min as f64 && v <= MAX_BINS as f64 {
        Ok(v as usize)
    } else {
        Err(Error::param_count(field, v, count_allowed(min)))
    }
}

fn check_width(field: &str, w: f64) -> Result<()> {
    if (MIN_WIDTH..=MAX_WIDTH).contains(&w) {
        Ok(())
    } else {
        Err(Error::param(field, w, "a number in [1e-100, 1e100]"))
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

/// A field of [`TallyConfig`] with its value ([`TallyConfig::fields`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TallyValue {
    /// A bin count.
    Count(usize),
    /// A bin width (mm or ps).
    Width(f64),
    /// An optional pair of bin counts (`brdf`).
    Pair(Option<(usize, usize)>),
    /// An optional scattering order (`max_order`).
    Order(Option<u32>),
    /// A switch.
    Flag(bool),
}

impl TallyValue {
    /// The kind's name, as the Python side reads it: "count", "length", "pair", "order", "bool".
    pub fn kind(&self) -> &'static str {
        match self {
            TallyValue::Count(_) => "count",
            TallyValue::Width(_) => "length",
            TallyValue::Pair(_) => "pair",
            TallyValue::Order(_) => "order",
            TallyValue::Flag(_) => "bool",
        }
    }

    /// This value as user input.
    pub fn input(&self) -> TallyInput {
        match *self {
            TallyValue::Count(n) => TallyInput::Number(n as f64),
            TallyValue::Width(w) => TallyInput::Number(w),
            TallyValue::Pair(p) => TallyInput::Pair(p.map(|(a, b)| (a as f64, b as f64))),
            TallyValue::Order(k) => TallyInput::Optional(k.map(f64::from)),
            TallyValue::Flag(b) => TallyInput::Flag(b),
        }
    }
}

/// A field's value as a user gives it: numbers as f64, so that any input (negative, huge,
/// fractional) gets the field's range in its message.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TallyInput {
    Number(f64),
    Pair(Option<(f64, f64)>),
    Optional(Option<f64>),
    Flag(bool),
}

impl TallyConfig {
    /// Every field and its value, in declaration order: the one list of the fields, which the
    /// binding, `subsurf.Tallies` and the `[tallies]` table of configuration files follow (the
    /// destructuring is exhaustive: a new field does not compile until it is listed here).
    pub fn fields(&self) -> [(&'static str, TallyValue); 12] {
        use TallyValue::*;
        let TallyConfig { nr, dr, nz, dz, na, nt, dt, brdf, max_order, spatial, angular, errors } = *self;
        [
            ("nr", Count(nr)),
            ("dr", Width(dr)),
            ("nz", Count(nz)),
            ("dz", Width(dz)),
            ("na", Count(na)),
            ("nt", Count(nt)),
            ("dt", Width(dt)),
            ("brdf", Pair(brdf)),
            ("max_order", Order(max_order)),
            ("spatial", Flag(spatial)),
            ("angular", Flag(angular)),
            ("errors", Flag(errors)),
        ]
    }

    /// A validated configuration from user input: the defaults with the given fields replaced
    /// (names as in [`Self::fields`]; an unknown name or a value of the wrong kind is an error).
    pub fn from_inputs<'a>(inputs: impl IntoIterator<Item = (&'a str, TallyInput)>) -> Result<TallyConfig> {
        let mut c = TallyConfig::default();
        for (name, v) in inputs {
            c.set(name, v)?;
        }
        c.validate()?;
        Ok(c)
    }

    fn set(&mut self, name: &str, v: TallyInput) -> Result<()> {
        let field = format!("tallies.{name}");
        let wrong = || {
            let kind = Self::default().fields().iter().find(|f| f.0 == name).map_or("?", |f| f.1.kind());
            Error::Invalid(format!("{field}: expected a value of kind {kind}, got {v:?}"))
        };
        match (name, v) {
            ("nr", TallyInput::Number(x)) => self.nr = count_from(&field, x, 1)?,
            ("dr", TallyInput::Number(x)) => self.dr = x,
            ("nz", TallyInput::Number(x)) => self.nz = count_from(&field, x, 1)?,
            ("dz", TallyInput::Number(x)) => self.dz = x,
            ("na", TallyInput::Number(x)) => self.na = count_from(&field, x, 1)?,
            ("nt", TallyInput::Number(x)) => self.nt = count_from(&field, x, 0)?,
            ("dt", TallyInput::Number(x)) => self.dt = x,
            ("brdf", TallyInput::Pair(p)) => {
                self.brdf = match p {
                    Some((c, q)) => Some((count_from("tallies.brdf[0]", c, 1)?, count_from("tallies.brdf[1]", q, 1)?)),
                    None => None,
                }
            }
            ("max_order", TallyInput::Optional(k)) => {
                self.max_order = match k {
                    Some(k) if k == k.trunc() && (0.0..=MAX_ORDER as f64).contains(&k) => Some(k as u32),
                    Some(k) => return Err(Error::param_count(&field, k, "an integer in [0, 10000] (or None)")),
                    None => None,
                }
            }
            ("spatial", TallyInput::Flag(b)) => self.spatial = b,
            ("angular", TallyInput::Flag(b)) => self.angular = b,
            ("errors", TallyInput::Flag(b)) => self.errors = b,
            _ if Self::default().fields().iter().any(|f| f.0 == name) => return Err(wrong()),
            _ => {
                let names: Vec<&str> = Self::default().fields().iter().map(|f| f.0).collect();
                return Err(Error::Invalid(format!("tallies: unknown field {name:?} (known: {names:?})")));
            }
        }
        Ok(())
    }

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
            check_product("brdf", &[nc, np])?;
        }
        if let Some(k) = self.max_order {
            if k > MAX_ORDER {
                return Err(Error::param_int("tallies.max_order", k, "an integer in [0, 10000] (or None)"));
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
        assert!(bad(|c| c.dz = f64::NAN).starts_with("tallies.dz = nan"));
        assert!(bad(|c| c.dr = 1e-200).starts_with("tallies.dr = 1e-200 is out of range"));
        assert!(bad(|c| c.dt = 1e101).contains("[1e-100, 1e100]"));
        assert!(bad(|c| c.brdf = Some((10_000_000, 10_000_000))).contains("brdf"));
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
        let num = |nr: f64, k: Option<f64>| {
            TallyConfig::from_inputs([("nr", TallyInput::Number(nr)), ("max_order", TallyInput::Optional(k))])
        };
        assert!(num(-1.0, None).unwrap_err().to_string().starts_with("tallies.nr = -1 is out of range"));
        assert!(num(1e20, None).unwrap_err().to_string().starts_with("tallies.nr = 100000000000000000000 is out"));
        assert!(num(2.5, None).is_err() && num(3.0, None).is_ok());
        assert!(num(3.0, Some(-1.0)).unwrap_err().to_string().starts_with("tallies.max_order = -1"));
        let e = TallyConfig::from_inputs([("nr", TallyInput::Flag(true))]).unwrap_err().to_string();
        assert!(e.starts_with("tallies.nr: expected a value of kind count"), "{e}");
        let e = TallyConfig::from_inputs([("bins", TallyInput::Flag(true))]).unwrap_err().to_string();
        assert!(e.contains("unknown field \"bins\"") && e.contains("errors"), "{e}");
        let ok = TallyConfig { nt: 0, brdf: Some((10, 1)), max_order: Some(0), ..Default::default() };
        assert!(ok.validate().is_ok());
    }

    /// Every field of [`TallyConfig::fields`] can be set by name: a configuration differing
    /// from the defaults in every field round-trips through its inputs.
    #[test]
    fn every_field_round_trips_by_name() {
        let c = TallyConfig {
            nr: 7,
            dr: 0.5,
            nz: 8,
            dz: 0.25,
            na: 9,
            nt: 3,
            dt: 2.0,
            brdf: Some((4, 5)),
            max_order: Some(6),
            spatial: false,
            angular: false,
            errors: false,
        };
        for ((_, a), (_, b)) in c.fields().iter().zip(TallyConfig::default().fields().iter()) {
            assert_ne!(a, b, "the test configuration must differ from the defaults in every field");
        }
        let back = TallyConfig::from_inputs(c.fields().iter().map(|(n, v)| (*n, v.input()))).unwrap();
        assert_eq!(back, c);
        let debug = format!("{:?}", TallyConfig::default());
        let names: Vec<&str> = debug.split([' ', '{', ',']).filter_map(|w| w.strip_suffix(':')).collect();
        let listed: Vec<&str> = TallyConfig::default().fields().iter().map(|f| f.0).collect();
        assert_eq!(names, listed, "fields() lists the struct's fields in order");
    }
}
