//! The error type of lidarqa-tpu.

/// What can go wrong when propagating uncertainty.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The sensor or geometry was refused by the model.
    #[error(transparent)]
    Model(#[from] lidarqa_model::Error),
    /// The georeferencing produced a non-finite value (e.g. total internal reflection in the prism).
    #[error("the georeferencing is not finite at this geometry ({what})")]
    NotFinite {
        /// What was being computed.
        what: &'static str,
    },
    /// A sweep specification that cannot be used.
    #[error("invalid sweep '{spec}': {reason}")]
    InvalidSweep {
        /// The specification as given.
        spec: String,
        /// Why it is refused.
        reason: String,
    },
    /// A geometry flag that does not fit the scanner.
    #[error("{0}")]
    Geometry(String),
}

/// Result with the lidarqa-tpu [`Error`].
pub type Result<T> = std::result::Result<T, Error>;
