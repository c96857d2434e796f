//! Strips of points with their raw observations, in one local Cartesian frame, and
//! re-georeferencing them with any mounting.
//!
//! The local frame `L` is North-East-Down at a survey centre (lidarqa-io's [`TangentFrame`];
//! metres; x north, y east, z down), and positions in it are model's [`Ned`].
//! Each point keeps its trajectory pose expressed in `L`: the GNSS/INS reference point `P0` in `L`
//! and the attitude `R_L = C_LE · C_EN(P0) · R_N` (body → `L`), where `C_EN(P0)` is the NED frame
//! at the pose and `C_LE` the ECEF → `L` rotation. Since `R_L` is itself a rotation
//! `Rz(h) Ry(p) Rx(r)`, Zhang et al. (2018) eq. (2) in `L` is the model's own
//! `P = P0 + R_L (R_M S + ΔP)` with the attitude angles of `R_L`: rigorous through ECEF (SPEC §3),
//! with no NED vector ever added to grid coordinates.

use crate::error::{Error, Result};
use lidarqa_io::TangentFrame;
use lidarqa_model::{
    Attitude, Ecef, Georeferencer, LinearObservation, LinearScanner, Mounting, Ned, rotation_zyx,
    scanner_vector, zyx_angles,
};
use lidarqa_tpu::{LinearRecovery, PoseAt, Recoverer};
use nalgebra::{Matrix3, Vector3};
use rayon::prelude::*;

/// A trajectory pose (lidarqa-tpu, ECEF) as `P0` in `L` (local NED, m) and the attitude of
/// `R_L = C_LE · C_EN(P0) · R_N` (body → `L`).
fn pose_in_local(frame: &TangentFrame, pose: &PoseAt) -> (Ned, Attitude) {
    let r_l = frame.ned_from_ecef() * pose.ecef_to_ned.transpose() * pose.body_to_ned;
    let a = zyx_angles(&r_l);
    (
        frame.to_ned(&pose.position_ecef_m),
        Attitude {
            roll_rad: a.x,
            pitch_rad: a.y,
            heading_rad: a.z,
        },
    )
}

/// What a calibration keeps of a point's recovered scanner-frame vector `S = R_Mᵀ (R_Nᵀ (P − P0) − ΔP)`.
///
/// A linear scanner's beams lie in its scan plane, so what leaves the plane is the misfit of the
/// mounting or trajectory the point was recovered with, and the point is re-georeferenced from
/// its range and scan angle alone. The beams of the other heads leave that plane by design (a
/// spinning multi-beam head's channels sweep cones up to ±30° out of it, an elliptical scanner's
/// cone is tilted, a Risley pair's rosette fills a disc): dropping the out-of-plane part would move
/// their points by metres, so the whole vector is kept.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ScanGeometry {
    /// Range and scan angle only: `S' = ρ (0, sin θ, cos θ)` (the linear scanner).
    #[default]
    Plane,
    /// The whole vector `S`, out-of-plane part included (every beam head).
    Beam,
}

/// One laser point with its raw observation, everything in the local frame `L` (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RawPoint {
    /// Current coordinates (as delivered, i.e. georeferenced with the prior mounting) in `L`, m.
    pub position_m: Ned,
    /// GNSS/INS reference point `P0` at the pulse time in `L`, m.
    pub origin_m: Ned,
    /// Attitude of `R_L` (body → `L`), rad: `R_L = Rz(heading) Ry(pitch) Rx(roll)`.
    pub attitude: Attitude,
    /// Range ρ (m) and scan angle θ (rad, positive to the right wing), recovered once.
    pub observation: LinearObservation,
    /// The scanner-frame x component of `S` (m, along the body's forward axis for a level
    /// mounting) that a beam head's return keeps ([`ScanGeometry::Beam`]); 0 for a linear
    /// scanner, whose point is re-georeferenced in its scan plane. With it
    /// `S = (x, r sin θ, r cos θ)`, `r = √(ρ² − x²)`.
    pub out_of_plane_m: f64,
    /// GPS seconds of week of the pulse, s (for output, and for the trajectory weighting's
    /// time-varying offsets).
    pub time_s: f64,
    /// Return intensity, sensor units (used by the automatic tie search).
    pub intensity: u16,
}

impl RawPoint {
    /// Builds a point from a pose and a recovery already computed (lidarqa-tpu
    /// [`Recoverer::linear_ecef`]) and the point's ECEF position, in the calibration's frame `L`;
    /// `geometry` says whether the out-of-plane part of `S` is kept.
    pub fn from_recovery(
        frame: &TangentFrame,
        pose: &PoseAt,
        recovery: &LinearRecovery,
        point: &Ecef,
        intensity: u16,
        geometry: ScanGeometry,
    ) -> RawPoint {
        let (origin_m, attitude) = pose_in_local(frame, pose);
        RawPoint {
            position_m: frame.to_ned(point),
            origin_m,
            attitude,
            observation: LinearObservation {
                range_m: recovery.range_m,
                scan_angle_rad: recovery.scan_angle_rad,
            },
            out_of_plane_m: match geometry {
                ScanGeometry::Plane => 0.0,
                ScanGeometry::Beam => recovery.out_of_plane_m,
            },
            time_s: pose.time_s,
            intensity,
        }
    }

    /// Recovers the raw observation of a georeferenced point (ECEF) with the mounting it was
    /// georeferenced with, once, and keeps it, in the calibration's frame `L`.
    ///
    /// # Errors
    /// [`Error::Tpu`] when the point coincides with the scanner origin.
    pub fn recover(
        frame: &TangentFrame,
        pose: &PoseAt,
        recoverer: &Recoverer,
        point: &Ecef,
        intensity: u16,
        geometry: ScanGeometry,
    ) -> Result<RawPoint> {
        let r = recoverer.linear_ecef(pose, point)?;
        Ok(RawPoint::from_recovery(
            frame, pose, &r, point, intensity, geometry,
        ))
    }

    /// A test point whose georeferencing is itself (zero range, level, no lever arm).
    #[cfg(test)]
    pub(crate) fn own_origin(p: Ned, intensity: u16) -> RawPoint {
        RawPoint {
            position_m: p,
            origin_m: p,
            attitude: Attitude::default(),
            observation: LinearObservation {
                range_m: 0.0,
                scan_angle_rad: 0.0,
            },
            out_of_plane_m: 0.0,
            time_s: 0.0,
            intensity,
        }
    }

    /// The scanner-frame vector `S` (m) this point is re-georeferenced from: `ρ (0, sin θ, cos θ)`
    /// in the scan plane, or with the kept out-of-plane part `(x, r sin θ, r cos θ)`,
    /// `r = √(ρ² − x²)` ([`ScanGeometry`]).
    #[inline]
    pub fn scanner_m(&self) -> Vector3<f64> {
        let (rho, theta) = (self.observation.range_m, self.observation.scan_angle_rad);
        if self.out_of_plane_m == 0.0 {
            return scanner_vector(rho, theta);
        }
        let x = self.out_of_plane_m;
        let r = (rho * rho - x * x).max(0.0).sqrt();
        let (s, c) = theta.sin_cos();
        Vector3::new(x, r * s, r * c)
    }

    /// Local north, east and up of [`RawPoint::position_m`], m.
    pub fn neu_m(&self) -> [f64; 3] {
        let p = &self.position_m;
        [p.north_m(), p.east_m(), p.up_m()]
    }
}

/// One strip: points of one flight line, all in the same local frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Strip {
    /// The strip's id: the LAS point source id or the file's stem (SPEC §7 tie picks).
    pub id: String,
    /// The points, in any order.
    pub points: Vec<RawPoint>,
}

impl Strip {
    /// The radius (m) within which a typical point of this strip has `neighbours` others: from
    /// the point count within 3 m of 256 evenly spaced sample points (median, so edges and gaps
    /// do not count); `None` for fewer than 16 points.
    ///
    /// The VTPM radius has to grow with the point spacing: Zhang & Jiang's (2011) 1 m holds ~3
    /// points of a strip flown at 800 m with 2 pts/m², too few for a RANSAC plane and a triangle.
    pub fn radius_for_neighbours_m(&self, neighbours: usize) -> Option<f64> {
        let xy: Vec<[f64; 2]> = self
            .points
            .iter()
            .map(|p| [p.position_m.north_m(), p.position_m.east_m()])
            .collect();
        radius_for_neighbours_m(&xy, neighbours)
    }

    /// Horizontal extent `[min north, min east, max north, max east]`, m; `None` when empty.
    pub fn extent_m(&self) -> Option<[f64; 4]> {
        let mut e = [
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        ];
        for p in &self.points {
            let (north, east) = (p.position_m.north_m(), p.position_m.east_m());
            e[0] = e[0].min(north);
            e[1] = e[1].min(east);
            e[2] = e[2].max(north);
            e[3] = e[3].max(east);
        }
        (!self.points.is_empty()).then_some(e)
    }
}

/// [`Strip::radius_for_neighbours_m`] of a strip given by its points' horizontal positions
/// (north, east) in file order: a streaming reader keeps these, not whole points.
pub fn radius_for_neighbours_m(xy: &[[f64; 2]], neighbours: usize) -> Option<f64> {
    if xy.len() < 16 {
        return None;
    }
    const WINDOW_M: f64 = 3.0;
    let index = GridIndex::new(xy, WINDOW_M);
    let step = (xy.len() / 256).max(1);
    let mut densities: Vec<f64> = (0..xy.len())
        .step_by(step)
        .map(|k| {
            let [x, y] = xy[k];
            let mut n = 0usize;
            index.candidates(x, y, WINDOW_M, |i| {
                let [px, py] = xy[i];
                if (px - x).powi(2) + (py - y).powi(2) <= WINDOW_M * WINDOW_M {
                    n += 1;
                }
            });
            n as f64 / (std::f64::consts::PI * WINDOW_M * WINDOW_M)
        })
        .collect();
    densities.sort_by(f64::total_cmp);
    let density = densities[densities.len() / 2];
    Some((neighbours as f64 / (std::f64::consts::PI * density)).sqrt())
}

/// Zhang et al. (2018) eq. (2) in the local frame with the model: `P = P0 + R_L (R_M S + ΔP)`,
/// through [`LinearScanner::footprint_ned`] (the reference path; [`Georeferencing`] is the fast
/// one).
/// A point that keeps the out-of-plane part of `S` (a beam head) takes the same formula with
/// its whole `S` ([`RawPoint::scanner_m`]). The point is in the calibration's frame `L`.
pub fn georeference(point: &RawPoint, mounting: &Mounting) -> Ned {
    if point.out_of_plane_m != 0.0 {
        return Georeferencing::new(mounting).apply(point);
    }
    Ned::from_vector(
        point.origin_m.vector()
            + LinearScanner.footprint_ned(&LinearScanner.parameters(
                &point.attitude,
                mounting,
                &point.observation,
            )),
    )
}

/// A mounting prepared for re-georeferencing many points: `R_M` computed once.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Georeferencing {
    r_m: Matrix3<f64>,
    lever_m: Vector3<f64>,
}

impl Georeferencing {
    /// Prepares `R_M = Rz(yaw) Ry(pitch) Rx(roll)` and the lever arm.
    pub fn new(mounting: &Mounting) -> Georeferencing {
        Georeferencing {
            r_m: rotation_zyx(
                mounting.boresight_roll_rad,
                mounting.boresight_pitch_rad,
                mounting.boresight_yaw_rad,
            ),
            lever_m: mounting.lever_arm_m,
        }
    }

    /// `P0 + R_L (R_M S + ΔP)` in `L`; equal to [`georeference`] to rounding.
    #[inline]
    pub fn apply(&self, p: &RawPoint) -> Ned {
        Ned::from_vector(self.apply_vector(p))
    }

    /// [`Georeferencing::apply`] as a plain vector, for the crate's kernels.
    #[inline]
    pub(crate) fn apply_vector(&self, p: &RawPoint) -> Vector3<f64> {
        let a = &p.attitude;
        let r_l = rotation_zyx(a.roll_rad, a.pitch_rad, a.heading_rad);
        p.origin_m.vector() + r_l * (self.r_m * p.scanner_m() + self.lever_m)
    }
}

/// A constant error of one strip's trajectory: the GNSS/INS position (local NED, m) and the
/// attitude (roll, pitch, heading, rad) each off by a fixed amount over the strip. Over a strip's
/// ten-odd seconds a navigation solution's correlated errors are nearly constant, so this is
/// how they enter the strip's points (the calibration's trajectory weighting).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct TrajectoryOffset {
    pub(crate) position_m: Vector3<f64>,
    pub(crate) attitude_rad: [f64; 3],
    /// How the offset varies over the strip's time (a Gauss–Markov mode); `None`: constant.
    pub(crate) profile: Option<TimeProfile>,
}

/// A function of time, piecewise linear on a uniform grid, held at its ends outside it.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct TimeProfile {
    pub(crate) start_s: f64,
    pub(crate) step_s: f64,
    pub(crate) values: Vec<f64>,
}

impl TimeProfile {
    pub(crate) fn at(&self, time_s: f64) -> f64 {
        let last = self.values.len() - 1;
        let u = if self.step_s > 0.0 {
            ((time_s - self.start_s) / self.step_s).clamp(0.0, last as f64)
        } else {
            0.0
        };
        let i = (u.floor() as usize).min(last.saturating_sub(1));
        let f = u - i as f64;
        if last == 0 {
            self.values[0]
        } else {
            self.values[i] * (1.0 - f) + self.values[i + 1] * f
        }
    }
}

impl Georeferencing {
    /// [`Georeferencing::apply`] with the trajectory of the point off by `offset`.
    pub(crate) fn apply_offset(&self, p: &RawPoint, offset: &TrajectoryOffset) -> Vector3<f64> {
        let a = &p.attitude;
        let k = offset.profile.as_ref().map_or(1.0, |f| f.at(p.time_s));
        let [dr, dp, dh] = offset.attitude_rad.map(|v| v * k);
        let r_l = rotation_zyx(a.roll_rad + dr, a.pitch_rad + dp, a.heading_rad + dh);
        p.origin_m.vector()
            + offset.position_m * k
            + r_l * (self.r_m * p.scanner_m() + self.lever_m)
    }
}

/// Strip correction: every point re-georeferenced from its raw observation with `mounting`
/// (in the calibration's frame `L`, in point order; rayon-parallel).
pub fn correct_strip(strip: &Strip, mounting: &Mounting) -> Vec<Ned> {
    let g = Georeferencing::new(mounting);
    strip.points.par_iter().map(|p| g.apply(p)).collect()
}

/// Checks strips: at least one point each, unique ids, finite values.
pub(crate) fn check_strips(strips: &[Strip]) -> Result<()> {
    for (i, s) in strips.iter().enumerate() {
        if s.points.is_empty() {
            return Err(Error::EmptyStrip {
                strip: s.id.clone(),
            });
        }
        if strips[..i].iter().any(|o| o.id == s.id) {
            return Err(Error::DuplicateStrip {
                strip: s.id.clone(),
            });
        }
        if let Some(index) = s.points.iter().position(|p| {
            !(p.position_m.vector().iter().all(|v| v.is_finite())
                && p.origin_m.vector().iter().all(|v| v.is_finite())
                && p.attitude.roll_rad.is_finite()
                && p.attitude.pitch_rad.is_finite()
                && p.attitude.heading_rad.is_finite()
                && p.observation.range_m.is_finite()
                && p.observation.scan_angle_rad.is_finite()
                && p.out_of_plane_m.is_finite())
        }) {
            return Err(Error::NonFinitePoint {
                strip: s.id.clone(),
                index,
            });
        }
    }
    Ok(())
}

/// A uniform grid over the horizontal (north, east) plane: cell lists in CSR layout.
#[derive(Debug, Clone)]
pub(crate) struct GridIndex {
    cell_m: f64,
    min: [f64; 2],
    nx: usize,
    ny: usize,
    starts: Vec<u32>,
    items: Vec<u32>,
}

impl GridIndex {
    /// Index of horizontal positions `xy` (north, east) with square cells of `cell_m`.
    pub(crate) fn new(xy: &[[f64; 2]], cell_m: f64) -> GridIndex {
        let mut min = [f64::INFINITY; 2];
        let mut max = [f64::NEG_INFINITY; 2];
        for p in xy {
            for k in 0..2 {
                min[k] = min[k].min(p[k]);
                max[k] = max[k].max(p[k]);
            }
        }
        if xy.is_empty() {
            min = [0.0; 2];
            max = [0.0; 2];
        }
        // Bounded (a few corrupted records kilometres away must not size it): the cells grow
        // until there are at most four per point (and 2^26 in all). Points far out land in the
        // edge cells, which the caller's distance check sorts out; only the speed changes.
        let cap = (4 * xy.len()).clamp(1 << 16, 1 << 26) as f64;
        let cells = |min: &[f64; 2], max: &[f64; 2], cell_m: f64| {
            (((max[0] - min[0]) / cell_m).floor() + 1.0)
                * (((max[1] - min[1]) / cell_m).floor() + 1.0)
        };
        if cells(&min, &max, cell_m) > cap {
            // The 1–99 % quantiles widened by a quarter of their span and ten cells.
            let step = (xy.len() / 200_000).max(1);
            for k in 0..2 {
                let mut v: Vec<f64> = xy.iter().step_by(step).map(|p| p[k]).collect();
                v.sort_by(f64::total_cmp);
                let q = |f: f64| v[((v.len() - 1) as f64 * f).round() as usize];
                let pad = 0.25 * (q(0.99) - q(0.01)) + 10.0 * cell_m;
                min[k] = min[k].max(q(0.01) - pad);
                max[k] = max[k].min(q(0.99) + pad);
            }
        }
        let mut cell_m = cell_m;
        while cells(&min, &max, cell_m) > cap {
            cell_m *= 2.0;
        }
        let nx = (((max[0] - min[0]) / cell_m).floor() as usize + 1).max(1);
        let ny = (((max[1] - min[1]) / cell_m).floor() as usize + 1).max(1);
        let cell_of = |p: &[f64; 2]| {
            let i = (((p[0] - min[0]) / cell_m) as usize).min(nx - 1);
            let j = (((p[1] - min[1]) / cell_m) as usize).min(ny - 1);
            i * ny + j
        };
        let mut counts = vec![0u32; nx * ny + 1];
        for p in xy {
            counts[cell_of(p) + 1] += 1;
        }
        for c in 1..counts.len() {
            counts[c] += counts[c - 1];
        }
        let mut fill = counts.clone();
        let mut items = vec![0u32; xy.len()];
        for (k, p) in xy.iter().enumerate() {
            let c = cell_of(p);
            items[fill[c] as usize] = k as u32;
            fill[c] += 1;
        }
        GridIndex {
            cell_m,
            min,
            nx,
            ny,
            starts: counts,
            items,
        }
    }

    /// Calls `f` with every index whose cell meets the square `[x ± r] × [y ± r]` (a superset of
    /// the disc; the caller checks the distance).
    pub(crate) fn candidates(&self, x: f64, y: f64, r: f64, mut f: impl FnMut(usize)) {
        let lo = |v: f64, m: f64| ((v - r - m) / self.cell_m).floor();
        let hi = |v: f64, m: f64| ((v + r - m) / self.cell_m).floor();
        let (i0, i1) = (lo(x, self.min[0]), hi(x, self.min[0]));
        let (j0, j1) = (lo(y, self.min[1]), hi(y, self.min[1]));
        if i1 < 0.0 || j1 < 0.0 || i0 >= self.nx as f64 || j0 >= self.ny as f64 {
            return;
        }
        let i0 = i0.max(0.0) as usize;
        let j0 = j0.max(0.0) as usize;
        let i1 = (i1 as usize).min(self.nx - 1);
        let j1 = (j1 as usize).min(self.ny - 1);
        for i in i0..=i1 {
            for j in j0..=j1 {
                let c = i * self.ny + j;
                for &k in &self.items[self.starts[c] as usize..self.starts[c + 1] as usize] {
                    f(k as usize);
                }
            }
        }
    }
}

/// Indices of `points` within horizontal distance `r` of (`x`, `y`).
pub(crate) fn within(index: &GridIndex, points: &[RawPoint], x: f64, y: f64, r: f64) -> Vec<usize> {
    let mut out = Vec::new();
    index.candidates(x, y, r, |k| {
        let p = &points[k].position_m;
        if (p.north_m() - x).powi(2) + (p.east_m() - y).powi(2) <= r * r {
            out.push(k);
        }
    });
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    fn point() -> RawPoint {
        RawPoint {
            position_m: Ned::default(),
            origin_m: Ned::new(10.0, -20.0, -500.0),
            attitude: Attitude::from_degrees(1.5, -2.0, 123.0),
            observation: LinearObservation {
                range_m: 520.0,
                scan_angle_rad: -0.3,
            },
            out_of_plane_m: 0.0,
            time_s: 0.0,
            intensity: 0,
        }
    }

    #[test]
    fn fast_path_equals_model() {
        let m = Mounting {
            boresight_roll_rad: 1e-3,
            boresight_pitch_rad: -5e-4,
            boresight_yaw_rad: 2e-3,
            lever_arm_m: Vector3::new(0.1, -0.05, 0.2),
        };
        let p = point();
        assert_relative_eq!(
            georeference(&p, &m).vector(),
            Georeferencing::new(&m).apply(&p).vector(),
            epsilon = 1e-9
        );
    }

    #[test]
    fn grid_finds_exactly_the_disc() {
        let pts: Vec<[f64; 2]> = (0..400)
            .map(|k| [(k % 20) as f64 * 0.7, (k / 20) as f64 * 0.9])
            .collect();
        let g = GridIndex::new(&pts, 1.3);
        let mut found = Vec::new();
        g.candidates(5.0, 7.0, 2.0, |k| {
            if (pts[k][0] - 5.0).powi(2) + (pts[k][1] - 7.0).powi(2) <= 4.0 {
                found.push(k)
            }
        });
        found.sort();
        let brute: Vec<usize> = (0..400)
            .filter(|&k| (pts[k][0] - 5.0).powi(2) + (pts[k][1] - 7.0).powi(2) <= 4.0)
            .collect();
        assert_eq!(found, brute);
        assert!(!brute.is_empty());
    }
}
