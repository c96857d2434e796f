//! The one surveyed control point or checkpoint, in the points' grid (projected easting,
//! northing, height): what the control CSV holds and targets, QC and the calibration read.

use serde::Serialize;

/// A surveyed control point or checkpoint (the control CSV: `id,x,y,z[,sigma_h,sigma_v][,radius_m]`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ControlPoint {
    /// Unique id.
    pub id: String,
    /// Easting (projected m).
    pub x: f64,
    /// Northing (projected m).
    pub y: f64,
    /// Height (m, up).
    pub z: f64,
    /// The point's own horizontal survey accuracy, RMSE_H = √(σ_north² + σ_east²) (m), if known.
    pub sigma_h_m: Option<f64>,
    /// The point's own vertical survey accuracy (m, 1σ), if known.
    pub sigma_v_m: Option<f64>,
    /// The radius of the target at this point (m), overriding the configured one.
    pub radius_m: Option<f64>,
}

impl ControlPoint {
    /// A control point with no sigmas and no radius.
    #[must_use]
    pub fn new(id: impl Into<String>, x: f64, y: f64, z: f64) -> Self {
        Self {
            id: id.into(),
            x,
            y,
            z,
            sigma_h_m: None,
            sigma_v_m: None,
            radius_m: None,
        }
    }
}
