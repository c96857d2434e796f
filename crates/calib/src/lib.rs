//! lidarqa-calib: how do we make the points more accurate?
//!
//! Boresight and lever-arm self-calibration of an airborne linear scanner from overlapping strips
//! with the **virtual tie point model** (VTPM) of Zhang & Jiang (2011), a point-to-plane
//! baseline (boresight only, as Leica Attune), strip correction and swath-to-swath overlap QC.
//! Computation only: plain structs in and out; the `lidarqa` CLI reads and writes the files.
//!
//! - Inputs are [`Strip`]s of [`RawPoint`]s: each point keeps its raw observation (range and scan
//!   angle, recovered once with lidarqa-tpu's [`lidarqa_tpu::Recoverer`]) and its pose, all in one
//!   local North-East-Down frame (lidarqa-io's [`lidarqa_io::TangentFrame`]) built through ECEF,
//!   so that re-georeferencing with any mounting ([`georeference`], [`Georeferencing`]) is
//!   Zhang et al. (2018) eq. (2), rigorously.
//! - Ties come from hand picks ([`Tie`], SPEC §7) or from the automatic search ([`auto_ties`]);
//!   control points ([`NedControlPoint`]) add absolute observations, which make the vertical lever
//!   arm observable.
//! - [`calibrate_vtpm`] solves by Levenberg–Marquardt with a central-difference Jacobian
//!   (Zhang & Jiang 2011, §2.4), checks observability at the solution and holds at the prior what
//!   the data do not determine; [`calibrate_plane`] is the baseline. Both return a [`Calibration`]
//!   that serialises to SPEC §8 `calibration.json`.
//! - [`displacement`] moves a delivered point from its mounting to a calibrated one on its map
//!   grid (with its line's [`LineShift`]), one point or four at once: `lidarqa correct`'s kernel.
//! - [`correct_strip`] re-georeferences a strip; [`overlap_qc`] measures swath-to-swath height
//!   differences on smooth surfaces (USGS Lidar Base Specification style).
//! - A delivery's QC measures: smooth cells and their planes ([`fit_cells`]), the interswath
//!   differences of two lines ([`plane_differences`]), a line's intraswath precision
//!   ([`intraswath`]) and the point density ([`density`]).
//!
//! ```
//! use lidarqa_calib::{Georeferencing, RawPoint, georeference};
//! use lidarqa_model::{Attitude, LinearObservation, Mounting, Ned};
//! use nalgebra::Vector3;
//!
//! // Level flight heading north, 500 m above the origin, a pulse 20° to the right wing.
//! let theta = 20f64.to_radians();
//! let p = RawPoint {
//!     position_m: Ned::default(),
//!     origin_m: Ned::new(0.0, 0.0, -500.0),
//!     attitude: Attitude::default(),
//!     observation: LinearObservation { range_m: 500.0 / theta.cos(), scan_angle_rad: theta },
//!     out_of_plane_m: 0.0,
//!     time_s: 0.0,
//!     intensity: 0,
//! };
//! let nominal = georeference(&p, &Mounting::default());
//! assert!((nominal.vector() - Vector3::new(0.0, 500.0 * theta.tan(), 0.0)).norm() < 1e-9);
//! // A boresight pitch Δβ of 0.05° moves the point along track by ρ cos θ · Δβ = 500 m · Δβ = 0.436 m.
//! let m = Mounting { boresight_pitch_rad: 0.05f64.to_radians(), ..Mounting::default() };
//! let moved = Georeferencing::new(&m).apply(&p);
//! assert!((moved.north_m() - 500.0 * 0.05f64.to_radians()).abs() < 1e-6);
//! ```

mod autoties;
mod calibrate;
mod calibrated_sensor;
mod density;
mod displacement;
mod error;
mod geometry;
mod lm;
mod overlap;
mod params;
mod plane;
mod smooth;
mod strip;
mod strip_adjust;
mod surfaces;
mod vtpm;
mod weighting;

pub use autoties::{
    AutoTieCandidate, AutoTieGrid, AutoTieOptions, auto_tie_candidates, auto_ties, select_auto_ties,
};
pub use calibrate::{
    Calibration, CalibrationOptions, IterationRecord, Method, TieReport, calibrate_vtpm, local_enu,
    mounting_from_json, tie_residuals,
};
pub use calibrated_sensor::calibrated_sensor;
pub use density::{Density, DensityPoint, density};
pub use displacement::{LineShift, Mountings, displacement};
pub use error::{Error, Result};
pub use lm::{LmOptions, Termination};
pub use overlap::{
    OverlapGrid, OverlapOptions, OverlapPair, OverlapProfile, OverlapReport, OverlapStrip,
    ProfileStrip, overlap_qc, robust_extent,
};
pub use params::{PARAM_COUNT, Param, mounting_from_vector, mounting_to_vector};
pub use plane::{PlaneOptions, calibrate_plane, check_plane_rms};
pub use smooth::{
    Cell, CellFit, Intraswath, MIN_SPREAD, cell_centre, cell_of, fit_cells, fit_plane, intraswath,
    plane_differences,
};
pub use strip::{
    Georeferencing, RawPoint, ScanGeometry, Strip, correct_strip, georeference,
    radius_for_neighbours_m,
};
pub use strip_adjust::{Confounded, LineCorrection, SigmaTest, StripAdjustment, StripModel};
pub use surfaces::{SurfaceOptions, calibrate_surfaces};
pub use vtpm::{
    DroppedPick, MAX_RADIUS_M, MAX_RANSAC_ITERATIONS, NedControlPoint, Tie, TieKind, TiePick,
    VtpmOptions, tie_reach_m,
};
pub use weighting::TrajectorySigma;
