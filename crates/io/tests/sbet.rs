//! SBET / SMRMSG files on disk: round trips, size checks, atomic writing.

use lidarqa_io::sbet_raw::{SbetRecord, SmrmsgRecord};
use lidarqa_io::{
    Error, SbetPose, SbetReader, SmrmsgReader, read_sbet, read_smrmsg, write_records_to_path,
};
use std::path::Path;

fn trajectory(n: usize) -> Vec<SbetRecord> {
    (0..n)
        .map(|i| {
            let t = 302_400.0 + i as f64 * 0.005; // 200 Hz, mid-week
            SbetRecord {
                time: t,
                latitude: 45f64.to_radians() + i as f64 * 1e-7,
                longitude: 9f64.to_radians(),
                altitude: 1200.0 + i as f64 * 0.01,
                x_velocity: 60.0,
                y_velocity: 0.5,
                z_velocity: -0.1,
                roll: 0.01,
                pitch: -0.02,
                platform_heading: 0.3,
                wander_angle: 0.1,
                x_body_specific_force: 0.1,
                y_body_specific_force: -0.2,
                z_body_specific_force: -9.81,
                x_body_angular_rate: 1e-3,
                y_body_angular_rate: -2e-3,
                z_body_angular_rate: 3e-3,
            }
        })
        .collect()
}

#[test]
fn sbet_file_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sbet.out");
    let recs = trajectory(50);
    write_records_to_path(&path, &recs, &[] as &[&Path]).unwrap();
    assert_eq!(std::fs::metadata(&path).unwrap().len(), 50 * 136);
    let back = SbetReader::from_path(&path).unwrap().read_all().unwrap();
    assert_eq!(back, recs);
    let poses = read_sbet(&path).unwrap();
    assert_eq!(poses[7], SbetPose::from(recs[7]));
    assert!((poses[0].true_heading_rad() - 0.2).abs() < 1e-15);
    assert_eq!(poses[3].height_m, 1200.03);
}

#[test]
fn smrmsg_file_round_trip_in_radians() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("smrmsg.out");
    let recs: Vec<SmrmsgRecord> = (0..5)
        .map(|i| SmrmsgRecord {
            time: 100.0 + f64::from(i),
            north_position_rms: 0.02,
            east_position_rms: 0.02,
            down_position_rms: 0.04,
            north_velocity_rms: 0.001,
            east_velocity_rms: 0.001,
            down_velocity_rms: 0.002,
            roll_rms: 0.18, // 0.003°
            pitch_rms: 0.18,
            heading_rms: 0.6, // 0.01°
        })
        .collect();
    write_records_to_path(&path, &recs, &[] as &[&Path]).unwrap();
    assert_eq!(std::fs::metadata(&path).unwrap().len(), 5 * 80);
    assert_eq!(
        SmrmsgReader::from_path(&path).unwrap().read_all().unwrap(),
        recs
    );
    let s = read_smrmsg(&path).unwrap();
    assert!((s[0].sigma_heading_rad - 0.01f64.to_radians()).abs() < 1e-17);
    assert!((s[0].sigma_roll_rad - 0.003f64.to_radians()).abs() < 1e-17);
}

#[test]
fn truncated_sbet_names_file_and_size() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cut.out");
    write_records_to_path(&path, &trajectory(3), &[] as &[&Path]).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    std::fs::write(&path, &bytes[..3 * 136 - 8]).unwrap();
    let e = SbetReader::from_path(&path).unwrap_err();
    assert!(matches!(
        e,
        Error::RecordSize {
            size: 400,
            record_len: 136,
            ..
        }
    ));
    assert_eq!(
        e.to_string(),
        format!(
            "{}: size 400 bytes is not a multiple of the 136-byte sbet record",
            path.display()
        )
    );
    // An SMRMSG reader on an SBET file of 3 records (408 bytes) is caught too: 408 = 5·80 + 8.
    std::fs::write(&path, &bytes).unwrap();
    assert!(matches!(
        SmrmsgReader::from_path(&path),
        Err(Error::RecordSize {
            size: 408,
            record_len: 80,
            ..
        })
    ));
}

#[test]
fn unordered_times_are_refused_on_write_and_nothing_is_left() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.out");
    let mut recs = trajectory(4);
    recs[2].time = recs[0].time - 1.0;
    let e = write_records_to_path(&path, &recs, &[] as &[&Path]).unwrap_err();
    assert!(matches!(e, Error::RecordTime { index: 2, .. }), "{e}");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

#[test]
fn output_equal_to_input_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sbet.out");
    write_records_to_path(&path, &trajectory(2), &[] as &[&Path]).unwrap();
    let e = write_records_to_path(&path, &trajectory(3), &[&path]).unwrap_err();
    assert!(matches!(e, Error::OutputIsInput { .. }));
    assert_eq!(std::fs::metadata(&path).unwrap().len(), 2 * 136);
}

#[test]
fn missing_file_names_the_path() {
    let e = SbetReader::from_path("/nonexistent/dir/sbet.out").unwrap_err();
    assert!(e.to_string().starts_with("/nonexistent/dir/sbet.out: "));
}
