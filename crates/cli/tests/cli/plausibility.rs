//! Issue #25's "silent or misleading results" that are physical-plausibility cases, each run as
//! the real binary: before this layer every one exited 0 with nothing on stderr.
//!
//! The leeward mounting check runs when `LIDARQA_LEEWARD_DIR` names a directory
//! with leeward's `points.las` and `sbet.out` (see the README's "Real data" section); it says it
//! skipped otherwise.

use crate::binary;
use binary::{lidarqa, s, with_calibration};

use lidarqa_fixtures as common;

use lidarqa_io::{sbet_raw, write_records_to_path};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Output;

fn tpu(sv: &common::Survey, sbet: &Path, sensor: &Path, extra: &[&str]) -> Output {
    let out = sv.dir.join("out.laz");
    let _ = std::fs::remove_file(&out);
    let base = [
        "tpu",
        s(&sv.strip),
        "--trajectory",
        s(sbet),
        "--sensor",
        s(sensor),
        "-o",
        s(&out),
        "--format",
        "json",
    ];
    lidarqa(&[&base[..], extra].concat())
}

/// Exit 1 with one `lidarqa: ` line holding every needle, no output file.
fn refused(out: &Output, dir: &Path, needles: &[&str]) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert_eq!(err.lines().count(), 1, "one line: {err}");
    assert!(err.starts_with("lidarqa: "), "{err}");
    for n in needles {
        assert!(err.contains(n), "`{err}` lacks `{n}`");
    }
    assert!(!dir.join("out.laz").exists());
}

/// Exit 0; the JSON summary and the stderr lines.
fn ok(out: &Output) -> (Value, String) {
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "{err}");
    (serde_json::from_slice(&out.stdout).unwrap(), err)
}

/// The warning with `code`, checked to be on stderr too.
fn warning<'a>(v: &'a Value, err: &str, code: &str) -> &'a str {
    let w = v["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .find(|w| w["code"] == code)
        .unwrap_or_else(|| panic!("no {code} warning in {}", v["warnings"]));
    let m = w["message"].as_str().unwrap();
    assert!(
        err.lines()
            .any(|l| l.starts_with("lidarqa: warning: ") && l.contains(m)),
        "stderr lacks the warning: {err}"
    );
    m
}

/// The simulated survey's SBET records (as `common::write_sbet`), for editing.
fn sbet_records(duration_s: f64) -> Vec<sbet_raw::SbetRecord> {
    let n = (duration_s * common::SBET_HZ).round() as usize + 1;
    (0..n)
        .map(|i| {
            let t = i as f64 / common::SBET_HZ;
            let (lat, lon, a) = common::pose(t);
            sbet_raw::SbetRecord {
                time: common::SOW0 + t,
                latitude: lat,
                longitude: lon,
                altitude: common::HEIGHT_M,
                roll: a.roll_rad,
                pitch: a.pitch_rad,
                platform_heading: a.heading_rad,
                ..Default::default()
            }
        })
        .collect()
}

fn write_sbet(dir: &Path, name: &str, recs: &[sbet_raw::SbetRecord]) -> PathBuf {
    let p = dir.join(name);
    write_records_to_path(&p, recs, &[] as &[&Path]).unwrap();
    p
}

const DURATION_S: f64 = 1.0;

#[test]
fn a_plausible_survey_has_an_empty_warnings_list() {
    let dir = tempfile::tempdir().unwrap();
    let sv = common::survey(dir.path(), 2000, "laz", None);
    let (v, err) = ok(&tpu(
        &sv,
        &sv.sbet,
        &sv.sensor,
        &["--smrmsg", s(&sv.smrmsg)],
    ));
    assert_eq!(v["warnings"], serde_json::json!([]), "{err}");
    assert!(!err.contains("warning"), "{err}");
    let m = &v["mounting_check"];
    assert_eq!(m["does_not_fit"], false);
    // The fitted boresight is the simulation's (pitch −0.03°, yaw 0.05°).
    let f = m["fitted_boresight_deg"].as_array().unwrap();
    assert!((f[1].as_f64().unwrap() + 0.03).abs() < 1e-3, "{m}");
    assert!((f[2].as_f64().unwrap() - 0.05).abs() < 1e-3, "{m}");
}

#[test]
fn sbet_in_degrees_and_altitude_1e30_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let sv = common::survey(dir.path(), 500, "las", None);
    let mut recs = sbet_records(DURATION_S);
    for r in &mut recs {
        r.latitude = r.latitude.to_degrees();
        r.longitude = r.longitude.to_degrees();
    }
    let deg = write_sbet(dir.path(), "deg.out", &recs);
    refused(
        &tpu(&sv, &deg, &sv.sensor, &[]),
        dir.path(),
        &[
            "deg.out",
            "latitudes look like degrees, SBET stores radians",
        ],
    );
    let mut recs = sbet_records(DURATION_S);
    recs[50].altitude = 1e30;
    let high = write_sbet(dir.path(), "high.out", &recs);
    refused(
        &tpu(&sv, &high, &sv.sensor, &[]),
        dir.path(),
        &["high.out", "record 50: height 1e30 m is not an aircraft's"],
    );
}

/// Points in 33N read as 34N (`--epsg 32634`): 470 km from the trajectory; `tpu` and `correct`
/// refuse (correct moved every point hundreds of km before).
#[test]
fn points_in_the_wrong_utm_zone_are_refused_by_tpu_and_correct() {
    let dir = tempfile::tempdir().unwrap();
    let sv = common::survey(dir.path(), 500, "las", None);
    let needles = [
        "km from the trajectory",
        "wrong UTM zone or CRS? the points are read in UTM zone 34N, the trajectory is in 33N",
    ];
    refused(
        &tpu(&sv, &sv.sbet, &sv.sensor, &["--epsg", "32634"]),
        dir.path(),
        &needles,
    );
    let cal = dir.path().join("calibration.json");
    std::fs::write(
        &cal,
        r#"{"parameters": {"lever_x_m": 0.1, "lever_y_m": -0.2, "lever_z_m": 0.3,
            "boresight_roll_deg": 0.02, "boresight_pitch_deg": -0.03, "boresight_yaw_deg": 0.05}}"#,
    )
    .unwrap();
    let out_dir = dir.path().join("corrected");
    let out = lidarqa(
        &[
            with_calibration("correct", &sv.strip, [&sv.sbet, &sv.sensor, &cal], &out_dir),
            vec!["--epsg", "32634"],
        ]
        .concat(),
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    for n in needles {
        assert!(err.contains(n), "{err}");
    }
    assert!(!out_dir.join("strip.las").exists());
}

/// Two points displaced by 18 km (what two byte flips in LAZ point data did): counted and named
/// in a warning, or skipped with --skip-invalid; the other points are untouched.
#[test]
fn corrupted_points_are_counted_in_a_warning_or_skipped() {
    let dir = tempfile::tempdir().unwrap();
    let mut sv = common::survey(dir.path(), 2000, "laz", None);
    sv.truth[700].las.x += 18_000.0;
    sv.truth[1400].las.y -= 18_000.0;
    common::write_las(&sv.strip, &sv.truth, &common::las_options(true, 6));
    let (v, err) = ok(&tpu(&sv, &sv.sbet, &sv.sensor, &[]));
    let m = warning(&v, &err, "implausible_points");
    assert!(m.contains("2 points (first: "), "{m}");
    assert!(m.contains("point 700)"), "{m}");
    assert_eq!(v["points_written"], 2000);
    // The two stay out of the mounting check: it still fits.
    assert_eq!(
        v["mounting_check"]["does_not_fit"], false,
        "{}",
        v["mounting_check"]
    );
    let (v, err) = ok(&tpu(&sv, &sv.sbet, &sv.sensor, &["--skip-invalid"]));
    assert_eq!(v["skipped"]["implausible"], 2, "{err}");
    assert_eq!(v["points_written"], 1998);
    let m = warning(&v, &err, "implausible_points");
    assert!(m.contains("they were skipped"), "{m}");
}

/// A point whose GPS time is not a number: refused in one line with the time converter's
/// message and the point, or skipped with --skip-invalid and counted.
#[test]
fn a_point_whose_gps_time_is_not_a_number_is_refused_or_skipped() {
    let dir = tempfile::tempdir().unwrap();
    let mut sv = common::survey(dir.path(), 2000, "laz", None);
    sv.truth[900].las.gps_time_s = Some(f64::NAN);
    common::write_las(&sv.strip, &sv.truth, &common::las_options(true, 6));
    let out = tpu(&sv, &sv.sbet, &sv.sensor, &[]);
    refused(
        &out,
        &sv.dir,
        &["GPS time NaN is not finite", "(point 900;"],
    );
    let (v, err) = ok(&tpu(&sv, &sv.sbet, &sv.sensor, &["--skip-invalid"]));
    assert_eq!(v["skipped"]["bad_gps_time"], 1, "{err}");
    assert_eq!(v["points_written"], 1999);
}

/// A sensor file with boresight yaw 5° on data flown with 0.05°: a warning in words with the
/// boresight that fits (yaw 0.05°, pitch −0.03°) and the file's 5°.
#[test]
fn a_sensor_file_with_the_wrong_boresight_is_named_with_the_fitted_one() {
    let dir = tempfile::tempdir().unwrap();
    let sv = common::survey(dir.path(), 2000, "laz", None);
    let text = std::fs::read_to_string(&sv.sensor).unwrap();
    let line = text
        .lines()
        .find(|l| l.starts_with("boresight_yaw_deg"))
        .unwrap();
    let wrong = dir.path().join("yaw5.toml");
    std::fs::write(&wrong, text.replacen(line, "boresight_yaw_deg = 5.0", 1)).unwrap();
    let (v, err) = ok(&tpu(&sv, &sv.sbet, &wrong, &[]));
    let m = warning(&v, &err, "mounting_does_not_fit");
    assert!(m.contains("does not fit the data"), "{m}");
    assert!(m.contains("yaw 5.000°) does not fit"), "{m}");
    assert!(m.contains("yaw 0.050°"), "{m}");
    let f = &v["mounting_check"]["fitted_boresight_deg"];
    assert!((f[2].as_f64().unwrap() - 0.05).abs() < 1e-3, "{f}");
    assert!((f[1].as_f64().unwrap() + 0.03).abs() < 1e-3, "{f}");
}

#[test]
fn trajectory_gap_inside_the_strip_is_an_error_a_short_one_and_a_duplicate_warnings() {
    let dir = tempfile::tempdir().unwrap();
    let sv = common::survey(dir.path(), 2000, "laz", None);
    // The points span 0.1 to 0.77 s. A 5 s gap at 0.4 s (the records after it moved 5 s
    // later): the points after 0.4 s fall in the gap.
    let mut recs = sbet_records(DURATION_S);
    for r in recs.iter_mut().skip(81) {
        r.time += 5.0;
    }
    let gap = write_sbet(dir.path(), "gap.out", &recs);
    refused(
        &tpu(&sv, &gap, &sv.sensor, &[]),
        dir.path(),
        &[
            "strip.laz",
            "gap.out has a 5.005 s gap",
            "with points inside it",
        ],
    );
    // Three samples missing at 0.5 s (a 20 ms gap) and one record twice: warnings.
    let mut recs = sbet_records(DURATION_S);
    recs.drain(101..104);
    let dup = recs[120];
    recs.insert(120, dup);
    let short = write_sbet(dir.path(), "short.out", &recs);
    let (v, err) = ok(&tpu(&sv, &short, &sv.sensor, &[]));
    let m = warning(&v, &err, "trajectory_gap");
    assert!(m.contains("0.020 s gap"), "{m}");
    let m = warning(&v, &err, "trajectory_duplicate_time");
    assert!(m.contains("records 120 and 121 share time"), "{m}");
}

#[test]
fn smrmsg_not_covering_the_points_or_in_a_wrong_unit_is_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let sv = common::survey(dir.path(), 2000, "laz", None);
    let rec = |t: f64, pos: f64| sbet_raw::SmrmsgRecord {
        time: common::SOW0 + t,
        north_position_rms: pos,
        east_position_rms: pos,
        down_position_rms: pos,
        roll_rms: 0.3,
        pitch_rms: 0.3,
        heading_rms: 0.6,
        ..Default::default()
    };
    // Covers 0 to 0.3 s only; the points run to 0.77 s.
    let short = dir.path().join("short_smrmsg.out");
    write_records_to_path(&short, &[rec(0.0, 0.02), rec(0.3, 0.02)], &[] as &[&Path]).unwrap();
    let (v, err) = ok(&tpu(&sv, &sv.sbet, &sv.sensor, &["--smrmsg", s(&short)]));
    let m = warning(&v, &err, "trajectory_sigma_not_covering");
    assert!(
        m.contains("points lie outside the time span of the trajectory σ"),
        "{m}"
    );
    // Centimetres written as metres.
    let cm = dir.path().join("cm_smrmsg.out");
    write_records_to_path(&cm, &[rec(0.0, 200.0), rec(2.0, 200.0)], &[] as &[&Path]).unwrap();
    let (v, err) = ok(&tpu(&sv, &sv.sbet, &sv.sensor, &["--smrmsg", s(&cm)]));
    let m = warning(&v, &err, "trajectory_sigma_unit");
    assert!(m.contains("a position σ of 200 m"), "{m}");
}

/// leeward with a zero boresight: the warning names the fitted yaw within 0.1° of 13.96°.
#[test]
fn leeward_with_a_zero_boresight_names_the_fitted_yaw() {
    let Some(data) = std::env::var_os("LIDARQA_LEEWARD_DIR").map(PathBuf::from) else {
        eprintln!("skipped: set LIDARQA_LEEWARD_DIR to leeward's data (points.las, sbet.out)");
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let text = std::fs::read_to_string(root.join("docs/real-data/leeward.toml")).unwrap();
    // The [mounting] table's boresight (the first of each key) set to zero.
    let mut zeroed = text.clone();
    for key in ["boresight_pitch_deg", "boresight_yaw_deg"] {
        let line = zeroed
            .lines()
            .find(|l| l.starts_with(key))
            .unwrap()
            .to_string();
        zeroed = zeroed.replacen(&line, &format!("{key} = 0.0"), 1);
    }
    let sensor = dir.path().join("leeward_zero.toml");
    std::fs::write(&sensor, zeroed).unwrap();
    let out = dir.path().join("out.las");
    let o = lidarqa(&[
        "tpu",
        s(&data.join("points.las")),
        "--trajectory",
        s(&data.join("sbet.out")),
        "--sensor",
        s(&sensor),
        "-o",
        s(&out),
        "--format",
        "json",
    ]);
    let (v, err) = ok(&o);
    let m = warning(&v, &err, "mounting_does_not_fit");
    let yaw = v["mounting_check"]["fitted_boresight_deg"][2]
        .as_f64()
        .unwrap();
    assert!((yaw - 13.96).abs() < 0.1, "fitted yaw {yaw}: {m}");
    assert!(m.contains(&format!("yaw {yaw:.3}°")), "{m}");
    eprintln!("leeward, zero boresight: {m}");
}
