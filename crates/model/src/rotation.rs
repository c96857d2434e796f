//! Elementary rotations, the attitude / boresight matrices of SPEC §3, and the rotation between a
//! local North-East-Down frame and ECEF at a latitude/longitude.
//!
//! All rotations are active (they rotate vectors) and right-handed. Attitude and boresight use the
//! same order, `R = Rz(yaw) · Ry(pitch) · Rx(roll)`, which is exactly Zhang et al.'s (2018) printed
//! `R_N = R(H) · R(P) · R(R)`.

use crate::scalar::{Scalar, c};
use nalgebra::{Matrix3, Vector3};

/// Rotation about X by `a` radians.
pub fn rot_x<D: Scalar>(a: D) -> Matrix3<D> {
    let (s, co) = a.sin_cos();
    let (o, l) = (c::<D>(0.0), c::<D>(1.0));
    Matrix3::new(l, o, o, o, co, -s, o, s, co)
}

/// Rotation about Y by `a` radians.
pub fn rot_y<D: Scalar>(a: D) -> Matrix3<D> {
    let (s, co) = a.sin_cos();
    let (o, l) = (c::<D>(0.0), c::<D>(1.0));
    Matrix3::new(co, o, s, o, l, o, -s, o, co)
}

/// Rotation about Z by `a` radians.
pub fn rot_z<D: Scalar>(a: D) -> Matrix3<D> {
    let (s, co) = a.sin_cos();
    let (o, l) = (c::<D>(0.0), c::<D>(1.0));
    Matrix3::new(co, -s, o, s, co, o, o, o, l)
}

/// `Rz(yaw) · Ry(pitch) · Rx(roll)`, angles in radians.
///
/// As the platform attitude this is Zhang et al.'s (2018) `R_N` (body B → navigation N, NED); as
/// the boresight it is `R_M` (scanner S → body B), whose small-angle form is Zhang et al.'s (2018)
/// `[[1, −Δγ, Δβ], [Δγ, 1, −Δα], [−Δβ, Δα, 1]]` with Δα = roll, Δβ = pitch, Δγ = yaw.
pub fn rotation_zyx<D: Scalar>(roll: D, pitch: D, yaw: D) -> Matrix3<D> {
    rot_z(yaw) * rot_y(pitch) * rot_x(roll)
}

/// [`rotation_zyx`] and its partial derivatives with respect to roll, pitch and yaw.
///
/// From the generator identity `d/dφ R_axis(φ) = R_axis(φ) · [e_axis]×`:
/// `∂R/∂roll = Rz Ry Rx [e_x]×`, `∂R/∂pitch = Rz Ry [e_y]× Rx`, `∂R/∂yaw = [e_z]× Rz Ry Rx`.
/// A handful of 3×3 products instead of a dual-number pass; the tests check it against num-dual.
pub fn rotation_zyx_with_partials(
    roll: f64,
    pitch: f64,
    yaw: f64,
) -> (Matrix3<f64>, [Matrix3<f64>; 3]) {
    let (rx, ry, rz) = (rot_x(roll), rot_y(pitch), rot_z(yaw));
    let kx = Vector3::<f64>::x().cross_matrix();
    let ky = Vector3::<f64>::y().cross_matrix();
    let kz = Vector3::<f64>::z().cross_matrix();
    let rzy = rz * ry;
    let r = rzy * rx;
    (r, [r * kx, rzy * ky * rx, kz * r])
}

/// The partials of [`rotation_zyx`] in roll, pitch and yaw from the matrix itself, as
/// [`rotation_zyx_with_partials`] gives them: `[a]× R` for each axis `a` of [`zyx_axes_of`].
pub fn zyx_partials_of(r: &Matrix3<f64>) -> [Matrix3<f64>; 3] {
    zyx_axes_of(r).map(|a| a.cross_matrix() * r)
}

/// The axes (in the output frame) that roll, pitch and yaw turn [`rotation_zyx`]'s `R` about,
/// so that `∂R/∂angle = [axis]× R` and `∂(R v)/∂angle = axis × (R v)`: `R x̂`, `Rz ŷ =
/// (−sin ψ, cos ψ, 0)` with `(cos ψ, sin ψ)` from the first column, and `ẑ`. No trigonometry:
/// for a per-point caller that has `R` already. Valid away from pitch = ±90° (as the angles
/// themselves).
pub fn zyx_axes_of(r: &Matrix3<f64>) -> [Vector3<f64>; 3] {
    // Entries of a rotation: the plain root cannot overflow (no `hypot` needed).
    let h = (r[(0, 0)] * r[(0, 0)] + r[(1, 0)] * r[(1, 0)]).sqrt();
    [
        r.column(0).into_owned(),
        Vector3::new(-r[(1, 0)] / h, r[(0, 0)] / h, 0.0),
        Vector3::z(),
    ]
}

/// Roll, pitch and yaw (radians) of a rotation matrix built as [`rotation_zyx`]; the inverse of it
/// away from pitch = ±90°.
pub fn zyx_angles(r: &Matrix3<f64>) -> Vector3<f64> {
    let roll = r[(2, 1)].atan2(r[(2, 2)]);
    let pitch = (-r[(2, 0)]).clamp(-1.0, 1.0).asin();
    let yaw = r[(1, 0)].atan2(r[(0, 0)]);
    Vector3::new(roll, pitch, yaw)
}

/// The rotation taking a local North-East-Down vector at (φ, λ) to ECEF: v_ecef = R v_ned.
///
/// Its columns are the N, E and D unit vectors in ECEF:
/// N = (−sin φ cos λ, −sin φ sin λ, cos φ), E = (−sin λ, cos λ, 0),
/// D = (−cos φ cos λ, −cos φ sin λ, −sin φ). The axes follow the geodetic normal, so the
/// frame is the same on every ellipsoid.
pub fn ecef_from_ned(latitude_rad: f64, longitude_rad: f64) -> Matrix3<f64> {
    let (sp, cp) = latitude_rad.sin_cos();
    let (sl, cl) = longitude_rad.sin_cos();
    ecef_from_ned_sin_cos(sp, cp, sl, cl)
}

/// [`ecef_from_ned`] from sin φ, cos φ, sin λ, cos λ (as an inverse projection gives them):
/// no trigonometry per point.
pub fn ecef_from_ned_sin_cos(sp: f64, cp: f64, sl: f64, cl: f64) -> Matrix3<f64> {
    Matrix3::new(
        -sp * cl,
        -sl,
        -cp * cl, //
        -sp * sl,
        cl,
        -cp * sl, //
        cp,
        0.0,
        -sp,
    )
}

/// The rotation taking an ECEF vector to local North-East-Down at (φ, λ): the transpose of
/// [`ecef_from_ned`].
pub fn ned_from_ecef(latitude_rad: f64, longitude_rad: f64) -> Matrix3<f64> {
    ecef_from_ned(latitude_rad, longitude_rad).transpose()
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    /// Zhang et al.'s (2018) printed R_N, evaluated element by element from its symbolic form.
    fn zhang_2018_printed(h: f64, p: f64, r: f64) -> Matrix3<f64> {
        let (ch, sh, cp, sp, cr, sr) = (h.cos(), h.sin(), p.cos(), p.sin(), r.cos(), r.sin());
        Matrix3::new(
            ch * cp,
            ch * sp * sr - sh * cr,
            sh * sr + ch * sp * cr,
            sh * cp,
            ch * cr + sh * sp * sr,
            sh * sp * cr - ch * sr,
            -sp,
            cp * sr,
            cp * cr,
        )
    }

    #[test]
    fn partials_from_the_matrix_are_the_partials() {
        for (r, p, y) in [(0.1, -0.2, 2.9), (-0.03, 0.05, -1.2), (0.4, 1.2, 0.0)] {
            let (m, want) = rotation_zyx_with_partials(r, p, y);
            let got = zyx_partials_of(&m);
            for k in 0..3 {
                assert_relative_eq!(got[k], want[k], epsilon = 1e-15);
            }
        }
    }

    #[test]
    fn attitude_matrix_equals_zhang_2018_printed_matrix() {
        let (h, p, r) = (4f64.to_radians(), 3f64.to_radians(), 3f64.to_radians());
        let ours = rotation_zyx(r, p, h);
        let paper = zhang_2018_printed(h, p, r);
        for i in 0..3 {
            for j in 0..3 {
                assert_relative_eq!(ours[(i, j)], paper[(i, j)], epsilon = 1e-15);
            }
        }
        // A few numbers written out, so a sign slip in both forms cannot hide.
        assert_relative_eq!(ours[(0, 0)], 0.997_564_050 * 0.998_629_535, epsilon = 1e-9);
        assert_relative_eq!(ours[(2, 0)], -0.052_335_956, epsilon = 1e-9);
    }

    #[test]
    fn small_angle_boresight_matches_zhang_2018_form() {
        let (a, b, g) = (1e-4, -2e-4, 3e-4);
        let r = rotation_zyx(a, b, g);
        let small = Matrix3::new(1.0, -g, b, g, 1.0, -a, -b, a, 1.0);
        assert!((r - small).amax() < 1e-7, "second-order terms only");
    }

    #[test]
    fn partials_match_dual_numbers() {
        use num_dual::DualSVec64;
        let (roll, pitch, yaw) = (0.3, -0.7, 2.1);
        let d = |x: f64, i: usize| DualSVec64::<3>::from_re(x).derivative(i);
        let dual = rotation_zyx(d(roll, 0), d(pitch, 1), d(yaw, 2));
        let (r, partials) = rotation_zyx_with_partials(roll, pitch, yaw);
        for i in 0..3 {
            for j in 0..3 {
                assert_relative_eq!(r[(i, j)], dual[(i, j)].re, epsilon = 1e-15);
                let eps = dual[(i, j)].eps.unwrap_generic(nalgebra::U3, nalgebra::U1);
                for (k, p) in partials.iter().enumerate() {
                    assert_relative_eq!(p[(i, j)], eps[k], epsilon = 1e-15);
                }
            }
        }
    }

    #[test]
    fn angles_round_trip() {
        let r = rotation_zyx(0.1, -0.2, 2.9);
        let a = zyx_angles(&r);
        assert_relative_eq!(a, Vector3::new(0.1, -0.2, 2.9), epsilon = 1e-14);
    }

    #[test]
    fn ned_rotation_is_orthonormal_and_down_is_minus_normal() {
        let (lat, lon) = (0.7_f64, -1.2_f64);
        let r = ecef_from_ned(lat, lon);
        assert!((r.transpose() * r - Matrix3::identity()).norm() < 1e-15);
        assert!((r.determinant() - 1.0).abs() < 1e-15);
        // Down = −(ellipsoid normal) = −(cos φ cos λ, cos φ sin λ, sin φ).
        let up = Vector3::new(lat.cos() * lon.cos(), lat.cos() * lon.sin(), lat.sin());
        assert!((r.column(2) + up).norm() < 1e-15);
        // North at the equator, λ = 0 is +Z; east is +Y.
        let r0 = ecef_from_ned(0.0, 0.0);
        assert!((r0.column(0) - Vector3::z()).norm() < 1e-15);
        assert!((r0.column(1) - Vector3::y()).norm() < 1e-15);
    }
}
