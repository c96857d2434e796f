//! One lidar return around a target, and how far round a target its points reach: the input
//! that extraction, the centre estimators and the plate model share.

use serde::Serialize;
use std::f64::consts::TAU;

/// One lidar return, in projected coordinates.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LidarPoint {
    /// Easting (projected m).
    pub x: f64,
    /// Northing (projected m).
    pub y: f64,
    /// Height (m, up).
    pub z: f64,
    /// Return intensity (sensor units, e.g. the LAS 16-bit value as f64).
    pub intensity: f64,
}

/// 360° minus the largest azimuth gap of `pts` around `c` (degrees).
pub(crate) fn coverage_deg(pts: &[[f64; 2]], c: [f64; 2]) -> f64 {
    let mut az: Vec<f64> = pts
        .iter()
        .filter(|p| p[0] != c[0] || p[1] != c[1])
        .map(|p| (p[1] - c[1]).atan2(p[0] - c[0]).rem_euclid(TAU))
        .collect();
    if az.len() < 2 {
        return 0.0;
    }
    az.sort_by(f64::total_cmp);
    let mut gap = az[0] + TAU - az[az.len() - 1];
    for w in az.windows(2) {
        gap = gap.max(w[1] - w[0]);
    }
    (TAU - gap).to_degrees()
}
