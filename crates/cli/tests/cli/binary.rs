//! Running the built `lidarqa` binary from the integration tests (each module uses part).
#![allow(dead_code)]

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// `lidarqa ARGS…`, its exit status and captured output.
pub fn lidarqa(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lidarqa"))
        .args(args)
        .output()
        .expect("the lidarqa binary runs")
}

/// `lidarqa ARGS…`, failing the test with the arguments and stderr unless it succeeds.
pub fn run_ok(args: &[&str]) -> Output {
    let out = lidarqa(args);
    assert!(
        out.status.success(),
        "lidarqa {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// The stdout of a successful `lidarqa ARGS…`.
pub fn stdout_ok(args: &[&str]) -> String {
    String::from_utf8(run_ok(args).stdout).expect("UTF-8 stdout")
}

/// The stdout of a successful `lidarqa ARGS…` as one JSON value.
pub fn json_ok(args: &[&str]) -> serde_json::Value {
    serde_json::from_slice(&run_ok(args).stdout).expect("one JSON value on stdout")
}

/// Exit 1 with one stderr line `lidarqa: …` containing every needle, and no panic (SPEC §6);
/// returns the line.
pub fn fails_with(out: &Output, needles: &[&str]) -> String {
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert_eq!(err.lines().count(), 1, "one line, got: {err}");
    assert!(err.starts_with("lidarqa: "), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    for n in needles {
        assert!(err.contains(n), "`{err}` lacks `{n}`");
    }
    err
}

/// `COMMAND INPUT --trajectory SBET --sensor SENSOR --calibration CAL -o OUTPUT`: a `tpu` or
/// `correct` run with a calibration.
pub fn with_calibration<'a>(
    command: &'a str,
    input: &'a Path,
    [sbet, sensor, cal]: [&'a Path; 3],
    output: &'a Path,
) -> Vec<&'a str> {
    vec![
        command,
        s(input),
        "--trajectory",
        s(sbet),
        "--sensor",
        s(sensor),
        "--calibration",
        s(cal),
        "-o",
        s(output),
    ]
}

/// A test path as an argument (the temporary directories are UTF-8).
pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Writes the scenario `text` to `DIR/s.toml` and simulates it into `DIR/sim` (which it returns),
/// failing the test with `simulate`'s stderr.
pub fn simulate_scenario(dir: &Path, text: &str) -> std::path::PathBuf {
    let toml = dir.join("s.toml");
    std::fs::write(&toml, text).unwrap();
    let sim = dir.join("sim");
    run_ok(&["simulate", "--scenario", s(&toml), "-o", s(&sim)]);
    sim
}

/// The demo scenario's first four lines (the low cross, each direction flown both ways) at
/// 25 kHz, with only the targets those strips see (the others would be control points outside
/// every strip): four strips that simulate and calibrate in seconds.
pub fn small_demo_scenario() -> String {
    let text =
        String::from_utf8(lidarqa(&["simulate", "--scenario", "demo", "--print"]).stdout).unwrap();
    let mut demo: toml::Table = toml::from_str(&text).unwrap();
    let f = |v: &toml::Value| v.as_float().unwrap();
    let scanner = demo["scanner"].as_table_mut().unwrap();
    scanner.insert("pulse_rate_hz".into(), toml::Value::Float(25_000.0));
    let half_fov_rad = f(&scanner["field_of_view_deg"]).to_radians();
    let lines = demo["lines"].as_array_mut().unwrap();
    lines.retain(|l| l["id"].as_integer().unwrap() <= 4);
    // Each kept line's track (start, end) and the half swath on the ground, 5 m inside its edge.
    let swaths: Vec<([f64; 2], [f64; 2], f64)> = lines
        .iter()
        .map(|l| {
            let xy = |k: &str| {
                let a = l[k].as_array().unwrap();
                [f(&a[0]), f(&a[1])]
            };
            (
                xy("start_m"),
                xy("end_m"),
                f(&l["height_m"]) * half_fov_rad.tan() - 5.0,
            )
        })
        .collect();
    let seen = |c: &[f64; 2]| {
        swaths.iter().any(|(a, b, half)| {
            let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
            let t =
                (((c[0] - a[0]) * dx + (c[1] - a[1]) * dy) / (dx * dx + dy * dy)).clamp(0.0, 1.0);
            (c[0] - a[0] - t * dx).hypot(c[1] - a[1] - t * dy) <= *half
        })
    };
    let targets = demo["scene"]["targets"].as_array_mut().unwrap();
    targets.retain(|t| {
        let c = t["center_m"].as_array().unwrap();
        seen(&[f(&c[0]), f(&c[1])])
    });
    assert!(targets.len() >= 4, "{targets:?}");
    toml::to_string(&demo).unwrap()
}

/// BLAKE3 of every file under `dir` (following no links), by path.
pub fn snapshot(dir: &Path) -> BTreeMap<PathBuf, String> {
    let mut out = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let e = e.unwrap();
            let t = e.file_type().unwrap();
            if t.is_dir() {
                stack.push(e.path());
            } else if t.is_file() {
                let bytes = std::fs::read(e.path()).unwrap();
                out.insert(e.path(), blake3::hash(&bytes).to_hex().to_string());
            }
        }
    }
    out
}
