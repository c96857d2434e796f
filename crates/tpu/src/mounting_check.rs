//! The mounting check: does the sensor file's mounting fit the points?
//!
//! For a linear scanner every point, taken into the body frame with its pose
//! (`B = R_Nᵀ C_NE (P − P0) − ΔP`), lies on one plane through the scanner origin, the scan plane,
//! whose normal is `R_M e_x = (cos p cos y, cos p sin y, −sin p)` (boresight pitch p, yaw y; roll
//! turns the plane in itself and is not observable from it). The normal is the eigenvector of the
//! smallest eigenvalue of `Σ B Bᵀ`, which merges exactly across tiles. Beside it, the RMS
//! recovery residual against the RMS 3-D σ says whether the mounting fits at all. `tpu` sums it
//! over every point, `correct` and `calibrate` over a sample. Written by hand: a 3×3 symmetric
//! eigenproblem (nalgebra) and a few sums, no crate does it.

use lidarqa_model::{Mounting, Sensor};
use lidarqa_products::MountingCheck;
use nalgebra::{Matrix3, SymmetricEigen, Vector3};
use serde::{Deserialize, Serialize};

/// A strip whose RMS recovery residual exceeds this many RMS 3-D σ does not fit its mounting:
/// the residual is one component of the point error, so a fitting model keeps it below ~1.
pub const MOUNTING_WARNING_RATIO: f64 = 3.0;
/// Below this RMS residual, m, the mounting is not questioned whatever the σ (centimetre-level
/// misfit of a sensor with tiny σ is not a mounting error worth a warning).
pub const MOUNTING_WARNING_FLOOR_M: f64 = 0.05;
/// An RMS recovery residual beyond this, m, is an error: kilometres off the scan plane is no
/// longer a mounting that is slightly off.
pub const MOUNTING_ERROR_M: f64 = 1_000.0;

/// The mergeable sums of the mounting check.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MountingTally {
    /// Points summed (range within the envelope).
    pub n: u64,
    /// Σ q², m² (recovery residual).
    pub sum_q2_m2: f64,
    /// Σ σ_3D², m².
    pub sum_sigma2_m2: f64,
    /// Σ B Bᵀ over the body-frame vectors (linear scanner), row-major, m².
    pub scatter_m2: [f64; 9],
    /// Whether `scatter_m2` was summed (linear scanner).
    pub linear: bool,
    /// The sensor file's boresight roll, pitch, yaw, degrees.
    pub file_boresight_deg: [f64; 3],
}

impl MountingTally {
    /// An empty tally for a sensor file's mounting.
    pub fn new(mounting: &Mounting, linear: bool) -> Self {
        MountingTally {
            linear,
            file_boresight_deg: [
                mounting.boresight_roll_rad.to_degrees(),
                mounting.boresight_pitch_rad.to_degrees(),
                mounting.boresight_yaw_rad.to_degrees(),
            ],
            ..MountingTally::default()
        }
    }

    /// Adds one point: residual, 3-D σ and (linear scanner) its body-frame vector from the
    /// scanner origin.
    pub fn add(&mut self, q_m: f64, sigma_3d_m: f64, body_m: Option<&Vector3<f64>>) {
        self.n += 1;
        self.sum_q2_m2 += q_m * q_m;
        self.sum_sigma2_m2 += sigma_3d_m * sigma_3d_m;
        if let Some(b) = body_m {
            let m = b * b.transpose();
            for (s, v) in self.scatter_m2.iter_mut().zip(m.transpose().iter()) {
                *s += v;
            }
        }
    }

    /// Adds another tally.
    pub fn merge(&mut self, o: &MountingTally) {
        if self.n == 0 {
            self.linear = o.linear;
            self.file_boresight_deg = o.file_boresight_deg;
        }
        self.n += o.n;
        self.sum_q2_m2 += o.sum_q2_m2;
        self.sum_sigma2_m2 += o.sum_sigma2_m2;
        for (a, b) in self.scatter_m2.iter_mut().zip(&o.scatter_m2) {
            *a += b;
        }
    }

    /// RMS recovery residual, m.
    pub fn rms_residual_m(&self) -> f64 {
        (self.sum_q2_m2 / self.n.max(1) as f64).sqrt()
    }

    /// RMS 3-D σ, m.
    pub fn rms_sigma_m(&self) -> f64 {
        (self.sum_sigma2_m2 / self.n.max(1) as f64).sqrt()
    }

    /// The boresight pitch and yaw (degrees) that put the points on the scanner's plane, and
    /// the RMS distance of the points from that plane (m); `None` without linear points.
    pub fn fit(&self) -> Option<FittedMounting> {
        if !self.linear || self.n < 3 {
            return None;
        }
        let m = Matrix3::from_row_slice(&self.scatter_m2);
        let e = SymmetricEigen::new(m);
        let k = e.eigenvalues.imin();
        let mut n: Vector3<f64> = e.eigenvectors.column(k).into_owned();
        // The normal nearest the file's scanner X (the sign of a plane normal is free).
        let [_, p, y] = self.file_boresight_deg.map(f64::to_radians);
        let file_x = Vector3::new(p.cos() * y.cos(), p.cos() * y.sin(), -p.sin());
        if n.dot(&file_x) < 0.0 {
            n = -n;
        }
        Some(FittedMounting {
            roll_deg: self.file_boresight_deg[0],
            pitch_deg: (-n.z).atan2(n.x.hypot(n.y)).to_degrees(),
            yaw_deg: n.y.atan2(n.x).to_degrees(),
            rms_m: (e.eigenvalues[k].max(0.0) / self.n as f64).sqrt(),
        })
    }

    /// Whether the residual is far beyond what the σ explain (see [`MOUNTING_WARNING_RATIO`]).
    pub fn does_not_fit(&self) -> bool {
        let rms = self.rms_residual_m();
        self.n > 0
            && rms > MOUNTING_WARNING_FLOOR_M
            && rms > MOUNTING_WARNING_RATIO * self.rms_sigma_m()
    }

    /// The sentence saying the mounting does not fit, with the fitted boresight.
    pub fn message(&self) -> String {
        let (rms, sig) = (self.rms_residual_m(), self.rms_sigma_m());
        let [r0, p0, y0] = self.file_boresight_deg;
        let head = format!(
            "the points are {rms:.3} m RMS off the scan {} ({:.0}× their RMS 3-D σ of {sig:.3} m): \
             the mounting in the sensor file (boresight roll {r0:.3}°, pitch {p0:.3}°, yaw {y0:.3}°) \
             does not fit the data",
            if self.linear { "plane" } else { "cone" },
            rms / sig.max(1e-12),
        );
        match self.fit() {
            Some(f) if f.rms_m <= MOUNTING_WARNING_RATIO * sig.max(MOUNTING_WARNING_FLOOR_M) => {
                format!(
                    "{head}; the boresight that does, fitted from the points: pitch {:.3}°, yaw \
                     {:.3}° (roll {:.3}° kept: not observable from the plane), leaving {:.3} m \
                     RMS off the plane",
                    f.pitch_deg, f.yaw_deg, f.roll_deg, f.rms_m
                )
            }
            Some(f) => format!(
                "{head}; no boresight fits either (best: pitch {:.3}°, yaw {:.3}°, still {:.3} m \
                 RMS off the plane): check the trajectory, the time base and the CRS",
                f.pitch_deg, f.yaw_deg, f.rms_m
            ),
            None => head,
        }
    }
}

impl MountingTally {
    /// The summary's `mounting_check`; `None` without points.
    pub fn view(&self) -> Option<MountingCheck> {
        (self.n > 0).then(|| {
            let f = self.fit();
            MountingCheck {
                rms_residual_m: self.rms_residual_m(),
                rms_sigma_3d_m: self.rms_sigma_m(),
                does_not_fit: self.does_not_fit(),
                file_boresight_deg: self.file_boresight_deg,
                fitted_boresight_deg: f.map(|f| [f.roll_deg, f.pitch_deg, f.yaw_deg]),
                fitted_plane_rms_m: f.map(|f| f.rms_m),
            }
        })
    }
}

/// A boresight fitted from the points (linear scanner).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FittedMounting {
    /// The file's roll, degrees (not observable from the scan plane).
    pub roll_deg: f64,
    /// Fitted boresight pitch, degrees.
    pub pitch_deg: f64,
    /// Fitted boresight yaw, degrees.
    pub yaw_deg: f64,
    /// RMS distance of the points from the fitted plane, m.
    pub rms_m: f64,
}

/// A conservative 3-D σ of a point at `range_m` from the sensor file's σ alone (every position
/// and lever-arm σ plus the range's, every angle's at the range): no smaller than the propagated
/// σ, so the mounting check does not fire on noise where no σ is propagated.
pub fn sigma_3d_bound(sensor: &Sensor, range_m: f64) -> f64 {
    use lidarqa_model::Source::*;
    let s = |x| sensor.sigma.get(x).powi(2);
    let metres: f64 = [GnssNorth, GnssEast, GnssUp, LeverX, LeverY, LeverZ, Range]
        .map(s)
        .iter()
        .sum();
    let angles: f64 = [
        Roll,
        Pitch,
        Heading,
        BoresightRoll,
        BoresightPitch,
        BoresightYaw,
        ScanAngle,
    ]
    .map(s)
    .iter()
    .sum();
    (metres + range_m * range_m * angles).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use lidarqa_model::rotation_zyx;

    /// Points on a scan plane turned by a known boresight: the fit returns it.
    #[test]
    fn mounting_fit_recovers_a_known_boresight() {
        let truth = Mounting {
            boresight_roll_rad: 0.0,
            boresight_pitch_rad: 0.3f64.to_radians(),
            boresight_yaw_rad: 13.96f64.to_radians(),
            lever_arm_m: Vector3::zeros(),
        };
        let r = rotation_zyx(0.0, truth.boresight_pitch_rad, truth.boresight_yaw_rad);
        let mut t = MountingTally::new(&Mounting::default(), true);
        for k in 0..200 {
            let a = (k as f64 / 200.0 - 0.5) * 0.6;
            let s = Vector3::new(0.0, 1000.0 * a.sin(), 1000.0 * a.cos());
            let b = r * s;
            // The residual the file's (zero) mounting leaves: S_x with R_M = I.
            t.add(b.x, 0.1, Some(&b));
        }
        let f = t.fit().unwrap();
        assert!((f.yaw_deg - 13.96).abs() < 1e-9, "{f:?}");
        assert!((f.pitch_deg - 0.3).abs() < 1e-9, "{f:?}");
        assert!(f.rms_m < 1e-3, "{f:?}");
        assert!(t.does_not_fit());
        let m = t.message();
        assert!(m.contains("yaw 13.960°"), "{m}");
        let mut split = MountingTally::new(&Mounting::default(), true);
        split.merge(&t);
        assert_eq!(split.fit(), t.fit());
    }
}
