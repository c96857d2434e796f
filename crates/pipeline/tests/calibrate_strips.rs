//! `load_all` (the strips of `lidarqa calibrate`) on a simulated strip whose raw observations are
//! known exactly: every point comes back with its true range and scan angle, and a strip fails
//! the same header checks as `tpu_tile` and `correct_tile`, naming the file.

use lidarqa_fixtures as common;

use lidarqa_pipeline::{TpuContext, TpuOptions, load_all};

#[test]
fn raw_observations_are_the_simulated_ones() {
    let dir = tempfile::tempdir().unwrap();
    let sv = common::survey(dir.path(), 2000, "laz", None);
    let ctx = TpuContext::from_files(&sv.sensor, &sv.sbet, None, TpuOptions::default()).unwrap();
    let (_, zone, loaded) = load_all(std::slice::from_ref(&sv.strip), &ctx).unwrap();
    assert_eq!(zone.epsg(), Some(32633));
    assert_eq!(loaded.len(), 1);
    // Every point has the same non-zero point source id: it is the strip's id.
    assert_eq!(loaded[0].stem, "strip");
    let points = &loaded[0].strip.points;
    assert_eq!(points.len(), sv.truth.len());
    let (mut range, mut angle) = (0f64, 0f64);
    for (p, t) in points.iter().zip(&sv.truth) {
        range = range.max((p.observation.range_m - t.range_m).abs());
        angle = angle.max((p.observation.scan_angle_rad - t.scan_angle_rad).abs());
    }
    // LAS stores 0.1 mm: the recovered range is within it, the angle within 0.1 mm at the range.
    assert!(range < 2e-4, "range off by {range} m");
    assert!(angle < 1e-6, "scan angle off by {angle} rad");
}

#[test]
fn strips_fail_the_header_checks_of_tpu_and_correct() {
    let dir = tempfile::tempdir().unwrap();
    let sv = common::survey(dir.path(), 100, "las", None);
    let ctx = TpuContext::from_files(&sv.sensor, &sv.sbet, None, TpuOptions::default()).unwrap();
    let no_crs = dir.path().join("no_crs.las");
    common::write_las(&no_crs, &sv.truth, &common::las_options(false, 6));
    let e = load_all(std::slice::from_ref(&no_crs), &ctx)
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("no_crs.las") && e.ends_with("pass --utm-zone or --epsg"),
        "{e}"
    );
    let no_time = dir.path().join("no_time.las");
    common::write_las(&no_time, &sv.truth, &common::las_options(true, 0));
    let e = load_all(std::slice::from_ref(&no_time), &ctx)
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("no_time.las") && e.contains("point format 0 has no GPS time"),
        "{e}"
    );
    let e = load_all(&[sv.strip.clone(), sv.strip.clone()], &ctx)
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("strip.las"), "{e}");
}
