//! Test support shared by every crate's tests (a dev-dependency only, never shipped).
//!
//! Two kinds of tests depend on things outside the repository, and both follow one rule:
//! they skip with a clear message on a developer's machine that lacks the thing, and they
//! **fail** under `CI=true`, where a silent skip would let CI claim more than it checked.
//!
//! - [`realdata`]: the public samples of real surveys, read in place from
//!   `../shared/realdata/<sample>` beside the repository (or `LIDARQA_REALDATA/<sample>`);
//!   the repository never copies them.
//! - [`python`]: the interpreter that runs the independent generators and readers
//!   (numpy, laspy, lazrs, pyproj), named by `LIDARQA_PYTHON`.

use std::ffi::{OsStr, OsString};
use std::path::{Path, PathBuf};

/// Whether this run is CI's (`CI=true`), where a missing prerequisite is a failure.
pub fn under_ci() -> bool {
    std::env::var("CI").is_ok_and(|v| v == "true")
}

/// The folder that holds the real samples: `LIDARQA_REALDATA`, else `../shared/realdata`
/// beside the workspace root.
pub fn realdata_root() -> PathBuf {
    match std::env::var_os("LIDARQA_REALDATA") {
        Some(dir) => PathBuf::from(dir),
        None => PathBuf::from(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../../shared/realdata"
        )),
    }
}

/// The folder of one real sample (e.g. `"armo_uav"`), or `None` with a message on stderr when
/// it is absent.
///
/// # Panics
/// Under `CI=true` when the sample is absent: CI must run every real-data test.
pub fn realdata(sample: &str) -> Option<PathBuf> {
    let dir = realdata_root().join(sample);
    if dir.is_dir() {
        return Some(dir);
    }
    let msg = format!(
        "real sample `{sample}` not found at {} (set LIDARQA_REALDATA to the folder of samples)",
        dir.display()
    );
    assert!(!under_ci(), "{msg}: CI=true requires it");
    eprintln!("{msg}: skipped");
    None
}

/// The Python named by `LIDARQA_PYTHON`, or `None` with a message naming `what` (the check
/// that is skipped) when it is unset.
///
/// # Panics
/// Under `CI=true` when `LIDARQA_PYTHON` is unset: CI must run the independent checks.
pub fn python(what: &str) -> Option<OsString> {
    if let Some(python) = std::env::var_os("LIDARQA_PYTHON") {
        return Some(python);
    }
    let msg =
        format!("{what} not run: set LIDARQA_PYTHON=python3 (with numpy, laspy, lazrs, pyproj)");
    assert!(!under_ci(), "{msg}; CI=true requires it");
    eprintln!("{msg}");
    None
}

/// Runs an independent check script (`python SCRIPT ARG`) and asserts that it succeeded and
/// printed its closing line with no failure (` passed, 0 failed`).
///
/// # Panics
/// When the script fails or reports a failed check; the message holds its output.
pub fn run_python_check(python: &OsStr, script: &Path, arg: &Path) {
    let out = std::process::Command::new(python)
        .arg(script)
        .arg(arg)
        .output()
        .expect("the Python interpreter runs");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let name = script.file_name().unwrap_or_default().to_string_lossy();
    assert!(
        out.status.success(),
        "{name} failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains(" passed, 0 failed"), "{stdout}");
}

/// Runs an inline Python script (`python -c SCRIPT ARGS…`), asserts that it succeeded, and
/// returns its standard output (also echoed to stderr, so `--nocapture` shows it).
///
/// # Panics
/// When the script fails; the message holds its stderr.
pub fn run_python_script(python: &OsStr, script: &str, args: &[&OsStr]) -> String {
    let out = std::process::Command::new(python)
        .arg("-c")
        .arg(script)
        .args(args)
        .output()
        .expect("the Python interpreter runs");
    assert!(
        out.status.success(),
        "python: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8_lossy(&out.stdout).trim().to_string();
    eprintln!("python: {stdout}");
    stdout
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_root_is_beside_the_workspace() {
        if std::env::var_os("LIDARQA_REALDATA").is_none() {
            let root = realdata_root();
            assert!(root.ends_with("shared/realdata"), "{}", root.display());
            // crates/testkit/../../.. is the workspace root's parent.
            let parent = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../..");
            assert_eq!(
                root.canonicalize().ok(),
                parent.join("shared/realdata").canonicalize().ok()
            );
        }
    }
}
