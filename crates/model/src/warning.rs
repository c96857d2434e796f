//! A finding about the inputs that is doubtful but not impossible.
//!
//! Libraries never print (STYLE.md): they return these beside their results, and the CLI sends
//! each one to stderr, into the JSON `warnings` array (SPEC §7, `{"code", "message"}`) and into
//! the report. An input that cannot be physically right is an error, not a warning.

use serde::{Deserialize, Serialize};
use std::fmt;

/// One warning: a stable machine-readable `code` and a sentence for people that names the value
/// at fault and the likely cause.
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub struct Warning {
    /// Stable identifier, snake_case (e.g. `mounting_does_not_fit`); programs match on this.
    pub code: String,
    /// One line for people: what was found, the value, and the likely cause or fix.
    pub message: String,
}

impl Warning {
    /// A warning with the given code and message.
    pub fn new(code: impl Into<String>, message: impl Into<String>) -> Self {
        Warning {
            code: code.into(),
            message: message.into(),
        }
    }
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "warning ({}): {}", self.code, self.message)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn display_names_the_code_and_the_message() {
        let w = Warning::new(
            "trajectory_gap",
            "a 5.0 s gap at 1000.0 s inside strip s1.laz",
        );
        assert_eq!(
            w.to_string(),
            "warning (trajectory_gap): a 5.0 s gap at 1000.0 s inside strip s1.laz"
        );
    }
}
