//! The beam model: one georeferencing model for every scanner that measures a range along a beam
//! whose direction its own encoders give: each return is
//!
//! `P − P0 = δP_gnss + R_N (R_M ρ H d(a, b, ε) + ΔP)`,
//!
//! the sensor origin plus range ρ times the unit beam direction. `d` is the direction in the
//! scanner head's frame from the scanner's own angles, `H` a fixed rotation of the head inside the
//! scanner frame (a tilted mount, a rotation axis laid horizontal), and `R_N`, `R_M`, `ΔP` the
//! attitude, boresight and lever arm of every other model ([`crate::Georeferencer`]).
//!
//! The head geometries ([`BeamKind`]):
//! - **rotating mirror** (RIEGL VUX/miniVUX 360°, polygon scanners): `d = [0, sin a, cos a]`, the
//!   linear scanner's vector; with `H = I` it is the linear scanner of Zhang Yue et al. (2018)
//!   exactly (a test checks that the σ agree).
//! - **spinning multi-beam** (Velodyne, Hesai, Ouster heads): head azimuth `a` about the head's
//!   z axis (its rotation axis), channel elevation `ε` above the head's x-y plane:
//!   `d = [cos ε cos a, cos ε sin a, sin ε]`. `H` lays the rotation axis in any orientation.
//! - **Risley prism pair** (Livox): two thin wedges turning at angles `a` and `b`, each deviating
//!   the beam by its fixed deviation `δ₁`, `δ₂` towards its own angle:
//!   `d = Rz(b) Ry(δ₂) Rz(−b) Rz(a) Ry(δ₁) Rz(−a) ẑ` (the first-order, constant-deviation
//!   model of a thin prism; the rosette follows from the two rotation rates).
//! - **elliptical / Palmer** (Leica oblique scanners, RIEGL's elliptic bathymetric scanners): a
//!   nutating mirror sweeps the beam on a cone of half-angle `α` about the head's z axis:
//!   `d = [sin α cos a, sin α sin a, cos α]`; a forward tilt of the axis in `H` draws the ellipse on
//!   the ground.
//!
//! The parameter vector is the platform's twelve sources then range, `scan_angle` (the first
//! encoder: mirror angle, head azimuth, first prism, nutation angle), `scan_angle_2` (the second
//! prism's encoder) and `channel_elevation`; a source a head does not use has a zero column.
//! The function is generic over the scalar so that dual numbers give the exact Jacobian of the same
//! code, as for the linear and conic scanners.
//!
//! Two terms are not parameters of the direction and are added to `J Σ Jᵀ` by
//! [`BeamScanner::covariance_ned`]:
//! - the range σ grows with the range, `σ_ρ = σ₀ + k·ρ` (the maker's "constant + ppm" form, the
//!   two added, as spec sheets quote them);
//! - the beam divergence γ (full angle) spreads the return over the footprint: σ = γ/4 in each
//!   direction across the beam, the quarter of the divergence of Glennie, C., "Rigorous 3D error
//!   analysis of kinematic scanning LIDAR systems", Journal of Applied Geodesy 1 (2007).

use crate::error::{Error, Result};
use crate::frames::{Attitude, Mounting};
use crate::georeferencer::{Georeferencer, gnss_offset_ned, platform_parameters, platform_then};
use crate::rotation::{rot_y, rot_z, rotation_zyx};
use crate::scalar::Scalar;
use crate::source::Source;
use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

/// Number of parameters of the beam model: the platform's twelve, range, two encoders, channel
/// elevation.
pub const BEAM_N: usize = 16;

/// The scanner head's geometry: how its encoder angles give the beam direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum BeamKind {
    /// 360° rotating (or polygon) mirror: `d = [0, sin a, cos a]`.
    RotatingMirror,
    /// Spinning multi-beam head: `d = [cos ε cos a, cos ε sin a, sin ε]`, channel elevation ε.
    SpinningMultibeam,
    /// Risley prism pair with the deviations of its two wedges, rad.
    Risley {
        /// Deviation of the first wedge, rad.
        deviation_1_rad: f64,
        /// Deviation of the second wedge, rad.
        deviation_2_rad: f64,
    },
    /// Elliptical / Palmer scanner: a cone of half-angle α about the head's z axis.
    Elliptical {
        /// Cone half-angle α, rad.
        half_angle_rad: f64,
    },
}

impl BeamKind {
    /// The sensor-file and JSON name: `rotating-mirror`, `spinning-multibeam`, `risley`,
    /// `elliptical`.
    pub fn name(&self) -> &'static str {
        match self {
            BeamKind::RotatingMirror => "rotating-mirror",
            BeamKind::SpinningMultibeam => "spinning-multibeam",
            BeamKind::Risley { .. } => "risley",
            BeamKind::Elliptical { .. } => "elliptical",
        }
    }

    /// The names of every beam kind, for error messages.
    pub const NAMES: [&'static str; 4] = [
        "rotating-mirror",
        "spinning-multibeam",
        "risley",
        "elliptical",
    ];
}

/// A beam scanner: its head geometry and constants.
#[derive(Debug, Clone, PartialEq)]
pub struct BeamScanner {
    /// The head geometry.
    pub kind: BeamKind,
    /// Head to scanner frame `H` (a fixed rotation: tilted mount, rotation axis orientation).
    pub head_to_scanner: Matrix3<f64>,
    /// Range σ per metre of range (the ppm part, as a ratio: 1 ppm = 1e-6), added to `[sigma]
    /// range_m`.
    pub range_sigma_per_m: f64,
    /// Full beam divergence γ, rad (0: no footprint term).
    pub beam_divergence_rad: f64,
    /// Nominal channel elevations ε, rad (spinning multi-beam; empty otherwise).
    pub channel_elevations_rad: Vec<f64>,
}

/// Raw observation of one return of a beam scanner.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct BeamObservation {
    /// Range ρ, m.
    pub range_m: f64,
    /// First encoder angle `a` (mirror angle, head azimuth, first prism, nutation), rad.
    pub angle_rad: f64,
    /// Second encoder angle `b` (the second Risley prism), rad; 0 for other heads.
    pub angle_2_rad: f64,
    /// Channel elevation ε (spinning multi-beam), rad; 0 for other heads.
    pub channel_elevation_rad: f64,
}

impl BeamScanner {
    /// The sources the beam scanner adds after the platform's.
    pub const SCANNER_SOURCES: [Source; 4] = [
        Source::Range,
        Source::ScanAngle,
        Source::ScanAngle2,
        Source::ChannelElevation,
    ];

    /// A scanner of `kind` with its head level in the scanner frame and no range-proportional σ or
    /// divergence.
    pub fn new(kind: BeamKind) -> BeamScanner {
        BeamScanner {
            kind,
            head_to_scanner: Matrix3::identity(),
            range_sigma_per_m: 0.0,
            beam_divergence_rad: 0.0,
            channel_elevations_rad: Vec::new(),
        }
    }

    /// Check the constants: finite, `H` a rotation, σ per metre and divergence ≥ 0, a Risley
    /// deviation or cone half-angle in (0°, 90°), channel elevations within ±90°.
    ///
    /// # Errors
    /// [`Error::InvalidBeam`] naming the constant at fault.
    pub fn check(&self) -> Result<()> {
        let bad = |m: String| Err(Error::InvalidBeam(m));
        let h = &self.head_to_scanner;
        if !h.iter().all(|v| v.is_finite())
            || (h.transpose() * h - Matrix3::identity()).amax() > 1e-9
            || (h.determinant() - 1.0).abs() > 1e-9
        {
            return bad("the head orientation is not a rotation".into());
        }
        if !(self.range_sigma_per_m.is_finite() && self.range_sigma_per_m >= 0.0) {
            return bad(format!(
                "range_sigma_ppm must be a finite number >= 0, got {}",
                self.range_sigma_per_m * 1e6
            ));
        }
        if !(self.beam_divergence_rad.is_finite() && self.beam_divergence_rad >= 0.0) {
            return bad(format!(
                "beam divergence must be a finite number >= 0, got {} mrad",
                self.beam_divergence_rad * 1e3
            ));
        }
        let in_open_quarter = |v: f64| v.is_finite() && v > 0.0 && v < std::f64::consts::FRAC_PI_2;
        match self.kind {
            BeamKind::Risley {
                deviation_1_rad,
                deviation_2_rad,
            } => {
                for (i, d) in [deviation_1_rad, deviation_2_rad].into_iter().enumerate() {
                    if !in_open_quarter(d) {
                        return bad(format!(
                            "prism deviation {} must lie in (0°, 90°), got {}°",
                            i + 1,
                            d.to_degrees()
                        ));
                    }
                }
            }
            BeamKind::Elliptical { half_angle_rad } => {
                if !in_open_quarter(half_angle_rad) {
                    return bad(format!(
                        "cone half-angle must lie in (0°, 90°), got {}°",
                        half_angle_rad.to_degrees()
                    ));
                }
            }
            BeamKind::SpinningMultibeam => {
                if self.channel_elevations_rad.is_empty() {
                    return bad("a spinning multi-beam head needs its channel elevations".into());
                }
                for (i, e) in self.channel_elevations_rad.iter().enumerate() {
                    if !(e.is_finite() && e.abs() < std::f64::consts::FRAC_PI_2) {
                        return bad(format!(
                            "channel {i} elevation must lie within ±90°, got {}°",
                            e.to_degrees()
                        ));
                    }
                }
            }
            BeamKind::RotatingMirror => {}
        }
        Ok(())
    }

    /// Unit beam direction in the head frame at the encoder angles `a`, `b` and elevation `ε`.
    pub fn head_direction<D: Scalar>(&self, a: D, b: D, elevation: D) -> Vector3<D> {
        let zero = D::zero();
        match self.kind {
            BeamKind::RotatingMirror => {
                let (s, c) = a.sin_cos();
                Vector3::new(zero, s, c)
            }
            BeamKind::SpinningMultibeam => {
                let (sa, ca) = a.sin_cos();
                let (se, ce) = elevation.sin_cos();
                Vector3::new(ce * ca, ce * sa, se)
            }
            BeamKind::Risley {
                deviation_1_rad,
                deviation_2_rad,
            } => {
                let wedge = |angle: D, deviation: f64| {
                    rot_z(angle) * rot_y(D::from(deviation)) * rot_z(-angle)
                };
                let z = Vector3::new(zero, zero, D::one());
                wedge(b, deviation_2_rad) * (wedge(a, deviation_1_rad) * z)
            }
            BeamKind::Elliptical { half_angle_rad } => {
                let (sa, ca) = a.sin_cos();
                let (s, c) = half_angle_rad.sin_cos();
                Vector3::new(D::from(s) * ca, D::from(s) * sa, D::from(c))
            }
        }
    }

    /// Unit beam direction in the scanner frame, `H d`.
    pub fn scanner_direction<D: Scalar>(&self, a: D, b: D, elevation: D) -> Vector3<D> {
        self.head_to_scanner.map(D::from) * self.head_direction(a, b, elevation)
    }

    /// The range σ at range `range_m`: `σ₀ + k ρ` with σ₀ the sensor's `[sigma] range_m`.
    pub fn range_sigma(&self, sigma_0_m: f64, range_m: f64) -> f64 {
        sigma_0_m + self.range_sigma_per_m * range_m
    }
}

impl Georeferencer<BEAM_N> for BeamScanner {
    type Observation = BeamObservation;

    const SOURCES: [Source; BEAM_N] = platform_then(BeamScanner::SCANNER_SOURCES);

    fn parameters(&self, a: &Attitude, m: &Mounting, o: &BeamObservation) -> SVector<f64, BEAM_N> {
        let mut p = platform_parameters(a, m);
        p[12] = o.range_m;
        p[13] = o.angle_rad;
        p[14] = o.angle_2_rad;
        p[15] = o.channel_elevation_rad;
        p
    }

    fn footprint_ned<D: Scalar>(&self, p: &SVector<D, BEAM_N>) -> Vector3<D> {
        let r_n = rotation_zyx(p[3], p[4], p[5]);
        let r_m = rotation_zyx(p[6], p[7], p[8]);
        let lever = Vector3::new(p[9], p[10], p[11]);
        let s = self.scanner_direction(p[13], p[14], p[15]) * p[12];
        gnss_offset_ned(p[0], p[1], p[2]) + r_n * (r_m * s + lever)
    }
}

/// The Jacobian of a beam footprint (m per SI unit of each source), for callers that want the
/// per-source budget: a convenience over [`Georeferencer::footprint_jacobian`].
pub fn beam_jacobian(
    scanner: &BeamScanner,
    attitude: &Attitude,
    mounting: &Mounting,
    observation: &BeamObservation,
) -> (Vector3<f64>, SMatrix<f64, 3, BEAM_N>) {
    scanner.footprint_jacobian(&scanner.parameters(attitude, mounting, observation))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::linear::{LINEAR_N, LinearObservation, LinearScanner};
    use crate::sensor::{Scanner, Sensor, Sigmas};

    fn sensor(range_m: f64, angle_deg: f64) -> Sensor {
        let deg = 1f64.to_radians();
        let sigma = Sigmas::zero()
            .with(Source::GnssNorth, 0.03)
            .and_then(|s| s.with(Source::GnssEast, 0.03))
            .and_then(|s| s.with(Source::GnssUp, 0.05))
            .and_then(|s| s.with(Source::Roll, 0.005 * deg))
            .and_then(|s| s.with(Source::Pitch, 0.005 * deg))
            .and_then(|s| s.with(Source::Heading, 0.008 * deg))
            .and_then(|s| s.with(Source::BoresightRoll, 0.003 * deg))
            .and_then(|s| s.with(Source::BoresightPitch, 0.003 * deg))
            .and_then(|s| s.with(Source::BoresightYaw, 0.005 * deg))
            .and_then(|s| s.with(Source::LeverX, 0.01))
            .and_then(|s| s.with(Source::LeverY, 0.01))
            .and_then(|s| s.with(Source::LeverZ, 0.01))
            .and_then(|s| s.with(Source::Range, range_m))
            .and_then(|s| s.with(Source::ScanAngle, angle_deg * deg))
            .unwrap();
        Sensor {
            scanner: Scanner::Linear,
            mounting: Mounting::default(),
            sigma,
            correlation: None,
        }
    }

    /// The rotating mirror with a level head is the linear scanner: the same footprint, and σ
    /// within 0.5 % (in fact to rounding) when configured alike.
    #[test]
    fn rotating_mirror_agrees_with_the_linear_scanner() {
        let s = sensor(0.02, 0.001);
        let attitude = Attitude::from_degrees(2.0, -1.5, 37.0);
        let mounting = Mounting {
            boresight_roll_rad: 0.01,
            boresight_pitch_rad: -0.02,
            boresight_yaw_rad: 0.03,
            lever_arm_m: Vector3::new(0.2, -0.1, 0.4),
        };
        let beam = BeamScanner::new(BeamKind::RotatingMirror);
        for theta_deg in [-60.0, -20.0, 0.0, 5.0, 35.0, 75.0] {
            let theta = f64::to_radians(theta_deg);
            let range = 600.0;
            let lin_p = LinearScanner.parameters(
                &attitude,
                &mounting,
                &LinearObservation {
                    range_m: range,
                    scan_angle_rad: theta,
                },
            );
            let (f_lin, j_lin) = LinearScanner.footprint_jacobian(&lin_p);
            let c_lin = j_lin
                * s.covariance(&<LinearScanner as Georeferencer<LINEAR_N>>::SOURCES)
                * j_lin.transpose();
            let obs = BeamObservation {
                range_m: range,
                angle_rad: theta,
                ..BeamObservation::default()
            };
            let (f_beam, _) = beam_jacobian(&beam, &attitude, &mounting, &obs);
            assert!((f_lin - f_beam).norm() < 1e-9, "{theta_deg}");
            let c_beam = beam.covariance_ned(&s, &attitude, &mounting, &obs);
            for k in 0..3 {
                let rel = (c_beam[(k, k)].sqrt() / c_lin[(k, k)].sqrt() - 1.0).abs();
                assert!(rel < 0.005, "axis {k} at {theta_deg}°: {rel}");
            }
        }
    }

    #[test]
    fn directions_are_unit_and_known() {
        let mb = BeamScanner::new(BeamKind::SpinningMultibeam);
        let d = mb.head_direction::<f64>(0.0, 0.0, 30f64.to_radians());
        assert!((d - Vector3::new(30f64.to_radians().cos(), 0.0, 0.5)).norm() < 1e-12);
        let r = BeamScanner::new(BeamKind::Risley {
            deviation_1_rad: 0.2,
            deviation_2_rad: 0.2,
        });
        // Both wedges towards the same side: the deviations add.
        let d = r.head_direction::<f64>(0.0, 0.0, 0.0);
        assert!((d.z.acos() - 0.4).abs() < 1e-12);
        // Opposed wedges cancel.
        let d = r.head_direction::<f64>(0.0, std::f64::consts::PI, 0.0);
        assert!(d.z > 1.0 - 1e-12, "{d:?}");
        let e = BeamScanner::new(BeamKind::Elliptical {
            half_angle_rad: 0.3,
        });
        for a in [0.0, 1.0, 2.5] {
            let d = e.head_direction::<f64>(a, 0.0, 0.0);
            assert!((d.norm() - 1.0).abs() < 1e-12);
            assert!((d.z.acos() - 0.3).abs() < 1e-12);
        }
    }

    #[test]
    fn ppm_and_divergence_add_what_they_should() {
        let mut s = sensor(0.01, 0.0);
        for src in Source::ALL {
            if *src != Source::Range {
                s.sigma.set(*src, 0.0).unwrap();
            }
        }
        let mut beam = BeamScanner::new(BeamKind::RotatingMirror);
        beam.range_sigma_per_m = 10e-6;
        let obs = BeamObservation {
            range_m: 1000.0,
            ..BeamObservation::default()
        };
        let (a, m) = (Attitude::default(), Mounting::default());
        let c = beam.covariance_ned(&s, &a, &m, &obs);
        // Nadir beam: down σ = 0.01 + 10 ppm × 1000 m = 0.02 m, nothing across.
        assert!((c[(2, 2)].sqrt() - 0.02).abs() < 1e-12);
        assert!(c[(0, 0)].abs() < 1e-18);
        beam.beam_divergence_rad = 0.4e-3;
        let c = beam.covariance_ned(&s, &a, &m, &obs);
        // 1000 m × 0.4 mrad / 4 = 0.1 m across the beam in both directions.
        assert!((c[(0, 0)].sqrt() - 0.1).abs() < 1e-12);
        assert!((c[(1, 1)].sqrt() - 0.1).abs() < 1e-12);
        assert!((c[(2, 2)].sqrt() - 0.02).abs() < 1e-12);
    }

    #[test]
    fn check_names_the_constant() {
        let mut b = BeamScanner::new(BeamKind::SpinningMultibeam);
        assert!(b.check().unwrap_err().to_string().contains("channel"));
        b.channel_elevations_rad = vec![0.1, -0.2];
        b.check().unwrap();
        let r = BeamScanner::new(BeamKind::Risley {
            deviation_1_rad: 0.0,
            deviation_2_rad: 0.3,
        });
        assert!(
            r.check()
                .unwrap_err()
                .to_string()
                .contains("prism deviation 1")
        );
    }
}
