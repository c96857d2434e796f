//! `lidarqa budget` run as a real binary: the JSON contract with values, and one-line errors with
//! exit code 1 for bad input.

use crate::binary;
use binary::lidarqa;

use lidarqa_products::{BudgetDocument, BudgetSweepDocument};
use serde_json::Value;

fn json(args: &[&str]) -> Value {
    binary::json_ok(&[args, &["--format", "json"]].concat())
}

/// [`json`], checked to be lidarqa-products' type `T` field for field.
fn typed_json<T: serde::de::DeserializeOwned + serde::Serialize>(args: &[&str]) -> Value {
    let out = binary::run_ok(&[args, &["--format", "json"]].concat());
    let text = String::from_utf8(out.stdout).unwrap();
    crate::assert_text_round_trips::<T>(&text, &args.join(" "));
    serde_json::from_str(&text).unwrap()
}

/// Runs, expects [`binary::fails_with`] with `needle` and nothing on stdout.
fn fails_with(args: &[&str], needle: &str) {
    let out = lidarqa(args);
    binary::fails_with(&out, &[needle]);
    assert!(out.stdout.is_empty(), "no partial output");
}

fn close(v: &Value, want: f64, tol: f64) {
    let got = v.as_f64().expect("a number");
    assert!((got - want).abs() <= tol, "got {got}, want {want}");
}

#[test]
fn zhang_2018_json_contract_and_values() {
    let v = typed_json::<BudgetDocument>(&["budget", "--preset", "zhang2018"]);
    assert_eq!(v["scanner"], "linear");
    assert!(v["refraction"].is_null());
    close(&v["footprint"]["east"], 46.188, 5e-4);
    close(&v["footprint"]["up"], -80.0, 1e-9);
    close(&v["geometry"]["scan_angle_deg"], 30.0, 1e-12);
    close(&v["geometry"]["range_m"], 92.376, 5e-4);
    let bp = v["sources"]
        .as_array()
        .unwrap()
        .iter()
        .find(|s| s["name"] == "boresight_pitch")
        .unwrap();
    assert_eq!(bp["unit"], "rad");
    close(&bp["sigma"], 1.396e-4, 1e-7);
    close(&bp["north"], 0.01117, 5e-6);
    close(&v["total"]["north"], 0.0527, 5e-5);
    close(&v["total"]["east"], 0.0519, 5e-5);
    close(&v["total"]["up"], 0.1004, 5e-5);
}

#[test]
fn czmil_json_geometry_and_totals() {
    let v = typed_json::<BudgetDocument>(&["budget", "--preset", "czmil"]);
    assert_eq!(v["refraction"], "scanner-frame");
    close(&v["geometry"]["prism_slope_deg"], 39.16, 5e-3);
    close(&v["geometry"]["exit_angle_deg"], 20.0, 1e-9);
    close(&v["geometry"]["range_water_m"], 51.7, 1e-9);
    close(&v["total"]["horizontal"], 0.1014, 5e-5);
    close(&v["total"]["vertical"], 0.1255, 5e-5);
    close(&v["total"]["three_d"], 0.1613, 5e-5);
}

#[test]
fn sweep_and_bias_json() {
    let v = typed_json::<BudgetSweepDocument>(&[
        "budget",
        "--preset",
        "czmil",
        "--sweep",
        "azimuth=0:90:45",
    ]);
    assert_eq!(v["sweep"], "azimuth");
    let pts = v["points"].as_array().unwrap();
    assert_eq!(pts.len(), 3);
    close(&pts[2]["at"], 90.0, 0.0);
    close(&pts[2]["geometry"]["azimuth_deg"], 90.0, 1e-12);
    let v = typed_json::<BudgetDocument>(&[
        "budget",
        "--preset",
        "zhang2018",
        "--scan-angle",
        "0",
        "--height",
        "1000",
        "--bias",
        "boresight_roll_deg=0.1",
    ]);
    // ρ sin 0.1° at 1000 m: 1.745 m towards the left wing.
    close(&v["bias"]["across_track"], -1.745_328, 1e-5);
    close(&v["bias"]["east"], -1.745_328, 1e-5);
    close(&v["bias_first_order"]["east"], -1.745_329, 1e-5);
}

#[test]
fn monte_carlo_flag_agrees_with_the_linear_totals() {
    let v = typed_json::<BudgetDocument>(&[
        "budget",
        "--preset",
        "zhang2018",
        "--monte-carlo",
        "20000",
        "--seed",
        "3",
    ]);
    let lin = v["total"]["up"].as_f64().unwrap();
    let mc = v["monte_carlo"]["sigma"]["up"].as_f64().unwrap();
    assert!((mc / lin - 1.0).abs() < 0.03, "{mc} vs {lin}");
}

#[test]
fn print_sensor_is_a_valid_sensor_file() {
    let out = lidarqa(&["budget", "--preset", "czmil", "--print-sensor"]);
    assert!(out.status.success());
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("czmil.toml");
    std::fs::write(&path, &out.stdout).unwrap();
    let from_file = json(&[
        "budget",
        "--sensor",
        path.to_str().unwrap(),
        "--range-air",
        "425.7",
        "--range-water",
        "51.7",
    ]);
    let preset = json(&["budget", "--preset", "czmil"]);
    for axis in ["horizontal", "vertical", "three_d"] {
        close(
            &from_file["total"][axis],
            preset["total"][axis].as_f64().unwrap(),
            1e-9,
        );
    }
}

#[test]
fn bad_input_is_one_line_and_exit_1() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("nope.toml");
    fails_with(
        &[
            "budget",
            "--sensor",
            missing.to_str().unwrap(),
            "--range",
            "100",
        ],
        "nope.toml",
    );
    let unknown = dir.path().join("unknown.toml");
    std::fs::write(
        &unknown,
        "[scanner]\ntype = \"linear\"\n[sigma]\nrange_m = 0.01\nwind_speed_m = 2\n",
    )
    .unwrap();
    fails_with(
        &[
            "budget",
            "--sensor",
            unknown.to_str().unwrap(),
            "--range",
            "100",
        ],
        "unknown.toml: key `sigma.wind_speed_m`",
    );
    let negative = dir.path().join("negative.toml");
    std::fs::write(
        &negative,
        "[scanner]\ntype = \"linear\"\n[sigma]\nrange_m = -0.01\n",
    )
    .unwrap();
    fails_with(
        &[
            "budget",
            "--sensor",
            negative.to_str().unwrap(),
            "--range",
            "100",
        ],
        "key `sigma.range_m`: must be a finite number >= 0, got -0.01",
    );
    // A beam that cannot reach the ground: 80° of roll to the left with a right-looking scan.
    fails_with(
        &[
            "budget",
            "--preset",
            "zhang2018",
            "--roll",
            "-80",
            "--height",
            "100",
        ],
        "cannot reach the surface",
    );
    fails_with(
        &["budget", "--preset", "zhang2018", "--range", "abc"],
        "'abc'",
    );
    fails_with(
        &["budget", "--preset", "zhang2018", "--range", "-5"],
        "range_m",
    );
    fails_with(&["budget", "--preset", "nope"], "unknown preset 'nope'");
    fails_with(
        &["budget", "--preset", "czmil", "--sweep", "tilt=0:1:1"],
        "unknown variable 'tilt'",
    );
    fails_with(
        &["budget", "--preset", "zhang2018", "--bias", "range_deg=1"],
        "unknown key 'range_deg'",
    );
    fails_with(
        &[
            "budget",
            "--preset",
            "zhang2018",
            "--bias",
            "time_water_ns=1",
        ],
        "this scanner does not have",
    );
    fails_with(&["budget"], "--preset");
}

/// The preset's former name still works, gives the same budget, and says once on stderr what to
/// write instead; the new name says nothing.
#[test]
fn former_preset_name_is_a_deprecated_alias() {
    let new = binary::run_ok(&["budget", "--preset", "zhang2018", "--format", "json"]);
    assert!(
        new.stderr.is_empty(),
        "{}",
        String::from_utf8_lossy(&new.stderr)
    );
    let old = binary::run_ok(&["budget", "--preset", "seed000", "--format", "json"]);
    assert_eq!(old.stdout, new.stdout);
    let err = String::from_utf8_lossy(&old.stderr);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.contains("deprecated") && err.contains("--preset zhang2018"),
        "{err}"
    );
    // The text table names the preset by its new name either way.
    let table = binary::stdout_ok(&["budget", "--preset", "seed000"]);
    assert!(table.contains("preset zhang2018"), "{table}");
    // Help lists the new name only.
    let help = binary::stdout_ok(&["budget", "--help"]);
    assert!(
        help.contains("zhang2018") && !help.contains("seed000"),
        "{help}"
    );
}
