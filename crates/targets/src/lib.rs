//! Measured accuracy of airborne lidar from high-reflectivity targets (Zhang et al. 2018, §3–4).
//!
//! The pipeline, one function per step, plain structs in and out (no file I/O):
//!
//! 1. [`fuzzy_c_means`] on intensity (Zhang et al. 2018, eqs. 4–6) and [`select_high_intensity`]:
//!    the high-reflectivity points. The paper's refinement threshold (1.5 × the mean of the rough
//!    cluster's max and min) is available as [`ThresholdRule::Paper`] but keeps no target point
//!    on realistic data; the default is the midpoint between the two top cluster centres (see
//!    the `fcm` module docs for the measurement).
//! 2. [`segment_clusters`]: connected components in XY (k-d tree); with an unknown radius each
//!    cluster is matched to the nearest control point within a search radius; unmatched
//!    clusters and control points without a target are reported ([`TargetReport`]).
//! 3. With a known radius, the plate model at every control point (module `plate`):
//!    a matched filter finds the disc, the centre is the posterior mean of an intensity
//!    (footprint mixing) and height-step likelihood over every return around it, the elevation
//!    the mean Z inside the circle minus the rim ([`PlateModel`]), with shape and neighbour
//!    flags. Otherwise [`estimate_centre`]: `sector-mec` (Zhang et al. 2018, §3.2, with Welzl's
//!    [`min_enclosing_circle`]), `centroid`, or `circle-fit` (robust circle fit in the target
//!    plane), with covariance, coverage and flags. [`extract_targets`] runs 1–3.
//! 4. [`evaluate`]: residuals lidar − control in north/east/up, RMSE (Zhang et al. 2018, formulas 7
//!    and 8), ASPRS Positional Accuracy Standards Ed. 2 (2023), NSSDA 95 %; and
//!    [`evaluate_vertical_tin`] for vertical checkpoints against a TIN of ground points.
//!
//! Coordinates are projected metres (x = east, y = north, z = up), f64 throughout.
//!
//! # Example
//!
//! Zhang et al.'s (2018) Table 2 (the residuals of four targets, cm) through [`evaluate`]:
//!
//! ```
//! use lidarqa_targets::{evaluate, ControlPoint, EvaluateOptions, MeasuredPoint};
//! // (id, ΔX = north, ΔY = east) in cm; Zhang et al. (2018) write x for north (SPEC §3).
//! let table2 = [("QZ01", -7.2, 12.9), ("QZ03", 9.5, 14.3), ("QZ04", 13.8, -16.7), ("QZ05", -13.1, 8.9)];
//! let control: Vec<ControlPoint> =
//!     table2.iter().enumerate().map(|(k, t)| ControlPoint::new(t.0, 100.0 * k as f64, 0.0, 0.0)).collect();
//! let lidar: Vec<MeasuredPoint> = table2
//!     .iter()
//!     .enumerate()
//!     .map(|(k, t)| MeasuredPoint::new(t.0, 100.0 * k as f64 + t.2 / 100.0, t.1 / 100.0, 0.0))
//!     .collect();
//! let e = evaluate(&lidar, &control, &EvaluateOptions::default()).unwrap();
//! // Formula (7): √(Σ(ΔX² + ΔY²)/4) = 17.56 cm; the paper's 21.66 cm is QZ04's own residual.
//! assert!((e.rmse.horizontal - 0.1756).abs() < 5e-5);
//! assert!((e.max_abs.horizontal - 0.2166).abs() < 5e-5);
//! ```

mod centre;
mod error;
mod evaluate;
mod extract;
mod fcm;
mod mec;
mod merge;
mod plate;
mod point;
mod posterior;

pub use centre::{
    CentreEstimate, CentreMethod, CentreOptions, Elevation, TargetFlag, estimate_centre,
    estimate_centre_with_background,
};
pub use error::{Error, FrameSide};
pub use evaluate::{
    ASPRS_MIN_CHECKPOINTS, Asprs, AsprsComponent, Axes, Components, EvaluateOptions, Evaluation,
    MAX_RESIDUAL_M, MeasuredPoint, NSSDA_HORIZONTAL_APPROX_FACTOR, NSSDA_HORIZONTAL_FACTOR,
    NSSDA_VERTICAL_FACTOR, Nssda, PointResidual, Position, VerticalEvaluation, VerticalResidual,
    asprs_combined_rmse, evaluate, evaluate_vertical_tin, nssda_horizontal, nssda_vertical,
};
pub use extract::{
    TargetConfig, TargetReport, TargetResult, UnmatchedCluster, UnmatchedReason, extract_targets,
    segment_clusters, validate_control,
};
pub use fcm::{
    ExtractionReport, FcmConfig, FcmReport, FcmResult, ThresholdRule, fuzzy_c_means,
    select_high_intensity,
};
/// The control points the extraction and the evaluation take (model's one grid control point).
pub use lidarqa_model::ControlPoint;
pub use mec::{Circle, min_enclosing_circle};
pub use merge::merge_reports;
pub use plate::PlateModel;
pub use point::LidarPoint;

/// The crate's result type.
pub type Result<T> = std::result::Result<T, Error>;
