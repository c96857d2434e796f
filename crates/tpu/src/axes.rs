//! Per-axis values in the local level frame at the point ([`Axes`], defined in lidarqa-model) and
//! signed displacements along and across track ([`Displacement`]).

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// The one six-axis struct of the workspace (σ, |displacement|, RMSE per axis), from
/// lidarqa-model.
pub use lidarqa_model::Axes;

/// A signed displacement, metres: north / east / up, and along / across track (across positive towards
/// the right wing). Read back from the products too (lidarqa-report re-exports it).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Displacement {
    /// North, m.
    pub north: f64,
    /// East, m.
    pub east: f64,
    /// Up, m.
    pub up: f64,
    /// Along the heading, m.
    pub along_track: f64,
    /// Across the heading, positive to the right wing, m.
    pub across_track: f64,
}

impl Displacement {
    /// From an NED vector (m) and the platform heading (rad).
    pub fn from_ned(v: &Vector3<f64>, heading_rad: f64) -> Displacement {
        let (s, c) = heading_rad.sin_cos();
        Displacement {
            north: v.x,
            east: v.y,
            up: -v.z,
            along_track: v.x * c + v.y * s,
            across_track: -v.x * s + v.y * c,
        }
    }
}
