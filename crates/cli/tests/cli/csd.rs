//! `lidarqa tpu FILE.csd`: the Optech CSD sample in, every return out with its σ; the flags that
//! do not apply to raw records are refused.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn lidarqa(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lidarqa"))
        .args(args)
        .output()
        .unwrap()
}

fn sensor() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/guide/raw-records-altm.toml")
}

#[test]
fn csd_sample_runs_without_trajectory_and_refuses_one() {
    let Some(dir) = lidarqa_testkit::realdata("optech_csd_pdal") else {
        return;
    };
    let csd = dir.join("sample.csd");
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("sample_tpu.laz");
    let (csd, out, sensor) = (csd.to_str().unwrap(), out.to_str().unwrap(), sensor());
    let sensor = sensor.to_str().unwrap();
    let o = lidarqa(&[
        "tpu", csd, "--sensor", sensor, "--epsg", "32617", "-o", out, "--format", "json",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["points_written"], 1000);
    assert_eq!(j["mounting"]["source"], "csd_header");
    assert_eq!(j["epsg"], 32617);
    // The header's boresight: misalignment + IMU offsets, 0.030 250 6 rad of roll.
    let roll = j["mounting"]["boresight_deg"][0].as_f64().unwrap();
    assert!((roll - 0.030_250_602_070_446_688f64.to_degrees()).abs() < 1e-12);
    let up = j["sigma"]["sigma_up"]["median"].as_f64().unwrap();
    assert!((0.05..0.2).contains(&up), "{up}");

    let o = lidarqa(&[
        "tpu",
        csd,
        "--sensor",
        sensor,
        "--epsg",
        "32617",
        "-o",
        out,
        "--trajectory",
        csd,
    ]);
    assert_eq!(o.status.code(), Some(1));
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        e.contains("carries its pose") && e.contains("drop --trajectory"),
        "{e}"
    );

    let o = lidarqa(&["tpu", csd, "--sensor", sensor, "-o", out]);
    assert_eq!(o.status.code(), Some(1));
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(e.contains("give the output's UTM CRS with --epsg"), "{e}");

    let o = lidarqa(&[
        "tpu",
        csd,
        "--sensor",
        sensor,
        "--epsg",
        "32617",
        "-o",
        out,
        "--mounting",
        "sensor-file",
        "--format",
        "json",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["mounting"]["source"], "sensor_file");
    assert_eq!(j["warnings"][0]["code"], "csd_header_mounting_overridden");
}
