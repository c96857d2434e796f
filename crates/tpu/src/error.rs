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
    /// A raw record of range and scan angle for a sensor that is not a linear scanner.
    #[error(
        "scanner is {kind}, but a raw record of range and scan angle comes from a linear scanner"
    )]
    NotLinearScanner {
        /// The sensor's scanner kind.
        kind: &'static str,
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
    /// A systematic-error list (`KEY=VALUE,...`) that cannot be read: the item and why.
    #[error("{0}")]
    InvalidBias(String),
    /// A trajectory that cannot be interpolated: fewer than two poses, a time going back, a
    /// non-finite value (`index` is the pose at fault).
    #[error("trajectory pose {index}: {message}")]
    InvalidTrajectory {
        /// Zero-based index of the pose at fault.
        index: usize,
        /// What is wrong, lowercase.
        message: String,
    },
    /// A time outside the trajectory's time span (no extrapolation).
    #[error("time {time_s} s is outside the trajectory span [{start_s}, {end_s}] s")]
    OutsideTrajectory {
        /// The time asked for, GPS seconds of week.
        time_s: f64,
        /// First pose time, s.
        start_s: f64,
        /// Last pose time, s.
        end_s: f64,
    },
    /// A point from which no raw observation can be recovered (it coincides with the scanner
    /// origin, or lies behind or off the scanner's beam geometry).
    #[error("cannot recover the raw observation: {0}")]
    Recovery(String),
    /// A bathymetric sounding that is not below its water surface.
    #[error(
        "negative depth: the sounding is {depth_m:.3} m below its water surface (water range {range_water_m:.3} m); a sounding must lie below the surface"
    )]
    NegativeDepth {
        /// Height of the surface above the sounding, m (≤ 0 here, or the water range is).
        depth_m: f64,
        /// Recovered water range ρ2, m.
        range_water_m: f64,
    },
    /// A bathymetric sounding with no water surface above it: no surface return of its own
    /// pulse and too few water-surface returns around it for a modelled surface.
    #[error(
        "no water surface above the sounding: no water-surface return (class 41) of its pulse and {found} within {radius_m} m (at least 3 needed for a modelled surface)"
    )]
    NoWaterSurface {
        /// Water-surface returns found within the radius.
        found: usize,
        /// Search radius, m.
        radius_m: f64,
    },
}

/// Result with the lidarqa-tpu [`Error`].
pub type Result<T> = std::result::Result<T, Error>;
