//! Raw-observation recovery: from a georeferenced point and the trajectory at its time back to
//! the scanner's own observation (range and scan angle, or azimuth and air range).
//!
//! Inverting Zhang et al. (2018) eq. (2) `P = P0 + R_N (R_M S + ΔP)` with the N-frame vector taken
//! rigorously through ECEF (SPEC §3):
//!
//! `S = R_Mᵀ (R_Nᵀ C_NE (P − P0) − ΔP)`
//!
//! with `C_NE` the ECEF → NED rotation at P0. For the linear scanner `S = [0, ρ sin θ, ρ cos θ]`,
//! so `ρ = |S|`, `θ = atan2(S_y, S_z)`, and `S_x` (which should be ~0) is returned as a quality
//! figure: a timing offset, a wrong trajectory or a wrong boresight shows up there first. The
//! beam as it is, `S_x` included, is returned too (`θ' = asin(S_y/ρ)`, `β = atan2(S_x, S_z)`,
//! for [`lidarqa_model::OffPlaneLinearScanner`]) so that the propagation does not drop it.
//!
//! For the conic scanner a topographic or water-surface return is `S = ρ1 · l3(θaz)`; with the
//! nominal prism and emitter angles (all 0, as [`Georeferencer::parameters`] sets them)
//! `l3(θaz) = Rz(θaz) · l3(0)`, so `ρ1 = |S|`, `θaz = atan2(S_y, S_x) − atan2(l3(0)_y, l3(0)_x)`,
//! and the distance of `S` from the nominal cone is the quality figure. Bathymetric soundings
//! (the in-water leg after the water-surface intersection) are recovered in
//! [`crate::sounding`] from the seabed point and its water surface.
//!
//! For a beam scanner (rotating mirror, spinning multi-beam, Risley pair, elliptical) `S` is
//! handed to the beam model's own inversion ([`lidarqa_model::BeamScanner::invert`]): the range,
//! the head's encoder angles and, for a multi-beam head, the channel; a Risley pair's prism
//! angles only up to the mirror pair that fires the same beam (both are returned).

use crate::error::{Error, Result};
use crate::trajectory::PoseAt;
use lidarqa_model::{
    Attitude, BeamInversion, BeamScanner, ConicObservation, ConicScanner, Ecef, Georeferencer,
    LinearObservation, Mounting, Ned, OffPlaneLinearScanner,
};
use nalgebra::{Matrix3, Vector3};

/// The mounting, prepared once for many recoveries.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Recoverer {
    /// `R_M`, scanner S → body B.
    r_m: Matrix3<f64>,
    /// Lever arm ΔP in B, m.
    lever_m: Vector3<f64>,
}

/// A linear-scanner observation recovered from a point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinearRecovery {
    /// Slant range ρ = |S|, m.
    pub range_m: f64,
    /// Scan angle θ = atan2(S_y, S_z), rad, positive towards the right wing.
    pub scan_angle_rad: f64,
    /// `S_x`, m: the component out of the scan plane (0 for a perfect model).
    pub out_of_plane_m: f64,
    /// Unit beam direction (scanner origin → point) in N at P0.
    pub beam_ned: Ned,
    /// `S` itself, scanner frame, m (for [`lidarqa_model::linear_jacobian_at_beam`]).
    pub scanner_m: Vector3<f64>,
}

impl LinearRecovery {
    /// The beam as it is, for [`OffPlaneLinearScanner`]: scan angle θ' = asin(S_y/ρ), rad
    /// (computed on demand: the per-point TPU works from `S` itself).
    pub fn beam_scan_angle_rad(&self) -> f64 {
        (self.scanner_m.y / self.range_m).clamp(-1.0, 1.0).asin()
    }

    /// The beam as it is: along-track angle β = atan2(S_x, S_z), rad.
    pub fn along_track_rad(&self) -> f64 {
        self.scanner_m.x.atan2(self.scanner_m.z)
    }

    /// The recovered beam as it is, out-of-plane part included: the model with its β and the
    /// observation (ρ, θ') that give back `S` exactly. The propagation uses these, so the σ
    /// follow the physical beam rather than its projection on the scan plane.
    pub fn off_plane(&self) -> (OffPlaneLinearScanner, LinearObservation) {
        (
            OffPlaneLinearScanner {
                along_track_rad: self.along_track_rad(),
            },
            LinearObservation {
                range_m: self.range_m,
                scan_angle_rad: self.beam_scan_angle_rad(),
            },
        )
    }
}

/// A conic-scanner observation recovered from a topographic / water-surface point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConicRecovery {
    /// The observation: azimuth, two-way air travel time, water time 0.
    pub observation: ConicObservation,
    /// Air range ρ1 = |S|, m.
    pub range_air_m: f64,
    /// Distance of `S` from the nominal cone at the recovered azimuth, m (0 for a perfect model).
    pub off_cone_m: f64,
    /// Unit beam direction (scanner origin → point) in N at P0.
    pub beam_ned: Ned,
    /// `S` itself, scanner frame, m.
    pub scanner_m: Vector3<f64>,
}

/// A beam-scanner observation recovered from a point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BeamRecovery {
    /// The range, encoder angles and channel, with the distance from the nearest beam the head
    /// fires as the quality figure.
    pub inversion: BeamInversion,
    /// Range ρ = |S|, m.
    pub range_m: f64,
    /// Unit beam direction (scanner origin → point) in N at P0.
    pub beam_ned: Ned,
    /// `S` itself, scanner frame, m.
    pub scanner_m: Vector3<f64>,
}

impl Recoverer {
    /// Prepares `R_M` and ΔP from the nominal mounting.
    pub fn new(mounting: &Mounting) -> Recoverer {
        Recoverer {
            r_m: mounting.scanner_to_body(),
            lever_m: mounting.lever_arm_m,
        }
    }

    /// `R_N R_M`: scanner frame S → N at the pose.
    pub fn body_from_scanner(&self, pose: &PoseAt) -> Matrix3<f64> {
        pose.body_to_ned * self.r_m
    }

    /// The lever arm ΔP in B, m.
    pub fn lever(&self) -> Vector3<f64> {
        self.lever_m
    }

    /// `S = R_Mᵀ (B − ΔP)`, scanner frame, of a point at `body_m` = `P − P0` in the body frame
    /// (for callers that rotate into the body frame their own way).
    pub fn scanner_from_body(&self, body_m: &Vector3<f64>) -> Vector3<f64> {
        self.r_m.transpose() * (body_m - self.lever_m)
    }

    /// `S = R_Mᵀ (R_Nᵀ C_NE (P − P0) − ΔP)`, scanner frame, metres; and the beam (scanner
    /// origin → point) in N.
    pub fn scanner_vector(&self, pose: &PoseAt, point: &Ecef) -> (Vector3<f64>, Vector3<f64>) {
        let s = self.scanner_from_ecef(pose, point);
        (s, self.beam_of(pose, &s))
    }

    /// `S` of [`Recoverer::scanner_vector`] alone.
    fn scanner_from_ecef(&self, pose: &PoseAt, point: &Ecef) -> Vector3<f64> {
        // R_Nᵀ C_NE = (C_EN R_N)ᵀ: straight from ECEF to the body frame.
        self.scanner_from_body(&(pose.body_to_ecef.transpose() * (*point - pose.position_ecef_m)))
    }

    /// Origin → point in N: `R_N R_M S`.
    fn beam_of(&self, pose: &PoseAt, s: &Vector3<f64>) -> Vector3<f64> {
        pose.body_to_ned * (self.r_m * s)
    }

    /// Range and scan angle of a linear-scanner point given in ECEF.
    ///
    /// # Errors
    /// [`Error::Recovery`] when the point is at the scanner origin or not finite.
    pub fn linear_ecef(&self, pose: &PoseAt, point: &Ecef) -> Result<LinearRecovery> {
        self.linear(pose, point, true)
    }

    /// [`Recoverer::linear_ecef`] without the beam (`beam_ned` is NaN), for a caller with no
    /// use for it (the per-point TPU without an incidence term): two rotations and three
    /// divisions less per point; every other value the same.
    ///
    /// # Errors
    /// As [`Recoverer::linear_ecef`].
    #[inline]
    pub fn linear_ecef_without_beam(&self, pose: &PoseAt, point: &Ecef) -> Result<LinearRecovery> {
        self.linear(pose, point, false)
    }

    #[inline]
    fn linear(&self, pose: &PoseAt, point: &Ecef, beam: bool) -> Result<LinearRecovery> {
        let s = self.scanner_from_ecef(pose, point);
        let range_m = s.norm();
        if !(range_m.is_finite() && range_m > 0.0) {
            return Err(Error::Recovery(format!("range {range_m} m")));
        }
        let beam_ned = if beam {
            self.beam_of(pose, &s) / range_m
        } else {
            Vector3::repeat(f64::NAN)
        };
        Ok(LinearRecovery {
            range_m,
            scan_angle_rad: s.y.atan2(s.z),
            out_of_plane_m: s.x,
            beam_ned: Ned::from_vector(beam_ned),
            scanner_m: s,
        })
    }

    /// Azimuth and air range of a conic-scanner topographic / water-surface point.
    ///
    /// # Errors
    /// [`Error::Recovery`] when the point is at the scanner origin or not finite.
    pub fn conic(
        &self,
        scanner: &ConicScanner,
        pose: &PoseAt,
        point: &Ecef,
    ) -> Result<ConicRecovery> {
        let (s, beam) = self.scanner_vector(pose, point);
        let range_air_m = s.norm();
        if !(range_air_m.is_finite() && range_air_m > 0.0) {
            return Err(Error::Recovery(format!("air range {range_air_m} m")));
        }
        let l3_0 = scanner.nominal_air_beam();
        let azimuth_rad = s.y.atan2(s.x) - l3_0.y.atan2(l3_0.x);
        // The nominal beam turned to this azimuth has S's horizontal direction and the
        // horizontal length |l3_0,xy| ρ1: S's distance from it needs no rotation.
        // Metres and a unit vector: the plain roots cannot overflow (no `hypot` needed).
        let l3_0_horizontal = (l3_0.x * l3_0.x + l3_0.y * l3_0.y).sqrt();
        let horizontal = (s.x * s.x + s.y * s.y).sqrt() - l3_0_horizontal * range_air_m;
        let vertical = s.z - l3_0.z * range_air_m;
        let off_cone_m = (horizontal * horizontal + vertical * vertical).sqrt();
        Ok(ConicRecovery {
            observation: ConicObservation {
                azimuth_rad,
                time_air_s: scanner.time_air_s(range_air_m),
                time_water_s: 0.0,
            },
            range_air_m,
            off_cone_m,
            beam_ned: Ned::from_vector(beam / range_air_m),
            scanner_m: s,
        })
    }
}

impl Recoverer {
    /// Range, encoder angles and channel of a beam scanner's point given in ECEF.
    ///
    /// # Errors
    /// [`Error::Recovery`] when the point is at the scanner origin or not finite.
    pub fn beam(&self, scanner: &BeamScanner, pose: &PoseAt, point: &Ecef) -> Result<BeamRecovery> {
        let (s, beam) = self.scanner_vector(pose, point);
        let range_m = s.norm();
        let inversion = scanner
            .invert(&s)
            .ok_or_else(|| Error::Recovery(format!("range {range_m} m")))?;
        Ok(BeamRecovery {
            inversion,
            range_m,
            beam_ned: Ned::from_vector(beam / range_m),
            scanner_m: s,
        })
    }
}

/// The air-leg direction l3 in S at azimuth `azimuth_rad` with nominal prism and emitter angles.
pub fn nominal_l3(scanner: &ConicScanner, azimuth_rad: f64) -> Vector3<f64> {
    let obs = ConicObservation {
        azimuth_rad,
        time_air_s: 0.0,
        time_water_s: 0.0,
    };
    let p = scanner.parameters(&Attitude::default(), &Mounting::default(), &obs);
    scanner.beam_directions(&p).0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::trajectory::{Pose, Trajectory};
    use approx::assert_relative_eq;
    use lidarqa_model::ecef_from_ned;
    use lidarqa_model::{LinearObservation, LinearScanner, Refraction};

    fn pose_and_mounting() -> (PoseAt, Mounting) {
        let (lat, lon) = (0.81_f64, 0.27_f64);
        let p0 = Ecef::new(4_100_000.0, 1_150_000.0, 4_700_000.0);
        let poses = [
            Pose {
                time_s: 0.0,
                position_ecef_m: p0,
                latitude_rad: lat,
                longitude_rad: lon,
                attitude: Attitude::from_degrees(2.0, -1.5, 123.0),
            },
            Pose {
                time_s: 1.0,
                position_ecef_m: p0,
                latitude_rad: lat,
                longitude_rad: lon,
                attitude: Attitude::from_degrees(2.0, -1.5, 123.0),
            },
        ];
        let m = Mounting {
            boresight_roll_rad: 0.01,
            boresight_pitch_rad: -0.02,
            boresight_yaw_rad: 0.03,
            lever_arm_m: Vector3::new(0.3, -0.2, 0.5),
        };
        (Trajectory::new(&poses).unwrap().at(0.5).unwrap(), m)
    }

    #[test]
    fn linear_round_trip_through_the_model() {
        let (pose, m) = pose_and_mounting();
        let obs = LinearObservation {
            range_m: 612.345,
            scan_angle_rad: -0.4321,
        };
        // β = 0 is Zhang et al.'s (2018) scanner; β ≠ 0 a beam off the scan plane, given back by
        // its β.
        for beta in [0.0, 0.0123_f64] {
            let g = OffPlaneLinearScanner {
                along_track_rad: beta,
            };
            let f = g.footprint_ned(&g.parameters(&pose.attitude(), &m, &obs));
            let point =
                pose.position_ecef_m + ecef_from_ned(pose.latitude_rad, pose.longitude_rad) * f;
            let r = Recoverer::new(&m).linear_ecef(&pose, &point).unwrap();
            assert_relative_eq!(r.range_m, 612.345, epsilon = 1e-8);
            let off = 612.345 * 0.4321f64.cos() * beta.sin();
            assert!((r.out_of_plane_m - off).abs() < 1e-8, "{beta}");
            assert_relative_eq!(r.beam_ned.vector().norm(), 1.0, epsilon = 1e-12);
            let (g2, obs2) = r.off_plane();
            assert_relative_eq!(g2.along_track_rad, beta, epsilon = 1e-12);
            assert_relative_eq!(obs2.range_m, 612.345, epsilon = 1e-8);
            assert_relative_eq!(obs2.scan_angle_rad, -0.4321, epsilon = 1e-12);
            if beta == 0.0 {
                assert_relative_eq!(r.scan_angle_rad, -0.4321, epsilon = 1e-12);
            }
            // Without the beam: every other value the same bits.
            let nb = Recoverer::new(&m)
                .linear_ecef_without_beam(&pose, &point)
                .unwrap();
            assert!(nb.beam_ned.vector().iter().all(|v| v.is_nan()));
            assert_eq!(
                LinearRecovery {
                    beam_ned: r.beam_ned,
                    ..nb
                },
                r
            );
        }
        // Zhang et al.'s (2018) own scanner gives the same point at β = 0.
        let f = LinearScanner.footprint_ned(&LinearScanner.parameters(&pose.attitude(), &m, &obs));
        let g = OffPlaneLinearScanner::default();
        assert_eq!(
            f,
            g.footprint_ned(&g.parameters(&pose.attitude(), &m, &obs))
        );
    }

    #[test]
    fn conic_round_trip_through_the_model() {
        let (pose, m) = pose_and_mounting();
        let s = ConicScanner::from_exit_angle(
            20f64.to_radians(),
            lidarqa_model::DEFAULT_N_PRISM,
            lidarqa_model::DEFAULT_N_AIR,
            lidarqa_model::DEFAULT_N_WATER,
            Refraction::ScannerFrame,
        )
        .unwrap();
        for az in [0.3_f64, 2.0, -2.5] {
            let obs = ConicObservation {
                azimuth_rad: az,
                time_air_s: s.time_air_s(425.7),
                time_water_s: 0.0,
            };
            let f = s.footprint_ned(&s.parameters(&pose.attitude(), &m, &obs));
            let point =
                pose.position_ecef_m + ecef_from_ned(pose.latitude_rad, pose.longitude_rad) * f;
            let r = Recoverer::new(&m).conic(&s, &pose, &point).unwrap();
            assert_relative_eq!(r.range_air_m, 425.7, epsilon = 1e-8);
            let d = (r.observation.azimuth_rad - az).rem_euclid(2.0 * std::f64::consts::PI);
            // ECEF coordinates of ~6e6 m round at ~1e-9 m: ~1e-12 rad at 425 m.
            assert!(d.min(2.0 * std::f64::consts::PI - d) < 1e-10, "{az}: {d}");
            assert!(r.off_cone_m < 1e-8);
        }
    }

    #[test]
    fn point_at_origin_is_refused() {
        let (pose, _) = pose_and_mounting();
        let r = Recoverer::new(&Mounting::default());
        assert!(r.linear_ecef(&pose, &pose.position_ecef_m).is_err());
    }
}
