//! The raw observations of a beam scanner's return from its beam: given the vector `S` from the
//! scanner origin to the point in the scanner frame (what a delivered point, its trajectory and
//! the mounting give back), the range and the encoder angles that fire the beam along it.
//!
//! With `d = Hᵀ S / ρ` the unit beam in the head frame (see [`crate::BeamScanner`]):
//! - **rotating mirror**: `a = atan2(d_y, d_z)`; the point's distance from the mirror plane,
//!   `ρ d_x`, is the residual (0 for a perfect model);
//! - **spinning multi-beam**: head azimuth `a = atan2(d_y, d_x)` and elevation `ε = asin d_z`, the
//!   beam as it is; the channel is the configured elevation nearest to `ε`, and `ρ |ε − ε_ch|`
//!   is the residual (a channel's intrinsic error, a wrong mounting or trajectory);
//! - **elliptical**: `a = atan2(d_y, d_x)` on the cone; `ρ |acos d_z − α|` is the residual;
//! - **Risley pair**: with `c = a − b` the beam is `Rz(b) f(c)`, `f(c) = Ry(δ₂) Rz(c) Ry(δ₁) ẑ`,
//!   whose z component `cos δ₁ cos δ₂ − sin δ₁ sin δ₂ cos c` fixes `cos c`; then `b` turns `f(c)`
//!   onto the beam's azimuth. `c` and `−c` both fire the same beam (the two prism pairs mirror
//!   each other about the plane of the axis and the beam), so the prism angles of a point are
//!   known only up to that pair: both are returned, and a caller without the scanner's time
//!   series of prism angles weighs them equally. Their covariances are mirror images of each
//!   other about that plane (the same along the beam and the same eigenvalues), so the mean of
//!   the two is the covariance of a return whose pair is unknown. A beam beyond the pair's
//!   reach (`|cos c| > 1`) takes the nearest reachable one and the angle between them, times ρ,
//!   as its residual.

use crate::beam::{BeamKind, BeamObservation, BeamScanner};
use nalgebra::Vector3;

/// The observations of one return recovered from its beam.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BeamInversion {
    /// The observations that fire the beam: one, or the two mirror prism pairs of a Risley head.
    pub observations: [BeamObservation; 2],
    /// How many of [`BeamInversion::observations`] are meaningful (1 or 2).
    pub count: usize,
    /// The point's distance from the nearest beam the head fires, m (0 for a perfect model).
    pub residual_m: f64,
    /// The nearest configured channel (spinning multi-beam), its index.
    pub channel: Option<usize>,
}

impl BeamInversion {
    /// The meaningful observations.
    pub fn observations(&self) -> &[BeamObservation] {
        &self.observations[..self.count]
    }
}

impl BeamScanner {
    /// The observations of the return at `s_m` (scanner origin → point, scanner frame, m);
    /// `None` when the vector is not finite or of zero length.
    pub fn invert(&self, s_m: &Vector3<f64>) -> Option<BeamInversion> {
        let rho = s_m.norm();
        if !(rho.is_finite() && rho > 0.0) {
            return None;
        }
        let d = self.head_to_scanner.transpose() * s_m / rho;
        let one = |angle_rad: f64, elevation: f64, residual_m: f64, channel| {
            let o = BeamObservation {
                range_m: rho,
                angle_rad,
                angle_2_rad: 0.0,
                channel_elevation_rad: elevation,
            };
            BeamInversion {
                observations: [o, o],
                count: 1,
                residual_m,
                channel,
            }
        };
        Some(match self.kind {
            BeamKind::RotatingMirror => one(d.y.atan2(d.z), 0.0, rho * d.x, None),
            BeamKind::SpinningMultibeam => {
                let e = d.z.clamp(-1.0, 1.0).asin();
                let nearest = self
                    .channel_elevations_rad
                    .iter()
                    .enumerate()
                    .min_by(|x, y| (x.1 - e).abs().total_cmp(&(y.1 - e).abs()));
                let (channel, residual) = match nearest {
                    Some((i, ch)) => (Some(i), rho * (e - ch).abs()),
                    None => (None, 0.0),
                };
                one(d.y.atan2(d.x), e, residual, channel)
            }
            BeamKind::Elliptical { half_angle_rad } => {
                let off = d.z.clamp(-1.0, 1.0).acos() - half_angle_rad;
                one(d.y.atan2(d.x), 0.0, rho * off.abs(), None)
            }
            BeamKind::Risley {
                deviation_1_rad,
                deviation_2_rad,
            } => {
                let (s1, c1) = deviation_1_rad.sin_cos();
                let (s2, c2) = deviation_2_rad.sin_cos();
                // d_z = A + B cos c.
                let (a0, b0) = (c1 * c2, -s1 * s2);
                let cos_c_raw = (d.z - a0) / b0;
                let cos_c = cos_c_raw.clamp(-1.0, 1.0);
                let residual = if cos_c == cos_c_raw {
                    0.0
                } else {
                    rho * (d.z.clamp(-1.0, 1.0).acos() - (a0 + b0 * cos_c).clamp(-1.0, 1.0).acos())
                        .abs()
                };
                let c = cos_c.acos();
                let azimuth = d.y.atan2(d.x);
                let pair = |c: f64| {
                    let f = Vector3::new(s1 * c.cos(), s1 * c.sin(), c1);
                    let f = Vector3::new(c2 * f.x + s2 * f.z, f.y, -s2 * f.x + c2 * f.z);
                    let b = azimuth - f.y.atan2(f.x);
                    BeamObservation {
                        range_m: rho,
                        angle_rad: b + c,
                        angle_2_rad: b,
                        channel_elevation_rad: 0.0,
                    }
                };
                BeamInversion {
                    observations: [pair(c), pair(-c)],
                    count: 2,
                    residual_m: residual,
                    channel: None,
                }
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rotation::rotation_zyx;

    fn scanners() -> Vec<BeamScanner> {
        let tilt = rotation_zyx(0.1, -0.3, 0.7);
        let mut mb = BeamScanner::new(BeamKind::SpinningMultibeam);
        mb.channel_elevations_rad = vec![-0.3, -0.1, 0.05, 0.2];
        let mut v = vec![
            BeamScanner::new(BeamKind::RotatingMirror),
            mb,
            BeamScanner::new(BeamKind::Risley {
                deviation_1_rad: 0.2,
                deviation_2_rad: 0.15,
            }),
            BeamScanner::new(BeamKind::Elliptical {
                half_angle_rad: 0.25,
            }),
        ];
        for s in v.clone() {
            v.push(BeamScanner {
                head_to_scanner: tilt,
                ..s
            });
        }
        v
    }

    /// Every type: the observations fired through the model give the beam back, to rounding.
    #[test]
    fn inversion_gives_the_beam_back() {
        for s in scanners() {
            for (a, b) in [(0.3, -1.1), (2.2, 0.4), (-2.9, 2.8), (1.0, 1.0)] {
                let e = s.channel_elevations_rad.get(2).copied().unwrap_or(0.0);
                let d = s.scanner_direction::<f64>(a, b, e);
                let v = d * 123.4;
                let inv = s.invert(&v).unwrap();
                assert!(inv.residual_m < 1e-9, "{:?}: {}", s.kind, inv.residual_m);
                for o in inv.observations() {
                    assert!((o.range_m - 123.4).abs() < 1e-9);
                    let back = s.scanner_direction::<f64>(
                        o.angle_rad,
                        o.angle_2_rad,
                        o.channel_elevation_rad,
                    );
                    assert!(
                        (back - d).norm() < 1e-12,
                        "{:?} {a} {b}: {back} vs {d}",
                        s.kind
                    );
                }
                assert_eq!(inv.count, if s.kind.name() == "risley" { 2 } else { 1 });
                if s.kind == BeamKind::SpinningMultibeam {
                    assert_eq!(inv.channel, Some(2));
                }
            }
        }
    }

    #[test]
    fn residuals_measure_the_distance_from_the_nearest_beam() {
        let mirror = BeamScanner::new(BeamKind::RotatingMirror);
        let inv = mirror.invert(&Vector3::new(0.5, 30.0, 100.0)).unwrap();
        assert!((inv.residual_m - 0.5).abs() < 1e-12);
        let mut mb = BeamScanner::new(BeamKind::SpinningMultibeam);
        mb.channel_elevations_rad = vec![0.0, 0.1];
        // 0.03 rad above channel 0 at 100 m.
        let v = Vector3::new(0.03f64.cos(), 0.0, 0.03f64.sin()) * 100.0;
        let inv = mb.invert(&v).unwrap();
        assert_eq!(inv.channel, Some(0));
        assert!((inv.residual_m - 3.0).abs() < 1e-9);
        // Beyond a Risley pair's reach (0.35 rad): 0.5 rad off the axis, 0.15 rad beyond.
        let r = BeamScanner::new(BeamKind::Risley {
            deviation_1_rad: 0.2,
            deviation_2_rad: 0.15,
        });
        let v = Vector3::new(0.5f64.sin(), 0.0, 0.5f64.cos()) * 10.0;
        assert!((r.invert(&v).unwrap().residual_m - 1.5).abs() < 1e-9);
        assert!(r.invert(&Vector3::zeros()).is_none());
    }
}
