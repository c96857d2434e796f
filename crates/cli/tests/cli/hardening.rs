//! Crash safety of the real binary (SPEC §7 "outputs are atomic"):
//!
//! - `lidarqa simulate` and `lidarqa tpu` killed with SIGKILL in the middle of writing leave every
//!   final-named output either absent, complete, or the previous run's file byte for byte; what
//!   the killed run leaves is only hidden `.NAME.PID.XXXXXX.tmp` files, which the next run of the
//!   same output removes;
//! - a full disk (here a file-size limit, `RLIMIT_FSIZE`, set with `ulimit -f` in a `sh` wrapper
//!   that also ignores SIGXFSZ, so the write fails with EFBIG; no root needed) gives exit code 1
//!   and one line naming the file, and leaves no output and no temporary file;
//! - an output that is also an input is refused by `tpu` (including `--smrmsg`), `correct` and
//!   `simulate`, the input untouched.

#![cfg(unix)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use crate::binary;
use binary::{fails_with, lidarqa, s};

const BIN: &str = env!("CARGO_BIN_EXE_lidarqa");

fn ok(args: &[&str]) {
    binary::run_ok(args);
}

fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

fn temps(dir: &Path) -> Vec<String> {
    names(dir)
        .into_iter()
        .filter(|n| n.starts_with('.') && n.ends_with(".tmp"))
        .collect()
}

/// The demo scenario at 4 kHz instead of 50 kHz: four strips of ~36 000 points, a few seconds
/// even in a debug build.
fn small_scenario(dir: &Path) -> PathBuf {
    let out = lidarqa(&["simulate", "--scenario", "demo", "--print"]);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    let small = text.replacen("pulse_rate_hz = 50000.0", "pulse_rate_hz = 4000.0", 1);
    assert_ne!(small, text, "the demo scenario's pulse rate line moved");
    let path = dir.join("small.toml");
    std::fs::write(&path, small).unwrap();
    path
}

/// The small scenario simulated as LAS into `tmp/survey`: (scenario file, survey directory).
fn small_survey(tmp: &Path) -> (PathBuf, PathBuf) {
    let scenario = small_scenario(tmp);
    let dir = tmp.join("survey");
    ok(&[
        "simulate",
        "--scenario",
        s(&scenario),
        "--format",
        "las",
        "-o",
        s(&dir),
    ]);
    (scenario, dir)
}

/// Polls every millisecond until a hidden temporary file whose name starts with `.{prefix}`
/// has data (the output has begun), then kills the child with SIGKILL. Returns false when the
/// child ended first.
fn kill_when_writing(child: &mut std::process::Child, dir: &Path, prefix: &str) -> bool {
    let start = Instant::now();
    let wanted = format!(".{prefix}");
    while start.elapsed() < Duration::from_secs(600) {
        if let Some(status) = child.try_wait().unwrap() {
            panic!("lidarqa ended ({status}) before writing {prefix}");
        }
        let writing = std::fs::read_dir(dir).unwrap().flatten().any(|e| {
            let name = e.file_name().to_string_lossy().into_owned();
            name.starts_with(&wanted)
                && name.ends_with(".tmp")
                && e.metadata().is_ok_and(|m| m.len() > 0)
        });
        if writing {
            child.kill().unwrap(); // SIGKILL on Unix: no destructor, no cleanup
            child.wait().unwrap();
            return true;
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    false
}

/// A LAS file is complete when its header's point count can be read to the end.
fn las_is_complete(path: &Path) -> bool {
    let Ok(mut r) = lidarqa_las_reader(path) else {
        return false;
    };
    r.read_all()
}

/// A tiny LAS checker that needs no library: header point count × record length + offset is the
/// file length (lidarqa writes no EVLRs), for LAS 1.2–1.4.
struct LasCheck {
    len: u64,
    expected: u64,
}

fn lidarqa_las_reader(path: &Path) -> std::io::Result<LasCheck> {
    let data = std::fs::read(path)?;
    if data.len() < 227 || &data[0..4] != b"LASF" {
        return Err(std::io::Error::other("not LAS"));
    }
    let u32_at = |i: usize| u64::from(u32::from_le_bytes(data[i..i + 4].try_into().unwrap()));
    let offset = u32_at(96);
    let record_len = u64::from(u16::from_le_bytes([data[105], data[106]]));
    let mut count = u32_at(107);
    if data[25] >= 4 && count == 0 && data.len() >= 255 {
        count = u64::from_le_bytes(data[247..255].try_into().unwrap());
    }
    Ok(LasCheck {
        len: data.len() as u64,
        expected: offset + count * record_len,
    })
}

impl LasCheck {
    fn read_all(&mut self) -> bool {
        self.len == self.expected
    }
}

#[test]
fn sigkill_mid_write_leaves_old_or_complete_outputs_and_only_hidden_temps() {
    let tmp = tempfile::tempdir().unwrap();
    let scenario = small_scenario(tmp.path());
    let dir = tmp.path().join("survey");
    let sim = |seed: &str| {
        Command::new(BIN)
            .args(["simulate", "--scenario", s(&scenario), "--format", "las"])
            .args(["--seed", seed, "-o", s(&dir)])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap()
    };

    // 1. A complete survey: the "previous" outputs.
    assert!(sim("1").wait().unwrap().success());
    let before: Vec<(String, Vec<u8>)> = names(&dir)
        .into_iter()
        .map(|n| {
            let bytes = std::fs::read(dir.join(&n)).unwrap();
            (n, bytes)
        })
        .collect();
    assert!(before.iter().any(|(n, _)| n == "strip_004.las"));
    assert!(temps(&dir).is_empty());

    // 2. The same survey with another seed, killed while strip 2 is being written.
    let mut child = sim("2");
    assert!(kill_when_writing(&mut child, &dir, "strip_002.las."));
    let left = temps(&dir);
    assert!(
        left.iter().any(|n| n.starts_with(".strip_002.las.")),
        "the killed run's temporary file: {left:?}"
    );
    for (name, old) in &before {
        let now = std::fs::read(dir.join(name)).unwrap();
        if name.ends_with(".las") {
            // Strip 1 is the new complete one, the others still the old ones: never partial.
            assert!(
                &now == old || las_is_complete(&dir.join(name)),
                "{name} is partial"
            );
            if name == "strip_001.las" {
                assert!(las_is_complete(&dir.join(name)));
            } else if name != "strip_002.las" {
                // (strip 2 may have been renamed in the microseconds before the kill)
                assert_eq!(&now, old, "{name} changed although it was never written");
            }
        } else {
            assert_eq!(&now, old, "{name} changed: written after strip 2");
        }
    }

    // 3. `lidarqa tpu` killed mid-write keeps the previous output byte for byte.
    let strip = dir.join("strip_001.las");
    let out_dir = tmp.path().join("tpu");
    std::fs::create_dir(&out_dir).unwrap();
    let output = out_dir.join("tpu.las");
    let previous = b"previous output, not LAS".to_vec();
    std::fs::write(&output, &previous).unwrap();
    let mut child = Command::new(BIN)
        .args(["tpu", s(&strip), "--trajectory", s(&dir.join("sbet.out"))])
        .args(["--sensor", s(&dir.join("sensor.toml")), "-o", s(&output)])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    assert!(kill_when_writing(&mut child, &out_dir, "tpu.las."));
    let now = std::fs::read(&output).unwrap();
    assert!(
        now == previous || las_is_complete(&output),
        "tpu.las is partial"
    );
    assert!(temps(&out_dir).len() <= 1, "{:?}", names(&out_dir));

    // 4. The next complete runs remove the dead runs' temporary files and write everything.
    assert!(sim("3").wait().unwrap().success());
    assert!(temps(&dir).is_empty(), "{:?}", names(&dir));
    for n in [
        "strip_001.las",
        "strip_002.las",
        "strip_003.las",
        "strip_004.las",
    ] {
        assert!(las_is_complete(&dir.join(n)), "{n}");
    }
    ok(&[
        "tpu",
        s(&strip),
        "--trajectory",
        s(&dir.join("sbet.out")),
        "--sensor",
        s(&dir.join("sensor.toml")),
        "-o",
        s(&output),
    ]);
    assert!(temps(&out_dir).is_empty(), "{:?}", names(&out_dir));
    assert!(las_is_complete(&output));
}

/// Runs `lidarqa ARGS` with a file-size limit of `blocks` × 512 bytes and SIGXFSZ ignored (the
/// disposition survives `exec`), so writing past the limit fails with EFBIG like a full disk.
fn lidarqa_with_file_limit(blocks: u32, args: &[&str]) -> Output {
    Command::new("sh")
        .arg("-c")
        .arg(format!(
            "trap '' XFSZ; ulimit -f {blocks} || exit 99; exec \"$0\" \"$@\""
        ))
        .arg(BIN)
        .args(args)
        .output()
        .expect("sh runs")
}

#[test]
fn full_disk_gives_one_line_and_no_output() {
    let tmp = tempfile::tempdir().unwrap();
    let (scenario, dir) = small_survey(tmp.path());
    let strip = dir.join("strip_001.las");
    assert!(std::fs::metadata(&strip).unwrap().len() > 400 * 512);

    // tpu: the output (~1.3 MB) cannot be written within 200 KB.
    let out_dir = tmp.path().join("out");
    std::fs::create_dir(&out_dir).unwrap();
    for name in ["tpu.las", "tpu.laz"] {
        let output = out_dir.join(name);
        let out = lidarqa_with_file_limit(
            if name.ends_with(".laz") { 20 } else { 400 },
            &[
                "tpu",
                s(&strip),
                "--trajectory",
                s(&dir.join("sbet.out")),
                "--sensor",
                s(&dir.join("sensor.toml")),
                "-o",
                s(&output),
            ],
        );
        assert_ne!(out.status.code(), Some(99), "ulimit -f refused");
        let err = fails_with(&out, &[name]);
        assert!(
            err.contains("File too large") || err.contains("No space left"),
            "{err}"
        );
        assert!(names(&out_dir).is_empty(), "{:?}", names(&out_dir));
    }

    // simulate: the strips (~1.2 MB each) cannot be written within 200 KB; the previous
    // survey in `dir` stays as it was.
    let before = std::fs::read(&strip).unwrap();
    let out = lidarqa_with_file_limit(
        400,
        &[
            "simulate",
            "--scenario",
            s(&scenario),
            "--format",
            "las",
            "--seed",
            "9",
            "-o",
            s(&dir),
        ],
    );
    fails_with(&out, &["strip_001.las"]);
    assert_eq!(std::fs::read(&strip).unwrap(), before);
    assert!(temps(&dir).is_empty(), "{:?}", names(&dir));
}

#[test]
fn an_input_that_is_also_an_output_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let (scenario, dir) = small_survey(tmp.path());
    let strip = dir.join("strip_001.las");
    let sbet = dir.join("sbet.out");
    let smrmsg = dir.join("smrmsg.out");
    let sensor = dir.join("sensor.toml");
    let snapshot = |p: &Path| std::fs::read(p).unwrap();
    let (strip0, sbet0, smrmsg0, sensor0) = (
        snapshot(&strip),
        snapshot(&sbet),
        snapshot(&smrmsg),
        snapshot(&sensor),
    );

    // tpu: the output is the strip, the trajectory, the SMRMSG or the sensor file.
    for (output, name) in [
        (&strip, "strip_001.las"),
        (&sbet, "sbet.out"),
        (&smrmsg, "smrmsg.out"),
        (&sensor, "sensor.toml"),
    ] {
        let out = lidarqa(&[
            "tpu",
            s(&strip),
            "--trajectory",
            s(&sbet),
            "--smrmsg",
            s(&smrmsg),
            "--sensor",
            s(&sensor),
            "-o",
            s(output),
        ]);
        fails_with(&out, &[name]);
    }
    // Another spelling of the same file.
    let other = dir.join("..").join("survey").join("strip_001.las");
    let out = lidarqa(&[
        "tpu",
        s(&strip),
        "--trajectory",
        s(&sbet),
        "--sensor",
        s(&sensor),
        "-o",
        s(&other),
    ]);
    fails_with(&out, &["strip_001.las"]);

    // correct: -o is the strips' own directory.
    let cal = tmp.path().join("calibration.json");
    std::fs::write(
        &cal,
        r#"{"parameters": {"lever_x_m": 0, "lever_y_m": 0, "lever_z_m": 0,
            "boresight_roll_deg": 0, "boresight_pitch_deg": 0, "boresight_yaw_deg": 0}}"#,
    )
    .unwrap();
    let out = lidarqa(&[
        "correct",
        s(&strip),
        "--trajectory",
        s(&sbet),
        "--sensor",
        s(&sensor),
        "--calibration",
        s(&cal),
        "-o",
        s(&dir),
    ]);
    fails_with(&out, &["strip_001.las"]);

    // simulate: the scenario file sits in the output directory under an output's name.
    let in_place = dir.join("sensor.toml");
    std::fs::copy(&scenario, &in_place).unwrap();
    let scenario_text = snapshot(&in_place);
    let out = lidarqa(&[
        "simulate",
        "--scenario",
        s(&in_place),
        "--format",
        "las",
        "-o",
        s(&dir),
    ]);
    fails_with(&out, &["sensor.toml"]);
    assert_eq!(snapshot(&in_place), scenario_text);
    std::fs::write(&sensor, &sensor0).unwrap();

    assert_eq!(snapshot(&strip), strip0);
    assert_eq!(snapshot(&sbet), sbet0);
    assert_eq!(snapshot(&smrmsg), smrmsg0);
    assert_eq!(snapshot(&sensor), sensor0);
    assert!(temps(&dir).is_empty(), "{:?}", names(&dir));
}
