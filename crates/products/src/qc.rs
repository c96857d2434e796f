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
    /// The soundings judged by IHO S-44, when an `iho-s44` standard was asked for.
    #[serde(default)]
    pub iho: Option<QcIho>,
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

/// One line's smooth-surface precision (USGS Lidar Base Specification: intraswath, smooth
/// surface repeatability).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct QcIntraswath {
    /// The line.
    pub line: String,
    /// Cells of `cell_m` with at least two of the line's single returns on smooth ground.
    pub cells: usize,
    /// Median over those cells of the range (max − min) of the returns' residuals from the
    /// plane of their smooth cell (slope-compensated range), m.
    pub median_range_m: Option<f64>,
    /// RMS of those residuals over all the cells' returns (the line's noise σ), m.
    pub rms_m: Option<f64>,
    /// Cell size: 2 × the delivery's aggregate nominal pulse spacing, rounded up to a whole
    /// metre, m.
    #[serde(default)]
    pub cell_m: f64,
    /// Median number of returns per cell (the range of n normal residuals is about
    /// d(n)·σ: 1.13 σ for 2, 2.06 σ for 4, 2.85 σ for 8).
    #[serde(default)]
    pub median_points: Option<f64>,
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

/// The soundings of a bathymetric delivery judged by IHO S-44 Edition 6.0.0 (2020), Table 1:
/// each sounding's predicted 95 % uncertainties (from the σ lidarqa tpu stores with every point)
/// against its depth's allowances.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct QcIho {
    /// Classes read as returns from the bottom (soundings).
    pub bottom_classes: Vec<u8>,
    /// Classes read as the water surface.
    pub surface_classes: Vec<u8>,
    /// Points in the bottom classes.
    pub bottom_points: usize,
    /// Of those, judged: with a depth and a TPU.
    pub soundings: usize,
    /// Not judged: no depth (no `depth` extra byte and no water-surface point near).
    pub no_depth: usize,
    /// Not judged: no TPU (`sigma_up` and `sigma_horizontal` extra bytes of lidarqa tpu).
    pub no_tpu: usize,
    /// Judged soundings whose depth is lidarqa tpu's `depth` extra byte.
    pub depth_from_tpu: usize,
    /// Judged soundings whose depth is the median height of the water-surface points of their
    /// cell (or its neighbours) minus their own height.
    pub depth_from_surface: usize,
    /// How the 95 % vertical uncertainty is formed from σ.
    pub tvu_95: String,
    /// How the 95 % horizontal uncertainty is formed from σ.
    pub thu_95: String,
    /// Every order of Table 1, most stringent first.
    pub orders: Vec<QcIhoOrder>,
}

/// One IHO S-44 order and the share of the soundings within its allowances.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct QcIhoOrder {
    /// `exclusive`, `special`, `1a`, `1b`, `2`.
    pub order: String,
    /// THU constant, m.
    pub thu_m: f64,
    /// THU depth-proportional part (0.05 = 5 % of depth).
    pub thu_depth_fraction: f64,
    /// TVU `a`, m.
    pub tvu_a_m: f64,
    /// TVU `b`.
    pub tvu_b: f64,
    /// Share of the judged soundings with THU (95 %) within `thu_m + thu_depth_fraction·d`.
    pub share_thu: f64,
    /// Share with TVU (95 %) within `√(a² + (b·d)²)`.
    pub share_tvu: f64,
    /// Share within both.
    pub share_both: f64,
}

/// `iho.json`, written by `lidarqa qc` with an `iho-s44` standard beside `qc.json` and read by
/// the report's IHO S-44 statement: `{"orders": [{"order", "percent_meeting", "by_depth":
/// [{"depth_min_m", "depth_max_m", "n", "percent_meeting"}]}]}`. S-44 requires the allowances
/// to be met at 95 % confidence, so an order is met when `percent_meeting ≥ 95`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct IhoDocument {
    /// One entry per order.
    pub orders: Vec<IhoDocumentOrder>,
}

/// One IHO S-44 order (`exclusive`, `special`, `1a`, `1b`, `2`) of [`IhoDocument`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct IhoDocumentOrder {
    /// The order's name.
    pub order: String,
    /// Percentage of soundings within the order's THU and TVU (95 %), %.
    pub percent_meeting: f64,
    /// The same per depth band.
    #[serde(default)]
    pub by_depth: Vec<IhoDepthBand>,
}

/// One depth band of an [`IhoDocumentOrder`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct IhoDepthBand {
    /// Shallowest depth of the band, m.
    pub depth_min_m: f64,
    /// Deepest depth, m.
    pub depth_max_m: f64,
    /// Soundings in the band.
    #[serde(default)]
    pub n: Option<u64>,
    /// Percentage of them within the order's THU and TVU, %.
    pub percent_meeting: f64,
}
