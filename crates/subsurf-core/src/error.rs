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
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Parameter { field, value, allowed } => {
                write!(f, "{field} = {value} is out of range: must be {allowed}")
            }
            Error::Invalid(msg) => f.write_str(msg),
        }
    }
}

impl std::error::Error for Error {}

/// Check `value` is finite and `>= 0`.
pub fn check_nonneg(field: &str, value: f64) -> Result<f64> {
    if value.is_finite() && value >= 0.0 {
        Ok(value)
    } else {
        Err(Error::param(field, value, "a finite number >= 0"))
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
        assert!(check_index("n", f64::INFINITY).is_err());
        assert_eq!(check_index("n", 1.0), Ok(1.0));
    }
}
