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
