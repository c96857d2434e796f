//! Lines, not files, in `calibrate` and `correct`: three files holding four flight lines, made by
//! `tests/lines_generator.py` (numpy + laspy on the independent calibration cross, none of
//! lidarqa's code). Two tiles `ab_w.las` and `ab_e.las` each hold part of two passes of point
//! source id 1 ~95 s apart; `cd.las` two passes of id 3 one second apart (no GPS-time gap) whose
//! sensor position jumps 200 m. Each
//! line's navigation is off by its own offset, drift and attitude error, the mounting by an
//! injected boresight and lever arm. Runs when `LIDARQA_PYTHON` names a Python with numpy,
//! laspy and pyproj:
//!
//! ```text
//! LIDARQA_PYTHON=python3 cargo test -p lidarqa --test cli flight_lines::
//! ```
//!
//! - `calibrate --adjust-strips=offset+drift+attitude` finds the four lines, says why (a
//!   GPS-time gap, a sensor position jump), and names each line's point source id and file in
//!   `strip_adjustment.lines`;
//! - `correct` then moves every line onto the points georeferenced without any error (the
//!   generator's floor): RMS 29–62 cm before, under 10 cm after, and the lines' mean residuals
//!   agree within 1.5 cm per axis (a line given another line's correction would be off by the
//!   difference of their ~5 cm errors). The common horizontal remainder (~3 and ~4 cm) is what
//!   ties between lines and height-only control cannot see: a shift of every line alike.

use crate::binary;
use binary::{run_ok, s};

use serde_json::Value;
use std::path::Path;
use std::process::Command;

fn generator() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/lines_generator.py")
}

fn python_json(python: &std::ffi::OsStr, args: &[&str]) -> Option<Value> {
    let out = Command::new(python)
        .arg(generator())
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "lines_generator.py {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).ok()
}

#[test]
fn lines_across_tiles_and_within_one_file_calibrate_and_correct_as_lines() {
    let Some(python) = lidarqa_testkit::python("the flight lines of calibrate and correct") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    python_json(&python, &["make", s(d), "--seed", "3", "--thin", "3"]);
    let cal = d.join("cal.json");
    let out = d.join("out");
    let common = |cmd: &str| -> Vec<String> {
        let mut v: Vec<String> = vec![cmd.into()];
        v.extend(["ab_w.las", "ab_e.las", "cd.las"].map(|f| s(&d.join(f)).to_string()));
        for (flag, file) in [("--trajectory", "sbet.out"), ("--sensor", "sensor.toml")] {
            v.push(flag.into());
            v.push(s(&d.join(file)).into());
        }
        v.extend(["--utm-zone".into(), "33".into()]);
        v
    };
    let mut args = common("calibrate");
    args.extend(
        [
            "--ties",
            s(&d.join("ties.csv")),
            "--control",
            s(&d.join("control.csv")),
            "--adjust-strips=offset+drift+attitude",
            "-o",
            s(&cal),
        ]
        .map(String::from),
    );
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    run_ok(&args);
    crate::assert_round_trips::<lidarqa_products::CalibrationDocument>(&cal);
    let c: Value = serde_json::from_str(&std::fs::read_to_string(&cal).unwrap()).unwrap();

    // The lines found, and why.
    let found: Vec<(String, u64, Value)> = c["lines"]["found"]
        .as_array()
        .unwrap()
        .iter()
        .map(|l| {
            (
                l["strip"].as_str().unwrap().to_string(),
                l["point_source_id"].as_u64().unwrap(),
                l["files"].clone(),
            )
        })
        .collect();
    let tiles = serde_json::json!(["ab_w", "ab_e"]);
    let want: Vec<(String, u64, Value)> = [
        ("1-1", 1, tiles.clone()),
        ("1-2", 1, tiles),
        ("3-1", 3, serde_json::json!(["cd"])),
        ("3-2", 3, serde_json::json!(["cd"])),
    ]
    .map(|(a, b, f)| (a.to_string(), b, f))
    .to_vec();
    assert_eq!(found, want);
    let reasons = c["lines"]["reasons"].to_string();
    assert!(
        reasons.contains(
            "point source id 1: 2 lines across 2 files, split at a GPS-time gap of 95.5 s"
        ),
        "{reasons}"
    );
    assert!(
        reasons.contains(
            "point source id 3: 2 lines, split at a sensor position jump of 199.8 m in 1.000 s"
        ),
        "{reasons}"
    );
    let codes = c["warnings"].to_string();
    assert!(codes.contains("line_split"), "{codes}");
    // Each strip adjustment line names what correct matches points by.
    let lines = c["strip_adjustment"]["lines"].as_array().unwrap();
    assert_eq!(lines.len(), 4);
    for (l, (id, psid, files)) in lines.iter().zip(&want) {
        assert_eq!(l["strip"], id.as_str());
        assert_eq!(l["point_source_id"], *psid);
        assert_eq!(&l["files"], files);
    }

    // correct, per line.
    let mut args = common("correct");
    args.extend(["--calibration", s(&cal), "-o", s(&out)].map(String::from));
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    run_ok(&args);
    let m = python_json(&python, &["check", s(d), s(&out)]).expect("the check's JSON");
    let mut means = Vec::new();
    for (id, _, _) in &want {
        let l = &m[id.as_str()];
        let before = l["rms_before_m"].as_f64().unwrap();
        let after = l["rms_after_m"].as_f64().unwrap();
        assert!(before > 0.25, "{id}: {before}");
        assert!(
            after < 0.10 && after < 0.25 * before,
            "{id}: {before} -> {after}"
        );
        let mean: Vec<f64> = (0..3)
            .map(|k| l["mean_after_m"][k].as_f64().unwrap())
            .collect();
        assert!(mean[2].abs() < 0.01, "{id}: {mean:?}");
        means.push(mean);
    }
    for k in 0..3 {
        let v: Vec<f64> = means.iter().map(|m| m[k]).collect();
        let spread =
            v.iter().cloned().fold(f64::MIN, f64::max) - v.iter().cloned().fold(f64::MAX, f64::min);
        assert!(spread < 0.015, "axis {k}: the lines' mean residuals {v:?}");
    }
}
