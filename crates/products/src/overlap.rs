//! `overlap_*.json`: `lidarqa overlap -o`, swath-to-swath height differences on smooth cells
//! (USGS Lidar Base Specification interswath accuracy), with a dz grid and a height profile
//! across the strips (Zhang & Jiang 2011, Fig. 10). dz = z(first strip) − z(second), m.

use crate::tpu_summary::GridGeometry;
use crate::values::StripId;
use serde::{Deserialize, Serialize};

/// RMSDz and max |dz| of one strip pair.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OverlapPair {
    /// The two strips' ids, `dz = z(first) − z(second)`.
    pub strips: [StripId; 2],
    /// √(mean dz²) over the smooth cells, m.
    pub rmsdz_m: f64,
    /// Largest |dz|, m.
    pub max_abs_dz_m: f64,
    /// Mean dz, m (a vertical offset between the strips).
    pub mean_dz_m: f64,
    /// Smooth cells compared.
    pub n: usize,
    /// Whether `n` reaches `lidarqa overlap --min-cells`: a pair with fewer is listed but left
    /// out of the grid, the profile's extent, the overall RMSDz and the worst pair.
    pub meaningful: bool,
}

/// The dz grid (see [`GridGeometry`] for the layout): per cell, the dz of the pair with the
/// largest |dz| there.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OverlapGrid {
    /// Cell size, m.
    pub cell_m: f64,
    /// Easting (or x) of the west edge, m.
    pub origin_x: f64,
    /// Northing (or y) of the south edge, m.
    pub origin_y: f64,
    /// Columns (west → east).
    pub nx: usize,
    /// Rows (south → north).
    pub ny: usize,
    /// dz per cell, m, row-major from the south-west; null where no pair is smooth.
    pub dz_m: Vec<Option<f64>>,
}

impl OverlapGrid {
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

/// One strip's heights along the profile.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OverlapProfileStrip {
    /// The strip's id.
    pub id: StripId,
    /// Height at each sample (the cell's plane where the strip is smooth there), m; null
    /// elsewhere.
    pub z_m: Vec<Option<f64>>,
}

/// A height profile across the strips.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OverlapProfile {
    /// Start and end of the line, `[[x0, y0], [x1, y1]]`, m.
    pub line: [[f64; 2]; 2],
    /// Distance of each sample from the start, m.
    pub distance_m: Vec<f64>,
    /// Heights per strip.
    pub strips: Vec<OverlapProfileStrip>,
}

/// `overlap_*.json`: the whole file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OverlapDocument {
    /// Pairs with at least one smooth cell in common.
    pub pairs: Vec<OverlapPair>,
    /// The dz grid.
    pub grid: OverlapGrid,
    /// The profile.
    pub profile: OverlapProfile,
}
