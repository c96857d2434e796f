//! The displacement of a delivered point from the mounting it was made with to a calibrated
//! one, and its line's trajectory correction, in ECEF and then onto the points' map grid
//! through the map's Jacobian at the point. Generic over the scalar so that one point (`f64`)
//! and four at once (nalgebra's SIMD types) run the same IEEE operations lane by lane, hence
//! the same bits. The map itself (grid ↔ ECEF) is the caller's: it passes the point's
//! P − P0 and the Jacobian.

use crate::{LineCorrection, ScanGeometry};
use lidarqa_model::Mounting;
use nalgebra::{Matrix3, SimdRealField, Vector3};

/// The mounting the points were made with (for the recovery) and the calibrated one, for
/// [`displacement`] on `T`.
#[derive(Debug, Clone)]
pub struct Mountings<T: nalgebra::Scalar> {
    old_r_m: Matrix3<T>,
    old_lever_m: Vector3<T>,
    new_r_m: Matrix3<T>,
    new_lever_m: Vector3<T>,
    /// Whether the recovered `S` is kept whole (a beam head) or put into the scan plane (the
    /// linear scanner).
    geometry: ScanGeometry,
}

impl<T: SimdRealField<Element = f64> + Copy> Mountings<T> {
    /// From the mounting the points were made with, the calibrated one and what of each
    /// point's scanner vector is kept (the scanner type's).
    pub fn new(old: &Mounting, new: &Mounting, geometry: ScanGeometry) -> Mountings<T> {
        let m = |m: Matrix3<f64>| m.map(T::splat);
        let v = |v: Vector3<f64>| v.map(T::splat);
        Mountings {
            old_r_m: m(old.scanner_to_body()),
            old_lever_m: v(old.lever_arm_m),
            new_r_m: m(new.scanner_to_body()),
            new_lever_m: v(new.lever_arm_m),
            geometry,
        }
    }
}

/// The range squared (m²) and the displacement on the grid (m) of a point with `beam` = P − P0
/// (ECEF), the body → ECEF rotation `r_be` and the map's Jacobian ∂P/∂(x, y, h) at it: for one
/// point (`T = f64`) or several at once (a SIMD type, the same IEEE operations lane by lane, so
/// the same bits). A point at the scanner origin or not finite gets a meaningless one (a range
/// that is zero or not finite).
#[inline(always)]
pub fn displacement<T: SimdRealField<Element = f64> + Copy>(
    m: &Mountings<T>,
    beam: &Vector3<T>,
    r_be: &Matrix3<T>,
    jacobian: &Matrix3<T>,
) -> (T, Vector3<T>) {
    // Recovery: B = R_BEᵀ (P − P0), S = R_Mᵀ (B − ΔP) (as `Recoverer::scanner_from_body`);
    // range ρ = |S|, scan angle θ = atan2(S_y, S_z), S' = ρ (0, sin θ, cos θ).
    let body = r_be.transpose() * beam;
    let s = m.old_r_m.transpose() * (body - m.old_lever_m);
    if m.geometry == ScanGeometry::Beam {
        // A beam head keeps the whole S: Δ = R_BE (R_M' S + ΔP' − B).
        let d = r_be * (m.new_r_m * s + m.new_lever_m - body);
        return (s.norm_squared(), grid_step(jacobian, &d));
    }
    // S' = (0, S_y, S_z) scaled to the range ρ = |S|: by ρ / r_yz = √(1 + S_x² / r_yz²), one
    // root and one division (S_x is the small out-of-plane residual); (0, 0, ρ) for r_yz = 0.
    let (x2, r2) = (s.x * s.x, s.y * s.y + s.z * s.z);
    let range2 = r2 + x2;
    let k = (T::one() + x2 / r2).simd_sqrt();
    let in_plane = r2.simd_gt(T::zero());
    let (s_y, s_z) = (
        (s.y * k).select(in_plane, T::zero()),
        (s.z * k).select(in_plane, range2.simd_sqrt()),
    );
    // Δ = P0 + R_BE (R_M' S' + ΔP') − P, taken in the body frame: R_BE (R_M' S' + ΔP' − B),
    // then on the grid through the map's Jacobian at the point.
    // (S'_x = 0: two columns of R_M'.)
    let d = r_be * (m.new_r_m.column(1) * s_y + m.new_r_m.column(2) * s_z + m.new_lever_m - body);
    (range2, grid_step(jacobian, &d))
}

/// An ECEF displacement `d` (m) on the grid through the map's Jacobian at the point.
#[inline(always)]
fn grid_step<T: SimdRealField<Element = f64> + Copy>(
    jacobian: &Matrix3<T>,
    d: &Vector3<T>,
) -> Vector3<T> {
    // Cramer's rule on the columns (∂P/∂x, ∂P/∂y, ∂P/∂h).
    let (jx, jy, jh) = (jacobian.column(0), jacobian.column(1), jacobian.column(2));
    let yh = jy.cross(&jh);
    let det = jx.dot(&yh);
    // One division: the three quotients then differ from dividing each by at most an ulp of a
    // step of metres.
    Vector3::new(d.dot(&yh), jx.dot(&d.cross(&jh)), jx.dot(&jy.cross(d))) * det.simd_recip()
}

/// A line's trajectory correction, prepared once: the line's estimated error and the local
/// level frame at its middle (over a line's few kilometres the frame turns by hundredths of a
/// degree: micrometres on centimetre corrections).
#[derive(Debug, Clone)]
pub struct LineShift {
    line: LineCorrection,
    /// NED → ECEF at the line's middle.
    c_en: Matrix3<f64>,
}

impl LineShift {
    /// From the line's correction and NED → ECEF at its middle.
    pub fn new(line: &LineCorrection, c_en: Matrix3<f64>) -> LineShift {
        LineShift {
            line: line.clone(),
            c_en,
        }
    }

    /// The line's correction.
    pub fn line(&self) -> &LineCorrection {
        &self.line
    }

    /// Adds the line's correction to the grid displacement `step` (m, from [`displacement`])
    /// of the point at `time_s` (s of the GPS week) with `beam` = P − P0 (ECEF), the body →
    /// ECEF rotation `r_be` and the map's Jacobian at it. Nothing is added where the Jacobian
    /// is singular.
    #[inline]
    pub fn apply(
        &self,
        time_s: f64,
        beam: &Vector3<f64>,
        r_be: &Matrix3<f64>,
        jacobian: &Matrix3<f64>,
        step: &mut Vector3<f64>,
    ) {
        let [n, e, u] = self.line.position_error_m(time_s);
        let mut extra = -(self.c_en * Vector3::new(n, e, -u));
        if let Some([dr, dp, dh]) = self.line.attitude_rad {
            // R_N = Rz(h) Ry(p) Rx(r): dR_N = [ω]× R_N with ω = δr R_N x̂ + δp Rz(h) ŷ + δh ẑ.
            let r_n = self.c_en.transpose() * r_be;
            let x_axis = r_n.column(0).into_owned();
            let h = r_n[(1, 0)].atan2(r_n[(0, 0)]);
            let omega_ned =
                x_axis * dr + Vector3::new(-h.sin(), h.cos(), 0.0) * dp + Vector3::z() * dh;
            let omega = self.c_en * omega_ned;
            // P' − P0 after the mounting's correction.
            let beam = beam + jacobian * *step;
            extra -= omega.cross(&beam);
        }
        if let Some(inv) = jacobian.try_inverse() {
            *step += inv * extra;
        }
    }
}
