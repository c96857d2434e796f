//! `correct_tile` on a simulated strip whose trajectory, mounting and raw observations are known
//! exactly: the corrected points are the true observations georeferenced with the new mounting,
//! and a tile without a CRS is corrected in the zone the context gives (`--utm-zone` /
//! `--epsg`), as `tpu_tile` does.

use lidarqa_fixtures as common;

use lidarqa_io::{
    Geodetic, Hemisphere, LasReader, PointChunk, UtmZone, ecef_to_geodetic, geodetic_to_ecef,
};
use lidarqa_model::{Georeferencer, LinearObservation, LinearScanner, Mounting, ecef_from_ned};
use lidarqa_pipeline::{CorrectTileJob, Error, TpuContext, TpuOptions, correct_tile};
use nalgebra::Vector3;
use std::path::Path;

fn read_all(path: &Path) -> PointChunk {
    let mut r = LasReader::from_path(path).unwrap();
    let mut c = PointChunk::new();
    r.fill(&mut c, 10_000_000).unwrap();
    c
}

/// A calibration's answer: the simulation's mounting changed by 0.1° and decimetres.
fn calibrated() -> Mounting {
    let m = common::mounting();
    Mounting {
        boresight_roll_rad: m.boresight_roll_rad + 0.1f64.to_radians(),
        boresight_pitch_rad: m.boresight_pitch_rad - 0.08f64.to_radians(),
        boresight_yaw_rad: m.boresight_yaw_rad + 0.1f64.to_radians(),
        lever_arm_m: m.lever_arm_m + Vector3::new(0.3, -0.2, 0.25),
    }
}

fn correct(ctx: &TpuContext, input: &Path, output: &Path) -> lidarqa_pipeline::Result<u64> {
    correct_tile(&CorrectTileJob {
        input,
        output,
        context: ctx,
        mounting: &calibrated(),
        other_inputs: &[],
        progress: Default::default(),
    })
    .map(|r| r.points)
}

#[test]
fn corrected_points_are_the_true_observations_with_the_new_mounting() {
    let dir = tempfile::tempdir().unwrap();
    let sv = common::survey(dir.path(), 3000, "laz", None);
    let ctx = TpuContext::from_files(&sv.sensor, &sv.sbet, None, TpuOptions::default()).unwrap();
    let out = dir.path().join("corrected.laz");
    assert_eq!(correct(&ctx, &sv.strip, &out).unwrap(), 3000);
    let got = read_all(&out);
    let input = read_all(&sv.strip);
    let proj = UtmZone::new(33, Hemisphere::North).unwrap().projection();
    let m = calibrated();
    let (mut worst, mut largest) = (0f64, 0f64);
    for ((t, p), q) in sv.truth.iter().zip(&got.points).zip(&input.points) {
        // Zhang et al. (2018) eq. 2 with the true pose and observation and the new mounting,
        // rigorously through ECEF → geodetic → UTM.
        let (lat, lon, att) = common::pose(t.time_sow - common::SOW0);
        let obs = LinearObservation {
            range_m: t.range_m,
            scan_angle_rad: t.scan_angle_rad,
        };
        let f = LinearScanner.footprint_ned(&LinearScanner.parameters(&att, &m, &obs));
        let p0 = geodetic_to_ecef(&Geodetic {
            latitude_rad: lat,
            longitude_rad: lon,
            height_m: common::HEIGHT_M,
        });
        let g = ecef_to_geodetic(&(p0 + ecef_from_ned(lat, lon) * f));
        let en = proj.forward(g.latitude_rad, g.longitude_rad);
        let d = Vector3::new(p.x - en.easting_m, p.y - en.northing_m, p.z - g.height_m);
        worst = worst.max(d.amax());
        let shift = Vector3::new(p.x - t.las.x, p.y - t.las.y, p.z - t.las.z);
        largest = largest.max(shift.norm());
        // Every other attribute is kept.
        let mut kept = q.clone();
        (kept.x, kept.y, kept.z) = (p.x, p.y, p.z);
        assert_eq!(*p, kept);
    }
    // The points moved by up to a metre and a half; what is left is the 0.1 mm LAS scale
    // (rounding on input and on output) and the SBET's interpolation between 5 ms poses.
    eprintln!("largest shift {largest:.3} m, worst axis difference {worst:.2e} m");
    assert!(largest > 1.0, "{largest}");
    assert!(worst < 2e-4, "{worst}");
}

#[test]
fn a_tile_without_crs_takes_the_context_zone() {
    let dir = tempfile::tempdir().unwrap();
    let sv = common::survey(dir.path(), 500, "las", None);
    let input = dir.path().join("nocrs.las");
    common::write_las(&input, &sv.truth, &common::las_options(false, 6));
    let ctx = TpuContext::from_files(&sv.sensor, &sv.sbet, None, TpuOptions::default()).unwrap();
    let out = dir.path().join("out.las");
    let e = correct(&ctx, &input, &out).unwrap_err();
    assert!(matches!(e, Error::UnknownCrs { .. }), "{e}");
    let msg = e.to_string();
    assert!(
        msg.contains("nocrs.las") && msg.contains("pass --utm-zone or --epsg"),
        "{msg}"
    );
    assert!(!out.exists());

    // With the zone given, the points are those of the same strip with its CRS in the header.
    let options = TpuOptions {
        crs: Some(UtmZone::new(33, Hemisphere::North).unwrap().into()),
        ..TpuOptions::default()
    };
    let ctx33 = TpuContext::from_files(&sv.sensor, &sv.sbet, None, options).unwrap();
    assert_eq!(correct(&ctx33, &input, &out).unwrap(), 500);
    let reference = dir.path().join("reference.las");
    assert_eq!(correct(&ctx, &sv.strip, &reference).unwrap(), 500);
    let (a, b) = (read_all(&out), read_all(&reference));
    let mut moved = 0;
    for ((p, q), t) in a.points.iter().zip(&b.points).zip(&sv.truth) {
        assert_eq!((p.x, p.y, p.z), (q.x, q.y, q.z));
        moved += usize::from((p.x - t.las.x).abs() > 0.01);
    }
    assert!(moved > 400, "{moved}");
}

#[test]
fn the_error_names_the_first_bad_point_in_file_order() {
    // Points are moved in batches (trajectory and map for a batch, then the arithmetic, then
    // the records) and in parallel runs; a point outside the trajectory is reported as the first
    // such point of the file, wherever it falls in a batch, and no output is left.
    let dir = tempfile::tempdir().unwrap();
    let sv = common::survey(dir.path(), 3000, "las", None);
    let ctx = TpuContext::from_files(&sv.sensor, &sv.sbet, None, TpuOptions::default()).unwrap();
    for bad in [[1300, 1500, 2900], [2101, 700, 2100], [1, 0, 63]] {
        let mut truth = sv.truth.clone();
        for k in bad {
            truth[k].las.gps_time_s = truth[k].las.gps_time_s.map(|t| t + 3600.0);
        }
        let input = dir.path().join("late.las");
        common::write_las(&input, &truth, &common::las_options(true, 6));
        let out = dir.path().join("out.las");
        let e = correct(&ctx, &input, &out).unwrap_err();
        let first = *bad.iter().min().unwrap();
        assert!(
            matches!(e, Error::OutsideTrajectory { index, .. } if index == first as u64),
            "{bad:?}: {e}"
        );
        assert!(!out.exists());
    }
}
