//! Per-axis values in the local level frame at the point: north, east, up, and the derived
//! horizontal = √(north² + east²), vertical = |up|, three_d = √(horizontal² + vertical²) (SPEC §3).

use nalgebra::{Matrix3, Vector3};
use serde::Serialize;

/// Magnitudes (σ or |displacement|) per axis, metres.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct Axes {
    /// North, m.
    pub north: f64,
    /// East, m.
    pub east: f64,
    /// Up, m.
    pub up: f64,
    /// √(north² + east²), m. Seed 004's σxy.
    pub horizontal: f64,
    /// |up|, m. Seed 004's σz.
    pub vertical: f64,
    /// √(horizontal² + vertical²), m. Seed 004's σxyz.
    pub three_d: f64,
}

impl Axes {
    /// From the absolute per-axis magnitudes (north, east, up), metres.
    pub fn from_magnitudes(north: f64, east: f64, up: f64) -> Axes {
        let (north, east, up) = (north.abs(), east.abs(), up.abs());
        let horizontal = north.hypot(east);
        Axes {
            north,
            east,
            up,
            horizontal,
            vertical: up,
            three_d: horizontal.hypot(up),
        }
    }

    /// σ per axis from an NED covariance matrix (m²); the up variance equals the down variance.
    pub fn from_ned_covariance(c: &Matrix3<f64>) -> Axes {
        Axes::from_magnitudes(
            c[(0, 0)].max(0.0).sqrt(),
            c[(1, 1)].max(0.0).sqrt(),
            c[(2, 2)].max(0.0).sqrt(),
        )
    }

    /// Magnitudes of an NED vector (m), reported as north / east / up.
    pub fn from_ned(v: &Vector3<f64>) -> Axes {
        Axes::from_magnitudes(v.x, v.y, v.z)
    }
}

/// A signed displacement, metres: north / east / up, and along / across track (across positive towards
/// the right wing).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
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
