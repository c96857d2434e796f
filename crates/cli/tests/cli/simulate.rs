//! `lidarqa simulate` as the real binary: the same seed gives byte-identical files whatever the
//! thread count, and independent readers (laspy + lazrs for the strips, numpy for the SBET and
//! SMRMSG records, `tests/simulate_check.py`) read every output and agree with `truth.json`. The
//! Python half runs when `LIDARQA_PYTHON` names an interpreter with laspy, lazrs and numpy.

use std::path::{Path, PathBuf};
use std::process::Command;

/// The demo scenario cut to short lines (fast in the test profile), as a scenario file.
fn small_scenario(dir: &Path) -> PathBuf {
    let out = Command::new(env!("CARGO_BIN_EXE_lidarqa"))
        .args(["simulate", "--scenario", "demo", "--print"])
        .output()
        .unwrap();
    assert!(out.status.success());
    let mut doc: toml::Table = toml::from_str(&String::from_utf8(out.stdout).unwrap()).unwrap();
    let lines = doc["lines"].as_array_mut().unwrap();
    for line in lines.iter_mut() {
        let t = line.as_table_mut().unwrap();
        for key in ["start_m", "end_m"] {
            let p = t[key].as_array_mut().unwrap();
            for v in p.iter_mut() {
                let x = v.as_float().unwrap();
                *v = toml::Value::Float(x.clamp(-60.0, 60.0));
            }
        }
    }
    doc["scanner"].as_table_mut().unwrap()["pulse_rate_hz"] = toml::Value::Float(20_000.0);
    // Keep only the targets whose plates the short lines still cover.
    let targets = doc["scene"]["targets"].as_array().unwrap().clone();
    doc["scene"].as_table_mut().unwrap()["targets"] = toml::Value::Array(
        targets
            .into_iter()
            .filter(|t| {
                let c = t["center_m"].as_array().unwrap();
                c.iter().all(|v| v.as_float().unwrap().abs() < 70.0)
            })
            .collect(),
    );
    let path = dir.join("small.toml");
    std::fs::write(&path, toml::to_string(&doc).unwrap()).unwrap();
    path
}

fn simulate(scenario: &Path, out: &Path, threads: &str) {
    let o = Command::new(env!("CARGO_BIN_EXE_lidarqa"))
        .env("RAYON_NUM_THREADS", threads)
        .args(["simulate", "--scenario"])
        .arg(scenario)
        .arg("-o")
        .arg(out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

fn files(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    names
}

#[test]
fn same_seed_byte_identical_files_read_by_laspy_and_numpy() {
    let tmp = tempfile::tempdir().unwrap();
    let scenario = small_scenario(tmp.path());
    let (one, two) = (tmp.path().join("one"), tmp.path().join("two"));
    simulate(&scenario, &one, "1");
    simulate(&scenario, &two, "2");
    let names = files(&one);
    assert_eq!(names, files(&two));
    for must in [
        "control.csv",
        "sbet.out",
        "sensor.toml",
        "smrmsg.out",
        "strip_001.laz",
        "strip_004.laz",
        "truth.json",
    ] {
        assert!(names.iter().any(|n| n == must), "{must} missing: {names:?}");
    }
    for name in &names {
        let (a, b) = (
            std::fs::read(one.join(name)).unwrap(),
            std::fs::read(two.join(name)).unwrap(),
        );
        assert!(!a.is_empty(), "{name} is empty");
        assert!(a == b, "{name} differs between 1 and 2 threads");
    }
    // The truth is lidarqa-products' document with the simulator's scene, field for field.
    crate::assert_round_trips::<lidarqa_products::TruthDocument<lidarqa_sim::SceneFile>>(
        &one.join("truth.json"),
    );

    let Some(python) = lidarqa_testkit::python("the laspy / numpy read of the simulator's outputs")
    else {
        return;
    };
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/simulate_check.py");
    let o = Command::new(python).arg(script).arg(&one).output().unwrap();
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(stdout.contains(" passed, 0 failed"), "{stdout}");
}
