//! Surveys as they are delivered: the public real samples read in place (`realdata`, see
//! lidarqa-testkit) through the commands they suit, each outcome checked against the peer's own
//! expectation or an independent computation; and the independent generator
//! (`tests/deliveries_generator.py`: tiles of several lines with orthometric heights).

use crate::binary;
use binary::{lidarqa, s};

use serde_json::Value;
use std::path::{Path, PathBuf};

fn docs() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/real-data")
}

fn json(o: &std::process::Output) -> Value {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    serde_json::from_slice(&o.stdout).unwrap()
}

fn codes(v: &Value) -> Vec<String> {
    v["warnings"]
        .as_array()
        .map(|a| {
            a.iter()
                .map(|w| w["code"].as_str().unwrap_or_default().to_string())
                .collect()
        })
        .unwrap_or_default()
}

/// The RIEGL ULS strip with its `.traj` as shipped (`Time[s],Roll[deg],…,Height[m]`): read
/// with its units, the same σ as the header renamed by hand to unit-less names, and the scan
/// angle recovered against the file's field named: 3.2° RMS, 9.4° at most (what the header
/// renamed by hand gave before, measured apart from this code).
#[test]
fn riegl_uls_trajectory_as_shipped() {
    let Some(data) = lidarqa_testkit::realdata("riegl_uls_voxelizer") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let stem = "H7_LS_F2_H20_200901-120129";
    let run = |traj: &Path, out: &str| {
        json(&lidarqa(&[
            "tpu",
            s(&data.join(format!("{stem}.laz"))),
            "--trajectory",
            s(traj),
            "--sensor",
            s(&docs().join("riegl_uls.toml")),
            "-o",
            s(&dir.path().join(out)),
            "--format",
            "json",
        ]))
    };
    let shipped = data.join(format!("{stem}.traj"));
    let v = run(&shipped, "a.laz");
    assert_eq!(v["points_written"], 14912);
    let check = &v["scan_angle_check"];
    let rms = check["rms_deg"].as_f64().unwrap();
    let max = check["max_deg"].as_f64().unwrap();
    assert!((3.0..3.4).contains(&rms), "RMS {rms}");
    assert!((9.0..9.8).contains(&max), "max {max}");
    assert!(codes(&v).iter().any(|c| c == "scan_angle_disagrees"), "{v}");
    // The header renamed by hand (no units: degrees and the CRS's metres) gives the same σ.
    let text = std::fs::read_to_string(&shipped).unwrap();
    let renamed = dir.path().join("renamed.txt");
    let (_, body) = text.split_once('\n').unwrap();
    std::fs::write(
        &renamed,
        format!("time,roll,pitch,yaw,easting,northing,height\n{body}"),
    )
    .unwrap();
    let w = run(&renamed, "b.laz");
    assert_eq!(v["sigma"], w["sigma"]);
}

/// ARMO's Car line: `--trajectory` names the LAZ itself; each point is posed by the sensor pose
/// stored with it, ordered by `frameNo` (its GPS time is whole seconds).
#[test]
fn armo_per_point_pose_as_trajectory() {
    let Some(data) = lidarqa_testkit::realdata("armo_uav") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let car = data.join("Car.adc.laz");
    let v = json(&lidarqa(&[
        "tpu",
        s(&car),
        "--trajectory",
        s(&car),
        "--sensor",
        s(&docs().join("armo_lidarpod.toml")),
        "-o",
        s(&dir.path().join("car.laz")),
        "--format",
        "json",
    ]));
    assert_eq!(v["points_written"], 72225);
    let c = codes(&v);
    assert!(c.iter().any(|c| c == "per_point_pose"), "{c:?}");
    // The pose the file carries in its extra bytes rides through, ahead of the σ, unrenamed.
    assert!(!c.iter().any(|c| c.starts_with("extra_bytes")), "{c:?}");
    let out = lidarqa_io::LasReader::from_path(dir.path().join("car.laz")).unwrap();
    let names: Vec<&str> = out
        .info()
        .extra_dims
        .iter()
        .map(|d| d.name.as_str())
        .collect();
    assert_eq!(&names[..2], ["frameNo", "SensorX"], "{names:?}");
    assert!(
        names.contains(&"SensorYawRads") && names.contains(&"sigma_up"),
        "{names:?}"
    );
    // The median σ (docs/guide/deliveries.md): 7.8 cm north, 8.0 cm east, 10.4 cm up.
    for (axis, median_m) in [("north", 0.0775), ("east", 0.0797), ("up", 0.1036)] {
        let got = v["sigma"][axis]["median"].as_f64().unwrap();
        assert!((got - median_m).abs() < 0.002, "{axis}: {got} m");
    }
    // Another file cannot be posed by Car's frames.
    let o = lidarqa(&[
        "tpu",
        s(&data.join("Tent.adc.laz")),
        "--trajectory",
        s(&car),
        "--sensor",
        s(&docs().join("armo_lidarpod.toml")),
        "-o",
        s(&dir.path().join("tent.laz")),
    ]);
    binary::fails_with(&o, &["Tent.adc.laz", "Car.adc.laz", "coarse"]);
}

/// lidR's Topography.laz: the mean rebuilt sensor height stays inside lidR's own test of
/// `track_sensor` on this file (3100 ± 3 m, `test-track_sensor.R`).
#[test]
fn lidr_topography_sensor_height_within_lidrs_test() {
    let Some(data) = lidarqa_testkit::realdata("lidr_topography") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("t.csv");
    let o = lidarqa(&["trajectory", s(&data.join("Topography.laz")), "-o", s(&out)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(&out).unwrap();
    let z: Vec<f64> = text
        .lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with("time"))
        .map(|l| l.split(',').nth(3).unwrap().parse().unwrap())
        .collect();
    let mean = z.iter().sum::<f64>() / z.len() as f64;
    assert!((mean - 3100.0).abs() <= 3.0, "mean sensor height {mean} m");
}

/// The VQ-880-G topo-bathy snippet: its class 26 (RIEGL's bathymetry, 49 486 of its 56 382
/// points, counted apart with laspy) is taken as water by default and left out of the lines,
/// and the message names what it assumed.
#[test]
fn vq880g_class_26_is_water_by_default() {
    let Some(data) = lidarqa_testkit::realdata("cblue_vq880g") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let las = data.join("las_snippet_fl.las");
    let o = lidarqa(&[
        "trajectory",
        s(&las),
        "-o",
        s(&dir.path().join("t.csv")),
        "--format",
        "json",
    ]);
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    // Its only multi-return pulses are 15 topographic ones shorter than 1 m: no trajectory can
    // be rebuilt, and the one error line says why and what was left out as water.
    assert_eq!(o.status.code(), Some(1), "{text}");
    assert!(text.contains("0 usable multi-return pulses"), "{text}");
    // The pulse checks in words, not a Rust debug structure.
    assert!(text.contains("15 multi-return;"), "{text}");
    assert!(!text.contains("PulseChecks"), "{text}");
    assert!(
        text.contains("49486 points in classes 40, 43, 44, 45, 26"),
        "{text}"
    );
    assert!(text.contains("class 26 of RIEGL"), "{text}");
}

/// leeward's strip and SBET with leeward's sensor (`docs/real-data/leeward.toml`): the points lie
/// on the fitted scan plane to 0.335 m RMS (the independent plane fit of
/// `docs/real-data/fit_scan_plane.py`), so no scan-angle or mounting warning.
#[test]
fn leeward_strip_runs_with_its_fitted_mounting() {
    let Some(data) = lidarqa_testkit::realdata("leeward") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let v = json(&lidarqa(&[
        "tpu",
        s(&data.join("points.las")),
        "--trajectory",
        s(&data.join("sbet.out")),
        "--sensor",
        s(&docs().join("leeward.toml")),
        "-o",
        s(&dir.path().join("l.laz")),
        "--format",
        "json",
    ]));
    assert_eq!(v["points_written"], 1325);
    let c = codes(&v);
    assert!(
        !c.iter()
            .any(|c| c == "mounting_does_not_fit" || c == "scan_angle_disagrees"),
        "{c:?}"
    );
}

/// The independent generator: tiles of two lines with orthometric heights, through
/// `trajectory` then `tpu DIR` with no geoid flag; with an ellipsoidal SBET and EGM2008
/// heights, EGM2008 applied (see the script's docstring).
#[test]
fn independent_generator_tiles_with_orthometric_heights() {
    let Some(python) = lidarqa_testkit::python("the deliveries generator") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/deliveries_generator.py");
    let o = std::process::Command::new(python)
        .arg(script)
        .arg(env!("CARGO_BIN_EXE_lidarqa"))
        .arg(dir.path())
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(stdout.contains(" passed, 0 failed"), "{stdout}");
}
