//! A trajectory stored with the points: a LAS/LAZ whose every point carries the sensor's pose
//! in extra bytes, as Routescene's LidarPod / LidarViewer exports it (lanl-ansi/ARMO's UAV
//! samples): `SensorX`, `SensorY`, `SensorZ` (the scanner's position in the points' projected
//! CRS and units) and `SensorRollRads`, `SensorPitchRads`, `SensorYawRads` (radians). PDAL
//! defines no dimension names for a per-point platform pose (its `Roll`, `Pitch`, `Azimuth` are
//! those of `readers.sbet`, a trajectory file), so these are the names read.
//!
//! The stored yaw is not a heading: it turns counter-clockwise, as an east-north-up yaw does,
//! and is zero when the body's x axis points to grid west, so the grid heading (clockwise from
//! grid north) is `heading = −yaw − 90°` ([`heading_from_yaw`]); roll and pitch are read as
//! stored. Nothing in the export says so; the points do. A spinning multi-beam head on its side
//! puts each laser ring on one cone about the body's x axis, and only the right attitude brings
//! every point of a ring back to one elevation from the spin plane.
//! `docs/real-data/armo_yaw_convention.py` measures that spread for each reading: reading the yaw
//! as a heading spreads each ring over degrees, `−yaw − 90°` with the stored pitch brings it
//! down to a few tenths of a degree, a negated pitch spreads it again. The roll turns the cones
//! about their own axis, so that test cannot see its sign.
//!
//! The pose of each point is its own stored pose: the trajectory has one pose per point, keyed
//! by a time each point of the file also gets. When the file's GPS time resolves the points
//! (fewer than one point in ten sharing a time with another), the key is the GPS time on
//! seconds of week. When it is coarse (ARMO's whole seconds), the key is made from the order
//! the file offers: `frameNo` (the scanner's revolution counter), a frame lasting the file's GPS
//! time span over its frame span, the points of one frame spread evenly over it in file order.
//! Such keys exist only for this file: a tile posed by them must be the file itself.

use crate::error::{Error, Result};
use crate::gpstime::{SECONDS_PER_WEEK_S, adjusted_standard_to_week};
use crate::pointcloud::{LasReader, PointChunk};
use std::path::Path;
use std::sync::Arc;

/// A per-point pose as read, before it becomes a trajectory (`trajtext` builds that).
pub(crate) struct PointPoses {
    /// (key, x, y, z, roll, pitch, grid heading) in key order, one per distinct key.
    pub(crate) poses: Vec<[f64; 7]>,
    /// Each point's key in file order, when GPS time is coarse (else the GPS time is the key).
    pub(crate) point_keys: Option<Arc<Vec<f64>>>,
    /// What was read and how it was ordered, for a note.
    pub(crate) note: String,
}

/// The pose dimensions: x, y, z, roll, pitch, yaw.
pub const POSE_DIMS: [&str; 6] = [
    "SensorX",
    "SensorY",
    "SensorZ",
    "SensorRollRads",
    "SensorPitchRads",
    "SensorYawRads",
];

/// The grid heading (rad, clockwise from grid north, in [−π, π)) of a stored `SensorYawRads`
/// (rad, counter-clockwise, zero with the body's x axis to grid west): `−yaw − π/2` (see the
/// module docs for the evidence).
#[must_use]
pub fn heading_from_yaw(yaw_rad: f64) -> f64 {
    use std::f64::consts::{FRAC_PI_2, PI, TAU};
    (-yaw_rad - FRAC_PI_2 + PI).rem_euclid(TAU) - PI
}

/// Frame counters that order the points when GPS time is coarse.
const FRAME_DIMS: [&str; 3] = ["frameNo", "FrameNo", "frame"];

/// The file carries a per-point pose (all of [`POSE_DIMS`]).
pub fn has_point_pose(path: &Path) -> bool {
    LasReader::from_path(path).is_ok_and(|r| {
        POSE_DIMS
            .iter()
            .all(|n| r.info().extra_dims.iter().any(|d| d.name == *n))
    })
}

/// Reads the per-point pose of `path` (see the module docs).
///
/// # Errors
/// The reader's errors; [`Error::InvalidLas`] naming the file when a pose dimension is missing,
/// a pose is not finite, or GPS time is coarse and no frame counter orders the points.
pub(crate) fn read_point_poses(path: &Path) -> Result<PointPoses> {
    let mut r = LasReader::from_path(path)?;
    let info = r.info().clone();
    let bad = |message: String| Error::InvalidLas {
        path: path.to_path_buf(),
        message,
    };
    if let Some(n) = POSE_DIMS
        .iter()
        .find(|n| !info.extra_dims.iter().any(|d| d.name == **n))
    {
        return Err(bad(format!(
            "no extra-bytes dimension `{n}`: not a file whose points carry the sensor pose \
             ({})",
            POSE_DIMS.join(", ")
        )));
    }
    let frame_dim = FRAME_DIMS
        .iter()
        .find(|n| info.extra_dims.iter().any(|d| d.name == **n))
        .copied();
    let mut chunk = PointChunk::new();
    let mut pose: Vec<[f64; 6]> = Vec::new();
    let mut gps: Vec<f64> = Vec::new();
    let mut frame: Vec<f64> = Vec::new();
    while r.fill(&mut chunk, 1 << 16)? > 0 {
        for i in 0..chunk.len() {
            let v = POSE_DIMS.map(|n| chunk.extra(i, n).unwrap_or(f64::NAN));
            if v.iter().any(|x| !x.is_finite()) {
                return Err(bad(format!(
                    "point {}: a sensor pose value is not finite",
                    pose.len()
                )));
            }
            pose.push(v);
            gps.push(chunk.points[i].gps_time_s.unwrap_or(f64::NAN));
            if let Some(f) = frame_dim {
                frame.push(chunk.extra(i, f).unwrap_or(f64::NAN));
            }
        }
    }
    let n = pose.len();
    if n < 2 {
        return Err(bad(format!("{n} points: a trajectory needs two poses")));
    }
    // GPS time resolves the points when fewer than one in ten shares its time.
    let mut sorted: Vec<f64> = gps.iter().copied().filter(|t| t.is_finite()).collect();
    sorted.sort_by(f64::total_cmp);
    sorted.dedup();
    let fine = gps.iter().all(|t| t.is_finite()) && sorted.len() * 10 >= n * 9;
    let on_week = |t: f64| {
        if t > SECONDS_PER_WEEK_S {
            adjusted_standard_to_week(t).seconds_of_week_s
        } else {
            t
        }
    };
    let (keys, order): (Vec<f64>, String) = if fine {
        (gps.iter().map(|t| on_week(*t)).collect(), "GPS time".into())
    } else {
        let Some(fname) = frame_dim else {
            return Err(bad(format!(
                "GPS time is coarse ({} distinct times for {n} points) and no frame counter \
                 ({}) orders the points: the pose of a point cannot be told from its time",
                sorted.len(),
                FRAME_DIMS.join(", ")
            )));
        };
        if frame.iter().any(|f| !f.is_finite()) {
            return Err(bad(format!("`{fname}` is not finite on every point")));
        }
        let (f0, f1) = frame
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), f| {
                (a.min(*f), b.max(*f))
            });
        let span_t = sorted.last().unwrap_or(&0.0) - sorted.first().unwrap_or(&0.0);
        // One frame's duration: the GPS span over the frame span (ARMO: ~0.1 s, a 10 Hz head).
        let frame_s = if f1 > f0 && span_t > 0.0 {
            span_t / (f1 - f0)
        } else {
            0.1
        };
        // Points in (frame, file order); each frame's points spread evenly over the frame.
        let mut idx: Vec<usize> = (0..n).collect();
        idx.sort_by(|a, b| frame[*a].total_cmp(&frame[*b]).then(a.cmp(b)));
        let mut keys = vec![0.0; n];
        let mut k = 0;
        while k < n {
            let f = frame[idx[k]];
            let end = (k..n).find(|j| frame[idx[*j]] != f).unwrap_or(n);
            let m = (end - k) as f64;
            for (r, j) in (k..end).enumerate() {
                keys[idx[j]] = (f - f0) * frame_s + (r as f64 + 0.5) / m * frame_s;
            }
            k = end;
        }
        (
            keys,
            format!("`{fname}` (GPS time is coarse: frames of {frame_s:.4} s)"),
        )
    };
    // One pose per distinct key, in key order.
    let mut by_key: Vec<usize> = (0..n).collect();
    by_key.sort_by(|a, b| keys[*a].total_cmp(&keys[*b]));
    let mut poses: Vec<[f64; 7]> = Vec::with_capacity(n);
    for i in by_key {
        if poses.last().is_some_and(|p| p[0] >= keys[i]) {
            continue;
        }
        let [x, y, z, roll, pitch, yaw] = pose[i];
        poses.push([keys[i], x, y, z, roll, pitch, heading_from_yaw(yaw)]);
    }
    let note = format!(
        "{}: the sensor pose stored with each of its {n} points is the trajectory ({} poses), \
         ordered by {order}",
        path.display(),
        poses.len()
    );
    Ok(PointPoses {
        poses,
        point_keys: (!fine).then(|| Arc::new(keys)),
        note,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpstime::LasTimeBase;
    use crate::pointcloud::{LasPoint, LasWriteOptions, LasWriter};
    use std::f64::consts::{FRAC_PI_2, FRAC_PI_6};

    #[test]
    fn stored_yaw_turns_counter_clockwise_from_west() {
        // yaw 0: body x to grid west (heading 270° = −90°); −90°: north; +90°: south (−180°);
        // 180°: east (+90°). A small positive yaw turns the body from west towards south.
        for (yaw_deg, heading_deg) in [
            (0.0, -90.0),
            (-90.0, 0.0),
            (90.0, -180.0),
            (180.0, 90.0),
            (-180.0, 90.0),
            (10.0, -100.0),
            (-135.0, 45.0),
        ] {
            let h = heading_from_yaw(f64::to_radians(yaw_deg));
            assert!(
                (h - f64::to_radians(heading_deg)).abs() < 1e-12,
                "yaw {yaw_deg}°: heading {}°, expected {heading_deg}°",
                h.to_degrees()
            );
        }
    }

    #[test]
    fn a_stored_pose_becomes_a_grid_heading_with_roll_and_pitch_as_stored() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("pose.las");
        let opts = LasWriteOptions {
            version_minor: 2,
            point_format: 1,
            scale: [0.001; 3],
            offset: [0.0; 3],
            time_base: LasTimeBase::AdjustedStandard,
            crs_vlrs: Vec::new(),
            extra_dims: Vec::new(),
            extra_dims_f64: POSE_DIMS
                .iter()
                .map(|n| (n.to_string(), String::new()))
                .collect(),
            file_source_id: 0,
            carried_extra: Default::default(),
        };
        let mut w = LasWriter::create(&path, &opts, &[] as &[&Path]).unwrap();
        // Two poses flying grid north (stored yaw −90°), then a third turned 30° to the east.
        let poses = [
            (0.0, [500.0, 1000.0, 80.0, 0.02, -0.01, -FRAC_PI_2]),
            (0.1, [500.0, 1001.0, 80.0, 0.02, -0.01, -FRAC_PI_2]),
            (
                0.2,
                [500.5, 1002.0, 80.0, 0.03, 0.04, -FRAC_PI_2 - FRAC_PI_6],
            ),
        ];
        for (t, pose) in poses {
            let p = LasPoint {
                x: pose[0],
                y: pose[1],
                z: 60.0,
                gps_time_s: Some(t),
                return_number: 1,
                number_of_returns: 1,
                ..LasPoint::default()
            };
            w.write_point_f64(&p, &[], &pose).unwrap();
        }
        w.finish().unwrap();
        let traj = crate::read_point_pose(&path).unwrap();
        assert_eq!(traj.poses.len(), 3);
        let h: Vec<f64> = traj
            .poses
            .iter()
            .map(|p| p.heading_rad.to_degrees())
            .collect();
        assert!(h[0].abs() < 1e-9 && h[1].abs() < 1e-9, "{h:?}");
        assert!((h[2] - 30.0).abs() < 1e-9, "{h:?}");
        assert_eq!(traj.poses[2].roll_rad, 0.03);
        assert_eq!(traj.poses[2].pitch_rad, 0.04);
    }
}
