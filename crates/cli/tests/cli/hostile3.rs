//! Hostile input, round two (continued): the output guard of every command that writes, `tpu`'s
//! plausibility checks in `correct` and `calibrate`, hand-edited calibration values, GPS weeks,
//! the scan-angle check, and the messages that now name the cause. Each case runs the real
//! binary on inputs made here; after every refusal the inputs and the files around them are
//! byte-identical (BLAKE3 of every file under the test's directory).
//!
//! One small survey (the demo scenario's first two lines at 2 kHz: two strips of ~18 000
//! points, 100 m above ground) is simulated once and copied into each test's own directory.

use crate::binary;

use binary::{fails_with, lidarqa, s, snapshot};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// The shared simulated survey (read-only; tests copy what they use).
fn survey() -> &'static Path {
    static SURVEY: OnceLock<tempfile::TempDir> = OnceLock::new();
    SURVEY
        .get_or_init(|| {
            let dir = tempfile::tempdir().unwrap();
            let text = binary::stdout_ok(&["simulate", "--scenario", "demo", "--print"]);
            let mut demo: toml::Table = toml::from_str(&text).unwrap();
            demo["scanner"]
                .as_table_mut()
                .unwrap()
                .insert("pulse_rate_hz".into(), toml::Value::Float(2_000.0));
            demo["lines"]
                .as_array_mut()
                .unwrap()
                .retain(|l| l["id"].as_integer().unwrap() <= 2);
            let toml = dir.path().join("small.toml");
            std::fs::write(&toml, toml::to_string(&demo).unwrap()).unwrap();
            let sim = dir.path().join("sim");
            binary::run_ok(&[
                "simulate",
                "--scenario",
                s(&toml),
                "--format",
                "las",
                "-o",
                s(&sim),
            ]);
            dir
        })
        .path()
}

/// A test directory with copies of the survey's `files` (strip_001.las, sbet.out, …).
fn workspace(files: &[&str]) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    for f in files {
        std::fs::copy(survey().join("sim").join(f), dir.path().join(f)).unwrap();
    }
    dir
}

/// Every entry (files and directories) under `dir`, to see that nothing was created.
fn entries(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let e = e.unwrap();
            if e.file_type().unwrap().is_dir() {
                stack.push(e.path());
            }
            out.push(e.path());
        }
    }
    out.sort();
    out
}

/// `lidarqa ARGS` refused with every needle, and nothing under `dir` changed or created.
fn refused_untouched(dir: &Path, args: &[&str], needles: &[&str]) -> String {
    let (before, names) = (snapshot(dir), entries(dir));
    let err = fails_with(&lidarqa(args), needles);
    assert_eq!(snapshot(dir), before, "lidarqa {args:?} changed files");
    assert_eq!(entries(dir), names, "lidarqa {args:?} created files");
    err
}

fn leak(p: PathBuf) -> &'static str {
    Box::leak(p.to_str().unwrap().to_owned().into_boxed_str())
}

/// Bad cases 1 and 2, every command family: an output equal to an input (or to another output)
/// is refused before any work. The inputs here are not LAS, SBET or TOML at all: a command that
/// read any of them first would fail on its content, so the guard's message proves it ran first.
#[test]
fn every_command_refuses_an_output_onto_an_input_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let j = |name: &str| leak(d.join(name));
    let tiles = d.join("tiles");
    std::fs::create_dir(&tiles).unwrap();
    for f in [
        "a.las",
        "b.las",
        "sbet.out",
        "sensor.toml",
        "control.csv",
        "ties.csv",
    ] {
        std::fs::write(d.join(f), format!("not really {f}\n")).unwrap();
    }
    std::fs::write(tiles.join("t.las"), "not a LAS\n").unwrap();
    let input = "refusing to overwrite the input file";
    let twice = "by this run; one output would overwrite the other";
    let shared = ["--trajectory", j("sbet.out"), "--sensor", j("sensor.toml")];
    let with = |head: &[&'static str], tail: &[&'static str]| -> Vec<&'static str> {
        let mut v = head.to_vec();
        v.extend(shared);
        v.extend(tail);
        v
    };
    let cases: Vec<(Vec<&str>, &str)> = vec![
        // tpu: -o onto the input, the summary onto an input or onto -o.
        (with(&["tpu", j("a.las")], &["-o", j("a.las")]), input),
        (
            with(
                &["tpu", j("a.las")],
                &["-o", j("x.las"), "--summary", j("sensor.toml")],
            ),
            input,
        ),
        (
            with(
                &["tpu", j("a.las")],
                &["-o", j("x.las"), "--summary", j("x.las")],
            ),
            twice,
        ),
        // correct: DIR/<strip's name> is the strip itself.
        (
            with(
                &["correct", j("a.las")],
                &["--calibration", j("ties.csv"), "-o", leak(d.to_path_buf())],
            ),
            input,
        ),
        // calibrate: -o onto the sensor file or a strip.
        (
            with(
                &["calibrate", j("a.las"), j("b.las")],
                &["--ties", j("ties.csv"), "-o", j("sensor.toml")],
            ),
            input,
        ),
        (
            with(
                &["calibrate", j("a.las"), j("b.las")],
                &["--auto-ties", "-o", j("b.las")],
            ),
            input,
        ),
        // overlap, targets, trajectory.
        (
            vec!["overlap", j("a.las"), j("b.las"), "-o", j("b.las")],
            input,
        ),
        (
            vec![
                "targets",
                j("a.las"),
                "--control",
                j("control.csv"),
                "-o",
                j("control.csv"),
            ],
            input,
        ),
        (vec!["trajectory", j("a.las"), "-o", j("a.las")], input),
        (
            vec![
                "trajectory",
                j("a.las"),
                "-o",
                j("t.csv"),
                "--sbet",
                j("a.las"),
            ],
            input,
        ),
        // qc: the output directory onto a delivery file, qc.json onto the control CSV.
        (vec!["qc", j("a.las"), "-o", j("a.las")], input),
        // plan: the manifest onto the sensor file.
        (
            vec![
                "plan",
                "tpu",
                "--tiles",
                leak(tiles.clone()),
                "--trajectory",
                j("sbet.out"),
                "--sensor",
                j("sensor.toml"),
                "-o",
                j("sensor.toml"),
            ],
            input,
        ),
    ];
    for (args, needle) in &cases {
        refused_untouched(d, args, &[needle]);
    }
    // tpu on Optech CSD records (the public sample, read in place): the summary onto the
    // sensor file or onto -o.
    if let Some(csd) = lidarqa_testkit::realdata("optech_csd_pdal") {
        let csd = leak(csd.join("sample.csd"));
        for (summary, needle) in [(j("sensor.toml"), input), (j("x.las"), twice)] {
            refused_untouched(
                d,
                &[
                    "tpu",
                    csd,
                    "--sensor",
                    j("sensor.toml"),
                    "--epsg",
                    "32617",
                    "-o",
                    j("x.las"),
                    "--summary",
                    summary,
                ],
                &[needle],
            );
        }
    }
    // qc.json of the output directory onto the control CSV (named so).
    let out = d.join("qcdir");
    std::fs::create_dir(&out).unwrap();
    std::fs::write(out.join("qc.json"), "control\n").unwrap();
    refused_untouched(
        d,
        &[
            "qc",
            j("a.las"),
            "--control",
            leak(out.join("qc.json")),
            "-o",
            leak(out),
        ],
        &[input],
    );
    // simulate: a scenario file kept in the output directory under an output's name.
    let sim = d.join("sim");
    std::fs::create_dir(&sim).unwrap();
    let scenario = binary::stdout_ok(&["simulate", "--scenario", "demo", "--print"]);
    std::fs::write(sim.join("sensor.toml"), scenario).unwrap();
    refused_untouched(
        d,
        &[
            "simulate",
            "--scenario",
            leak(sim.join("sensor.toml")),
            "-o",
            leak(sim),
        ],
        &[input],
    );
}

/// A new X, Y, Z for record k at X, Y, Z.
type Edit = dyn Fn(usize, [f64; 3]) -> [f64; 3];

/// Edits every record's X, Y, Z of a LAS file in place (the header's scale; format 6 records).
fn edit_xyz(strip: &Path, mut f: impl FnMut(usize, [f64; 3]) -> [f64; 3]) {
    let mut bytes = std::fs::read(strip).unwrap();
    let offset = u32::from_le_bytes(bytes[96..100].try_into().unwrap()) as usize;
    let len = u16::from_le_bytes(bytes[105..107].try_into().unwrap()) as usize;
    let double = |at: usize| f64::from_le_bytes(bytes[at..at + 8].try_into().unwrap());
    let scale = [double(131), double(139), double(147)];
    let off = [double(155), double(163), double(171)];
    let count = (bytes.len() - offset) / len;
    for k in 0..count {
        let at = offset + k * len;
        let raw: [f64; 3] = std::array::from_fn(|i| {
            i32::from_le_bytes(bytes[at + 4 * i..at + 4 * i + 4].try_into().unwrap()) as f64
        });
        let new = f(k, std::array::from_fn(|i| raw[i] * scale[i] + off[i]));
        for i in 0..3 {
            let v = ((new[i] - off[i]) / scale[i]).round() as i32;
            bytes[at + 4 * i..at + 4 * i + 4].copy_from_slice(&v.to_le_bytes());
        }
    }
    std::fs::write(strip, bytes).unwrap();
}

/// A calibration.json with these parameters, each estimated (σ given) unless named in `held`.
fn calibration(path: &Path, lever_x: f64, yaw_deg: f64, held: &[&str]) {
    let keys = [
        "lever_x_m",
        "lever_y_m",
        "lever_z_m",
        "boresight_roll_deg",
        "boresight_pitch_deg",
        "boresight_yaw_deg",
    ];
    let sigma: serde_json::Map<String, serde_json::Value> = keys
        .iter()
        .map(|k| {
            let v = if held.contains(k) {
                serde_json::Value::Null
            } else {
                serde_json::json!(0.01)
            };
            (k.to_string(), v)
        })
        .collect();
    let doc = serde_json::json!({
        "parameters": {"lever_x_m": lever_x, "lever_y_m": 0.0, "lever_z_m": 0.0,
            "boresight_roll_deg": 0.0, "boresight_pitch_deg": 0.0, "boresight_yaw_deg": yaw_deg},
        "sigma": sigma,
    });
    std::fs::write(path, serde_json::to_string_pretty(&doc).unwrap()).unwrap();
}

/// Bad case 4: `correct` moved every point in silence when the points did not fit the mounting
/// they were made with (shifted 300 m, all at one XYZ, 1 000 m high), where `tpu` warns. Now
/// refused before the output is committed, naming the misfit; good points are corrected.
#[test]
fn correct_refuses_points_that_do_not_fit_their_mounting() {
    let w = workspace(&["strip_001.las", "sbet.out", "sensor.toml"]);
    let d = w.path();
    let cal = d.join("calibration.json");
    calibration(&cal, 0.05, 0.01, &["lever_z_m"]);
    let args = |strip: &Path, out: &Path| -> Vec<&'static str> {
        binary::with_calibration(
            "correct",
            strip,
            [&d.join("sbet.out"), &d.join("sensor.toml"), &cal],
            out,
        )
        .into_iter()
        .map(|a| leak(PathBuf::from(a)))
        .collect()
    };
    // The good strip is corrected, without a warning.
    let good = binary::run_ok(&args(&d.join("strip_001.las"), &d.join("good")));
    let err = String::from_utf8_lossy(&good.stderr);
    assert!(!err.contains("warning"), "{err}");
    assert!(d.join("good/strip_001.las").exists());
    let bad: [(&str, Box<Edit>); 3] = [
        ("east300", Box::new(|_, [x, y, z]| [x + 300.0, y, z])),
        ("onexyz", Box::new(|_, _| [640_010.0, 2_800_010.0, 5.0])),
        ("high1000", Box::new(|_, [x, y, z]| [x, y, z + 1000.0])),
    ];
    for (name, f) in bad {
        let strip = d.join(format!("{name}.las"));
        std::fs::copy(d.join("strip_001.las"), &strip).unwrap();
        edit_xyz(&strip, f);
        let out = d.join(format!("out_{name}"));
        refused_untouched(
            d,
            &args(&strip, &out),
            &[
                &format!("{name}.las"),
                "off the scan plane",
                "does not fit the data",
                "correcting would move every point",
            ],
        );
        assert!(!out.exists(), "{name}: the output directory was created");
    }
}

/// Bad case 4: a hand-edited calibration boresight of 5° whose σ is null (held: not
/// estimated) moved the points by metres, unchecked. Refused by `correct` and
/// `tpu --calibration`, naming the key and both values.
#[test]
fn a_held_calibration_value_edited_by_hand_is_refused() {
    let w = workspace(&["strip_001.las", "sbet.out", "sensor.toml"]);
    let d = w.path();
    let cal = d.join("calibration.json");
    calibration(&cal, 0.05, 5.0, &["boresight_yaw_deg"]);
    for command in ["correct", "tpu"] {
        let out = d.join(if command == "tpu" { "out.las" } else { "out" });
        refused_untouched(
            d,
            &binary::with_calibration(
                command,
                &d.join("strip_001.las"),
                [&d.join("sbet.out"), &d.join("sensor.toml"), &cal],
                &out,
            ),
            &[
                "parameters.boresight_yaw_deg is 5",
                "sigma.boresight_yaw_deg is null",
                "the sensor file's value 0",
            ],
        );
    }
}

/// Rewrites an SBET's heights (f64 at byte 24 of each 136-byte record) by `dz`.
fn shift_sbet_height(path: &Path, dz: f64) {
    let mut bytes = std::fs::read(path).unwrap();
    for rec in bytes.chunks_exact_mut(136) {
        let h = f64::from_le_bytes(rec[24..32].try_into().unwrap()) + dz;
        rec[24..32].copy_from_slice(&h.to_le_bytes());
    }
    std::fs::write(path, bytes).unwrap();
}

/// Bad case 5: `calibrate` with a trajectory 200 m too low wrote a lever arm as "determined".
/// Now it runs `tpu`'s recovery checks on every strip first and refuses, naming the height
/// mismatch; the same with 200 m too high.
#[test]
fn calibrate_refuses_a_trajectory_200_m_off_naming_the_height() {
    let w = workspace(&["strip_001.las", "strip_002.las", "sbet.out", "sensor.toml"]);
    let d = w.path();
    for (dz, needle) in [
        (-200.0, "the trajectory 200.0 m too low"),
        (200.0, "the trajectory 200.0 m too high"),
    ] {
        let sbet = d.join(format!("sbet{dz}.out"));
        std::fs::copy(d.join("sbet.out"), &sbet).unwrap();
        shift_sbet_height(&sbet, dz);
        refused_untouched(
            d,
            &[
                "calibrate",
                leak(d.join("strip_001.las")),
                leak(d.join("strip_002.las")),
                "--trajectory",
                leak(sbet),
                "--sensor",
                leak(d.join("sensor.toml")),
                "--auto-ties",
                "-o",
                leak(d.join("cal/calibration.json")),
            ],
            &[
                "strip_001.las",
                "does not fit the data",
                needle,
                "a calibration from it",
            ],
        );
    }
}

/// Bad case 5: a text trajectory from the week before the points' week was used even with
/// `--gps-week` given. Now refused naming both weeks.
#[test]
fn a_text_trajectory_of_another_gps_week_is_refused() {
    let w = workspace(&["strip_001.las", "sbet.out", "sensor.toml"]);
    let d = w.path();
    // The SBET as a text trajectory in adjusted standard GPS time of week 2199 (the survey
    // flew in week 2200).
    let bytes = std::fs::read(d.join("sbet.out")).unwrap();
    let mut text = String::from("time,latitude,longitude,height,roll,pitch,heading\n");
    for rec in bytes.chunks_exact(136) {
        let v: Vec<f64> = rec
            .chunks_exact(8)
            .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
            .collect();
        let adjusted = 2199.0 * 604_800.0 + v[0] - 1e9;
        text += &format!(
            "{adjusted:.6},{:.10},{:.10},{:.4},{:.6},{:.6},{:.6}\n",
            v[1].to_degrees(),
            v[2].to_degrees(),
            v[3],
            v[7].to_degrees(),
            v[8].to_degrees(),
            v[9].to_degrees()
        );
    }
    let traj = d.join("trajectory.csv");
    std::fs::write(&traj, text).unwrap();
    let args = [
        "tpu",
        leak(d.join("strip_001.las")),
        "--trajectory",
        leak(traj),
        "--sensor",
        leak(d.join("sensor.toml")),
        "--gps-week",
        "2200",
        "-o",
        leak(d.join("out.las")),
    ];
    refused_untouched(
        d,
        &args,
        &[
            "trajectory.csv",
            "GPS week 2199",
            "--gps-week gives week 2200",
        ],
    );
    // Without --gps-week: the points' adjusted standard GPS times carry their week too.
    let mut args = args.to_vec();
    args.drain(6..8);
    refused_untouched(
        d,
        &args,
        &[
            "strip_001.las",
            "GPS week 2200",
            "not in week 2199",
            "the trajectory's",
        ],
    );
}

/// Bad case 6: `tpu`'s scan-angle check said nothing of a 160–180° disagreement when the
/// sensor file's angle σ were large enough (a unit slip) to explain anything. The bound is now
/// capped: the warning is in the JSON and on stderr.
#[test]
fn tpu_warns_of_a_scan_angle_disagreement_whatever_the_sigma() {
    let w = workspace(&["strip_001.las", "sbet.out", "sensor.toml"]);
    let d = w.path();
    let strip = d.join("high.las");
    std::fs::copy(d.join("strip_001.las"), &strip).unwrap();
    edit_xyz(&strip, |_, [x, y, z]| [x, y, z + 1000.0]);
    let text = std::fs::read_to_string(d.join("sensor.toml")).unwrap();
    let loose: String = text
        .lines()
        .map(|l| {
            if l.starts_with("scan_angle_deg") {
                "scan_angle_deg = 40.0".to_string()
            } else {
                l.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    assert_ne!(loose, text, "the sensor file's scan_angle_deg line moved");
    let sensor = d.join("loose.toml");
    std::fs::write(&sensor, loose + "\n").unwrap();
    let out = lidarqa(&[
        "tpu",
        s(&strip),
        "--trajectory",
        s(&d.join("sbet.out")),
        "--sensor",
        s(&sensor),
        "-o",
        s(&d.join("out.las")),
        "--format",
        "json",
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let rms = v["scan_angle_check"]["rms_deg"].as_f64().unwrap();
    assert!(rms > 150.0, "{rms}");
    let codes: Vec<&str> = v["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|w| w["code"].as_str().unwrap())
        .collect();
    assert!(codes.contains(&"scan_angle_disagrees"), "{codes:?}");
    assert!(err.contains("(scan_angle_disagrees)"), "{err}");
}

/// A weak case: `trajectory` blamed the LAS for a flag's error (and printed a Rust debug
/// struct). Now the flag is named, before any file is read.
#[test]
fn trajectory_names_the_flag_not_the_las() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("a.las"), "not a LAS\n").unwrap();
    for (flag, value) in [
        ("--block-s", "0"),
        ("--min-lines", "3"),
        ("--window-s", "-1"),
    ] {
        let err = refused_untouched(
            d,
            &[
                "trajectory",
                leak(d.join("a.las")),
                "-o",
                leak(d.join("t.csv")),
                leak(PathBuf::from(format!("{flag}={value}"))),
            ],
            &[flag, value],
        );
        assert!(!err.contains("a.las"), "{err}");
    }
}

/// The good data the speed check once refused: the cBLUE side-by-side scenario (a 10 kHz
/// trajectory with independent per-pulse noise) and every built-in scenario, shortened to a
/// few seconds of flight at a low pulse rate. `plan tpu` reads and checks the trajectory and the
/// sensor file up front without the points, so each costs the simulation only.
#[test]
fn the_trajectory_checks_accept_every_simulated_trajectory() {
    let dir = tempfile::tempdir().unwrap();
    let cblue = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/cblue/scenario.toml"),
    )
    .unwrap();
    let mut scenarios = vec![("cblue".to_string(), cblue)];
    for name in ["demo", "calibration", "forest", "bathymetry"] {
        scenarios.push((
            name.to_string(),
            binary::stdout_ok(&["simulate", "--scenario", name, "--print"]),
        ));
    }
    for (name, text) in scenarios {
        let mut t: toml::Table = toml::from_str(&text).unwrap();
        let scanner = t["scanner"].as_table_mut().unwrap();
        scanner.insert("pulse_rate_hz".into(), toml::Value::Float(200.0));
        // The first line only, shortened to 600 m of flight.
        let lines = t["lines"].as_array_mut().unwrap();
        lines.truncate(1);
        let line = lines[0].as_table_mut().unwrap();
        let f = |v: &toml::Value| v.as_float().unwrap();
        let (a, b) = (
            line["start_m"].as_array().unwrap().clone(),
            line["end_m"].as_array().unwrap().clone(),
        );
        let (ax, ay, bx, by) = (f(&a[0]), f(&a[1]), f(&b[0]), f(&b[1]));
        let len = (bx - ax).hypot(by - ay);
        let k = (600.0 / len).min(1.0);
        line.insert(
            "end_m".into(),
            toml::Value::Array(vec![
                toml::Value::Float(ax + k * (bx - ax)),
                toml::Value::Float(ay + k * (by - ay)),
            ]),
        );
        let sub = dir.path().join(&name);
        std::fs::create_dir(&sub).unwrap();
        let sim = binary::simulate_scenario(&sub, &toml::to_string(&t).unwrap());
        let tiles = sub.join("tiles");
        std::fs::create_dir(&tiles).unwrap();
        let strip = std::fs::read_dir(&sim)
            .unwrap()
            .map(|e| e.unwrap().path())
            .find(|p| p.extension().is_some_and(|e| e == "laz" || e == "las"))
            .unwrap();
        std::fs::rename(&strip, tiles.join(strip.file_name().unwrap())).unwrap();
        let out = binary::run_ok(&[
            "plan",
            "tpu",
            "--tiles",
            s(&tiles),
            "--trajectory",
            s(&sim.join("sbet.out")),
            "--smrmsg",
            s(&sim.join("smrmsg.out")),
            "--sensor",
            s(&sim.join("sensor.toml")),
            "-o",
            s(&sub.join("manifest.json")),
        ]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!err.contains("would move"), "{name}: {err}");
    }
}

/// A weak case: `collect` merged the reports of tiles or a sensor file changed since the plan.
/// Now it compares them with the digests the plan recorded and refuses, naming the file.
#[test]
fn collect_refuses_inputs_changed_since_the_plan() {
    let w = workspace(&["strip_001.las", "sbet.out", "sensor.toml"]);
    let d = w.path();
    let tiles = d.join("tiles");
    std::fs::create_dir(&tiles).unwrap();
    std::fs::rename(d.join("strip_001.las"), tiles.join("t1.las")).unwrap();
    let manifest = d.join("manifest.json");
    binary::run_ok(&[
        "plan",
        "tpu",
        "--tiles",
        s(&tiles),
        "--trajectory",
        s(&d.join("sbet.out")),
        "--sensor",
        s(&d.join("sensor.toml")),
        "-o",
        s(&manifest),
    ]);
    binary::run_ok(&["run", s(&manifest), "--index", "0"]);
    binary::run_ok(&["collect", s(&manifest)]);
    // The sensor file edited after the run.
    let sensor = d.join("sensor.toml");
    let original = std::fs::read(&sensor).unwrap();
    let mut edited = original.clone();
    edited.extend_from_slice(b"# edited after the plan\n");
    std::fs::write(&sensor, &edited).unwrap();
    refused_untouched(
        d,
        &[
            "collect",
            s(&manifest),
            "--summary",
            s(&d.join("summary.json")),
        ],
        &[
            "sensor.toml",
            "changed since the manifest",
            "run lidarqa plan again",
        ],
    );
    std::fs::write(&sensor, &original).unwrap();
    // A tile rewritten after the run (one byte of its last record).
    let tile = tiles.join("t1.las");
    let mut bytes = std::fs::read(&tile).unwrap();
    let last = bytes.len() - 1;
    bytes[last] ^= 1;
    std::fs::write(&tile, bytes).unwrap();
    refused_untouched(
        d,
        &[
            "collect",
            s(&manifest),
            "--summary",
            s(&d.join("summary.json")),
        ],
        &["t1.las", "changed since the manifest", "not complete"],
    );
}

/// A weak case: `targets` over several files ended the whole run when one file's bright points
/// were no target, and said "none within 2 m (nearest is 0.456 m)". Now that file is skipped
/// with a warning when another resolves the targets, and alone it is told as it is: a cluster
/// near a control point whose plate of the given radius does not fit.
#[test]
fn targets_skips_a_file_that_sees_no_target_and_says_why() {
    let w = workspace(&["strip_001.las", "control.csv"]);
    let d = w.path();
    let sparse = d.join("strip_001.las");
    let control = d.join("control.csv");
    // Alone (2 kHz: too few points on a 0.8 m target for its plate).
    let err = refused_untouched(
        d,
        &[
            "targets",
            s(&sparse),
            "--control",
            s(&control),
            "-o",
            s(&d.join("t.csv")),
        ],
        &[
            "strip_001.las",
            "a high-intensity cluster lies",
            "no plate of its radius 0.8 m",
        ],
    );
    assert!(!err.contains("none of the"), "{err}");
    // With a dense strip of the same line (10 kHz), which resolves the targets.
    let text = binary::stdout_ok(&["simulate", "--scenario", "demo", "--print"]);
    let mut demo: toml::Table = toml::from_str(&text).unwrap();
    demo["scanner"]
        .as_table_mut()
        .unwrap()
        .insert("pulse_rate_hz".into(), toml::Value::Float(10_000.0));
    demo["lines"]
        .as_array_mut()
        .unwrap()
        .retain(|l| l["id"].as_integer().unwrap() == 1);
    let sub = d.join("dense");
    std::fs::create_dir(&sub).unwrap();
    let sim = binary::simulate_scenario(&sub, &toml::to_string(&demo).unwrap());
    let dense = sim.join("strip_001.laz");
    let out = lidarqa(&[
        "targets",
        s(&sparse),
        s(&dense),
        "--control",
        s(&control),
        "-o",
        s(&d.join("t.csv")),
        "--format",
        "json",
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(!v["targets"].as_array().unwrap().is_empty(), "{v}");
    let skipped: Vec<&str> = v["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|w| w["code"] == "targets_file_skipped")
        .map(|w| w["message"].as_str().unwrap())
        .collect();
    assert!(
        skipped
            .iter()
            .any(|m| m.contains(s(&sparse)) && m.contains("no plate")),
        "{skipped:?}"
    );
    assert!(err.contains("(targets_file_skipped)"), "{err}");
}

/// A weak case: a `simulate` re-run that failed (or was killed) while it renamed its files into
/// place left old and new files mixed under their final names, with nothing to tell. Now the
/// directory holds `lidarqa-incomplete.txt` from the first rename to the last.
#[test]
fn a_simulate_rerun_that_fails_while_renaming_marks_the_directory_incomplete() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sim");
    let scenario = survey().join("small.toml");
    let sim = |seed: &str| {
        lidarqa(&[
            "simulate",
            "--scenario",
            s(&scenario),
            "--seed",
            seed,
            "--format",
            "las",
            "-o",
            s(&out),
        ])
    };
    assert!(sim("1").status.success());
    let marker = out.join("lidarqa-incomplete.txt");
    assert!(!marker.exists());
    // truth.json replaced by a directory: the re-run fails after the strips are renamed.
    std::fs::remove_file(out.join("truth.json")).unwrap();
    std::fs::create_dir(out.join("truth.json")).unwrap();
    let old_strip = std::fs::read(out.join("strip_001.las")).unwrap();
    let failed = sim("2");
    assert_eq!(failed.status.code(), Some(1));
    assert_ne!(std::fs::read(out.join("strip_001.las")).unwrap(), old_strip);
    let text = std::fs::read_to_string(&marker).unwrap();
    assert!(
        text.contains("did not finish") && text.contains("earlier run's"),
        "{text}"
    );
    // A complete run removes it.
    std::fs::remove_dir(out.join("truth.json")).unwrap();
    assert!(sim("2").status.success());
    assert!(!marker.exists());
}

/// Writes `strip` with `n` records' X, Y, Z replaced by far-off values (corrupted records).
fn corrupt_records(strip: &Path, n: usize) {
    let mut k = 0;
    let count = {
        let bytes = std::fs::read(strip).unwrap();
        let offset = u32::from_le_bytes(bytes[96..100].try_into().unwrap()) as usize;
        let len = u16::from_le_bytes(bytes[105..107].try_into().unwrap()) as usize;
        (bytes.len() - offset) / len
    };
    edit_xyz(strip, |i, xyz| {
        if i == k * count / n && k < n {
            k += 1;
            [2e6 + k as f64, -2e6, 1.9e6]
        } else {
            xyz
        }
    });
}

/// Bad case 3: `calibrate --auto-ties` on strips with 100 corrupted XYZ records each tried to
/// allocate 11 TB (a grid sized by the outliers' extent) and aborted. Now its grids are sized
/// from the robust extent: it ends with exit 0 or one line and exit 1, never an abort.
#[test]
fn calibrate_auto_ties_on_corrupted_records_does_not_abort() {
    let w = workspace(&["strip_001.las", "strip_002.las", "sbet.out", "sensor.toml"]);
    let d = w.path();
    for f in ["strip_001.las", "strip_002.las"] {
        corrupt_records(&d.join(f), 100);
    }
    let out = lidarqa(&[
        "calibrate",
        s(&d.join("strip_001.las")),
        s(&d.join("strip_002.las")),
        "--trajectory",
        s(&d.join("sbet.out")),
        "--sensor",
        s(&d.join("sensor.toml")),
        "--auto-ties",
        "-o",
        s(&d.join("cal/calibration.json")),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        matches!(out.status.code(), Some(0 | 1)),
        "{:?}: {err}",
        out.status
    );
    assert!(
        !err.contains("panicked") && !err.contains("memory allocation"),
        "{err}"
    );
    if out.status.code() == Some(1) {
        fails_with(&out, &[]);
    }
}
