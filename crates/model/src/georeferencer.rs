//! The common shape of a georeferencing model: a parameter vector of named sources in, the footprint
//! relative to the GNSS/INS reference point (NED metres) out, generic over the scalar so that dual
//! numbers give the exact Jacobian of the very same code.

use crate::frames::{Attitude, Mounting};
use crate::scalar::Scalar;
use crate::source::Source;
use nalgebra::{SMatrix, SVector, Vector3};
use num_dual::{DualSVec64, jacobian};

/// A georeferencing model with `N` named parameters (SPEC §4 sources).
pub trait Georeferencer<const N: usize> {
    /// The raw observation of one pulse besides attitude and mounting (range and scan angle, or
    /// azimuth and travel times).
    type Observation;

    /// The sources, in the order of the parameter vector.
    const SOURCES: [Source; N];

    /// The nominal parameter vector (SI units) for one pulse; GNSS position errors are 0.
    fn parameters(
        &self,
        attitude: &Attitude,
        mounting: &Mounting,
        observation: &Self::Observation,
    ) -> SVector<f64, N>;

    /// Footprint minus GNSS/INS reference point, NED metres, at parameters `p`:
    /// `P − P0 = δP_gnss + R_N (R_M S + ΔP)`.
    fn footprint_ned<D: Scalar>(&self, p: &SVector<D, N>) -> Vector3<D>;

    /// Footprint (NED, m) and its exact Jacobian (m per SI unit of each source).
    ///
    /// The default runs [`Georeferencer::footprint_ned`] once with `N`-direction dual numbers. A model
    /// may override it with a cheaper composition of per-stage dual-number Jacobians (the linear
    /// scanner does); it must agree with the default to rounding.
    fn footprint_jacobian(&self, p: &SVector<f64, N>) -> (Vector3<f64>, SMatrix<f64, 3, N>) {
        jacobian(|q: SVector<DualSVec64<N>, N>| self.footprint_ned(&q), p)
    }
}

/// GNSS/INS position error (north, east, up parameters) as an NED offset.
pub(crate) fn gnss_offset_ned<D: Scalar>(north: D, east: D, up: D) -> Vector3<D> {
    Vector3::new(north, east, -up)
}

/// The trajectory's sources (GNSS position north, east, up; roll, pitch, heading): the first six
/// parameters of every model, and what a trajectory file's σ cover.
pub const TRAJECTORY_SOURCES: [Source; 6] = [
    Source::GnssNorth,
    Source::GnssEast,
    Source::GnssUp,
    Source::Roll,
    Source::Pitch,
    Source::Heading,
];

/// The mounting's sources (boresight roll, pitch, yaw; lever arm X, Y, Z): parameters 6 to 11 of
/// every model.
const MOUNTING_SOURCES: [Source; 6] = [
    Source::BoresightRoll,
    Source::BoresightPitch,
    Source::BoresightYaw,
    Source::LeverX,
    Source::LeverY,
    Source::LeverZ,
];

/// A model's [`Georeferencer::SOURCES`]: the platform's twelve (trajectory, mounting) then the
/// scanner's own, so that every model orders the platform alike. `N` must be `12 + K` (checked
/// when the constant is evaluated).
pub(crate) const fn platform_then<const K: usize, const N: usize>(
    scanner: [Source; K],
) -> [Source; N] {
    assert!(N == 12 + K, "N must be 12 + K");
    let mut out = [Source::GnssNorth; N];
    let mut i = 0;
    while i < 6 {
        out[i] = TRAJECTORY_SOURCES[i];
        out[6 + i] = MOUNTING_SOURCES[i];
        i += 1;
    }
    let mut k = 0;
    while k < K {
        out[12 + k] = scanner[k];
        k += 1;
    }
    out
}

/// The platform's part of a parameter vector (the order of [`platform_then`]): GNSS position
/// errors 0, the attitude and the mounting; the scanner's parameters are left 0 for the caller.
pub(crate) fn platform_parameters<const N: usize>(a: &Attitude, m: &Mounting) -> SVector<f64, N> {
    let mut p = SVector::zeros();
    p[3] = a.roll_rad;
    p[4] = a.pitch_rad;
    p[5] = a.heading_rad;
    p[6] = m.boresight_roll_rad;
    p[7] = m.boresight_pitch_rad;
    p[8] = m.boresight_yaw_rad;
    p[9] = m.lever_arm_m.x;
    p[10] = m.lever_arm_m.y;
    p[11] = m.lever_arm_m.z;
    p
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{CONIC_N, ConicScanner, LINEAR_N, LinearScanner};

    #[test]
    fn every_source_is_the_platform_s_or_one_scanner_s() {
        // The io sensor file refuses a key of the other scanner by these lists: each source must
        // be in exactly one of platform, linear, conic.
        let linear = <LinearScanner as Georeferencer<LINEAR_N>>::SOURCES;
        let conic = <ConicScanner as Georeferencer<CONIC_N>>::SOURCES;
        assert_eq!(linear[..12], conic[..12]);
        assert_eq!(linear[12..], LinearScanner::SCANNER_SOURCES);
        assert_eq!(conic[12..], ConicScanner::SCANNER_SOURCES);
        for s in Source::ALL {
            // The beam scanner shares range and scan angle with the linear one; its own are the
            // second encoder and the channel elevation.
            let beam_only = &crate::BeamScanner::SCANNER_SOURCES[2..];
            let n = [
                &linear[..12],
                &LinearScanner::SCANNER_SOURCES,
                &ConicScanner::SCANNER_SOURCES,
                beam_only,
            ]
            .iter()
            .filter(|l| l.contains(s))
            .count();
            assert_eq!(n, 1, "{s}");
        }
        assert_eq!(linear[..6], TRAJECTORY_SOURCES);
        assert_eq!(linear[5], Source::Heading);
        assert_eq!(linear[11], Source::LeverZ);
    }

    #[test]
    fn platform_parameters_sit_where_their_sources_are() {
        let a = Attitude::from_degrees(1.0, 2.0, 3.0);
        let m = Mounting {
            boresight_roll_rad: 0.4,
            boresight_pitch_rad: 0.5,
            boresight_yaw_rad: 0.6,
            lever_arm_m: nalgebra::Vector3::new(0.7, 0.8, 0.9),
        };
        let p: SVector<f64, 14> = platform_parameters(&a, &m);
        let sources = <LinearScanner as Georeferencer<LINEAR_N>>::SOURCES;
        let at = |s: Source| p[sources.iter().position(|x| *x == s).unwrap()];
        assert_eq!(at(Source::GnssUp), 0.0);
        assert_eq!(at(Source::Heading), a.heading_rad);
        assert_eq!(at(Source::BoresightPitch), 0.5);
        assert_eq!(at(Source::LeverY), 0.8);
        assert_eq!(at(Source::Range), 0.0);
    }
}
