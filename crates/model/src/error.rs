//! The error type of lidarqa-model.

/// What can go wrong when building a sensor or a geometry.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A 1-sigma value is negative or not finite.
    #[error("sigma of {source_name} must be a finite number >= 0, got {value}")]
    InvalidSigma {
        /// The source's snake_case name.
        source_name: &'static str,
        /// The value given (SI units).
        value: f64,
    },
    /// A refraction index is not a finite number > 1 (or, for air, >= 1).
    #[error("refraction index {name} must be a finite number > 1, got {value}")]
    InvalidRefractionIndex {
        /// Which index (`n_prism`, `n_air`, `n_water`).
        name: &'static str,
        /// The value given.
        value: f64,
    },
    /// The requested prism exit angle cannot be produced by any prism slope.
    #[error(
        "no prism slope gives an exit angle of {exit_angle_deg} deg (reachable: 0 to {max_deg:.3} deg)"
    )]
    UnreachableExitAngle {
        /// Requested exit angle, degrees.
        exit_angle_deg: f64,
        /// Largest exit angle before total internal reflection, degrees.
        max_deg: f64,
    },
    /// A prism slope outside (0°, 90°) or beyond total internal reflection.
    #[error(
        "prism slope {prism_slope_deg} deg is not usable (must be in (0, 90) deg without total internal reflection)"
    )]
    InvalidPrismSlope {
        /// The slope given, degrees.
        prism_slope_deg: f64,
    },
    /// A correlation matrix that is not square, symmetric, unit-diagonal and positive semi-definite.
    #[error("correlation matrix: {0}")]
    InvalidCorrelation(String),
    /// A beam scanner constant is out of range (see `BeamScanner::check`).
    #[error("beam scanner: {0}")]
    InvalidBeam(String),
    /// The beam never reaches the level surface below the sensor (it points up or sideways).
    #[error(
        "the beam cannot reach the surface {height_m} m below the sensor: it points {elevation_deg:.3} deg above the horizon"
    )]
    BeamMissesSurface {
        /// Height above the surface, metres.
        height_m: f64,
        /// Elevation of the beam above the horizon, degrees (>= 0 means it never descends).
        elevation_deg: f64,
    },
    /// A geometric quantity that must be positive is not.
    #[error("{name} must be a finite number > 0, got {value}")]
    NotPositive {
        /// Name of the quantity, with its unit suffix.
        name: &'static str,
        /// The value given.
        value: f64,
    },
    /// A geometric quantity that must be finite is not.
    #[error("{name} must be a finite number, got {value}")]
    NotFinite {
        /// Name of the quantity, with its unit suffix.
        name: &'static str,
        /// The value given.
        value: f64,
    },
}

/// Result with the lidarqa-model [`Error`].
pub type Result<T> = std::result::Result<T, Error>;
