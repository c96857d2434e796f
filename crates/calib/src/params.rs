//! The six mounting parameters solved for, in the order and with the keys of SPEC §8.

use lidarqa_model::Mounting;
use nalgebra::Vector3;

/// Number of mounting parameters (lever arm x/y/z, boresight roll/pitch/yaw).
pub const PARAM_COUNT: usize = 6;

/// One of the six mounting parameters.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Param {
    /// Lever arm along body X (forward), m.
    LeverX,
    /// Lever arm along body Y (right wing), m.
    LeverY,
    /// Lever arm along body Z (down), m.
    LeverZ,
    /// Boresight roll Δα (about scanner X), rad.
    BoresightRoll,
    /// Boresight pitch Δβ (about scanner Y), rad.
    BoresightPitch,
    /// Boresight yaw Δγ (about scanner Z), rad.
    BoresightYaw,
}

impl Param {
    /// All six, in parameter-vector order.
    pub const ALL: [Param; PARAM_COUNT] = [
        Param::LeverX,
        Param::LeverY,
        Param::LeverZ,
        Param::BoresightRoll,
        Param::BoresightPitch,
        Param::BoresightYaw,
    ];

    /// Position in the parameter vector.
    pub fn index(self) -> usize {
        self as usize
    }

    /// The JSON key with its unit suffix (SPEC §8): `lever_x_m`, …, `boresight_yaw_deg`.
    pub fn key(self) -> &'static str {
        match self {
            Param::LeverX => "lever_x_m",
            Param::LeverY => "lever_y_m",
            Param::LeverZ => "lever_z_m",
            Param::BoresightRoll => "boresight_roll_deg",
            Param::BoresightPitch => "boresight_pitch_deg",
            Param::BoresightYaw => "boresight_yaw_deg",
        }
    }

    /// True for the three boresight angles (radians inside, degrees in JSON).
    pub fn is_angle(self) -> bool {
        matches!(
            self,
            Param::BoresightRoll | Param::BoresightPitch | Param::BoresightYaw
        )
    }

    /// SI value (m or rad) → the JSON unit of [`Param::key`] (m or degrees).
    pub fn to_display(self, si: f64) -> f64 {
        if self.is_angle() { si.to_degrees() } else { si }
    }

    /// The JSON unit (m or degrees) → SI (m or rad).
    pub fn from_display(self, shown: f64) -> f64 {
        if self.is_angle() {
            shown.to_radians()
        } else {
            shown
        }
    }
}

/// The six parameters as a vector `[lever_x, lever_y, lever_z, roll, pitch, yaw]`, m and rad.
pub fn mounting_to_vector(m: &Mounting) -> [f64; PARAM_COUNT] {
    [
        m.lever_arm_m.x,
        m.lever_arm_m.y,
        m.lever_arm_m.z,
        m.boresight_roll_rad,
        m.boresight_pitch_rad,
        m.boresight_yaw_rad,
    ]
}

/// The inverse of [`mounting_to_vector`].
pub fn mounting_from_vector(x: &[f64; PARAM_COUNT]) -> Mounting {
    Mounting {
        boresight_roll_rad: x[3],
        boresight_pitch_rad: x[4],
        boresight_yaw_rad: x[5],
        lever_arm_m: Vector3::new(x[0], x[1], x[2]),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vector_round_trip_and_keys() {
        let x = [0.1, -0.05, 0.2, 1e-3, -5e-4, 1.4e-3];
        assert_eq!(mounting_to_vector(&mounting_from_vector(&x)), x);
        assert_eq!(Param::ALL[4].key(), "boresight_pitch_deg");
        assert!((Param::BoresightYaw.to_display(std::f64::consts::PI) - 180.0).abs() < 1e-12);
        assert_eq!(Param::LeverZ.to_display(0.2), 0.2);
    }
}
