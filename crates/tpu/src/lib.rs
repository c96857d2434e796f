//! lidarqa-tpu: how accurate *should* the points be?
//!
//! Error propagation through the georeferencing models of lidarqa-model:
//! - a per-source budget `|∂P/∂p_i| · σ_i` and the total `√diag(J Σ Jᵀ)` with a full covariance
//!   ([`budget`]), the Jacobian exact from dual numbers;
//! - the exact and first-order displacement that systematic errors cause ([`bias_effect`]);
//! - sweeps over scan angle, azimuth, height, depth ([`Sweep`]);
//! - a seeded Monte Carlo cross-check ([`monte_carlo`]);
//! - for the per-point TPU of a real survey: trajectory interpolation ([`Trajectory`], slerp of
//!   the attitude), raw-observation recovery from a georeferenced point ([`Recoverer`]),
//!   per-point propagation with the trajectory's own σ and an `incidence` term
//!   ([`PointPropagator`]), the propagated covariance at the point, on the grid and by source
//!   ([`local_covariance`], [`grid_covariance`], [`add_shares`]), all of it for one point of a
//!   tile from its prepared inputs ([`PointKernel`]), and plane-fit surface normals
//!   ([`plane_normals`]). File handling is in lidarqa-pipeline;
//! - what a trajectory can physically be: heights, speeds, attitude rates, gaps and σ of an
//!   aircraft ([`check_trajectory`], [`check_gaps`], [`check_trajectory_sigmas`]);
//! - a raw linear-scanner record's return georeferenced from its own observations, with its σ
//!   ([`RawLinearPropagator`]);
//! - bathymetric soundings of a conic scanner: their raw observation from the seabed point and
//!   its water surface ([`Recoverer::sounding_from_surface_return`],
//!   [`Recoverer::sounding_from_plane`]) and the IHO S-44 Ed. 6 orders they meet ([`IhoOrder`],
//!   [`thu_95_m`]).
//!
//! ```
//! use lidarqa_tpu::{evaluate, Preset};
//!
//! // Zhang et al. (2018) Table 1 at scan angle 30°, 80 m below: 5.27 / 5.19 / 10.04 cm
//! // (north / east / up).
//! let e = evaluate(&Preset::Zhang2018.sensor(), &Preset::Zhang2018.geometry(), None).unwrap();
//! assert!((e.total.north - 0.0527).abs() < 5e-5);
//! assert!((e.total.up - 0.1004).abs() < 5e-5);
//! ```
//!
//! Zhang et al. (2018) quote 0.133 / 0.147 / 0.119 m for the same σ. Their formula (3) with the
//! units right gives the values above, and no attitude or scan angle within the paper's ranges
//! (±3°, ±4°, ±30°) gets near the published ones: the non-GNSS part is bounded by about 3 cm, so
//! the published figures cannot come from Table 1 (SPEC §3). lidarqa reports the correct values.

mod axes;
mod beam_point;
mod bias;
mod budget;
mod error;
mod geometry;
mod iho;
mod montecarlo;
mod mounting_check;
mod normals;
mod point;
mod point_kernel;
mod point_sigma;
mod presets;
mod raw_record;
mod recover;
mod request;
mod sounding;
mod sweep;
mod trajectory;
mod trajectory_checks;

pub use axes::{Axes, Displacement, displacement_from_ned};
pub use beam_point::{BEAM_FOOTPRINT_SOURCE, BeamPropagator, BeamUncertainty};
pub use bias::{BiasEffect, Biases, bias_effect};
pub use budget::{Budget, SourceTerm, budget, footprint_jacobian, propagate_covariance};
pub use error::{Error, Result};
pub use geometry::{
    ConicRanges, Evaluation, Footprint, Geometry, GeometryFacts, LinearRange,
    MAX_MONTE_CARLO_SAMPLES, MAX_RANGE_M, evaluate, evaluate_monte_carlo,
};
pub use iho::{
    IhoLimits, IhoOrder, THU_95_CBLUE, THU_95_CIRCULAR_PER_AXIS, TVU_95_FACTOR, thu_95_m,
};
pub use montecarlo::{MonteCarlo, monte_carlo};
pub use mounting_check::{
    FittedMounting, MOUNTING_ERROR_M, MOUNTING_WARNING_FLOOR_M, MOUNTING_WARNING_RATIO,
    MountingTally, sigma_3d_bound,
};
pub use normals::{
    GridBuffers, IncidenceClass, MAX_NEIGHBOURS, MIN_NEIGHBOURS, SHARE_STRIDE, Surface,
    WIDEN_FLATNESS, WIDEN_RADIUS_FACTOR, cos_incidence, fit_normal, incidence_angle, incidence_at,
    judge_surfaces, judge_surfaces_into, judge_surfaces_shared, judged_incidence, plane_normals,
    prior_cos_incidence,
};
pub use point::{Incidence, MAX_INCIDENCE_RAD, PointPropagator, PointUncertainty};
pub use point_kernel::{
    KernelOptions, KernelPoint, PointKernel, PointTpu, Recovered, SoundingTpu, SourceVariances,
    WaterAt,
};
pub use point_sigma::{
    NO_WATER_LEG, add_shares, grid_covariance, local_covariance, p0_to_point, sounding_overrides,
    topographic_overrides,
};
pub use presets::Preset;
pub use raw_record::{RawLinearPropagator, RawReturn};
pub use recover::{BeamRecovery, ConicRecovery, LinearRecovery, Recoverer, nominal_l3};
pub use request::{GeometryRequest, SweepEvaluation, SweepPoint, evaluate_sweep};
pub use sounding::{
    SAME_PULSE_S, SURFACE_NEIGHBOURS, SURFACE_RADIUS_M, SoundingRecovery, SurfacePlane,
    SurfaceSource, WaterReturn, WaterSurfaceIndex,
};
pub use sweep::{MAX_SWEEP_POINTS, Sweep, SweepVariable};
pub use trajectory::{Pose, PoseAt, PoseSigma, SegmentRotation, Trajectory, TrajectorySigmas};
pub use trajectory_checks::{
    ATTITUDE_BASELINE_S, DUPLICATE_POSITION_TOLERANCE_M, GAP_ERROR_S, GAP_WARNING_SAMPLES, Gap,
    ImplausibleTrajectory, MAX_ATTITUDE_RATE_DEG_S, MAX_ATTITUDE_SIGMA_DEG, MAX_HEIGHT_M,
    MAX_POSITION_SIGMA_M, MAX_SPEED_MPS, MIN_HEIGHT_M, SPEED_BASELINE_S, TrajectoryFacts,
    TrajectorySample, check_gaps, check_trajectory, check_trajectory_sigmas,
};
