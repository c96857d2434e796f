//! `lidarqa sensor` run as a real binary: the listing, a preset's sensor file read back by
//! `lidarqa budget` with the σ of the spec sheet and of the navigation grade asked for, and
//! one-line refusals.

use crate::binary;
use binary::lidarqa;

use serde_json::Value;

fn sigma_of(budget: &Value, name: &str) -> f64 {
    budget["sources"]
        .as_array()
        .unwrap()
        .iter()
        .find(|s| s["name"] == name)
        .map_or(0.0, |s| s["sigma"].as_f64().unwrap())
}

#[test]
fn list_shows_scanners_and_navigation_grades() {
    let v = binary::json_ok(&["sensor", "--list", "--format", "json"]);
    let names: Vec<&str> = v["scanners"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["name"].as_str().unwrap())
        .collect();
    for want in [
        "riegl-vq-1560ii",
        "riegl-vux-240",
        "riegl-minivux-3uav",
        "riegl-vq-880-g",
        "optech-galaxy",
        "optech-titan",
        "leica-terrainmapper-3",
        "leica-chiroptera-5",
        "czmil-supernova",
        "velodyne-hdl-32e",
        "hesai-xt32",
        "livox-avia",
        "routescene-lidarpod",
    ] {
        assert!(names.contains(&want), "{want} missing from {names:?}");
    }
    let imus: Vec<&str> = v["imus"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["name"].as_str().unwrap())
        .collect();
    assert!(imus.contains(&"applanix-ap60"), "{imus:?}");
    let table = binary::stdout_ok(&["sensor", "--list"]);
    assert!(table.contains("navigation grades"), "{table}");
}

/// A linear and a conic preset, written by `lidarqa sensor` and read by `lidarqa budget`: the
/// range σ of the spec sheet (VUX-240: 20 mm) and the heading σ of the navigation grade asked
/// for (AP40: 0.008°; AP60: 0.005°) come back in the budget.
#[test]
fn a_preset_is_a_sensor_file_the_commands_accept() {
    let dir = tempfile::tempdir().unwrap();
    let vux = dir.path().join("vux.toml");
    let text = binary::stdout_ok(&["sensor", "riegl-vux-240", "--imu", "applanix-ap40"]);
    assert!(text.contains("RIEGL VUX-240"), "{text}");
    std::fs::write(&vux, &text).unwrap();
    let v = binary::json_ok(&[
        "budget",
        "--sensor",
        binary::s(&vux),
        "--height",
        "150",
        "--scan-angle",
        "20",
        "--format",
        "json",
    ]);
    assert_eq!(v["scanner"], "linear");
    assert!((sigma_of(&v, "range") - 0.020).abs() < 1e-12);
    assert!((sigma_of(&v, "heading") - 0.008f64.to_radians()).abs() < 1e-15);
    let up = v["total"]["up"].as_f64().unwrap();
    assert!(up > 0.02 && up < 0.5, "{up}");

    let czmil = dir.path().join("czmil.toml");
    std::fs::write(&czmil, binary::stdout_ok(&["sensor", "czmil-supernova"])).unwrap();
    let v = binary::json_ok(&[
        "budget",
        "--sensor",
        binary::s(&czmil),
        "--height",
        "400",
        "--azimuth",
        "30",
        "--format",
        "json",
    ]);
    assert_eq!(v["scanner"], "conic");
    assert!((sigma_of(&v, "heading") - 0.005f64.to_radians()).abs() < 1e-15);

    // --imu none: no trajectory σ.
    let bare = dir.path().join("bare.toml");
    std::fs::write(
        &bare,
        binary::stdout_ok(&["sensor", "riegl-vux-240", "--imu", "none"]),
    )
    .unwrap();
    let v = binary::json_ok(&[
        "budget",
        "--sensor",
        binary::s(&bare),
        "--height",
        "150",
        "--format",
        "json",
    ]);
    assert_eq!(sigma_of(&v, "heading"), 0.0);
}

#[test]
fn refusals_are_one_line_and_name_the_cause() {
    let out = lidarqa(&["sensor", "riegl-q999"]);
    binary::fails_with(
        &out,
        &["unknown scanner preset 'riegl-q999'", "riegl-vux-240"],
    );
    let out = lidarqa(&["sensor", "livox-avia", "--imu", "ins-x"]);
    binary::fails_with(
        &out,
        &["unknown navigation preset 'ins-x'", "applanix-ap60"],
    );
    // A beam scanner's budget is refused by its type's name.
    let dir = tempfile::tempdir().unwrap();
    let avia = dir.path().join("avia.toml");
    std::fs::write(&avia, binary::stdout_ok(&["sensor", "livox-avia"])).unwrap();
    let out = lidarqa(&[
        "budget",
        "--sensor",
        binary::s(&avia),
        "--height",
        "50",
        "--scan-angle",
        "10",
    ]);
    binary::fails_with(&out, &["risley scanner"]);
}
