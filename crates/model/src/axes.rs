//! Per-axis values in the local level frame at the point: north, east, up, and the derived
//! horizontal = √(north² + east²), vertical = |up|, three_d = √(horizontal² + vertical²) (SPEC §3).

use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

/// Values per axis, metres: σ, |displacement| or an RMSE (the magnitudes of
/// [`Axes::from_magnitudes`]), or signed components with derived magnitudes
/// ([`Axes::from_components`]). The one six-axis struct of the workspace: tpu, targets and the
/// report's JSON share it.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Axes {
    /// North, m.
    pub north: f64,
    /// East, m.
    pub east: f64,
    /// Up, m.
    pub up: f64,
    /// √(north² + east²), m. Li et al.'s (2016) σxy.
    pub horizontal: f64,
    /// |up|, m. Li et al.'s (2016) σz.
    pub vertical: f64,
    /// √(horizontal² + vertical²), m. Li et al.'s (2016) σxyz.
    pub three_d: f64,
}

impl Axes {
    /// From the absolute per-axis magnitudes (north, east, up), metres.
    pub fn from_magnitudes(north: f64, east: f64, up: f64) -> Axes {
        Axes::from_components(north.abs(), east.abs(), up.abs())
    }

    /// From north, east, up (m) as given (signed, e.g. a mean error), with horizontal =
    /// √(north² + east²), vertical = |up|, three_d = √(horizontal² + up²).
    #[must_use]
    pub fn from_components(north: f64, east: f64, up: f64) -> Axes {
        let horizontal = north.hypot(east);
        Axes {
            north,
            east,
            up,
            horizontal,
            vertical: up.abs(),
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn signed_components_and_magnitudes() {
        // 3-4-5 and 5-12-13 triangles.
        let c = Axes::from_components(-3.0, 4.0, -12.0);
        assert_eq!((c.north, c.east, c.up), (-3.0, 4.0, -12.0));
        assert_eq!((c.horizontal, c.vertical, c.three_d), (5.0, 12.0, 13.0));
        let m = Axes::from_magnitudes(-3.0, 4.0, -12.0);
        assert_eq!((m.north, m.up), (3.0, 12.0));
        assert_eq!((m.horizontal, m.vertical, m.three_d), (5.0, 12.0, 13.0));
        let cov = Matrix3::from_diagonal(&Vector3::new(9.0, 16.0, 144.0));
        assert_eq!(Axes::from_ned_covariance(&cov), m);
    }
}
