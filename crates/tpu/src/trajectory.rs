//! A trajectory (time-sorted GNSS/INS poses) and its interpolation at a pulse time, plus the
//! trajectory's own 1-σ (from an SMRMSG file) interpolated the same way.
//!
//! Positions are ECEF metres; attitude is the SPEC §3 `R_N = Rz(heading) Ry(pitch) Rx(roll)`
//! (body B → local North-East-Down N at the pose). Between two poses:
//!
//! - **position**: linear in ECEF. At the usual 200 Hz an aircraft's acceleration `a` gives an
//!   error of at most `a Δt² / 8` (≈ 3 µm at 1 m/s²), so a cubic Hermite on velocities would
//!   change nothing measurable;
//! - **latitude / longitude** of the N frame: linear (longitude through the ±180° seam);
//! - **attitude**: the body → ECEF rotations `C_EN(φ, λ) · R_N` of the two poses are
//!   interpolated by slerp (constant angular rate along the shortest arc; evaluated by
//!   Rodrigues' formula on each segment's turn, [`SegmentRotation`]), then expressed in the
//!   N frame at the interpolated position. Interpolating roll, pitch and heading one by one would
//!   jump across ±180° of heading and is not a rotation interpolation at all; going through
//!   ECEF also keeps the slow turn of the N frame with position out of the attitude.
//!
//! A time outside `[first, last]` is an error ([`Error::OutsideTrajectory`]), never an
//! extrapolation.

use crate::error::{Error, Result};
use lidarqa_model::{Attitude, Ecef, ecef_from_ned, ecef_from_ned_sin_cos, zyx_angles};
#[cfg(test)]
use nalgebra::Quaternion;
use nalgebra::{Matrix3, Rotation3, Unit, UnitQuaternion, Vector3};
use std::f64::consts::PI;

/// One trajectory pose, SI units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    /// GPS seconds of week, s.
    pub time_s: f64,
    /// GNSS/INS reference point P0, ECEF metres.
    pub position_ecef_m: Ecef,
    /// Geodetic latitude of P0, rad (defines the N frame).
    pub latitude_rad: f64,
    /// Longitude of P0, rad, east positive.
    pub longitude_rad: f64,
    /// Roll, pitch and **true** heading, rad (SPEC §3).
    pub attitude: Attitude,
}

/// The trajectory state at one time: what recovery and propagation need, computed once.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PoseAt {
    /// The time, GPS seconds of week.
    pub time_s: f64,
    /// P0, ECEF metres.
    pub position_ecef_m: Ecef,
    /// Latitude of P0, rad.
    pub latitude_rad: f64,
    /// Longitude of P0, rad.
    pub longitude_rad: f64,
    /// `R_N`: body → N at P0.
    pub body_to_ned: Matrix3<f64>,
    /// ECEF → N at P0 (`C_EN ᵀ`).
    pub ecef_to_ned: Matrix3<f64>,
    /// Body → ECEF (`C_EN R_N`), the interpolated rotation itself.
    pub body_to_ecef: Matrix3<f64>,
}

impl PoseAt {
    /// Roll, pitch, true heading of `R_N`, rad (heading in (−π, π]): computed on demand, as
    /// only the conic scanner's parameters need Euler angles (two `atan2` and an `asin`).
    pub fn attitude(&self) -> Attitude {
        let a = zyx_angles(&self.body_to_ned);
        Attitude {
            roll_rad: a.x,
            pitch_rad: a.y,
            heading_rad: a.z,
        }
    }
}

/// Time-sorted poses, ready for interpolation.
#[derive(Debug, Clone, PartialEq)]
pub struct Trajectory {
    times_s: Vec<f64>,
    positions_ecef_m: Vec<Vector3<f64>>,
    lat_lon_rad: Vec<[f64; 2]>,
    /// sin φ, cos φ, sin λ, cos λ of each pose.
    sin_cos_rad: Vec<[f64; 4]>,
    body_to_ecef: Vec<UnitQuaternion<f64>>,
    /// Segment i's rotation from pose i to pose i + 1.
    turns: Vec<Option<Turn>>,
    /// Segment i's change of latitude and of longitude (wrapped to (−π, π]), rad: once per
    /// segment, not per point (the wrap is an `fmod`).
    lat_lon_steps_rad: Vec<[f64; 2]>,
    /// 1 / (t_{i+1} − t_i) of segment i (0 for two poses at one time): a point's weight in its
    /// segment by a multiplication, not a division.
    inverse_durations: Vec<f64>,
}

fn wrap_pi(a: f64) -> f64 {
    let w = (a + PI).rem_euclid(2.0 * PI) - PI;
    if w == -PI { PI } else { w }
}

/// `a · (b/a)^w` along the shortest arc as a quaternion: the definition the interpolation of
/// [`SegmentRotation`] is tested against. The rotation angle comes from `atan2` (in
/// [`Turn::between`]) so that small angles keep full precision (nalgebra's `angle()` uses
/// `acos`, good only to ~1e-8 rad).
#[cfg(test)]
fn slerp(a: &UnitQuaternion<f64>, turn: &Option<Turn>, w: f64) -> UnitQuaternion<f64> {
    match turn {
        None => *a,
        Some(t) => {
            let (s, c) = sin_cos_small(0.5 * t.angle_rad * w);
            let v = t.axis.into_inner() * s;
            a * UnitQuaternion::new_unchecked(Quaternion::new(c, v.x, v.y, v.z))
        }
    }
}

/// Largest |x| (rad) [`sin_cos_small`] takes its series for: there the first dropped terms,
/// x¹¹/11! and x¹²/12!, are below 10⁻¹⁷ of the result.
const SMALL_ANGLE_RAD: f64 = 0.1;

/// `x.sin_cos()` without a libm call for the small angles of interpolation within one
/// trajectory segment (the turn of one pose interval, the change of latitude or longitude along
/// it): Taylor series to x⁹ and x¹⁰, exact to rounding for |x| ≤ [`SMALL_ANGLE_RAD`]; libm's
/// beyond.
fn sin_cos_small(x: f64) -> (f64, f64) {
    if x.abs() > SMALL_ANGLE_RAD {
        return x.sin_cos();
    }
    // Multiplications by the rounded reciprocals, not divisions: a division's latency is many
    // multiplications', and each term is so much smaller than the 1 it is taken from that the
    // reciprocal's half-ulp does not reach the result's last place (the test below).
    const INV: [f64; 9] = [
        1.0 / 6.0,
        1.0 / 20.0,
        1.0 / 42.0,
        1.0 / 72.0,
        1.0 / 2.0,
        1.0 / 12.0,
        1.0 / 30.0,
        1.0 / 56.0,
        1.0 / 90.0,
    ];
    let x2 = x * x;
    let sin =
        x * (1.0 - x2 * INV[0] * (1.0 - x2 * INV[1] * (1.0 - x2 * INV[2] * (1.0 - x2 * INV[3]))));
    let cos = 1.0
        - x2 * INV[4]
            * (1.0 - x2 * INV[5] * (1.0 - x2 * INV[6] * (1.0 - x2 * INV[7] * (1.0 - x2 * INV[8]))));
    (sin, cos)
}

/// The rotation from one pose to the next, `a⁻¹ b`, as the unit axis and angle the slerp
/// scales (computed once per segment, not per point); `None` for no rotation.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Turn {
    axis: Unit<Vector3<f64>>,
    angle_rad: f64,
}

impl Turn {
    fn between(a: &UnitQuaternion<f64>, b: &UnitQuaternion<f64>) -> Option<Turn> {
        let d = a.inverse() * b;
        let (mut s, mut v) = (d.w, d.imag());
        if s < 0.0 {
            s = -s;
            v = -v;
        }
        let n = v.norm();
        if n == 0.0 {
            return None;
        }
        Some(Turn {
            axis: Unit::new_unchecked(v / n),
            angle_rad: 2.0 * n.atan2(s),
        })
    }
}

/// One trajectory segment's body → ECEF rotation prepared for interpolation at many times:
/// `R(w) = R_i (I + sin φ K + (1 − cos φ) K²)` with φ = w θ, K the cross-product matrix of the
/// segment's turn axis (Rodrigues' formula), i.e. the slerp's rotation at `w`, from the
/// three matrices `R_i`, `R_i K`, `R_i K²` and one small-angle sine and versine per point
/// instead of a quaternion product and its rotation matrix. A caller keeps one per worker and
/// passes it to [`Trajectory::at_from`] or [`Trajectory::body_to_ecef_at`].
#[derive(Debug, Clone, Default)]
pub struct SegmentRotation {
    /// The segment last searched for (the search's hint).
    index: usize,
    /// The segment the matrices below belong to (`None` until the first call).
    prepared: Option<usize>,
    r: Matrix3<f64>,
    r_k: Matrix3<f64>,
    r_k2: Matrix3<f64>,
    angle_rad: f64,
}

impl SegmentRotation {
    fn of(start: &UnitQuaternion<f64>, turn: &Option<Turn>, index: usize) -> SegmentRotation {
        let r = start.to_rotation_matrix().into_inner();
        let (r_k, r_k2, angle_rad) = match turn {
            None => (Matrix3::zeros(), Matrix3::zeros(), 0.0),
            Some(t) => {
                let k = t.axis.into_inner().cross_matrix();
                let r_k = r * k;
                (r_k, r_k * k, t.angle_rad)
            }
        };
        SegmentRotation {
            index,
            prepared: Some(index),
            r,
            r_k,
            r_k2,
            angle_rad,
        }
    }

    /// The rotation at the fraction `w` of the segment.
    #[inline]
    fn at(&self, w: f64) -> Matrix3<f64> {
        let (s, v) = sin_versine_small(w * self.angle_rad);
        self.r + self.r_k * s + self.r_k2 * v
    }
}

/// `(sin x, 1 − cos x)` for the small turn of one segment: Taylor series (the versine's own, so
/// that no 1 − cos cancels), exact to rounding for |x| ≤ [`SMALL_ANGLE_RAD`]; libm's beyond
/// (the versine as 2 sin²(x/2)).
#[inline]
fn sin_versine_small(x: f64) -> (f64, f64) {
    if x.abs() > SMALL_ANGLE_RAD {
        let h = (0.5 * x).sin();
        return (x.sin(), 2.0 * h * h);
    }
    let (sin, _) = sin_cos_small(x);
    const INV: [f64; 5] = [1.0 / 2.0, 1.0 / 12.0, 1.0 / 30.0, 1.0 / 56.0, 1.0 / 90.0];
    let x2 = x * x;
    let versine = x2
        * INV[0]
        * (1.0 - x2 * INV[1] * (1.0 - x2 * INV[2] * (1.0 - x2 * INV[3] * (1.0 - x2 * INV[4]))));
    (sin, versine)
}

impl Trajectory {
    /// Checks and prepares the poses: at least two, times finite and non-decreasing, every value
    /// finite.
    ///
    /// # Errors
    /// [`Error::InvalidTrajectory`] naming the pose at fault.
    pub fn new(poses: &[Pose]) -> Result<Trajectory> {
        if poses.len() < 2 {
            return Err(Error::InvalidTrajectory {
                index: poses.len(),
                message: format!("{} poses; interpolation needs at least 2", poses.len()),
            });
        }
        let mut t = Trajectory {
            times_s: Vec::with_capacity(poses.len()),
            positions_ecef_m: Vec::with_capacity(poses.len()),
            lat_lon_rad: Vec::with_capacity(poses.len()),
            sin_cos_rad: Vec::with_capacity(poses.len()),
            body_to_ecef: Vec::with_capacity(poses.len()),
            turns: Vec::with_capacity(poses.len()),
            lat_lon_steps_rad: Vec::with_capacity(poses.len()),
            inverse_durations: Vec::with_capacity(poses.len()),
        };
        for (i, p) in poses.iter().enumerate() {
            let a = &p.attitude;
            let finite = [
                p.time_s,
                p.latitude_rad,
                p.longitude_rad,
                a.roll_rad,
                a.pitch_rad,
                a.heading_rad,
            ]
            .iter()
            .chain(p.position_ecef_m.vector().iter())
            .all(|v| v.is_finite());
            if !finite {
                return Err(Error::InvalidTrajectory {
                    index: i,
                    message: "a value is not finite".into(),
                });
            }
            if let Some(prev) = t.times_s.last()
                && p.time_s < *prev
            {
                return Err(Error::InvalidTrajectory {
                    index: i,
                    message: format!("time {} s is earlier than the previous {prev} s", p.time_s),
                });
            }
            let r = ecef_from_ned(p.latitude_rad, p.longitude_rad) * a.body_to_ned();
            t.times_s.push(p.time_s);
            t.positions_ecef_m.push(p.position_ecef_m.vector());
            t.lat_lon_rad.push([p.latitude_rad, p.longitude_rad]);
            let ((sp, cp), (sl, cl)) = (p.latitude_rad.sin_cos(), p.longitude_rad.sin_cos());
            t.sin_cos_rad.push([sp, cp, sl, cl]);
            t.body_to_ecef.push(UnitQuaternion::from_rotation_matrix(
                &Rotation3::from_matrix_unchecked(r),
            ));
        }
        t.turns = t
            .body_to_ecef
            .windows(2)
            .map(|w| Turn::between(&w[0], &w[1]))
            .collect();
        t.lat_lon_steps_rad = t
            .lat_lon_rad
            .windows(2)
            .map(|w| [w[1][0] - w[0][0], wrap_pi(w[1][1] - w[0][1])])
            .collect();
        t.inverse_durations = t
            .times_s
            .windows(2)
            .map(|w| {
                if w[1] > w[0] {
                    1.0 / (w[1] - w[0])
                } else {
                    0.0
                }
            })
            .collect();
        Ok(t)
    }

    /// Number of poses.
    pub fn len(&self) -> usize {
        self.times_s.len()
    }

    /// Always false: a trajectory has at least two poses.
    pub fn is_empty(&self) -> bool {
        self.times_s.is_empty()
    }

    /// First and last pose time, GPS seconds of week.
    pub fn span_s(&self) -> (f64, f64) {
        (self.times_s[0], self.times_s[self.times_s.len() - 1])
    }

    /// The interpolated state at `time_s` (see the module docs).
    ///
    /// # Errors
    /// [`Error::OutsideTrajectory`] when `time_s` is not finite or outside the span.
    pub fn at(&self, time_s: f64) -> Result<PoseAt> {
        self.at_from(time_s, &mut SegmentRotation::default())
    }

    /// [`Trajectory::at`] keeping the segment of the previous call in `segment` (start with its
    /// `Default`): points come in time order, so the segment is usually the same or the next
    /// one, the binary search is skipped, and the segment's rotation is prepared once
    /// ([`SegmentRotation`]). The same result to rounding.
    ///
    /// # Errors
    /// As [`Trajectory::at`].
    #[inline]
    pub fn at_from(&self, time_s: f64, segment: &mut SegmentRotation) -> Result<PoseAt> {
        let (i, w) = self.prepared_segment(time_s, segment)?;
        let position_ecef_m = self.position_at(i, w);
        let [la0, lo0] = self.lat_lon_rad[i];
        let [step_la, step_lo] = self.lat_lon_steps_rad[i];
        let (dla, dlo) = (w * step_la, w * step_lo);
        let latitude_rad = la0 + dla;
        let lon = lo0 + dlo;
        let longitude_rad = if lon.abs() > PI { wrap_pi(lon) } else { lon };
        // sin and cos of φ0 + Δφ and λ0 + Δλ by the angle sums, from the pose's own: the
        // changes along one segment are tiny, so no libm call per point.
        let [sp0, cp0, sl0, cl0] = self.sin_cos_rad[i];
        let ((sd, cd), (se, ce)) = (sin_cos_small(dla), sin_cos_small(dlo));
        let (sp, cp) = (sp0 * cd + cp0 * sd, cp0 * cd - sp0 * sd);
        let (sl, cl) = (sl0 * ce + cl0 * se, cl0 * ce - sl0 * se);
        let body_to_ecef = segment.at(w);
        let ecef_to_ned = ecef_from_ned_sin_cos(sp, cp, sl, cl).transpose();
        Ok(PoseAt {
            time_s,
            position_ecef_m,
            latitude_rad,
            longitude_rad,
            body_to_ned: ecef_to_ned * body_to_ecef,
            ecef_to_ned,
            body_to_ecef,
        })
    }

    /// P0 (ECEF metres) and the body → ECEF rotation at `time_s`: the same interpolation as
    /// [`Trajectory::at`] without the NED frame, for a caller that works in ECEF (strip
    /// correction). `segment` keeps the segment of the previous call (start with its
    /// `Default`): points come in time order, so the search is usually skipped, and the
    /// segment's rotation is prepared once for Rodrigues' formula (see [`SegmentRotation`]).
    ///
    /// # Errors
    /// As [`Trajectory::at`].
    #[inline]
    pub fn body_to_ecef_at(
        &self,
        time_s: f64,
        segment: &mut SegmentRotation,
    ) -> Result<(Ecef, Matrix3<f64>)> {
        let (i, w) = self.prepared_segment(time_s, segment)?;
        Ok((self.position_at(i, w), segment.at(w)))
    }

    /// The segment `[i, i + 1]` holding `time_s` and the weight of pose `i + 1`, searched from
    /// `segment`'s and with `segment` prepared for it.
    #[inline]
    fn prepared_segment(&self, time_s: f64, segment: &mut SegmentRotation) -> Result<(usize, f64)> {
        let (i, w) = self.segment_from(time_s, &mut segment.index)?;
        if segment.prepared != Some(i) {
            *segment = SegmentRotation::of(&self.body_to_ecef[i], &self.turns[i], i);
        }
        Ok((i, w))
    }

    /// P0 at the fraction `w` of segment `i` (linear in ECEF, module docs).
    fn position_at(&self, i: usize, w: f64) -> Ecef {
        Ecef::from_vector(self.positions_ecef_m[i].lerp(&self.positions_ecef_m[i + 1], w))
    }

    /// [`Trajectory::segment`] trying the segment at `hint` and the next one first (then
    /// `hint` is set to the segment found).
    fn segment_from(&self, time_s: f64, hint: &mut usize) -> Result<(usize, f64)> {
        let t = &self.times_s;
        // The segment the search would find: every earlier time is ≤ time_s, the next > it.
        let fits = |i: usize| i + 1 < t.len() && t[i] <= time_s && time_s < t[i + 1];
        let found = [*hint, *hint + 1].into_iter().find(|&i| fits(i));
        let (i, w) = match found {
            Some(i) => (i, (time_s - t[i]) * self.inverse_durations[i]),
            None => self.segment(time_s)?,
        };
        *hint = i;
        Ok((i, w))
    }

    /// The segment `[i, i + 1]` holding `time_s` and the weight of pose `i + 1`.
    fn segment(&self, time_s: f64) -> Result<(usize, f64)> {
        let (start_s, end_s) = self.span_s();
        if !(time_s >= start_s && time_s <= end_s) {
            return Err(Error::OutsideTrajectory {
                time_s,
                start_s,
                end_s,
            });
        }
        let n = self.times_s.len();
        let i = self
            .times_s
            .partition_point(|&x| x <= time_s)
            .saturating_sub(1)
            .min(n - 2);
        // (0 for two poses at one time.)
        Ok((i, (time_s - self.times_s[i]) * self.inverse_durations[i]))
    }
}

/// The trajectory's own 1-σ at one time (an SMRMSG record in SI units).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PoseSigma {
    /// GPS seconds of week, s.
    pub time_s: f64,
    /// σ of the north position, m (replaces the sensor file's `gnss_north`).
    pub north_m: f64,
    /// σ of the east position, m (replaces `gnss_east`).
    pub east_m: f64,
    /// σ of the down position, m (replaces `gnss_up`: same magnitude).
    pub down_m: f64,
    /// σ of roll, rad (replaces `roll`).
    pub roll_rad: f64,
    /// σ of pitch, rad (replaces `pitch`).
    pub pitch_rad: f64,
    /// σ of heading, rad (replaces `heading`).
    pub heading_rad: f64,
    /// The σ are those of a trajectory rebuilt from the points: added in quadrature to the
    /// sensor's GNSS, pitch and heading σ instead of replacing them, and roll's is left out
    /// (a roll error of the rebuilt trajectory turns the beam within the scan plane, which the
    /// recovered scan angle absorbs: the propagated point σ does not depend on it).
    pub added: bool,
}

/// Time-sorted trajectory σ, linearly interpolated. SMRMSG files are often written at 1 Hz and
/// may start or end a little inside the SBET: a time beyond either end takes the nearest
/// record's σ (a σ changes slowly; the pose itself is never extrapolated).
#[derive(Debug, Clone, PartialEq)]
pub struct TrajectorySigmas {
    records: Vec<PoseSigma>,
}

impl TrajectorySigmas {
    /// Checks the records: at least one, times non-decreasing, σ finite and ≥ 0.
    ///
    /// # Errors
    /// [`Error::InvalidTrajectory`] naming the record at fault.
    pub fn new(records: Vec<PoseSigma>) -> Result<TrajectorySigmas> {
        if records.is_empty() {
            return Err(Error::InvalidTrajectory {
                index: 0,
                message: "no trajectory sigma records".into(),
            });
        }
        for (i, r) in records.iter().enumerate() {
            let ok = r.time_s.is_finite()
                && [
                    r.north_m,
                    r.east_m,
                    r.down_m,
                    r.roll_rad,
                    r.pitch_rad,
                    r.heading_rad,
                ]
                .iter()
                .all(|v| v.is_finite() && *v >= 0.0);
            if !ok {
                return Err(Error::InvalidTrajectory {
                    index: i,
                    message: "a sigma is negative or not finite".into(),
                });
            }
            if i > 0 && r.time_s < records[i - 1].time_s {
                return Err(Error::InvalidTrajectory {
                    index: i,
                    message: "sigma record time goes back".into(),
                });
            }
        }
        Ok(TrajectorySigmas { records })
    }

    /// σ at `time_s` (linear between records, the nearest record beyond either end).
    pub fn at(&self, time_s: f64) -> PoseSigma {
        let r = &self.records;
        let i = r.partition_point(|x| x.time_s <= time_s);
        if i == 0 {
            return PoseSigma { time_s, ..r[0] };
        }
        if i == r.len() {
            return PoseSigma {
                time_s,
                ..r[r.len() - 1]
            };
        }
        let (a, b) = (&r[i - 1], &r[i]);
        let w = if b.time_s > a.time_s {
            (time_s - a.time_s) / (b.time_s - a.time_s)
        } else {
            0.0
        };
        let l = |x: f64, y: f64| x + w * (y - x);
        PoseSigma {
            time_s,
            north_m: l(a.north_m, b.north_m),
            east_m: l(a.east_m, b.east_m),
            down_m: l(a.down_m, b.down_m),
            roll_rad: l(a.roll_rad, b.roll_rad),
            pitch_rad: l(a.pitch_rad, b.pitch_rad),
            heading_rad: l(a.heading_rad, b.heading_rad),
            added: a.added,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    fn pose(t: f64, heading_deg: f64) -> Pose {
        Pose {
            time_s: t,
            position_ecef_m: Ecef::new(4_000_000.0 + 60.0 * t, 1_000_000.0, 4_800_000.0),
            latitude_rad: 0.8,
            longitude_rad: 0.25,
            attitude: Attitude::from_degrees(1.0, -2.0, heading_deg),
        }
    }

    #[test]
    fn search_from_a_hint_finds_the_same_pose() {
        let poses: Vec<Pose> = (0..50)
            .map(|k| pose(f64::from(k) * 0.1, 3.0 * f64::from(k)))
            .collect();
        let t = Trajectory::new(&poses).unwrap();
        let mut segment = SegmentRotation::default();
        // In order (same and next segment), on pose times, backwards, the last time, a jump.
        for time in [
            0.0, 0.01, 0.1, 0.15, 0.2, 0.31, 0.3, 4.9, 2.25, 2.3, 0.05, 4.85,
        ] {
            let a = t.at(time).unwrap();
            let b = t.at_from(time, &mut segment).unwrap();
            assert_eq!(a.position_ecef_m, b.position_ecef_m, "{time}");
            assert_eq!(a.body_to_ned, b.body_to_ned, "{time}");
            let i = segment.index;
            assert!(t.times_s[i] <= time && (time < t.times_s[i + 1] || i + 2 == 50));
        }
        assert!(t.at_from(5.5, &mut segment).is_err());
    }

    #[test]
    fn heading_interpolates_across_180_degrees() {
        let t = Trajectory::new(&[pose(0.0, 179.0), pose(1.0, -179.0)]).unwrap();
        let mid = t.at(0.5).unwrap();
        // 180°, not 0° as per-angle linear interpolation would give.
        assert_relative_eq!(mid.attitude().heading_rad.abs(), PI, epsilon = 1e-3);
        assert_relative_eq!(mid.attitude().roll_rad, 1f64.to_radians(), epsilon = 1e-4);
        assert_relative_eq!(mid.position_ecef_m.x_m(), 4_000_030.0, epsilon = 1e-9);
    }

    #[test]
    fn body_to_ecef_is_the_pose_without_its_ned_frame() {
        let t = Trajectory::new(&[pose(0.0, 30.0), pose(0.005, 31.0), pose(0.01, 29.5)]).unwrap();
        // In order, backwards, repeated, at the nodes: the kept segment never changes the
        // result.
        let mut segment = SegmentRotation {
            index: 7,
            ..SegmentRotation::default()
        };
        for time in [
            0.0, 0.0012, 0.005, 0.0099, 0.01, 0.0051, 0.0, 0.0049, 0.0049,
        ] {
            let p = t.at(time).unwrap();
            let (position, r) = t.body_to_ecef_at(time, &mut segment).unwrap();
            assert_eq!(position, p.position_ecef_m);
            assert_relative_eq!(
                r,
                p.ecef_to_ned.transpose() * p.body_to_ned,
                epsilon = 1e-15
            );
            assert_eq!(segment.index, if time < 0.005 { 0 } else { 1 });
        }
        assert!(t.body_to_ecef_at(0.0101, &mut segment).is_err());
        assert!(t.body_to_ecef_at(f64::NAN, &mut segment).is_err());
    }

    #[test]
    fn nodes_are_reproduced_and_outside_is_refused() {
        let t = Trajectory::new(&[pose(0.0, 10.0), pose(0.005, 10.01), pose(0.01, 10.02)]).unwrap();
        let a = t.at(0.005).unwrap();
        assert_relative_eq!(
            a.attitude().heading_rad,
            10.01f64.to_radians(),
            epsilon = 1e-12
        );
        assert_relative_eq!(
            a.attitude().pitch_rad,
            (-2f64).to_radians(),
            epsilon = 1e-12
        );
        let e = t.at(0.0101).unwrap_err();
        assert!(matches!(e, Error::OutsideTrajectory { .. }), "{e}");
        assert!(t.at(f64::NAN).is_err());
    }

    #[test]
    fn slerp_has_constant_rate_for_a_pure_heading_turn() {
        let t = Trajectory::new(&[pose(0.0, 10.0), pose(1.0, 30.0)]).unwrap();
        for w in [0.1, 0.25, 0.7] {
            let h = t.at(w).unwrap().attitude().heading_rad.to_degrees();
            // Roll and pitch are body-fixed here, so a heading change is a rotation about N's
            // down axis: exactly linear in time.
            assert_relative_eq!(h, 10.0 + 20.0 * w, epsilon = 1e-9);
        }
    }

    #[test]
    fn rodrigues_rotation_is_the_slerp_to_rounding() {
        // Segments turning by a few mrad (within the series) and by 0.3 rad (libm's), points
        // in time order across segment changes and back again: the rotation of
        // `body_to_ecef_at` is the slerp's quaternion within a few ulps of its unit entries.
        let pose = |t: f64, h: f64| Pose {
            time_s: t,
            position_ecef_m: Ecef::new(4_000_000.0 + t, 1_000.0 * t, 4_800_000.0),
            latitude_rad: 0.85,
            longitude_rad: 0.2,
            attitude: Attitude::from_degrees(2.0 * t, -3.0 + 0.1 * t, h),
        };
        let t = Trajectory::new(&[
            pose(0.0, 10.0),
            pose(0.005, 10.2),
            pose(0.01, 10.2),
            pose(1.0, 27.0),
            pose(1.5, 27.3),
        ])
        .unwrap();
        let mut segment = SegmentRotation::default();
        let times = (0..=300)
            .map(|k| f64::from(k) * 0.005)
            .chain([0.0, 0.004, 1.2, 0.003]);
        let mut worst = 0f64;
        for time in times {
            let (i, w) = t.segment(time).unwrap();
            let q = slerp(&t.body_to_ecef[i], &t.turns[i], w);
            let (p, r) = t.body_to_ecef_at(time, &mut segment).unwrap();
            worst = worst.max((r - q.to_rotation_matrix().into_inner()).amax());
            assert_eq!(p.vector(), t.position_at(i, w).vector());
        }
        assert!(worst <= 4.0 * f64::EPSILON, "largest difference {worst:e}");
    }

    #[test]
    fn small_angle_versine_is_libm_to_rounding() {
        for x in (-1000..=1000)
            .map(|k| f64::from(k) * 1e-4)
            .chain([1e-300, 7.3e-8, 0.3])
        {
            let (s, v) = sin_versine_small(x);
            assert!(
                (s - x.sin()).abs() <= x.sin().abs() * f64::EPSILON,
                "sin {x}"
            );
            // The versine against 2 sin²(x/2), which has no cancellation.
            let v0 = 2.0 * (0.5 * x).sin().powi(2);
            assert!(
                (v - v0).abs() <= 2.0 * v0 * f64::EPSILON,
                "versine {x}: {v} vs {v0}"
            );
        }
    }

    #[test]
    fn small_angle_series_is_libm_to_rounding() {
        // Every x of the series' range at 1e-4 steps, and tiny ones: within one unit in the
        // last place of libm's (itself correctly rounded to ~0.5 ulp).
        let xs = (-1000..=1000).map(|k| f64::from(k) * 1e-4).chain([
            1e-300,
            -3e-9,
            7.3e-8,
            SMALL_ANGLE_RAD,
            -SMALL_ANGLE_RAD,
        ]);
        for x in xs {
            let ((s, c), (s0, c0)) = (sin_cos_small(x), x.sin_cos());
            assert!(
                (s - s0).abs() <= s0.abs() * f64::EPSILON,
                "sin {x}: {s} vs {s0}"
            );
            assert!((c - c0).abs() <= f64::EPSILON, "cos {x}: {c} vs {c0}");
        }
        assert_eq!(sin_cos_small(0.5), 0.5f64.sin_cos());
    }

    #[test]
    fn the_interpolated_frame_is_that_of_the_interpolated_position() {
        // A fast turn and a long segment across the ±180° meridian: the frame from the angle
        // sums is that of the interpolated latitude and longitude to rounding, and the body →
        // ECEF rotation that of the slerp through libm.
        let pose = |t: f64, lat: f64, lon: f64, h: f64| Pose {
            time_s: t,
            position_ecef_m: Ecef::new(-6_300_000.0, 1_000.0 * t, 700_000.0),
            latitude_rad: lat,
            longitude_rad: lon,
            attitude: Attitude::from_degrees(2.0 * t, -3.0, h),
        };
        let t = Trajectory::new(&[
            pose(0.0, 0.11, PI - 2e-6, 170.0),
            pose(0.005, 0.1100003, -PI + 2e-6, 171.0),
            pose(2.0, 0.2, -3.1, -150.0),
        ])
        .unwrap();
        for time in [0.0, 0.001, 0.0025, 0.00499, 0.005, 0.4, 1.3, 2.0] {
            let p = t.at(time).unwrap();
            let exact = ecef_from_ned(p.latitude_rad, p.longitude_rad).transpose();
            assert_relative_eq!(p.ecef_to_ned, exact, epsilon = 4e-16);
            assert!(p.longitude_rad.abs() <= PI, "{}", p.longitude_rad);
            let (i, w) = t.segment(time).unwrap();
            let q = match &t.turns[i] {
                None => t.body_to_ecef[i],
                Some(turn) => {
                    t.body_to_ecef[i]
                        * UnitQuaternion::from_axis_angle(&turn.axis, turn.angle_rad * w)
                }
            };
            assert_relative_eq!(
                p.body_to_ecef,
                *q.to_rotation_matrix().matrix(),
                epsilon = 4e-16
            );
            assert_relative_eq!(p.body_to_ned, p.ecef_to_ned * p.body_to_ecef, epsilon = 0.0);
        }
    }

    #[test]
    fn bad_poses_are_named() {
        let e = Trajectory::new(&[pose(1.0, 0.0), pose(0.5, 0.0)]).unwrap_err();
        assert_eq!(
            e.to_string(),
            "trajectory pose 1: time 0.5 s is earlier than the previous 1 s"
        );
        assert!(Trajectory::new(&[pose(1.0, 0.0)]).is_err());
    }

    #[test]
    fn sigmas_interpolate_and_clamp() {
        let s = TrajectorySigmas::new(vec![
            PoseSigma {
                time_s: 10.0,
                north_m: 0.02,
                ..PoseSigma::default()
            },
            PoseSigma {
                time_s: 11.0,
                north_m: 0.04,
                ..PoseSigma::default()
            },
        ])
        .unwrap();
        assert_relative_eq!(s.at(10.25).north_m, 0.025, epsilon = 1e-15);
        assert_eq!(s.at(5.0).north_m, 0.02);
        assert_eq!(s.at(50.0).north_m, 0.04);
    }
}
