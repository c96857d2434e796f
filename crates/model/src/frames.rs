//! Frame-carrying types used at crate boundaries (SPEC §3).
//!
//! Inside a kernel plain nalgebra vectors are fine; across crates a vector says which frame it is in:
//! [`Ecef`] positions, local [`Ned`] (or [`Enu`]) vectors and projected [`Grid`] coordinates are
//! distinct types, so handing one to a function that expects another does not compile.
//!
//! ```
//! use lidarqa_model::{Ecef, Grid, Ned};
//! let beam = Ned::new(0.0, 0.6, 0.8);
//! assert_eq!(beam.up_m(), -0.8);
//! assert_eq!(Ecef::new(1.0, 2.0, 3.0).vector().z, 3.0);
//! assert_eq!(Grid::new(500_000.0, 4_000_000.0, 12.0).northing_m(), 4_000_000.0);
//! ```
//!
//! ```compile_fail
//! use lidarqa_model::{Ecef, Ned};
//! fn beam_only(_: &Ned) {}
//! beam_only(&Ecef::new(1.0, 2.0, 3.0)); // ECEF where NED is expected: refused
//! ```
//!
//! ```compile_fail
//! use lidarqa_model::{Ecef, Grid};
//! fn ecef_only(_: &Ecef) {}
//! ecef_only(&Grid::new(500_000.0, 4_000_000.0, 12.0)); // grid where ECEF is expected: refused
//! ```

use crate::rotation::{rotation_zyx, rotation_zyx_with_partials};
use nalgebra::{Matrix3, Vector3};

/// A position in Earth-centred, Earth-fixed coordinates (X, Y, Z), metres.
///
/// The frame types are thin wrappers so that a boundary function taking one frame refuses
/// another at compile time; they carry no arithmetic beyond what callers need (for `Ecef`:
/// position − position is a displacement, position + displacement a position).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Ecef(Vector3<f64>);

impl Ecef {
    /// From X, Y, Z in metres.
    pub fn new(x_m: f64, y_m: f64, z_m: f64) -> Ecef {
        Ecef(Vector3::new(x_m, y_m, z_m))
    }

    /// From a plain ECEF vector (metres).
    pub fn from_vector(v: Vector3<f64>) -> Ecef {
        Ecef(v)
    }

    /// As a plain ECEF vector (metres).
    pub fn vector(&self) -> Vector3<f64> {
        self.0
    }

    /// X (through the equator at the prime meridian), m.
    pub fn x_m(&self) -> f64 {
        self.0.x
    }

    /// Y (through the equator at 90° east), m.
    pub fn y_m(&self) -> f64 {
        self.0.y
    }

    /// Z (towards the north pole), m.
    pub fn z_m(&self) -> f64 {
        self.0.z
    }
}

/// The displacement between two ECEF positions, an ECEF vector (m).
impl std::ops::Sub for Ecef {
    type Output = Vector3<f64>;
    fn sub(self, rhs: Ecef) -> Vector3<f64> {
        self.0 - rhs.0
    }
}

/// An ECEF position moved by an ECEF displacement (m).
impl std::ops::Add<Vector3<f64>> for Ecef {
    type Output = Ecef;
    fn add(self, rhs: Vector3<f64>) -> Ecef {
        Ecef(self.0 + rhs)
    }
}

/// A vector in a local North-East-Down frame (the navigation frame N at a point), metres.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Ned(Vector3<f64>);

impl Ned {
    /// From north, east and down components in metres.
    pub fn new(north_m: f64, east_m: f64, down_m: f64) -> Ned {
        Ned(Vector3::new(north_m, east_m, down_m))
    }

    /// From a plain NED vector (metres).
    pub fn from_vector(v: Vector3<f64>) -> Ned {
        Ned(v)
    }

    /// As a plain NED vector (metres).
    pub fn vector(&self) -> Vector3<f64> {
        self.0
    }

    /// North component, m.
    pub fn north_m(&self) -> f64 {
        self.0.x
    }

    /// East component, m.
    pub fn east_m(&self) -> f64 {
        self.0.y
    }

    /// Down component, m (positive below the origin).
    pub fn down_m(&self) -> f64 {
        self.0.z
    }

    /// Up component, m (= −down).
    pub fn up_m(&self) -> f64 {
        -self.0.z
    }
}

/// A vector in a local East-North-Up frame, metres: the axes of [`Ned`] reordered, down turned
/// up (where a computation is more natural with z up, e.g. fitting flight lines).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Enu(Vector3<f64>);

impl Enu {
    /// From east, north and up components in metres.
    pub fn new(east_m: f64, north_m: f64, up_m: f64) -> Enu {
        Enu(Vector3::new(east_m, north_m, up_m))
    }

    /// From a plain ENU vector (metres).
    pub fn from_vector(v: Vector3<f64>) -> Enu {
        Enu(v)
    }

    /// As a plain ENU vector (metres).
    pub fn vector(&self) -> Vector3<f64> {
        self.0
    }

    /// East component, m.
    pub fn east_m(&self) -> f64 {
        self.0.x
    }

    /// North component, m.
    pub fn north_m(&self) -> f64 {
        self.0.y
    }

    /// Up component, m.
    pub fn up_m(&self) -> f64 {
        self.0.z
    }
}

/// Projected coordinates: grid easting and northing of a map projection (e.g. UTM) and height
/// up, metres. Grid axes are not the local north/east: they differ by the grid convergence and
/// scale (SPEC §3), so a [`Ned`] vector is never added to a `Grid` position.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Grid(Vector3<f64>);

impl Grid {
    /// From easting, northing and height in metres.
    pub fn new(easting_m: f64, northing_m: f64, height_m: f64) -> Grid {
        Grid(Vector3::new(easting_m, northing_m, height_m))
    }

    /// From a plain `[easting, northing, height]` vector (metres).
    pub fn from_vector(v: Vector3<f64>) -> Grid {
        Grid(v)
    }

    /// As a plain `[easting, northing, height]` vector (metres).
    pub fn vector(&self) -> Vector3<f64> {
        self.0
    }

    /// Grid easting, m (false easting included).
    pub fn easting_m(&self) -> f64 {
        self.0.x
    }

    /// Grid northing, m (false northing included).
    pub fn northing_m(&self) -> f64 {
        self.0.y
    }

    /// Height, m (in the height system of the coordinates given).
    pub fn height_m(&self) -> f64 {
        self.0.z
    }
}

/// Platform attitude from the INS, radians: `R_N = Rz(heading) · Ry(pitch) · Rx(roll)` rotates the
/// body frame B (X forward, Y right, Z down) into N.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Attitude {
    /// Roll about body X, rad, positive right wing down.
    pub roll_rad: f64,
    /// Pitch about body Y, rad, positive nose up.
    pub pitch_rad: f64,
    /// Heading (true) about body Z, rad, clockwise from north.
    pub heading_rad: f64,
}

impl Attitude {
    /// Attitude from angles in degrees.
    pub fn from_degrees(roll_deg: f64, pitch_deg: f64, heading_deg: f64) -> Attitude {
        Attitude {
            roll_rad: roll_deg.to_radians(),
            pitch_rad: pitch_deg.to_radians(),
            heading_rad: heading_deg.to_radians(),
        }
    }
    /// `R_N = Rz(heading) · Ry(pitch) · Rx(roll)`: body B → local NED.
    pub fn body_to_ned(&self) -> Matrix3<f64> {
        rotation_zyx(self.roll_rad, self.pitch_rad, self.heading_rad)
    }
}

/// How the scanner is mounted on the IMU: boresight `R_M = Rz(yaw) · Ry(pitch) · Rx(roll)` rotates
/// the scanner frame S into the body frame B; the lever arm is the scanner origin in B relative to
/// the GNSS/INS reference point.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Mounting {
    /// Boresight roll (about S X), rad. Zhang et al. (2018) Δα.
    pub boresight_roll_rad: f64,
    /// Boresight pitch (about S Y), rad. Zhang et al. (2018) Δβ.
    pub boresight_pitch_rad: f64,
    /// Boresight yaw (about S Z), rad. Zhang et al. (2018) Δγ.
    pub boresight_yaw_rad: f64,
    /// Lever arm in the body frame (X forward, Y right, Z down), m. Zhang et al. (2018) ΔP.
    pub lever_arm_m: Vector3<f64>,
}

impl Mounting {
    /// The boresight `R_M = Rz(yaw) · Ry(pitch) · Rx(roll)`: scanner S → body B.
    pub fn scanner_to_body(&self) -> Matrix3<f64> {
        rotation_zyx(
            self.boresight_roll_rad,
            self.boresight_pitch_rad,
            self.boresight_yaw_rad,
        )
    }
}

/// `R_M` (scanner → body), its partials in boresight roll, pitch, yaw and the lever arm ΔP of
/// a mounting: the same for every point of a tile, prepared once.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MountingPartials {
    pub(crate) r_m: Matrix3<f64>,
    pub(crate) d_r_m: [Matrix3<f64>; 3],
    pub(crate) lever_m: Vector3<f64>,
}

impl MountingPartials {
    /// Prepares `m`.
    pub fn new(m: &Mounting) -> MountingPartials {
        let (r_m, d_r_m) = rotation_zyx_with_partials(
            m.boresight_roll_rad,
            m.boresight_pitch_rad,
            m.boresight_yaw_rad,
        );
        MountingPartials {
            r_m,
            d_r_m,
            lever_m: m.lever_arm_m,
        }
    }
}
