//! `tpu_summary.json`: the per-point TPU of a survey (`lidarqa tpu`, `lidarqa collect`),
//! summarised. σ are metres.

use lidarqa_model::Warning;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::PathBuf;

/// The whole file: every tile's line and the merged statistics. `Default` is an empty summary
/// (tests build theirs from it).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TpuSummaryDocument {
    /// The tiles, in the order given.
    pub tiles: Vec<TileLine>,
    /// `"linear"`, `"conic"` or a beam scanner's type (`"rotating-mirror"`, ...).
    pub scanner: String,
    /// Points read.
    pub points_read: u64,
    /// Points written.
    pub points_written: u64,
    /// Points with a TPU (= `points_written`; the report's name).
    pub points: u64,
    /// Skipped points by reason (every reason listed, 0 included).
    pub skipped: BTreeMap<String, u64>,
    /// Per σ (north, east, up, horizontal, vertical[, total_thu, total_tvu]): statistics, m;
    /// null when no point was written.
    pub sigma: BTreeMap<String, Option<Stats>>,
    /// How percentiles are computed.
    pub percentiles: String,
    /// Mean over points of each source's share of the point's variance (diagonal terms; they
    /// sum to 1).
    pub source_share: BTreeMap<String, f64>,
    /// Points whose incidence angle was estimated.
    pub points_with_surface_normal: u64,
    /// Where the incidence term's normals came from and why some points have none.
    pub incidence: IncidenceCounts,
    /// Equal-width histograms of σ horizontal and vertical (40 bins).
    pub histogram: SigmaHistograms,
    /// Mean σ vertical per 10 m cell (coarsened to ≤ 200 cells a side).
    pub grid: Option<SigmaGrid>,
    /// Recovered vs LAS scan angle (linear scanner), degrees.
    pub scan_angle_check: Option<ScanAngleCheck>,
    /// Recovery residual, m.
    pub recovery_residual_m: Option<RecoveryResidual>,
    /// IHO S-44 Ed. 6 orders met by the bathymetric soundings (class 40) by depth band; only
    /// present when there are soundings.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub iho_s44: Option<SoundingsIho>,
    /// Whether the sensor file's mounting fits the points, and the boresight that does.
    pub mounting_check: Option<MountingCheck>,
    /// Doubtful findings (SPEC §7): `{code, message}`, empty when none.
    pub warnings: Vec<Warning>,
}

impl TpuSummaryDocument {
    /// The statistics of σ `name` (`north`, `east`, `up`, `horizontal`, `vertical`, ...), when
    /// present and not null.
    pub fn sigma(&self, name: &str) -> Option<&Stats> {
        self.sigma.get(name).and_then(Option::as_ref)
    }
}

/// One tile's line.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TileLine {
    /// The input tile.
    pub input: PathBuf,
    /// The output written.
    pub output: PathBuf,
    /// Points read.
    pub points_read: u64,
    /// Points written.
    pub points_written: u64,
    /// Points skipped.
    pub points_skipped: u64,
}

/// Summary statistics of one σ, metres.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Stats {
    /// Smallest value, m (exact).
    pub min: f64,
    /// Median, m (histogram, ±0.12 %).
    pub median: f64,
    /// 95th percentile, m (histogram, ±0.12 %): 95 % of the points have a smaller σ.
    pub p95: f64,
    /// Largest value, m (exact).
    pub max: f64,
    /// Mean, m.
    pub mean: f64,
}

/// How the incidence term was taken, in points per `incidence_class`, or why it was left out.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IncidenceCounts {
    /// Normals read from the file's `NormalX/NormalY/NormalZ` (PDAL `filters.normal`).
    pub file_normals: u64,
    /// File normals that were zero or not finite (term left out).
    pub invalid_file_normals: u64,
    /// Planar neighbourhoods whose plane the beam meets: a fitted normal.
    pub planar: u64,
    /// Of `planar`, those planar only once widened across the next scan lines.
    pub planar_widened: u64,
    /// Linear neighbourhoods (e.g. one scan line): the normal across the line nearest the
    /// vertical.
    pub linear: u64,
    /// Judged planes that contain the beam: the prior for an unmeasured surface.
    pub beam_in_plane: u64,
    /// Scattered neighbourhoods (vegetation, noise): the prior for an unmeasured surface.
    pub scattered: u64,
    /// Fewer neighbours than a plane needs: term left out.
    pub too_few_points: u64,
}

impl IncidenceCounts {
    /// Points counted.
    pub fn total(&self) -> u64 {
        self.file_normals
            + self.invalid_file_normals
            + self.planar
            + self.linear
            + self.beam_in_plane
            + self.scattered
            + self.too_few_points
    }
}

/// Equal-width histogram for display: `counts[k]` values in `[edges_m[k], edges_m[k + 1])`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinearHistogram {
    /// Bin edges, m, increasing (one more than the counts).
    pub edges_m: Vec<f64>,
    /// Values per bin.
    pub counts: Vec<u64>,
}

/// The summary's `histogram`; `None` when no point was written.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SigmaHistograms {
    /// σ vertical.
    pub vertical: Option<LinearHistogram>,
    /// σ horizontal.
    pub horizontal: Option<LinearHistogram>,
}

/// A regular grid in projected coordinates.
///
/// Cell `(row j, column i)` covers easting `[origin_x + i·cell_m, origin_x + (i+1)·cell_m)` and
/// northing `[origin_y + j·cell_m, origin_y + (j+1)·cell_m)`: the origin is the **south-west
/// (lower-left) corner**, rows go north, and values are stored row-major at index `j·nx + i`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GridGeometry {
    /// Cell size, m.
    pub cell_m: f64,
    /// Easting of the grid's west edge, m.
    pub origin_x: f64,
    /// Northing of the grid's south edge, m.
    pub origin_y: f64,
    /// Columns (west → east).
    pub nx: usize,
    /// Rows (south → north).
    pub ny: usize,
}

/// The summary's `grid`: mean σ vertical per cell (see [`GridGeometry`] for the layout).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SigmaGrid {
    /// Cell size, m.
    pub cell_m: f64,
    /// Easting of the west edge, m.
    pub origin_x: f64,
    /// Northing of the south edge, m.
    pub origin_y: f64,
    /// Columns (west → east).
    pub nx: usize,
    /// Rows (south → north).
    pub ny: usize,
    /// Mean σ vertical per cell, m, row-major from the south-west; null where no point fell.
    pub sigma_vertical_m: Vec<Option<f64>>,
}

impl SigmaGrid {
    /// The grid the values lie on.
    pub fn geometry(&self) -> GridGeometry {
        GridGeometry {
            cell_m: self.cell_m,
            origin_x: self.origin_x,
            origin_y: self.origin_y,
            nx: self.nx,
            ny: self.ny,
        }
    }
}

/// Recovered vs LAS-field scan angle, degrees.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScanAngleCheck {
    /// Points compared.
    pub points: u64,
    /// RMS of recovered − LAS, degrees.
    pub rms_deg: f64,
    /// Largest |recovered − LAS|, degrees.
    pub max_deg: f64,
    /// The LAS field's step, degrees.
    pub las_step_deg: f64,
    /// Largest disagreement beyond half a LAS step, degrees (0 when the rounding explains all).
    pub max_beyond_las_step_deg: f64,
}

/// The recovery residual, metres.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RecoveryResidual {
    /// `out_of_plane` (linear: S_x), `off_cone` (conic), `off_beam` (a beam scanner) or
    /// `sounding` (bathymetric).
    pub kind: String,
    /// RMS, m.
    pub rms: f64,
    /// Largest |value|, m.
    pub max_abs: f64,
}

/// The mounting check: whether the sensor file's mounting fits the points.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MountingCheck {
    /// RMS recovery residual of the points within the range envelope, m.
    pub rms_residual_m: f64,
    /// RMS of their 3-D σ, m.
    pub rms_sigma_3d_m: f64,
    /// Whether the residual is beyond what the σ explain (the `mounting_does_not_fit` warning).
    pub does_not_fit: bool,
    /// The sensor file's boresight roll, pitch, yaw, degrees.
    pub file_boresight_deg: [f64; 3],
    /// The boresight that puts the points on the scan plane (linear scanner): roll (the file's,
    /// not observable), pitch, yaw, degrees.
    pub fitted_boresight_deg: Option<[f64; 3]>,
    /// RMS distance of the points from the fitted plane, m.
    pub fitted_plane_rms_m: Option<f64>,
}

/// The summary's `iho_s44`: IHO S-44 orders met by the soundings, by depth band.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SoundingsIho {
    /// The standard and table the limits come from.
    pub standard: String,
    /// How THU at 95 % is computed.
    pub thu_95: String,
    /// How TVU at 95 % is computed.
    pub tvu_95: String,
    /// Soundings (class 40) with a TPU.
    pub soundings: u64,
    /// Soundings whose water surface is their pulse's own surface return.
    pub surface_from_pulse: u64,
    /// Soundings under a modelled (fitted) surface.
    pub surface_modelled: u64,
    /// Recovery residual of the soundings, m.
    pub recovery_residual_m: RecoveryResidual,
    /// Per order (`exclusive`, `special`, `1a`, `1b`, `2`): its limits and the percentage of
    /// all soundings meeting both THU and TVU.
    pub orders: BTreeMap<String, IhoOrderLine>,
    /// Per depth band with soundings.
    pub bands: Vec<IhoBand>,
    /// Map of the order achieved.
    pub order_grid: Option<OrderGrid>,
}

/// One order's limits (S-44 Ed. 6 Table 1) and the share of soundings meeting them.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IhoOrderLine {
    /// Constant part of the THU, m.
    pub thu_m: f64,
    /// Depth-proportional part of the THU (0.05 = 5 % of depth).
    pub thu_depth_fraction: f64,
    /// TVU constant `a`, m.
    pub tvu_a_m: f64,
    /// TVU depth factor `b`.
    pub tvu_b: f64,
    /// Percentage of soundings meeting THU and TVU at 95 %.
    pub percent_meeting: f64,
}

/// One depth band's line.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IhoBand {
    /// `[from, to)`, m; `to` = −1 for "and deeper".
    pub depth_m: [f64; 2],
    /// Soundings in the band.
    pub soundings: u64,
    /// Per order, percentage meeting both THU and TVU.
    pub percent_meeting: BTreeMap<String, f64>,
    /// Per order, percentage meeting THU.
    pub percent_thu: BTreeMap<String, f64>,
    /// Per order, percentage meeting TVU.
    pub percent_tvu: BTreeMap<String, f64>,
    /// RMS over the band's soundings of their 1σ horizontal, m.
    pub rms_sigma_horizontal_m: f64,
    /// RMS of their 1σ vertical, m.
    pub rms_sigma_vertical_m: f64,
}

/// The map of the IHO order achieved (see [`GridGeometry`] for the layout).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OrderGrid {
    /// Cell size, m.
    pub cell_m: f64,
    /// Easting of the west edge, m.
    pub origin_x: f64,
    /// Northing of the south edge, m.
    pub origin_y: f64,
    /// Columns (west → east).
    pub nx: usize,
    /// Rows (south → north).
    pub ny: usize,
    /// Per cell, row-major from the south-west: the most stringent order (`exclusive`,
    /// `special`, `1a`, `2`; 1a and 1b share their limits) met by ≥ 95 % of the cell's
    /// soundings, `none`, or null where there is no sounding.
    pub order: Vec<Option<String>>,
}

impl OrderGrid {
    /// The grid the values lie on.
    pub fn geometry(&self) -> GridGeometry {
        GridGeometry {
            cell_m: self.cell_m,
            origin_x: self.origin_x,
            origin_y: self.origin_y,
            nx: self.nx,
            ny: self.ny,
        }
    }
}
