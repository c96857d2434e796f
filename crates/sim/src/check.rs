//! Value checks shared by the scenario and scene checks: each error names the TOML key and value.

use crate::error::{Error, Result};

/// The error for `key = value`, refused for `reason`.
pub(crate) fn invalid(
    key: impl Into<String>,
    value: impl std::fmt::Display,
    reason: &str,
) -> Error {
    Error::InvalidValue {
        key: key.into(),
        value: value.to_string(),
        reason: reason.into(),
    }
}

/// `v` if finite and > 0.
pub(crate) fn positive(key: &str, v: f64) -> Result<f64> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(invalid(key, v, "must be a finite number > 0"))
    }
}

/// `v` if finite and >= 0.
pub(crate) fn non_negative(key: &str, v: f64) -> Result<f64> {
    if v.is_finite() && v >= 0.0 {
        Ok(v)
    } else {
        Err(invalid(key, v, "must be a finite number >= 0"))
    }
}

/// `v` if finite.
pub(crate) fn finite(key: &str, v: f64) -> Result<f64> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(invalid(key, v, "must be a finite number"))
    }
}
