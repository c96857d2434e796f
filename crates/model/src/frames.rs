//! Frame-carrying types used at crate boundaries (SPEC §3).
//!
//! Inside a kernel plain nalgebra vectors are fine; across crates a vector says which frame it is in.

use nalgebra::Vector3;

/// A vector in the local navigation frame N (North-East-Down), metres.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Ned {
    /// North component, m.
    pub north_m: f64,
    /// East component, m.
    pub east_m: f64,
    /// Down component, m (positive below the origin).
    pub down_m: f64,
}

impl Ned {
    /// From a plain NED vector (metres).
    pub fn from_vector(v: &Vector3<f64>) -> Ned {
        Ned {
            north_m: v.x,
            east_m: v.y,
            down_m: v.z,
        }
    }

    /// As a plain NED vector (metres).
    pub fn to_vector(self) -> Vector3<f64> {
        Vector3::new(self.north_m, self.east_m, self.down_m)
    }

    /// Up component, m (= −down).
    pub fn up_m(self) -> f64 {
        -self.down_m
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
}

/// How the scanner is mounted on the IMU: boresight `R_M = Rz(yaw) · Ry(pitch) · Rx(roll)` rotates
/// the scanner frame S into the body frame B; the lever arm is the scanner origin in B relative to
/// the GNSS/INS reference point.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Mounting {
    /// Boresight roll (about S X), rad. Seed 000 Δα.
    pub boresight_roll_rad: f64,
    /// Boresight pitch (about S Y), rad. Seed 000 Δβ.
    pub boresight_pitch_rad: f64,
    /// Boresight yaw (about S Z), rad. Seed 000 Δγ.
    pub boresight_yaw_rad: f64,
    /// Lever arm in the body frame (X forward, Y right, Z down), m. Seed 000 ΔP.
    pub lever_arm_m: Vector3<f64>,
}
