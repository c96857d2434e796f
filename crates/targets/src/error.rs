//! The crate's error type.

/// Which input of an evaluation looks wrong (for the caller to name its file).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FrameSide {
    /// The control points.
    Control,
    /// The targets (lidar-measured points).
    Targets,
    /// Cannot tell which: they disagree.
    Both,
}

/// Everything that can go wrong in `lidarqa-targets`.
///
/// Each variant carries the value at fault; messages are lowercase without a final period
/// (STYLE.md, "Errors and user messages").
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The point cloud handed in is empty.
    #[error("no lidar points given")]
    NoPoints,

    /// Targets and control that cannot be in one projected frame (one side in degrees, or
    /// residuals of kilometres): folding them into an RMSE would be silently wrong.
    #[error("{message}")]
    NotOneFrame {
        /// The side at fault: [`FrameSide::Control`], [`FrameSide::Targets`] or both.
        side: FrameSide,
        /// What was seen and the likely cause.
        message: String,
    },
    /// A coordinate, intensity or sigma is NaN or infinite.
    #[error("non-finite {what} at index {index}: {value}")]
    NonFinite {
        /// Which quantity (e.g. `"intensity"`, `"x"`).
        what: &'static str,
        /// Index of the offending point (0-based, in the slice handed in).
        index: usize,
        /// The value found.
        value: f64,
    },
    /// A configuration value is out of its valid range.
    #[error("invalid {key} = {value}: {reason}")]
    InvalidConfig {
        /// The configuration key (field name).
        key: &'static str,
        /// The rejected value.
        value: f64,
        /// What the valid range is.
        reason: &'static str,
    },
    /// Fuzzy c-means cannot split the values into `clusters` classes.
    #[error(
        "fuzzy c-means needs at least {clusters} distinct intensity values, got {distinct} among {n} points"
    )]
    TooFewDistinctValues {
        /// Requested number of clusters c.
        clusters: usize,
        /// Distinct values found (counted up to `clusters`).
        distinct: usize,
        /// Number of values.
        n: usize,
    },
    /// The intensity threshold left no point (or the high cluster was empty).
    #[error(
        "no high-intensity point: none of {n} points reaches the threshold {threshold} ({rule})"
    )]
    NoHighIntensityPoints {
        /// Number of points searched.
        n: usize,
        /// The intensity threshold (intensity units of the input).
        threshold: f64,
        /// Name of the threshold rule that produced it.
        rule: String,
    },
    /// Two control points share an id.
    #[error("duplicate control point id {id:?}")]
    DuplicateControlId {
        /// The repeated id.
        id: String,
    },
    /// Two measured targets share an id.
    #[error("duplicate target id {id:?}")]
    DuplicateTargetId {
        /// The repeated id.
        id: String,
    },
    /// No control point given.
    #[error("no control points given")]
    NoControl,
    /// High-intensity clusters exist but none lies near any control point: typically the
    /// point cloud and the control are in different coordinate reference systems.
    #[error(
        "none of the {clusters} high-intensity clusters lies within {search_radius_m} m of any of the {control} control points (nearest is {nearest_m:.3} m away: different coordinate systems?)"
    )]
    NoTargetNearControl {
        /// Number of clusters found.
        clusters: usize,
        /// Number of control points.
        control: usize,
        /// The search radius used (m).
        search_radius_m: f64,
        /// Horizontal distance from the closest cluster centroid to its nearest control point (m).
        nearest_m: f64,
    },
    /// High-intensity clusters lie near control points, but only near those with a known
    /// target radius, where the plate model found no plate of that radius.
    #[error(
        "a high-intensity cluster lies {nearest_m:.3} m from control point {id}, but no plate of its radius {radius_m} m fits there (the plate model found no target): a wrong radius_m (a diameter?) or a target that is not a flat disc?"
    )]
    NoPlateAtControl {
        /// The control point nearest a cluster.
        id: String,
        /// Its target radius (m).
        radius_m: f64,
        /// Horizontal distance from that cluster's centroid to the control point (m).
        nearest_m: f64,
    },
    /// No target id matches a control id.
    #[error("no target id matches a control id ({targets} targets, {control} control points)")]
    NoCommonIds {
        /// Number of measured targets.
        targets: usize,
        /// Number of control points.
        control: usize,
    },
    /// A centre estimator name that is not one of `sector-mec`, `centroid`, `circle-fit`.
    #[error("unknown centre method {name:?} (expected sector-mec, centroid or circle-fit)")]
    UnknownMethod {
        /// The rejected name.
        name: String,
    },
    /// Too few ground points to build a TIN.
    #[error("a tin needs at least 3 non-collinear ground points, got {n}")]
    TooFewGroundPoints {
        /// Number of ground points given.
        n: usize,
    },
    /// The TIN could not be built.
    #[error("cannot build the tin: {0}")]
    Tin(String),
    /// No checkpoint lies inside the TIN's convex hull.
    #[error("none of the {checkpoints} checkpoints lies inside the tin of {ground} ground points")]
    NoCheckpointInsideTin {
        /// Number of checkpoints.
        checkpoints: usize,
        /// Number of ground points.
        ground: usize,
    },
}
