//! lidarqa-pipeline: the per-tile entry points of lidarqa (SPEC §9), shared by the CLI, job
//! arrays and Python bindings.
//!
//! [`tpu_tile`] reads one LAS/LAZ tile, recovers every point's raw observation from the
//! trajectory, propagates its total uncertainty and writes the tile with extra-bytes σ
//! (`sigma_north`, `sigma_east`, `sigma_up`, `sigma_horizontal`, `sigma_vertical`, f32 metres,
//! 1-σ in the local level frame at the point; for conic sensors also cBLUE's `total_thu` =
//! 1.7308 σ_H and `total_tvu` = 1.96 σ_V at 95 %). It has no global state: a survey is the
//! tiles run independently (in parallel with rayon, or as a job array) and their
//! [`TileReport`]s merged with [`TileReport::merge`].
//!
//! [`tpu_csd`] does the same for Optech CSD raw sensor records, whose pulses carry their own
//! pose: every return georeferenced from its recorded observations, no trajectory, no recovery.
//!
//! Per point (SPEC §3, the computation in lidarqa-tpu):
//! 1. LAS X/Y (UTM) → geodetic → ECEF on the CRS's ellipsoid; LAS Z is taken as the
//!    **ellipsoidal** height (no geoid model: orthometric heights would show as a range error);
//! 2. LAS GPS time → GPS seconds of week; the trajectory is interpolated there (linear position,
//!    slerp attitude);
//! 3. the raw observation is recovered, `S = R_Mᵀ (R_Nᵀ C_NE (P − P0) − ΔP)`;
//! 4. `J Σ Jᵀ` with the model's exact Jacobian, the SMRMSG σ (if given) for GNSS and attitude,
//!    plus the `incidence` term from a k-nearest-neighbour plane fit when the sensor file has
//!    `[scanner] beam_divergence_mrad`;
//! 5. the covariance is rotated from N at the aircraft to N at the point.
//!
//! Conic bathymetric soundings (class 40) are recovered from their pulse's water-surface return
//! (class 41, same GPS time) or, without one, from a plane fitted to the surface returns within
//! 20 m (lidarqa-tpu's `sounding` module); they also get `depth` and `iho_order` extra bytes and
//! are counted in the summary's `iho_s44` block (IHO S-44 Ed. 6 orders by depth band). A sounding
//! with no water surface above it or not below its surface is an error naming the point, or
//! with `skip_invalid` a counted skip (`no_water_surface`, `negative_depth`).
//!
//! Skipped points (with `skip_outside` / `skip_invalid`) are counted by reason and not written:
//! every output point has a σ.
//!
//! ```no_run
//! use lidarqa_pipeline::{TileReport, TpuContext, TpuOptions, TpuTileJob, tpu_tile};
//! use std::path::Path;
//!
//! let ctx = TpuContext::from_files(
//!     Path::new("sensor.toml"),
//!     Path::new("sbet.out"),
//!     Some(Path::new("smrmsg.out")),
//!     TpuOptions::default(),
//! )?;
//! let report = tpu_tile(&TpuTileJob {
//!     input: Path::new("strip.laz"),
//!     output: Path::new("strip_tpu.laz"),
//!     context: &ctx,
//!     progress: Default::default(),
//! })?;
//! let (_, survey) = TileReport::merge(&[report]).unwrap();
//! println!("{} points, median σ_up {:?} m", survey.points_written,
//!          survey.sigma["up"].map(|s| s.median));
//! # Ok::<(), lidarqa_pipeline::Error>(())
//! ```

mod calibrate_strips;
mod calibration_file;
mod context;
mod correct_tile;
mod csd_tpu;
mod digest;
mod error;
mod evaluate_files;
mod heights;
mod lines;
mod manifest;
mod overlap_files;
pub mod plausibility;
mod qc;
mod recovery_check;
mod retile;
mod stored;
mod summary;
mod targets_csv;
mod targets_files;
mod targets_tile;
mod tile;
mod tpu_tiles;

pub use calibrate_strips::{
    CalibrateJob, CalibrateStep, LineName, LoadedStrip, POINTS_PER_TILE, StripCalibration,
    TieSource, TrajectoryWeighting, VTPM_NEIGHBOURS, calibrate_strips, frame_for, load_all,
    local_to_projected, projected_to_local,
};
pub use calibration_file::{
    check_held_parameters, read_calibrated_mounting, read_line_corrections,
};
pub use context::{TpuContext, TpuOptions};
pub use correct_tile::{
    CorrectTileJob, CorrectTileReport, LineMatch, correct_tile, correct_tile_with_line,
    correct_tile_with_lines,
};
pub use csd_tpu::{
    CsdHeaderView, CsdMounting, CsdPoint, CsdTpuJob, CsdTpuReport, MountingView, csd_propagator,
    georeference_csd_return, tpu_csd,
};
pub use digest::{FileDigest, seed_for_tile};
pub use error::{Error, Result};
pub use evaluate_files::{
    evaluate_nva, evaluate_target_files, ground_points, predicted_from_sensor,
};
pub use lidarqa_io::Progress;
pub use lines::{
    FlightLine, JUMP_FLOOR_M, LineEntry, LineIndex, LineOptions, LinePoint, Lines, SensorAt,
    gap_starts, line_index, read_lines,
};
pub use manifest::{
    Entry, EntryOutcome, InputFile, MANIFEST_FORMAT, Manifest, ManifestOptions, REPORT_SUFFIX,
    TILE_REPORT_FORMAT, Task, TpuPlan, collect, entry_status, plan_tpu, resolve, run_entry,
    run_manifest_entry,
};
pub use overlap_files::{overlap_files, overlap_lines, overlap_strip};
pub use qc::{QcOptions, QlLimits, QualityLevel, Standard, qc_delivery, qc_lines, qc_prediction};
pub use retile::{RetileReport, TileFile, TileGrid, retile};
pub use stored::{StoredHistogram, StoredSummary};
pub use summary::{
    AngleCheck, DEPTH_BANDS_M, IhoTally, IncidenceTally, ResidualCheck, SIGMA_MAP_CELL_M,
    SIGMA_MAP_MAX_SIDE, SIGMA_NAMES, SigmaMap, SkipReason, TileReport, TpuSummary,
};
pub use targets_csv::targets_csv;
pub use targets_files::{control_for_targets, find_targets, points_near_control};
pub use targets_tile::{TargetsTileJob, TargetsTileReport, extract_targets_tile};
pub use tile::{TpuTileJob, tpu_tile};
pub use tpu_tiles::tpu_tiles;
