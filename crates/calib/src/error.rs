//! The error type of lidarqa-calib.

/// What can go wrong when calibrating, correcting or comparing strips.
///
/// Messages are lowercase with no final period and name the strip, tie or option at fault.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// An option outside its valid range.
    #[error("option {name} must be {expected}, got {value}")]
    InvalidOption {
        /// The option's name (with its unit suffix).
        name: &'static str,
        /// What it must be.
        expected: &'static str,
        /// The value given.
        value: f64,
    },
    /// The strip adjustment cannot run with these options.
    #[error("strip adjustment {0}")]
    InvalidStripAdjustment(String),
    /// Fewer strips than the job needs.
    #[error("{what} needs at least {needed} strips, got {got}")]
    TooFewStrips {
        /// What was asked for.
        what: &'static str,
        /// Minimum number of strips.
        needed: usize,
        /// Number given.
        got: usize,
    },
    /// A strip with no points.
    #[error("strip {strip} has no points")]
    EmptyStrip {
        /// The strip's id.
        strip: String,
    },
    /// Two strips with the same id.
    #[error("strip id {strip} is used twice")]
    DuplicateStrip {
        /// The repeated id.
        strip: String,
    },
    /// A point whose coordinates or raw observation are not finite.
    #[error("strip {strip}: point {index} has a non-finite coordinate or observation")]
    NonFinitePoint {
        /// The strip's id.
        strip: String,
        /// Zero-based index of the point in the strip.
        index: usize,
    },
    /// A strip whose horizontal extent meets no other strip's.
    #[error("strip {strip} does not overlap any other strip")]
    NoOverlap {
        /// The strip's id.
        strip: String,
    },
    /// A tie pick naming a strip that is not among the inputs.
    #[error("tie {tie}: unknown strip {strip}")]
    UnknownStrip {
        /// The tie's id.
        tie: String,
        /// The strip named by the pick.
        strip: String,
    },
    /// A tie with fewer than two usable strips, or two ties with the same id.
    #[error("tie {tie}: {message}")]
    InvalidTie {
        /// The tie's id.
        tie: String,
        /// What is wrong, lowercase.
        message: String,
    },
    /// A tie pick with no point of its strip within the search radius.
    #[error(
        "tie {tie} is outside strip {strip}: no point within {radius_m} m of (north {north_m:.3}, east {east_m:.3})"
    )]
    TieOutsideStrip {
        /// The tie's id.
        tie: String,
        /// The strip's id.
        strip: String,
        /// Search radius, m.
        radius_m: f64,
        /// Pick, local north, m.
        north_m: f64,
        /// Pick, local east, m.
        east_m: f64,
    },
    /// A tie or control point that no strip covers.
    #[error("{what} {id} at (north {north_m:.3}, east {east_m:.3}) is outside every strip")]
    OutsideEveryStrip {
        /// `tie` or `control point`.
        what: &'static str,
        /// Its id.
        id: String,
        /// Local north, m.
        north_m: f64,
        /// Local east, m.
        east_m: f64,
    },
    /// RANSAC found no plane, or the pick is outside every triangle of the coplanar points.
    #[error("tie {tie}: no coplanar triangle around the pick in strip {strip} ({reason})")]
    NoCoplanarTriangle {
        /// The tie's id.
        tie: String,
        /// The strip's id.
        strip: String,
        /// Why, lowercase.
        reason: String,
    },
    /// Not enough independent observations for the unknowns.
    #[error(
        "too few ties: {ties} ties give {observations} independent observations, {unknowns} unknowns need at least {unknowns}{}",
        dropped_note(dropped)
    )]
    TooFewTies {
        /// Number of ties (control points included).
        ties: usize,
        /// Independent scalar observations they give.
        observations: usize,
        /// Number of unknowns.
        unknowns: usize,
        /// The picks that could not be formed, and why (they are why so few remain).
        dropped: Vec<crate::DroppedPick>,
    },
    /// No planar patch usable by the plane-based baseline or the automatic tie search.
    #[error("no usable {what}: {reason}")]
    NothingUsable {
        /// What was searched for.
        what: &'static str,
        /// Why nothing qualified.
        reason: String,
    },
    /// The adjustment produced a non-finite value.
    #[error("the adjustment diverged ({0})")]
    Diverged(String),
    /// A calibration document that cannot be used.
    #[error("calibration: {0}")]
    InvalidCalibration(String),
    /// Raw-observation recovery failed (from lidarqa-tpu).
    #[error(transparent)]
    Tpu(#[from] lidarqa_tpu::Error),
    /// The ties determine none of the parameters (each is held, with the reason).
    #[error("the ties determine none of the mounting parameters ({0})")]
    NothingDetermined(String),
}

/// Result with the lidarqa-calib [`Error`].
pub type Result<T> = std::result::Result<T, Error>;

/// ` (N picks dropped; the first: tie T in strip S: why)`, or nothing.
fn dropped_note(dropped: &[crate::DroppedPick]) -> String {
    match dropped.first() {
        None => String::new(),
        Some(d) => format!(
            " ({} picks dropped; the first: tie {} in strip {}: {})",
            dropped.len(),
            d.tie,
            d.strip,
            d.reason
        ),
    }
}
