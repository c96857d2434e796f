//! Running the built `lidarqa` binary from the integration tests (each test file uses part).
#![allow(dead_code)]

use std::path::Path;
use std::process::{Command, Output};

/// `lidarqa ARGS…`, its exit status and captured output.
pub fn lidarqa(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lidarqa"))
        .args(args)
        .output()
        .expect("the lidarqa binary runs")
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
    let out = lidarqa(&["simulate", "--scenario", s(&toml), "-o", s(&sim)]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    sim
}

/// The demo scenario's text at a quarter of its pulse rate (25 kHz): four strips that simulate
/// and calibrate in seconds.
pub fn small_demo_scenario() -> String {
    let text =
        String::from_utf8(lidarqa(&["simulate", "--scenario", "demo", "--print"]).stdout).unwrap();
    let small = text.replacen("pulse_rate_hz = 50000.0", "pulse_rate_hz = 25000.0", 1);
    assert_ne!(small, text, "the demo scenario's pulse rate line moved");
    small
}
