//! The one error type of the core. The Python binding maps it to `ValueError` in one place.

use std::fmt;

/// Every way the core can refuse an input. Never panic on user data: return one of these.
#[derive(Debug, Clone, PartialEq)]
pub enum Error {
    /// A numeric parameter outside its allowed range, e.g. `layers[1].g = 1.2 (must satisfy |g| < 1)`.
    Parameter {
        /// The field, as the user knows it (`layers[0].mua`, `n_above`, `g`).
        field: String,
        /// The offending value.
        value: f64,
        /// The allowed range in words, e.g. "a finite number >= 0".
        allowed: &'static str,
    },
    /// An integer parameter outside its allowed range, e.g. `tallies.nr = 0 (must be an integer
    /// in [1, 10000000])`.
    IntParameter {
        /// The field, as the user knows it.
        field: String,
        /// The offending value.
        value: i128,
        /// The allowed range in words.
        allowed: &'static str,
    },
    /// Any other invalid input (empty stack, inconsistent grids …), with a full message.
    Invalid(String),
}

/// Shorthand used throughout the crate.
pub type Result<T> = std::result::Result<T, Error>;

impl Error {
    /// Build a [`Error::Parameter`].
    pub fn param(field: impl Into<String>, value: f64, allowed: &'static str) -> Self {
        Error::Parameter { field: field.into(), value, allowed }
    }

    /// Build an [`Error::IntParameter`].
    pub fn param_int(field: impl Into<String>, value: impl Into<i128>, allowed: &'static str) -> Self {
        Error::IntParameter { field: field.into(), value: value.into(), allowed }
    }

    /// The error for an integer parameter given as a number: [`Error::IntParameter`] when `value`
    /// is integral, else [`Error::Parameter`] (so `2.5` and `nan` are shown as given).
    pub fn param_count(field: impl Into<String>, value: f64, allowed: &'static str) -> Self {
        if value == value.trunc() && value.abs() < 1e38 {
            Error::param_int(field, value as i128, allowed)
        } else {
            Error::param(field, value, allowed)
        }
    }

    /// The field an error is about, if any.
    fn field_mut(&mut self) -> Option<&mut String> {
        match self {
            Error::Parameter { field, .. } | Error::IntParameter { field, .. } => Some(field),
            Error::Invalid(_) => None,
        }
    }

    /// The same error with `prefix` before the field name (`mua` → `layers[1].mua`).
    pub fn within(mut self, prefix: &str) -> Self {
        if let Some(f) = self.field_mut() {
            *f = format!("{prefix}{f}");
        }
        self
    }

    /// The same error about element `index` of array arguments (numpy order): the index goes
    /// after the argument's name in each term of the field (`wi.z` → `wi[2, 0].z`,
    /// `|wi|` → `|wi[3]|`, `sigma_a + sigma_s_prime` → `sigma_a[3] + sigma_s_prime[3]`).
    /// An empty `index` (a scalar argument) leaves the name as it is.
    pub fn at(mut self, index: &[usize]) -> Self {
        if index.is_empty() {
            return self;
        }
        if let Some(field) = self.field_mut() {
            let idx = index.iter().map(|i| i.to_string()).collect::<Vec<_>>().join(", ");
            *field = field
                .split(" + ")
                .map(|term| {
                    let start = term.find(|c: char| c.is_alphabetic() || c == '_').unwrap_or(0);
                    let end = term[start..]
                        .find(|c: char| !(c.is_alphanumeric() || c == '_'))
                        .map_or(term.len(), |k| start + k);
                    format!("{}[{idx}]{}", &term[..end], &term[end..])
                })
                .collect::<Vec<_>>()
                .join(" + ");
        }
        self
    }
}

/// The multi-index (numpy C order) of flat element `flat` of an array of `shape`.
pub fn unravel(mut flat: usize, shape: &[usize]) -> Vec<usize> {
    let mut idx = vec![0; shape.len()];
    for (k, &n) in shape.iter().enumerate().rev() {
        if n > 0 {
            idx[k] = flat % n;
            flat /= n;
        }
    }
    idx
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Parameter { field, value, allowed } => {
                write!(f, "{field} = {} is out of range: must be {allowed}", fmt_value(*value))
            }
            Error::IntParameter { field, value, allowed } => {
                write!(f, "{field} = {value} is out of range: must be {allowed}")
            }
            Error::Invalid(msg) => f.write_str(msg),
        }
    }
}

impl std::error::Error for Error {}

/// A float as messages show it: exactly as Python's `repr(float)` does (shortest round-trip
/// digits; `1.0`, `0.25`, `nan`, `inf`, and exponent form `1e-05`, `1e+20` outside [1e-4, 1e16)),
/// so messages read the same from Rust and from Python.
pub fn fmt_value(v: f64) -> String {
    if v.is_nan() {
        return "nan".into();
    }
    if v.is_infinite() {
        return if v > 0.0 { "inf".into() } else { "-inf".into() };
    }
    let a = v.abs();
    if a == 0.0 || (1e-4..1e16).contains(&a) {
        let s = format!("{v}");
        return if s.contains('.') { s } else { s + ".0" };
    }
    let s = format!("{v:e}");
    let (mant, exp) = s.split_once('e').expect("exponent form");
    let e: i32 = exp.parse().expect("an integer exponent");
    format!("{mant}e{}{:02}", if e < 0 { '-' } else { '+' }, e.abs())
}

/// Check `value` is finite and `>= 0`.
pub fn check_nonneg(field: &str, value: f64) -> Result<f64> {
    if value.is_finite() && value >= 0.0 {
        Ok(value)
    } else {
        Err(Error::param(field, value, "a finite number >= 0"))
    }
}

/// Check an interaction coefficient (mm⁻¹): 0, or a finite number ≥ [`f64::MIN_POSITIVE`]
/// (2.2e-308). A subnormal coefficient has no finite reciprocal (mean free path), so the
/// physics cannot be computed with it.
pub fn check_coefficient(field: &str, value: f64) -> Result<f64> {
    if value == 0.0 || (value.is_finite() && value >= f64::MIN_POSITIVE) {
        Ok(value)
    } else {
        Err(Error::param(field, value, "0 or a finite number >= 2.2e-308 (mm^-1)"))
    }
}

/// Check `|g| < 1` and finite.
pub fn check_g(field: &str, g: f64) -> Result<f64> {
    if g.is_finite() && g.abs() < 1.0 {
        Ok(g)
    } else {
        Err(Error::param(field, g, "a finite number with |g| < 1"))
    }
}

/// Check a refractive index: finite and `>= 1`.
pub fn check_index(field: &str, n: f64) -> Result<f64> {
    if n.is_finite() && n >= 1.0 {
        Ok(n)
    } else {
        Err(Error::param(field, n, "a finite number >= 1"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_name_field_and_range() {
        let e = check_g("layers[2].g", 1.0).unwrap_err();
        assert_eq!(e.to_string(), "layers[2].g = 1.0 is out of range: must be a finite number with |g| < 1");
        assert!(check_nonneg("mua", f64::NAN).is_err());
        assert!(check_nonneg("mua", -0.1).is_err());
        assert!(check_nonneg("mua", f64::INFINITY).is_err());
        assert_eq!(check_nonneg("mua", 0.0), Ok(0.0));
        assert!(check_index("n", 0.99).is_err());
        assert!(check_coefficient("mus", 1e-320).unwrap_err().to_string().starts_with("mus = 1e-320 is out"));
        assert!(check_coefficient("mus", -1.0).is_err() && check_coefficient("mus", f64::INFINITY).is_err());
        assert_eq!(check_coefficient("mus", 0.0), Ok(0.0));
        assert!(check_index("n", f64::INFINITY).is_err());
        assert_eq!(check_index("n", 1.0), Ok(1.0));
        let e = |f: &str| Error::param(f, 1.0, "x");
        assert_eq!(e("wi.z").at(&[2, 0]).to_string(), "wi[2, 0].z = 1.0 is out of range: must be x");
        assert!(e("|wi|").at(&[3]).to_string().starts_with("|wi[3]| = 1.0"));
        assert!(e("sigma_a + sigma_s_prime").at(&[3]).to_string().starts_with("sigma_a[3] + sigma_s_prime[3] = 1.0"));
        assert!(e("eta").at(&[]).to_string().starts_with("eta = 1.0"));
        assert!(e("mua").within("layers[1].").to_string().starts_with("layers[1].mua = 1.0"));
        assert!(Error::param_int("nr", 0, "x").within("tallies.").to_string().starts_with("tallies.nr = 0 is"));
        assert_eq!(unravel(7, &[2, 3, 2]), vec![1, 0, 1]);
        // as Python's repr(float)
        for (v, want) in [
            (3.0, "3.0"),
            (-1.0, "-1.0"),
            (0.25, "0.25"),
            (1e-200, "1e-200"),
            (1e308, "1e+308"),
            (1.5e-5, "1.5e-05"),
            (1e16, "1e+16"),
            (123456789.0, "123456789.0"),
            (0.0001, "0.0001"),
            (f64::NAN, "nan"),
            (f64::NEG_INFINITY, "-inf"),
        ] {
            assert_eq!(fmt_value(v), want);
        }
        assert_eq!(Error::param_count("n", 2.0, "x").to_string(), "n = 2 is out of range: must be x");
        assert_eq!(Error::param_count("n", 2.5, "x").to_string(), "n = 2.5 is out of range: must be x");
    }
}
