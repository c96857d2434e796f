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
//! Skipped points (with `skip_outside` / `skip_invalid`, and conic bathymetric soundings, class
//! 40, whose in-water leg is not recovered yet) are counted by reason and not written: every
//! output point has a σ.
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
//! })?;
//! let (_, survey) = TileReport::merge(&[report]).unwrap();
//! println!("{} points, median σ_up {:?} m", survey.summary.points_written,
//!          survey.summary.sigma["up"].map(|s| s.median));
//! # Ok::<(), lidarqa_pipeline::Error>(())
//! ```

mod context;
mod error;
mod summary;
mod tile;

pub use context::{TpuContext, TpuOptions};
pub use error::{Error, Result};
pub use summary::{
    AngleCheck, Histogram, HistogramsView, LinearHistogram, ResidualCheck, ResidualView,
    SIGMA_MAP_CELL_M, SIGMA_MAP_MAX_SIDE, SIGMA_NAMES, ScanAngleView, SigmaGridView, SigmaMap,
    SkipReason, Stats, SummaryView, SurveyReport, TileLine, TileReport, TpuSummary,
};
pub use tile::{TpuTileJob, tpu_tile, tpu_tile_with_progress};
