//! `qc.json`, the product of `lidarqa qc`: one serde type, written by lidarqa-pipeline and read by
//! lidarqa-report, so that the two cannot drift apart.
//!
//! ```json
//! {"format": "lidarqa-qc/1",
//!  "lines": {"count": 3, "reasons": ["…"], "lines": [{"id": "1", …}]},
//!  "interswath": [{"lines": ["1", "2"], "rmsdz_m": 0.021, "max_abs_dz_m": 0.07, "cells": 812}],
//!  "interswath_min_cells": 30,
//!  "intraswath": [{"line": "1", …}], "density": {…}, "nva": {…} | null,
//!  "verdicts": [{"standard": "usgs-lbs-2024:QL2", "requirements": [{…}], "pass": true}],
//!  "rasters": [{"kind": "dz", "path": "dz_1_2.tif", …}], "warnings": [{"code", "message"}]}
//! ```
//!
//! Lines are named as lidarqa-pipeline's line splitting names them: the point source id, or
//! `<id>-<k>` for the k-th pass (in GPS time) of an id that holds several.

use lidarqa_model::Warning;
use serde::{Deserialize, Serialize};

/// The `format` value of the current `qc.json`.
pub const QC_FORMAT: &str = "lidarqa-qc/1";

/// The whole `qc.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct QcDocument {
    /// [`QC_FORMAT`].
    pub format: String,
    /// The delivery's files, as given.
    pub inputs: Vec<String>,
    /// Horizontal CRS of the delivery (EPSG), when the files declare one.
    pub epsg: Option<u32>,
    /// The flight lines found, and why.
    pub lines: QcLines,
    /// Swath-to-swath height differences per overlapping line pair on smooth ground cells.
    pub interswath: Vec<QcInterswath>,
    /// Pairs with fewer cells than this are listed but not judged.
    pub interswath_min_cells: usize,
    /// How the smooth cells were chosen.
    pub smooth_cells: QcSmoothCells,
    /// Smooth-surface repeatability within each line.
    pub intraswath: Vec<QcIntraswath>,
    /// Point and last-return density.
    pub density: QcDensity,
    /// Checkpoints against the TIN of the ground points, when `--control` was given.
    pub nva: Option<QcNva>,
    /// The TPU's prediction, when a trajectory and a sensor file were given.
    pub predicted: Option<QcPredicted>,
    /// One verdict table per standard.
    pub verdicts: Vec<QcVerdict>,
    /// GeoTIFF rasters written beside `qc.json`.
    pub rasters: Vec<QcRaster>,
    /// Doubtful inputs and what limits the verdicts.
    pub warnings: Vec<Warning>,
}

/// The flight lines of the delivery.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct QcLines {
    /// Number of lines.
    pub count: usize,
    /// Why the files were read as these lines, one sentence per point source id.
    pub reasons: Vec<String>,
    /// The lines.
    pub lines: Vec<QcLine>,
}

/// One flight line.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct QcLine {
    /// The line's name.
    pub id: String,
    /// Its point source id.
    pub point_source_id: u16,
    /// Points.
    pub points: usize,
    /// First and last GPS time, s (file time base); `None` without GPS time.
    pub gps_time_s: Option<[f64; 2]>,
    /// The files holding it.
    pub files: Vec<String>,
}

/// One line pair's interswath consistency (USGS Lidar Base Specification).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct QcInterswath {
    /// The two lines, dz = z(first) − z(second).
    pub lines: [String; 2],
    /// √(mean dz²) over the smooth cells both lines share, m.
    pub rmsdz_m: f64,
    /// Largest |dz|, m.
    pub max_abs_dz_m: f64,
    /// Number of smooth cells compared.
    pub cells: usize,
}

/// The smooth-cell test.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct QcSmoothCells {
    /// Cell size, m.
    pub cell_m: f64,
    /// Largest slope, degrees.
    pub max_slope_deg: f64,
    /// Largest plane-fit RMS, m.
    pub max_roughness_m: f64,
    /// Fewest points of one line in a cell.
    pub min_points: usize,
    /// Which points: `"ground (class 2)"` or `"all last returns (no ground class)"`.
    pub points: String,
}

/// One line's smooth-surface repeatability.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct QcIntraswath {
    /// The line.
    pub line: String,
    /// Cells assessed (ground, slope within the limit, enough points).
    pub cells: usize,
    /// Median over the cells of the range (max − min) of the plane-fit residuals, m.
    pub median_range_m: Option<f64>,
    /// RMS of the plane-fit residuals over all those cells' points, m.
    pub rms_m: Option<f64>,
}

/// Density over the delivery.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct QcDensity {
    /// Cell of the spatial-distribution test (2 × the nominal pulse spacing), m.
    pub cell_m: f64,
    /// Footprint area: 10 m cells holding any point, m².
    pub area_m2: f64,
    /// All points per m² over the footprint.
    pub points_per_m2: f64,
    /// Last returns (one per pulse) per m² over the footprint.
    pub last_returns_per_m2: f64,
    /// Distribution cells inside the footprint.
    pub cells: usize,
    /// Share of those holding at least one last return.
    pub cells_with_last_return: f64,
    /// 10 m cells whose last-return density is under the required one.
    pub coarse_cells_under: usize,
    /// 10 m cells in the footprint.
    pub coarse_cells: usize,
}

/// Checkpoints against the TIN of the ground points (NVA).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct QcNva {
    /// The checkpoint file.
    pub file: String,
    /// Checkpoints inside the TIN.
    pub checkpoints: usize,
    /// Checkpoints outside it (not assessed).
    pub outside_tin: usize,
    /// RMSEz of the lidar against the checkpoints, m.
    pub rmse_z_m: f64,
    /// RMSEz with the checkpoints' own accuracy included (ASPRS 2023), m.
    pub product_rmse_z_m: f64,
    /// Mean error, m.
    pub mean_z_m: f64,
    /// 1.96 × RMSEz, m.
    pub accuracy_95_m: f64,
    /// The ASPRS statement.
    pub statement: String,
}

/// The TPU's prediction for the delivery.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct QcPredicted {
    /// Flying height above the ground used, m.
    pub height_m: f64,
    /// Predicted σ_up of one point, m.
    pub sigma_up_m: f64,
    /// Predicted σ horizontal of one point, m.
    pub sigma_horizontal_m: f64,
}

/// One standard's verdict table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct QcVerdict {
    /// The standard as given (`usgs-lbs-2024:QL2`, `asprs-2023`, `iho-s44:1a`).
    pub standard: String,
    /// The document cited.
    pub citation: String,
    /// Each requirement.
    pub requirements: Vec<QcRequirement>,
    /// All judged requirements pass; `None` when none could be judged.
    pub pass: Option<bool>,
}

/// One requirement of a standard.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct QcRequirement {
    /// What is required.
    pub requirement: String,
    /// The measured value (unit in `unit`), when measured.
    pub measured: Option<f64>,
    /// The TPU's predicted value beside it, when predicted.
    pub predicted: Option<f64>,
    /// `"<="` or `">="`.
    pub comparison: String,
    /// The threshold.
    pub threshold: f64,
    /// Unit of `measured` and `threshold` (`m`, `points/m²`, `checkpoints`, `share`).
    pub unit: String,
    /// Sample size behind the measured value (cells, checkpoints, points).
    pub sample_size: usize,
    /// Pass or fail; `None`: not judged (see `note`).
    pub pass: Option<bool>,
    /// Why not judged, or what limits the verdict.
    pub note: Option<String>,
}

/// One GeoTIFF written.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct QcRaster {
    /// `dz`, `density` or `sigma_up`.
    pub kind: String,
    /// File name, beside `qc.json`.
    pub path: String,
    /// The line pair of a `dz` raster.
    pub lines: Option<[String; 2]>,
    /// Cell size, m.
    pub cell_m: f64,
}
