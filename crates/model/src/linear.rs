//! The linear (oscillating-mirror) scanner of Zhang et al. (2018).
//!
//! Zhang et al. (2018) eq. (2): `P = P0 + R_N (R_M S + ΔP)` with `S = [0, ρ sin θ, ρ cos θ]` (θ > 0
//! to the right wing), `R_N = Rz(H) Ry(P) Rx(R)` and `R_M = Rz(Δγ) Ry(Δβ) Rx(Δα)`.
//! [`OffPlaneLinearScanner`] is the same scanner for a pulse recovered from a real point, which
//! leaves that plane by a small along-track angle.

use crate::error::{Error, Result};
use crate::frames::{Attitude, Mounting, MountingPartials};
use crate::georeferencer::{Georeferencer, gnss_offset_ned, platform_parameters, platform_then};
use crate::rotation::{rotation_zyx, rotation_zyx_with_partials, zyx_axes_of};
use crate::scalar::Scalar;
use crate::source::Source;
use nalgebra::{Matrix3, SMatrix, SVector, Vector2, Vector3};
use num_dual::{DualSVec64, jacobian};

/// Number of parameters of the linear model.
pub const LINEAR_N: usize = 14;

/// The linear scanner model; it has no constants of its own.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LinearScanner;

/// Raw observation of one linear-scanner pulse.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinearObservation {
    /// Slant range ρ, m.
    pub range_m: f64,
    /// Instantaneous scan angle θ, rad, positive towards the right wing (+Y of S).
    pub scan_angle_rad: f64,
}

/// The linear scanner with the pulse tilted out of the scan plane by a fixed along-track angle β:
/// `S = ρ [cos θ sin β, sin θ, cos θ cos β]`, i.e. `Ry(β)` applied to Zhang et al.'s (2018) vector.
///
/// Real pulses recovered from delivered points leave the nominal plane (a boresight, timing or
/// trajectory misfit); near nadir the range and attitude σ depend on the small across-track
/// part of the beam, so the propagation uses the beam as it is. β is a constant of the pulse,
/// not an error source: the parameter vector and its sources are those of [`LinearScanner`]
/// (θ is then the angle of the beam from the X-Z plane), and β = 0 is [`LinearScanner`] exactly.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct OffPlaneLinearScanner {
    /// Along-track angle β, rad, positive towards scanner +X.
    pub along_track_rad: f64,
}

/// Pulse vector in the scanner frame: `S = [0, ρ sin θ, ρ cos θ]` (Zhang et al. 2018).
pub fn scanner_vector<D: Scalar>(range_m: D, scan_angle_rad: D) -> Vector3<D> {
    let (s, c) = scan_angle_rad.sin_cos();
    Vector3::new(D::zero(), range_m * s, range_m * c)
}

/// [`scanner_vector`] turned by `Ry(β)` out of the scan plane (β = 0 leaves it as it is).
fn tilted_scanner_vector<D: Scalar>(
    range_m: D,
    scan_angle_rad: D,
    along_track_rad: f64,
) -> Vector3<D> {
    let s = scanner_vector(range_m, scan_angle_rad);
    if along_track_rad == 0.0 {
        return s;
    }
    let (sb, cb) = along_track_rad.sin_cos();
    let (sb, cb) = (D::from(sb), D::from(cb));
    Vector3::new(s.z * sb, s.y, s.z * cb)
}

/// The linear footprint `δP_gnss + R_N (R_M S + ΔP)` with S tilted by β.
fn linear_footprint<D: Scalar>(p: &SVector<D, LINEAR_N>, along_track_rad: f64) -> Vector3<D> {
    let r_n = rotation_zyx(p[3], p[4], p[5]);
    let r_m = rotation_zyx(p[6], p[7], p[8]);
    let lever = Vector3::new(p[9], p[10], p[11]);
    let s = tilted_scanner_vector(p[12], p[13], along_track_rad);
    gnss_offset_ned(p[0], p[1], p[2]) + r_n * (r_m * s + lever)
}

/// The linear footprint and its Jacobian, composed by the chain rule from the Jacobians of the
/// three stages: `R_N` and `R_M` from [`rotation_zyx_with_partials`], `S` from a 2-direction
/// dual pass. It is the per-point TPU's kernel, many times cheaper than one 14-direction dual
/// pass (see the tpu `budget` benchmark); a test checks it against that pass.
fn linear_jacobian(
    p: &SVector<f64, LINEAR_N>,
    along_track_rad: f64,
) -> (Vector3<f64>, SMatrix<f64, 3, LINEAR_N>) {
    let r_n = rotation_zyx(p[3], p[4], p[5]);
    let (r_m, d_r_m) = rotation_zyx_with_partials(p[6], p[7], p[8]);
    let (s, d_s) = jacobian(
        |q: SVector<DualSVec64<2>, 2>| tilted_scanner_vector(q[0], q[1], along_track_rad),
        &Vector2::new(p[12], p[13]),
    );
    let mounting = MountingPartials {
        r_m,
        d_r_m,
        lever_m: Vector3::new(p[9], p[10], p[11]),
    };
    let (f, j) = compose_linear(&r_n, &mounting, &s, &d_s);
    (f + gnss_offset_ned(p[0], p[1], p[2]), j)
}

/// The [`OffPlaneLinearScanner`] footprint (zero GNSS offsets) and Jacobian of the pulse whose
/// scanner vector is `s_m`, at the attitude `body_to_ned` (`R_N`): the same as
/// [`Georeferencer::footprint_jacobian`] at the parameters of the β, ρ and θ' that give `s_m`
/// back, without their trigonometry. `∂S/∂ρ = S/ρ` and `∂S/∂θ' = (−S_y S_x/h, h, −S_y S_z/h)`
/// with `h = √(S_x² + S_z²) = ρ cos θ'`; `R_N`'s partials from its axes ([`zyx_axes_of`]). This is
/// the per-point TPU's kernel for a recovered point.
#[inline]
pub fn linear_jacobian_at_beam(
    body_to_ned: &Matrix3<f64>,
    mounting: &MountingPartials,
    s_m: &Vector3<f64>,
) -> (Vector3<f64>, SMatrix<f64, 3, LINEAR_N>) {
    let rho = s_m.norm();
    // Metres: the plain root cannot overflow.
    let h = (s_m.x * s_m.x + s_m.z * s_m.z).sqrt();
    let d_s = SMatrix::<f64, 3, 2>::from_columns(&[
        s_m / rho,
        Vector3::new(-s_m.y * s_m.x / h, h, -s_m.y * s_m.z / h),
    ]);
    compose_linear(body_to_ned, mounting, s_m, &d_s)
}

/// `R_N (R_M S + ΔP)` and its Jacobian by the chain rule from the stages: `R_N` (its partials
/// in roll, pitch, heading as turns of `R_N (R_M S + ΔP)` about [`zyx_axes_of`]), the
/// mounting's, and `S` with its partials in ρ and θ.
fn compose_linear(
    r_n: &Matrix3<f64>,
    mounting: &MountingPartials,
    s: &Vector3<f64>,
    d_s: &SMatrix<f64, 3, 2>,
) -> (Vector3<f64>, SMatrix<f64, 3, LINEAR_N>) {
    let MountingPartials {
        r_m,
        d_r_m,
        lever_m,
    } = mounting;
    let body = r_m * s + lever_m;
    let f = r_n * body;
    let r_ns = r_n * r_m;
    let axes = zyx_axes_of(r_n);
    let mut j = SMatrix::<f64, 3, LINEAR_N>::zeros();
    j[(0, 0)] = 1.0;
    j[(1, 1)] = 1.0;
    j[(2, 2)] = -1.0;
    for k in 0..3 {
        j.set_column(3 + k, &axes[k].cross(&f));
        j.set_column(6 + k, &(r_n * (d_r_m[k] * s)));
        j.set_column(9 + k, &r_n.column(k).into_owned());
    }
    j.set_column(12, &(r_ns * d_s.column(0)));
    j.set_column(13, &(r_ns * d_s.column(1)));
    (f, j)
}

impl LinearScanner {
    /// The sources the linear scanner adds after the platform's (range, scan angle); the conic
    /// scanner has none of them.
    pub const SCANNER_SOURCES: [Source; 2] = [Source::Range, Source::ScanAngle];
}

impl Georeferencer<LINEAR_N> for LinearScanner {
    type Observation = LinearObservation;

    const SOURCES: [Source; LINEAR_N] = platform_then(LinearScanner::SCANNER_SOURCES);

    fn parameters(
        &self,
        a: &Attitude,
        m: &Mounting,
        o: &LinearObservation,
    ) -> SVector<f64, LINEAR_N> {
        let mut p = platform_parameters(a, m);
        p[12] = o.range_m;
        p[13] = o.scan_angle_rad;
        p
    }

    fn footprint_ned<D: Scalar>(&self, p: &SVector<D, LINEAR_N>) -> Vector3<D> {
        linear_footprint(p, 0.0)
    }

    /// The same Jacobian as the default, composed by the chain rule from the stages (`R_N`,
    /// `R_M`, `S`): the per-point TPU's kernel, many times cheaper than one dual pass.
    fn footprint_jacobian(
        &self,
        p: &SVector<f64, LINEAR_N>,
    ) -> (Vector3<f64>, SMatrix<f64, 3, LINEAR_N>) {
        linear_jacobian(p, 0.0)
    }
}

impl Georeferencer<LINEAR_N> for OffPlaneLinearScanner {
    type Observation = LinearObservation;

    const SOURCES: [Source; LINEAR_N] = <LinearScanner as Georeferencer<LINEAR_N>>::SOURCES;

    fn parameters(
        &self,
        a: &Attitude,
        m: &Mounting,
        o: &LinearObservation,
    ) -> SVector<f64, LINEAR_N> {
        LinearScanner.parameters(a, m, o)
    }

    fn footprint_ned<D: Scalar>(&self, p: &SVector<D, LINEAR_N>) -> Vector3<D> {
        linear_footprint(p, self.along_track_rad)
    }

    /// The same Jacobian as the default, composed by the chain rule from the stages (`R_N`,
    /// `R_M`, `S`): the per-point TPU's kernel, many times cheaper than one dual pass.
    fn footprint_jacobian(
        &self,
        p: &SVector<f64, LINEAR_N>,
    ) -> (Vector3<f64>, SMatrix<f64, 3, LINEAR_N>) {
        linear_jacobian(p, self.along_track_rad)
    }
}

/// The range at which a pulse at `scan_angle_rad` meets level ground `height_m` below the GNSS/INS
/// reference point, for the given attitude and mounting.
pub fn linear_range_for_height(
    attitude: &Attitude,
    mounting: &Mounting,
    scan_angle_rad: f64,
    height_m: f64,
) -> Result<f64> {
    if !(height_m.is_finite() && height_m > 0.0) {
        return Err(Error::NotPositive {
            name: "height_m",
            value: height_m,
        });
    }
    let r_n = attitude.body_to_ned();
    let r_m = mounting.scanner_to_body();
    let origin_down = (r_n * mounting.lever_arm_m).z;
    let dir = r_n * r_m * scanner_vector(1.0, scan_angle_rad);
    crate::conic::range_to_level(height_m - origin_down, &dir, height_m)
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn zhang_2018_footprint_at_level_flight() {
        let theta = 30f64.to_radians();
        let obs = LinearObservation {
            range_m: 80.0 / theta.cos(),
            scan_angle_rad: theta,
        };
        let p = LinearScanner.parameters(&Attitude::default(), &Mounting::default(), &obs);
        let f = LinearScanner.footprint_ned(&p);
        assert_relative_eq!(f, Vector3::new(0.0, 46.188_021_535, 80.0), epsilon = 1e-8);
    }

    #[test]
    fn staged_jacobian_equals_one_pass_dual_jacobian() {
        let (att, m) = (Attitude::from_degrees(2.5, -1.5, 123.0), mounting());
        let obs = LinearObservation {
            range_m: 812.0,
            scan_angle_rad: -0.31,
        };
        assert_staged_is_dual(&LinearScanner, &LinearScanner.parameters(&att, &m, &obs));
    }

    fn mounting() -> Mounting {
        Mounting {
            boresight_roll_rad: 0.01,
            boresight_pitch_rad: -0.02,
            boresight_yaw_rad: 0.03,
            lever_arm_m: Vector3::new(0.3, -0.2, 0.5),
        }
    }

    fn assert_staged_is_dual<G: Georeferencer<LINEAR_N>>(g: &G, p: &SVector<f64, LINEAR_N>) {
        let (f1, j1) = jacobian(
            |q: SVector<DualSVec64<LINEAR_N>, LINEAR_N>| g.footprint_ned(&q),
            p,
        );
        let (f2, j2) = g.footprint_jacobian(p);
        assert_relative_eq!(f1, f2, epsilon = 1e-9);
        assert_relative_eq!(j1, j2, epsilon = 1e-9);
    }

    #[test]
    fn jacobian_at_the_beam_is_the_parameters_jacobian() {
        let (att, m) = (Attitude::from_degrees(2.5, -1.5, 123.0), mounting());
        for s in [
            Vector3::new(0.39, 120.0, 1000.0),
            Vector3::new(-2.1, -430.0, 610.0),
            Vector3::new(0.0, 0.0, 300.0),
        ] {
            let obs = LinearObservation {
                range_m: s.norm(),
                scan_angle_rad: (s.y / s.norm()).asin(),
            };
            let g = OffPlaneLinearScanner {
                along_track_rad: s.x.atan2(s.z),
            };
            let (f1, j1) = g.footprint_jacobian(&g.parameters(&att, &m, &obs));
            let (f2, j2) =
                linear_jacobian_at_beam(&att.body_to_ned(), &MountingPartials::new(&m), &s);
            assert_relative_eq!(f1, f2, max_relative = 1e-14, epsilon = 1e-12);
            assert_relative_eq!(j1, j2, max_relative = 1e-13, epsilon = 1e-12);
        }
    }

    #[test]
    fn off_plane_beam_is_the_tilted_vector_and_its_staged_jacobian_is_exact() {
        let (att, m) = (Attitude::from_degrees(2.5, -1.5, 123.0), mounting());
        // S = (0.39, 120, 1000) m: θ = asin(S_y/ρ), β = atan2(S_x, S_z).
        let s = Vector3::new(0.39, 120.0, 1000.0);
        let obs = LinearObservation {
            range_m: s.norm(),
            scan_angle_rad: (s.y / s.norm()).asin(),
        };
        let g = OffPlaneLinearScanner {
            along_track_rad: s.x.atan2(s.z),
        };
        let p = g.parameters(&att, &m, &obs);
        let r_m = rotation_zyx(0.01, -0.02, 0.03);
        let expected =
            rotation_zyx(att.roll_rad, att.pitch_rad, att.heading_rad) * (r_m * s + m.lever_arm_m);
        assert_relative_eq!(g.footprint_ned(&p), expected, epsilon = 1e-9);
        assert_staged_is_dual(&g, &p);
        // β = 0 is Zhang et al.'s (2018) scanner, bit for bit.
        let flat = OffPlaneLinearScanner::default();
        assert_eq!(
            flat.footprint_jacobian(&p),
            LinearScanner.footprint_jacobian(&p)
        );
    }

    #[test]
    fn range_for_height_inverts_footprint() {
        let (att, m) = (Attitude::from_degrees(3.0, 3.0, 4.0), mounting());
        let theta = -0.4;
        let rho = linear_range_for_height(&att, &m, theta, 1000.0).unwrap();
        let obs = LinearObservation {
            range_m: rho,
            scan_angle_rad: theta,
        };
        let f = LinearScanner.footprint_ned(&LinearScanner.parameters(&att, &m, &obs));
        assert_relative_eq!(f.z, 1000.0, epsilon = 1e-9);
    }

    #[test]
    fn range_for_height_refuses_a_beam_above_the_horizon() {
        let att = Attitude::from_degrees(-80.0, 0.0, 0.0);
        let e = linear_range_for_height(&att, &Mounting::default(), 30f64.to_radians(), 100.0)
            .unwrap_err();
        assert!(matches!(e, Error::BeamMissesSurface { .. }), "{e}");
    }
}
