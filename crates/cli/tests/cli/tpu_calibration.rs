//! `lidarqa tpu --calibration`: the calibrated mounting and its σ replace the sensor file's
//! (SPEC §8). A boresight σ cut from the sensor file's 0.008° to 0.001° cuts the
//! boresight share of every point's variance by (1/8)² (before renormalising), and the TPU of
//! the raw strip with the calibration equals the TPU of the strip that `lidarqa correct` wrote,
//! with a sensor file holding the calibrated mounting: the calibration moves the points the
//! TPU is computed at exactly as `correct` moves them.

use crate::binary;
use binary::{lidarqa, s, with_calibration};

use lidarqa_fixtures as common;

use lidarqa_io::{LasReader, PointChunk, sensor_to_toml};
use serde_json::Value;
use std::path::Path;

/// Boresight 0.001° and lever 1 mm, the mounting 0.1° / 5 cm from the simulation's, and a
/// correlation between lever x and boresight pitch (as a calibration's would be).
const CALIBRATION: &str = r#"{
  "parameters": {"lever_x_m": 0.15, "lever_y_m": -0.23, "lever_z_m": 0.32,
    "boresight_roll_deg": 0.12, "boresight_pitch_deg": -0.13, "boresight_yaw_deg": 0.15},
  "sigma": {"lever_x_m": 0.001, "lever_y_m": 0.001, "lever_z_m": 0.001,
    "boresight_roll_deg": 0.001, "boresight_pitch_deg": 0.001, "boresight_yaw_deg": 0.001},
  "correlation": [[1, 0, 0, 0, -0.5, 0], [0, 1, 0, 0, 0, 0], [0, 0, 1, 0, 0, 0],
                  [0, 0, 0, 1, 0, 0], [-0.5, 0, 0, 0, 1, 0], [0, 0, 0, 0, 0, 1]]
}"#;

fn run_ok(args: &[&str]) -> Value {
    let out = lidarqa(&[args, &["--format", "json"]].concat());
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("one JSON object")
}

fn sigmas(path: &Path) -> Vec<[f64; 3]> {
    let mut r = LasReader::from_path(path).unwrap();
    let mut c = PointChunk::new();
    r.fill(&mut c, 1_000_000).unwrap();
    let cols: Vec<Vec<f64>> = ["sigma_north", "sigma_east", "sigma_up"]
        .iter()
        .map(|n| c.extra_column(n).unwrap())
        .collect();
    (0..c.len())
        .map(|i| [cols[0][i], cols[1][i], cols[2][i]])
        .collect()
}

#[test]
fn calibration_replaces_the_mounting_and_its_sigma() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let sv = common::survey(d, 2000, "laz", None);
    let cal = d.join("calibration.json");
    std::fs::write(&cal, CALIBRATION).unwrap();
    let tpu = |strip: &Path, sensor: &Path, out: &Path, extra: &[&str]| {
        let base = [
            "tpu",
            s(strip),
            "--trajectory",
            s(&sv.sbet),
            "--sensor",
            s(sensor),
            "-o",
            s(out),
        ];
        run_ok(&[&base[..], extra].concat())
    };
    let before = tpu(&sv.strip, &sv.sensor, &d.join("before.laz"), &[]);
    let after = tpu(
        &sv.strip,
        &sv.sensor,
        &d.join("after.laz"),
        &["--calibration", s(&cal)],
    );

    // Shares: each boresight source's variance falls by (σ_cal / σ_file)²; the shares are
    // renormalised by each point's total, which falls too (mean ratio of totals below).
    let file_sigma = common::sensor().sigma;
    let (sb, sa) = (sigmas(&d.join("before.laz")), sigmas(&d.join("after.laz")));
    let total_ratio: f64 = sb
        .iter()
        .zip(&sa)
        .map(|(b, a)| b.iter().map(|v| v * v).sum::<f64>() / a.iter().map(|v| v * v).sum::<f64>())
        .sum::<f64>()
        / sb.len() as f64;
    for (name, source) in [
        ("boresight_roll", lidarqa_model::Source::BoresightRoll),
        ("boresight_pitch", lidarqa_model::Source::BoresightPitch),
    ] {
        let k = 0.001f64.to_radians() / file_sigma.get(source);
        let b = before["source_share"][name].as_f64().unwrap();
        let a = after["source_share"][name].as_f64().unwrap();
        let expected = b * k * k * total_ratio;
        eprintln!("{name}: share {b:.4} → {a:.6}, expected {expected:.6} (k = {k:.3})");
        assert!(b > 0.02, "{name} matters before: {b}");
        assert!(
            (a / expected - 1.0).abs() < 0.10,
            "{name}: share {a} after, expected {expected}"
        );
    }

    // The same TPU as the strip corrected by `lidarqa correct`, with the calibrated sensor.
    let corrected = d.join("corrected");
    let out = lidarqa(&with_calibration(
        "correct",
        &sv.strip,
        [&sv.sbet, &sv.sensor, &cal],
        &corrected,
    ));
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let doc: Value = serde_json::from_str(CALIBRATION).unwrap();
    let calibrated = lidarqa_calib::calibrated_sensor(&common::sensor(), &doc).unwrap();
    let calibrated_toml = d.join("calibrated.toml");
    std::fs::write(&calibrated_toml, sensor_to_toml(&calibrated)).unwrap();
    let corrected_tpu = tpu(
        &corrected.join("strip.laz"),
        &calibrated_toml,
        &d.join("corrected_tpu.laz"),
        &[],
    );
    let sc = sigmas(&d.join("corrected_tpu.laz"));
    assert_eq!(sc.len(), sa.len());
    let worst = sa
        .iter()
        .zip(&sc)
        .flat_map(|(a, c)| (0..3).map(move |k| (a[k] / c[k] - 1.0).abs()))
        .fold(0.0, f64::max);
    assert!(worst < 1e-4, "σ differ by {worst:.2e} (relative)");
    // Recovered with the mounting the points were made with: the out-of-plane residual stays
    // at the LAS rounding, not the 0.1° shift of the calibration.
    for v in [&after, &corrected_tpu] {
        let rms = v["recovery_residual_m"]["rms"].as_f64().unwrap();
        assert!(rms < 2e-3, "recovery residual {rms} m");
    }
}

#[test]
fn a_calibration_that_is_not_one_is_refused_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let sv = common::survey(d, 200, "laz", None);
    let cal = d.join("calibration.json");
    std::fs::write(&cal, r#"{"parameters": {"lever_x_m": 0.1}}"#).unwrap();
    let out = lidarqa(&with_calibration(
        "tpu",
        &sv.strip,
        [&sv.sbet, &sv.sensor, &cal],
        &d.join("out.laz"),
    ));
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.contains("calibration.json") && err.contains("lever_y_m"),
        "{err}"
    );
    assert!(!d.join("out.laz").exists());
}
