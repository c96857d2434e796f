//! Why no trajectory could be built, or a file could not be read or written.

use crate::PulseChecks;
use std::path::PathBuf;

/// The trajectory reconstruction's errors.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Too few usable multi-return pulses.
    #[error(
        "{lines} usable multi-return pulses (first and last return at least {min_separation_m} m \
         apart) where one block needs {min_lines}: the data need vegetation or other \
         multi-return targets, and their GPS times and return numbers ({checks})"
    )]
    TooFewPulses {
        /// Lines found.
        lines: u64,
        /// Lines needed.
        min_lines: usize,
        /// Separation asked for, m.
        min_separation_m: f64,
        /// What the checks found.
        checks: PulseChecks,
    },
    /// An option out of range.
    #[error("{0}")]
    InvalidOption(String),
    /// A point file or an output could not be read or written.
    #[error(transparent)]
    Io(#[from] lidarqa_io::Error),
    /// A file whose content cannot be right (mixed time bases, orthometric heights for an
    /// SBET, no trajectory from its points).
    #[error("{}: {message}", path.display())]
    Implausible {
        /// The file at fault (or whose points show the fault).
        path: PathBuf,
        /// What, the value, and the likely cause.
        message: String,
    },
    /// A point format without GPS time: pulses cannot be told apart.
    #[error("{}: point format {format} has no GPS time; the pulses need it", path.display())]
    NoGpsTime {
        /// The LAS/LAZ file.
        path: PathBuf,
        /// Its point format.
        format: u8,
    },
    /// A time that cannot be put into GPS seconds of week.
    #[error("{message} (epoch {index})")]
    BadTime {
        /// Zero-based epoch index.
        index: u64,
        /// lidarqa-io's message.
        message: String,
    },
}

/// The crate's result.
pub type Result<T> = std::result::Result<T, Error>;
