//! The plausibility checks of `tpu` for the commands that move points or estimate a mounting
//! from them (`correct`, `calibrate`): each sampled point's raw observation is recovered with the
//! sensor file's mounting and the trajectory, as `tpu` does, and
//!
//! - its distance from the scan plane is summed into the mounting check
//!   ([`MountingTally`], the same criterion as `tpu`'s `mounting_does_not_fit`);
//! - its recovered scan angle is compared with the file's scan-angle field (the same check as
//!   `tpu`'s `scan_angle_disagrees` and `scan_angle_outliers`);
//! - a range beyond [`DEFAULT_MAX_RANGE_M`] is counted.
//!
//! `tpu` propagates each point's σ; here a conservative bound of it from the sensor file's σ
//! alone ([`sigma_3d_bound`]) stands in, so the mounting check fires no more often than
//! `tpu`'s. The vertical offset between trajectory and points that best explains a scan-angle
//! disagreement ([`RecoveryTally::height_offset_m`]) names the likely cause: a trajectory
//! hundreds of metres too low (another height datum, a wrong file) keeps the points on the
//! scan plane and shows only in the angles.
//!
//! Written here (a few sums over recovered vectors); the recovery itself is lidarqa-tpu's.

use crate::context::{OpenTile, TpuContext};
use crate::error::{Error, Result};
use crate::plausibility::DEFAULT_MAX_RANGE_M;
use crate::summary::AngleCheck;
use lidarqa_io::{LasReader, RawChunk};
use lidarqa_model::{Ecef, Scanner, Sensor, Warning};
use lidarqa_tpu::{MOUNTING_ERROR_M, MountingTally, sigma_3d_bound};
use lidarqa_tpu::{PoseAt, Recoverer};
use nalgebra::Matrix3;
use std::path::Path;

/// Points of a strip's first chunk read by [`check_strip_sample`].
const SAMPLE_READ: usize = 200_000;
/// Of which this many, evenly spaced, are checked.
const SAMPLE_CHECKED: usize = 2_000;
/// Scan angles below this, degrees, do not enter the height-offset estimate (near nadir the
/// across-track distance, and so the offset, is ill-determined).
const MIN_ANGLE_FOR_OFFSET_DEG: f64 = 5.0;

/// The recovery with the sensor file's mounting (linear scanner).
pub(crate) struct RecoveryCheck<'a> {
    recoverer: Recoverer,
    /// Scanner → body of the sensor file's mounting.
    r_m: Matrix3<f64>,
    sensor: &'a Sensor,
}

impl<'a> RecoveryCheck<'a> {
    /// The check for `ctx`'s sensor file; `None` for a scanner other than the linear one (whose
    /// checks are `tpu`'s alone for now).
    pub(crate) fn new(ctx: &'a TpuContext) -> Option<RecoveryCheck<'a>> {
        matches!(ctx.sensor.scanner, Scanner::Linear).then(|| RecoveryCheck {
            recoverer: Recoverer::new(&ctx.recovery_mounting),
            r_m: ctx.recovery_mounting.scanner_to_body(),
            sensor: &ctx.sensor,
        })
    }

    /// An empty tally, the LAS field's step from its point format.
    pub(crate) fn tally(&self, point_format: u8) -> RecoveryTally {
        RecoveryTally {
            mounting: MountingTally::new(&self.sensor.mounting, true),
            scan: AngleCheck {
                step_deg: if point_format >= 6 { 0.006 } else { 1.0 },
                ..AngleCheck::default()
            },
            beyond_range: 0,
            max_range_m: 0.0,
            offsets_m: Vec::new(),
        }
    }

    /// Adds one point at `ecef` with its pose and the file's scan angle (degrees).
    pub(crate) fn add(&self, tally: &mut RecoveryTally, pose: &PoseAt, ecef: &Ecef, scan_deg: f64) {
        let Ok(r) = self.recoverer.linear_ecef_without_beam(pose, ecef) else {
            return;
        };
        if r.range_m > DEFAULT_MAX_RANGE_M {
            tally.beyond_range += 1;
            tally.max_range_m = tally.max_range_m.max(r.range_m);
            return;
        }
        tally.mounting.add(
            r.out_of_plane_m,
            sigma_3d_bound(self.sensor, r.range_m),
            Some(&(self.r_m * r.scanner_m)),
        );
        let recovered_deg = r.scan_angle_rad.to_degrees();
        tally.scan.add(recovered_deg - scan_deg);
        // The down distance the file's angle implies for the recovered across-track distance.
        // (A trajectory below the ground puts the points above the scanner: the recovered
        // down distance is negative, the formula the same.)
        if scan_deg.abs() > MIN_ANGLE_FOR_OFFSET_DEG {
            let across = r.range_m * r.scan_angle_rad.sin();
            let down = r.range_m * r.scan_angle_rad.cos();
            let down_file = across / scan_deg.to_radians().tan();
            if down_file.is_finite() && down_file > 0.0 {
                tally.offsets_m.push(down - down_file);
            }
        }
    }
}

/// The sums of the checks over the sampled points.
#[derive(Debug, Clone)]
pub(crate) struct RecoveryTally {
    mounting: MountingTally,
    scan: AngleCheck,
    beyond_range: u64,
    max_range_m: f64,
    /// Per point with a clear scan angle: how much farther below the trajectory the point lies
    /// than the file's scan angle says, m (positive: the trajectory is too high... or the
    /// points too low).
    offsets_m: Vec<f64>,
}

impl RecoveryTally {
    /// The median vertical offset that explains the scan-angle disagreement, m: positive when
    /// the points lie farther below the trajectory than their scan angles say (the trajectory
    /// too high or the points too low).
    pub(crate) fn height_offset_m(&self) -> Option<f64> {
        if self.offsets_m.len() < 10 {
            return None;
        }
        lidarqa_model::median(&mut self.offsets_m.clone())
    }

    /// Whether the points do not fit the sensor file's mounting (`tpu`'s criterion) or lie
    /// kilometres off the scan plane.
    pub(crate) fn mounting_does_not_fit(&self) -> bool {
        self.mounting.does_not_fit() || self.mounting.rms_residual_m() > MOUNTING_ERROR_M
    }

    /// The mounting check's sentence.
    pub(crate) fn mounting_message(&self) -> String {
        format!(
            "{} (checked on {} sampled points)",
            self.mounting.message(),
            self.mounting.n
        )
    }

    /// The scan-angle warnings (`tpu`'s), each with the height offset that would explain the
    /// disagreement when one does.
    pub(crate) fn scan_warnings(
        &self,
        path: &Path,
        sensor: &Sensor,
        format: lidarqa_io::TrajectoryFormat,
    ) -> Vec<Warning> {
        let mut out = crate::tile::scan_angle_disagreement(path, &self.scan, sensor, format);
        if let Some(h) = self.height_sentence() {
            for w in &mut out {
                w.message.push_str(&h);
            }
        }
        out
    }

    /// "; …": the vertical offset between trajectory and points that the file's scan angles
    /// imply, when it is more than a metre.
    pub(crate) fn height_sentence(&self) -> Option<String> {
        let dz = self.height_offset_m().filter(|dz| dz.abs() > 1.0)?;
        Some(format!(
            "; the file's scan angles put the points {:.1} m {} below the trajectory than it \
             does: the trajectory {:.1} m too {} (or the points as much too {}: another height \
             datum, a geoid applied twice or not at all, another survey's trajectory?)",
            dz.abs(),
            if dz > 0.0 { "less far" } else { "farther" },
            dz.abs(),
            if dz > 0.0 { "high" } else { "low" },
            if dz > 0.0 { "low" } else { "high" },
        ))
    }

    /// The warning for points beyond the range envelope.
    pub(crate) fn range_warning(&self, path: &Path) -> Option<Warning> {
        (self.beyond_range > 0).then(|| {
            Warning::new(
                "implausible_points",
                format!(
                    "{}: {} of {} sampled points lie beyond {DEFAULT_MAX_RANGE_M} m of the scanner \
                     (farthest {:.1} m): corrupted point data, or points and a trajectory that do \
                     not belong together?",
                    path.display(),
                    self.beyond_range,
                    self.mounting.n + self.beyond_range,
                    self.max_range_m
                ),
            )
        })
    }
}

/// The point at `xyz` (the file's units) in ECEF with its pose, when it has a GPS time within
/// the trajectory.
pub(crate) fn pose_and_ecef(
    tile: &OpenTile,
    xyz: [f64; 3],
    time: Option<f64>,
) -> Option<(PoseAt, Ecef)> {
    let unit_m = tile.crs.unit().metres();
    let [x, y, z] = xyz;
    if !(x.is_finite() && y.is_finite() && z.is_finite()) {
        return None;
    }
    let sow = tile.converter.to_seconds_of_week(time?).ok()?;
    let pose = tile.trajectory.at(sow).ok()?;
    let (lat, lon) = tile.crs.inverse(x * unit_m, y * unit_m);
    let ecef = tile
        .crs
        .ellipsoid()
        .geodetic_to_ecef(&lidarqa_io::Geodetic {
            latitude_rad: lat,
            longitude_rad: lon,
            height_m: z * unit_m + tile.heights.offset_m(lat, lon),
        });
    Some((pose, ecef))
}

/// `calibrate`'s check of one strip before any work: its first points (up to 200 000, 2 000 of
/// them checked) recovered with the sensor file's mounting. A calibration from points that do
/// not fit the mounting they were made with, or whose scan angles say the trajectory is
/// elsewhere, would estimate the lever arm and boresight that absorb the fault and call them
/// determined; so either is refused, naming the likely cause. Points beyond the range
/// envelope (corrupted records) are left out, not refused.
///
/// # Errors
/// [`Error::Implausible`] naming the strip; I/O errors naming it.
pub(crate) fn check_strip_sample(ctx: &TpuContext, path: &Path, tile: &OpenTile) -> Result<()> {
    let Some(check) = RecoveryCheck::new(ctx) else {
        return Ok(());
    };
    let mut reader = LasReader::from_path(path)?;
    let mut chunk = RawChunk::default();
    reader.fill_raw(&mut chunk, SAMPLE_READ)?;
    let step = chunk.len().div_ceil(SAMPLE_CHECKED).max(1);
    let mut tally = check.tally(tile.info.point_format);
    for p in chunk.points().step_by(step) {
        if let Some((pose, ecef)) = pose_and_ecef(tile, p.xyz(), p.gps_time()) {
            check.add(&mut tally, &pose, &ecef, f64::from(p.scan_angle_deg()));
        }
    }
    let refuse = |message: String| Error::Implausible {
        path: path.to_path_buf(),
        message: format!(
            "{message}; a calibration from it would fit a lever arm and boresight that absorb the \
             fault: check that the strips, the trajectory (its heights, its time base) and the \
             sensor file belong together"
        ),
    };
    if tally.mounting_does_not_fit() {
        let height = tally.height_sentence().unwrap_or_default();
        return Err(refuse(format!("{}{height}", tally.mounting_message())));
    }
    // The warnings name the strip first; the error names it already.
    let own = |w: Warning| {
        let prefix = format!("{}: ", path.display());
        w.message
            .strip_prefix(&prefix)
            .map_or(w.message.clone(), str::to_string)
    };
    let scan = tally.scan_warnings(path, &ctx.sensor, ctx.trajectory_format());
    if let Some(w) = scan.into_iter().next() {
        return Err(refuse(own(w)));
    }
    // Points beyond the range envelope are not refused here: a few corrupted records are
    // left out of the checks above and of the calibration's own grids (robust extents).
    Ok(())
}
