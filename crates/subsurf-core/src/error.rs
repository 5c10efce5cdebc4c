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

    /// The same error with `prefix` before the field name (`mua` → `layers[1].mua`).
    pub fn within(self, prefix: &str) -> Self {
        match self {
            Error::Parameter { field, value, allowed } => {
                Error::Parameter { field: format!("{prefix}{field}"), value, allowed }
            }
            other => other,
        }
    }

    /// The same error about element `index` of array arguments (numpy order): the index goes
    /// after the argument's name in each term of the field (`wi.z` → `wi[2, 0].z`,
    /// `|wi|` → `|wi[3]|`, `sigma_a + sigma_s_prime` → `sigma_a[3] + sigma_s_prime[3]`).
    /// An empty `index` (a scalar argument) leaves the name as it is.
    pub fn at(self, index: &[usize]) -> Self {
        match self {
            Error::Parameter { field, value, allowed } if !index.is_empty() => {
                let idx = index.iter().map(|i| i.to_string()).collect::<Vec<_>>().join(", ");
                let field = field
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
                Error::Parameter { field, value, allowed }
            }
            other => other,
        }
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
            Error::Invalid(msg) => f.write_str(msg),
        }
    }
}

impl std::error::Error for Error {}

/// A number as messages show it: magnitudes in [1e-5, 1e9) in shortest round-trip decimal
/// (`3`, `-1`, `0.25`), others in exponent form (`1e-200`, `1.000001e12`).
pub fn fmt_value(v: f64) -> String {
    let a = v.abs();
    if v.is_finite() && v != 0.0 && !(1e-5..1e9).contains(&a) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
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
        assert_eq!(e.to_string(), "layers[2].g = 1 is out of range: must be a finite number with |g| < 1");
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
        assert_eq!(e("wi.z").at(&[2, 0]).to_string(), "wi[2, 0].z = 1 is out of range: must be x");
        assert!(e("|wi|").at(&[3]).to_string().starts_with("|wi[3]| = 1"));
        assert!(e("sigma_a + sigma_s_prime").at(&[3]).to_string().starts_with("sigma_a[3] + sigma_s_prime[3] = 1"));
        assert!(e("eta").at(&[]).to_string().starts_with("eta = 1"));
        assert!(e("mua").within("layers[1].").to_string().starts_with("layers[1].mua = 1"));
        assert_eq!(unravel(7, &[2, 3, 2]), vec![1, 0, 1]);
        assert_eq!(fmt_value(3.0), "3");
        assert_eq!(fmt_value(-1.0), "-1");
        assert_eq!(fmt_value(0.25), "0.25");
        assert_eq!(fmt_value(1e-200), "1e-200");
        assert_eq!(fmt_value(1e308), "1e308");
        assert_eq!(fmt_value(f64::NAN), "NaN");
        assert_eq!(fmt_value(f64::INFINITY), "inf");
    }
}
