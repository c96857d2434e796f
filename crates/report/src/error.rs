//! The crate's error: every variant names the file at fault.

use std::path::PathBuf;

/// Everything that can go wrong while reading products or writing the report.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The input directory does not exist or is not a directory.
    #[error("{}: not a directory", path.display())]
    NotADirectory {
        /// The path given.
        path: PathBuf,
    },
    /// A file or directory could not be read.
    #[error("{}: {source}", path.display())]
    Read {
        /// The file or directory.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// A product is not valid JSON or does not match its schema.
    #[error("{}: malformed JSON{}: {source}", path.display(), if key.is_empty() || key == "." { String::new() } else { format!(" at `{key}`") })]
    Json {
        /// The product file.
        path: PathBuf,
        /// The JSON key at fault (dotted path, `.` for the document itself).
        key: String,
        /// serde_json's error (with the line and column).
        source: serde_json::Error,
    },
    /// A product parses but a value is impossible (e.g. a grid whose `nx·ny` differs from the
    /// number of cells, a histogram whose edges do not increase).
    #[error("{}: {key}: {message}", path.display())]
    Invalid {
        /// The product file.
        path: PathBuf,
        /// The JSON key at fault (dotted path).
        key: String,
        /// What is wrong with it.
        message: String,
    },
    /// Writing the report failed (the message names the output file).
    #[error(transparent)]
    Write(#[from] lidarqa_io::Error),
    /// Writing the report failed after it was opened.
    #[error("{}: {source}", path.display())]
    WriteIo {
        /// The output file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
}

impl Error {
    /// The file this error is about.
    pub fn path(&self) -> Option<&std::path::Path> {
        match self {
            Error::NotADirectory { path }
            | Error::Read { path, .. }
            | Error::Json { path, .. }
            | Error::Invalid { path, .. }
            | Error::WriteIo { path, .. } => Some(path),
            Error::Write(_) => None,
        }
    }
}

/// The crate's result.
pub type Result<T> = std::result::Result<T, Error>;
