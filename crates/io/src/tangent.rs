//! The local level frame at a point: North-East-Down axes tangent to the ellipsoid at an ECEF
//! origin, and the same axes as East-North-Up.
//!
//! A calibration re-georeferences every strip in one Cartesian frame, and the trajectory
//! reconstruction fits its flight lines in one: projected coordinates are not Cartesian (their
//! scale and north drift across a project), ECEF axes are not level. A tangent frame is both, and
//! it is exact: ECEF → local is a translation and a rotation, with no series and no
//! approximation, so a point goes there and back to rounding. Positions in it are typed
//! ([`Ned`], [`Enu`]) so that they cannot be handed where an [`Ecef`] is expected.
//!
//! The rotation is the model's `C_NE(φ, λ)` ([`ned_from_ecef`]); the East-North-Up axes are its
//! rows reordered, the down row negated, which changes no bit of any product.

use crate::geodesy::{Ellipsoid, Geodetic};
use lidarqa_model::{Ecef, Enu, Ned, ecef_from_ned, ned_from_ecef};
use nalgebra::Matrix3;

/// A local level frame at an ECEF origin: x north, y east, z down (or east, north, up through
/// the `enu` methods), metres.
///
/// ```
/// use lidarqa_io::{Ellipsoid, Geodetic, TangentFrame};
/// use lidarqa_model::Ned;
/// let wgs84 = Ellipsoid::WGS84;
/// let origin = Geodetic { latitude_rad: 0.8, longitude_rad: 0.2, height_m: 100.0 };
/// let frame = TangentFrame::at(&wgs84, &origin);
/// // 50 m straight above the origin is 50 m up: down = −50.
/// let above = wgs84.geodetic_to_ecef(&Geodetic { height_m: 150.0, ..origin });
/// assert!((frame.to_ned(&above).vector() - Ned::new(0.0, 0.0, -50.0).vector()).norm() < 1e-8);
/// assert!((frame.to_enu(&above).up_m() - 50.0).abs() < 1e-8);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TangentFrame {
    origin: Ecef,
    latitude_rad: f64,
    longitude_rad: f64,
    /// ECEF → local NED, `C_NE(φ, λ)`.
    ned_from_ecef: Matrix3<f64>,
}

impl TangentFrame {
    /// The frame at `origin`, whose geodetic latitude and longitude (rad) define its axes.
    pub fn new(origin: Ecef, latitude_rad: f64, longitude_rad: f64) -> TangentFrame {
        TangentFrame {
            origin,
            latitude_rad,
            longitude_rad,
            ned_from_ecef: ecef_from_ned(latitude_rad, longitude_rad).transpose(),
        }
    }

    /// The frame at the geodetic position `origin` on `ellipsoid`.
    pub fn at(ellipsoid: &Ellipsoid, origin: &Geodetic) -> TangentFrame {
        TangentFrame::new(
            ellipsoid.geodetic_to_ecef(origin),
            origin.latitude_rad,
            origin.longitude_rad,
        )
    }

    /// Origin, ECEF.
    pub fn origin(&self) -> Ecef {
        self.origin
    }

    /// Latitude and longitude of the origin, rad.
    pub fn origin_lat_lon_rad(&self) -> (f64, f64) {
        (self.latitude_rad, self.longitude_rad)
    }

    /// The rotation ECEF → local NED, `C_NE(φ, λ)`.
    pub fn ned_from_ecef(&self) -> Matrix3<f64> {
        self.ned_from_ecef
    }

    /// The rotation ECEF → local ENU: [`TangentFrame::ned_from_ecef`]'s rows reordered, down
    /// turned up.
    pub fn enu_from_ecef(&self) -> Matrix3<f64> {
        enu_rows(&self.ned_from_ecef)
    }

    /// ECEF → local NED, m: `C_NE (P − origin)`.
    pub fn to_ned(&self, p: &Ecef) -> Ned {
        Ned::from_vector(self.ned_from_ecef * (*p - self.origin))
    }

    /// Local NED → ECEF, m: `origin + C_NEᵀ v`.
    pub fn ned_to_ecef(&self, v: &Ned) -> Ecef {
        self.origin + self.ned_from_ecef.transpose() * v.vector()
    }

    /// ECEF → local ENU, m.
    pub fn to_enu(&self, p: &Ecef) -> Enu {
        Enu::from_vector(self.enu_from_ecef() * (*p - self.origin))
    }

    /// Local ENU → ECEF, m.
    pub fn enu_to_ecef(&self, v: &Enu) -> Ecef {
        self.origin + self.enu_from_ecef().transpose() * v.vector()
    }
}

/// ECEF → East-North-Up at (φ, λ): [`ned_from_ecef`]'s rows reordered, down turned up.
pub fn enu_from_ecef(latitude_rad: f64, longitude_rad: f64) -> Matrix3<f64> {
    enu_rows(&ned_from_ecef(latitude_rad, longitude_rad))
}

fn enu_rows(ned: &Matrix3<f64>) -> Matrix3<f64> {
    Matrix3::from_rows(&[
        ned.row(1).into_owned(),
        ned.row(0).into_owned(),
        -ned.row(2).into_owned(),
    ])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame() -> (Ellipsoid, Geodetic, TangentFrame) {
        let e = Ellipsoid::WGS84;
        let g = Geodetic {
            latitude_rad: 59.5_f64.to_radians(),
            longitude_rad: 17.25_f64.to_radians(),
            height_m: 40.0,
        };
        (e, g, TangentFrame::at(&e, &g))
    }

    /// The frame is a rotation and a translation: ECEF → NED → ECEF returns the point to the
    /// rounding of coordinates of 6.4e6 m (1 ulp ≈ 1e-9 m).
    #[test]
    fn ecef_round_trips_through_ned_and_enu() {
        let (_, _, f) = frame();
        for d in [[0.0, 0.0, 0.0], [1500.0, -800.0, 600.0], [-3e4, 2e4, -1e3]] {
            let p = f.origin() + nalgebra::Vector3::from(d);
            assert!((f.ned_to_ecef(&f.to_ned(&p)) - p).amax() < 1e-8);
            assert!((f.enu_to_ecef(&f.to_enu(&p)) - p).amax() < 1e-8);
        }
    }

    /// East-North-Up is North-East-Down reordered with down negated, bit for bit.
    #[test]
    fn enu_is_ned_reordered_exactly() {
        let (_, _, f) = frame();
        let p = f.origin() + nalgebra::Vector3::new(1234.5, -987.25, 321.125);
        let (n, e) = (f.to_ned(&p), f.to_enu(&p));
        assert_eq!(e.east_m(), n.east_m());
        assert_eq!(e.north_m(), n.north_m());
        assert_eq!(e.up_m(), n.up_m());
        let (lat, lon) = f.origin_lat_lon_rad();
        assert_eq!(enu_from_ecef(lat, lon), f.enu_from_ecef());
    }

    /// Against the exact chain (geodetic ↔ ECEF): a point on the local vertical is straight up;
    /// a point 1 km along the local north stays on the origin's meridian and stands above the
    /// ellipsoid, which curves away under the tangent plane, by d²/2(M + h) with the meridian's
    /// radius of curvature M (to the next term, from M's change along the meridian:
    /// ≈ d³ M′/6M³ ≈ 4e-8 m).
    #[test]
    fn axes_follow_the_exact_chain() {
        let (e, g, f) = frame();
        let above = e.geodetic_to_ecef(&Geodetic {
            height_m: g.height_m + 250.0,
            ..g
        });
        assert!((f.to_ned(&above).vector() - Ned::new(0.0, 0.0, -250.0).vector()).amax() < 1e-8);

        let north = f.ned_to_ecef(&Ned::new(1000.0, 0.0, 0.0));
        let q = e.ecef_to_geodetic(&north);
        assert!((q.longitude_rad - g.longitude_rad).abs() < 1e-15);
        let r_m = e.meridian_radius_m(g.latitude_rad) + g.height_m;
        let rise_m = q.height_m - g.height_m;
        assert!(
            (rise_m - 1000.0_f64.powi(2) / (2.0 * r_m)).abs() < 1e-6,
            "{rise_m}"
        );
    }
}
