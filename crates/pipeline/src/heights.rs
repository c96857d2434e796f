//! How a height the file stores becomes the ellipsoidal height the georeferencing needs: a
//! constant (0 for ellipsoidal heights or a trajectory rebuilt in the points' own height system,
//! or the user's separation) or a geoid model's N at the point.

use lidarqa_io::{Crs, GeoidModel};
use std::sync::Arc;

/// How a height the file stores becomes the ellipsoidal height the georeferencing needs.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Heights {
    /// Plus a constant: 0 for ellipsoidal heights (or a trajectory in the points' own height
    /// system), the geoid separation N of `--geoid-separation-m`.
    Offset(f64),
    /// Plus N of a geoid model at the position.
    Geoid(Arc<GeoidModel>),
}

impl Heights {
    /// What is added to a height at (lat, lon) in radians; NaN where the model has no value.
    pub(crate) fn offset_m(&self, latitude_rad: f64, longitude_rad: f64) -> f64 {
        match self {
            Heights::Offset(n) => *n,
            Heights::Geoid(g) => g
                .undulation_m(latitude_rad, longitude_rad)
                .unwrap_or(f64::NAN),
        }
    }

    /// Nothing is added.
    pub(crate) fn is_zero(&self) -> bool {
        *self == Heights::Offset(0.0)
    }

    /// The offset at a projected position of `crs` (metres).
    pub(crate) fn offset_at(&self, crs: &Crs, x_m: f64, y_m: f64) -> f64 {
        match self {
            Heights::Offset(n) => *n,
            Heights::Geoid(_) => {
                let u = crs.unproject(x_m, y_m);
                self.offset_m(u.latitude_rad(), u.longitude_rad())
            }
        }
    }
}
